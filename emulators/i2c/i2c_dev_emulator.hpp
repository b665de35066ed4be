// An emulated Linux i2c-dev adapter: implements stend::transport::I2cDevFile (open, ioctl
// I2C_FUNCS, ioctl I2C_RDWR, close) on the real struct i2c_rdwr_ioctl_data / struct i2c_msg,
// validating the message array as the kernel does (≤ I2C_RDWR_IOCTL_MAX_MSGS messages, ≤ 8192
// bytes each, 7-bit addresses) and failing with the errno a real adapter driver returns: a
// missing device NACKs with ENXIO (i801, designware) or EREMOTEIO (many SoC drivers).
// Fault injection: each ioctl fails with `fault_errno` with probability `p`.
#pragma once

#include <stend/devices/i2c_dev.hpp>

#include <atomic>
#include <cerrno>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "i2c_bus_model.hpp"

namespace stend::emu {

class EmulatedI2cDevFile final : public transport::I2cDevFile {
 public:
  void add_adapter(const std::string& path, std::shared_ptr<EmulatedI2cBus> bus);
  void set_nack_errno(int e) { nack_errno_ = e; }
  void set_fault(int fault_errno, double probability, std::uint64_t seed = 1);
  std::uint64_t ioctls() const { return ioctls_; }
  std::uint64_t faults_injected() const { return faults_; }

  int open(const char* path, int flags) override;
  int ioctl_funcs(int fd, unsigned long* funcs) override;
  int ioctl_rdwr(int fd, i2c_rdwr_ioctl_data* data) override;
  int close(int fd) override;

 private:
  std::mutex m_;
  std::map<std::string, std::shared_ptr<EmulatedI2cBus>> adapters_;
  std::map<int, std::shared_ptr<EmulatedI2cBus>> open_;
  int next_fd_ = 100;
  int nack_errno_ = ENXIO;
  int fault_errno_ = 0;
  double fault_p_ = 0.0;
  std::uint64_t rng_ = 1;
  std::atomic<std::uint64_t> ioctls_{0}, faults_{0};
};

}  // namespace stend::emu
