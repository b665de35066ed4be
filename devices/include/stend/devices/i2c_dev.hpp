// Linux i2c-dev route: open("/dev/i2c-N"), ioctl(I2C_FUNCS), ioctl(I2C_RDWR) with an array of
// struct i2c_msg (the write of the register address, then an I2C_M_RD message: one combined
// transaction with a repeated start and a single STOP).
//
// Seam for tests: the three system calls go through I2cDevFile. linux_i2c_dev_file() is the real
// one; emulators/i2c provides an emulated adapter that implements the same contract on the real
// struct i2c_rdwr_ioctl_data, so the code that builds the i2c_msg array and interprets errno is
// the code under test. errno mapping: ENXIO / EREMOTEIO → no ACK; ETIMEDOUT → time-out;
// EAGAIN (arbitration lost), EIO → bus error.
#pragma once

#include <stend/devices/i2c.hpp>

#include <memory>
#include <string>

struct i2c_rdwr_ioctl_data;  // <linux/i2c-dev.h>

namespace stend::transport {

// The system calls of the i2c-dev route. Contract of open(2) / ioctl(2) / close(2): return -1
// and set errno on failure.
class I2cDevFile {
 public:
  virtual ~I2cDevFile() = default;
  virtual int open(const char* path, int flags) = 0;
  virtual int ioctl_funcs(int fd, unsigned long* funcs) = 0;        // I2C_FUNCS
  virtual int ioctl_rdwr(int fd, i2c_rdwr_ioctl_data* data) = 0;    // I2C_RDWR
  virtual int close(int fd) = 0;
};

// The real system calls.
std::shared_ptr<I2cDevFile> linux_i2c_dev_file();

class I2cDevBus final : public I2cBus {
 public:
  // Opens `path` (e.g. "/dev/i2c-1") and checks that the adapter does plain I2C (I2C_FUNC_I2C).
  explicit I2cDevBus(std::string path, std::shared_ptr<I2cDevFile> file = linux_i2c_dev_file());
  ~I2cDevBus() override;
  I2cDevBus(const I2cDevBus&) = delete;
  I2cDevBus& operator=(const I2cDevBus&) = delete;

  std::string name() const override { return path_; }
  void write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r,
                  std::size_t rlen) override;
  std::size_t max_read() const override { return 4096; }  // i2c-dev caps a message at 8192
  std::size_t max_write() const override { return 4096; }

 private:
  std::string path_;
  std::shared_ptr<I2cDevFile> file_;
  int fd_ = -1;
};

}  // namespace stend::transport
