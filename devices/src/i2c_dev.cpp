// Linux i2c-dev route (see stend/devices/i2c_dev.hpp).
#include <stend/devices/i2c_dev.hpp>

#include <fcntl.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace stend::transport {
namespace {

class LinuxI2cDevFile final : public I2cDevFile {
 public:
  int open(const char* path, int flags) override { return ::open(path, flags); }
  int ioctl_funcs(int fd, unsigned long* funcs) override { return ::ioctl(fd, I2C_FUNCS, funcs); }
  int ioctl_rdwr(int fd, i2c_rdwr_ioctl_data* data) override { return ::ioctl(fd, I2C_RDWR, data); }
  int close(int fd) override { return ::close(fd); }
};

}  // namespace

std::shared_ptr<I2cDevFile> linux_i2c_dev_file() { return std::make_shared<LinuxI2cDevFile>(); }

I2cDevBus::I2cDevBus(std::string path, std::shared_ptr<I2cDevFile> file) : path_(std::move(path)), file_(std::move(file)) {
  fd_ = file_->open(path_.c_str(), O_RDWR | O_CLOEXEC);
  if (fd_ < 0) {
    const int err = errno;
    std::string hint = err == ENOENT ? "; load the i2c-dev module (modprobe i2c-dev) and check the bus number (i2cdetect -l)"
                       : err == EACCES ? "; add the user to the i2c group or adjust the udev rule"
                                       : "";
    throw I2cError("I2C: cannot open " + path_ + ": " + std::strerror(err) + hint, I2cError::Kind::kOpen);
  }
  unsigned long funcs = 0;
  if (file_->ioctl_funcs(fd_, &funcs) < 0 || (funcs & I2C_FUNC_I2C) == 0) {
    file_->close(fd_);
    fd_ = -1;
    throw I2cError("I2C: adapter " + path_ + " does not do plain I2C transfers (I2C_FUNC_I2C missing; SMBus-only adapter)",
                   I2cError::Kind::kOpen);
  }
}

I2cDevBus::~I2cDevBus() {
  if (fd_ >= 0) file_->close(fd_);
}

void I2cDevBus::write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r, std::size_t rlen) {
  i2c_msg msgs[2] = {};
  std::uint32_t n = 0;
  if (wlen > 0) {
    msgs[n].addr = address;
    msgs[n].flags = 0;
    msgs[n].len = static_cast<std::uint16_t>(wlen);
    msgs[n].buf = const_cast<std::uint8_t*>(w);  // the kernel only reads a write message
    ++n;
  }
  if (rlen > 0) {
    msgs[n].addr = address;
    msgs[n].flags = I2C_M_RD;
    msgs[n].len = static_cast<std::uint16_t>(rlen);
    msgs[n].buf = r;
    ++n;
  }
  if (n == 0) return;
  i2c_rdwr_ioctl_data data{msgs, n};
  if (file_->ioctl_rdwr(fd_, &data) >= 0) return;
  const int err = errno;
  const std::string who = i2c_hex(address) + " on " + path_;
  switch (err) {
    case ENXIO:
    case EREMOTEIO:
      throw I2cError("I2C: no ACK from " + who + " (" + std::strerror(err) +
                         "); check wiring, power and the address pin (AD0/SA0/SDO)",
                     I2cError::Kind::kNack);
    case ETIMEDOUT:
      throw I2cError("I2C: time-out talking to " + who + " (SCL held low?)", I2cError::Kind::kTimeout);
    case EAGAIN:
      throw I2cError("I2C: arbitration lost talking to " + who, I2cError::Kind::kBus);
    default:
      throw I2cError("I2C: transfer with " + who + " failed: " + std::strerror(err), I2cError::Kind::kBus);
  }
}

}  // namespace stend::transport
