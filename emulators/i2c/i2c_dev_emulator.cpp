#include "i2c_dev_emulator.hpp"

#include <linux/i2c-dev.h>
#include <linux/i2c.h>

#include <vector>

namespace stend::emu {

void EmulatedI2cDevFile::add_adapter(const std::string& path, std::shared_ptr<EmulatedI2cBus> bus) {
  std::lock_guard<std::mutex> lock(m_);
  adapters_[path] = std::move(bus);
}

void EmulatedI2cDevFile::set_fault(int fault_errno, double probability, std::uint64_t seed) {
  std::lock_guard<std::mutex> lock(m_);
  fault_errno_ = fault_errno;
  fault_p_ = probability;
  rng_ = seed;
}

int EmulatedI2cDevFile::open(const char* path, int /*flags*/) {
  std::lock_guard<std::mutex> lock(m_);
  auto it = adapters_.find(path);
  if (it == adapters_.end()) {
    errno = ENOENT;
    return -1;
  }
  const int fd = next_fd_++;
  open_[fd] = it->second;
  return fd;
}

int EmulatedI2cDevFile::ioctl_funcs(int fd, unsigned long* funcs) {
  std::lock_guard<std::mutex> lock(m_);
  if (open_.count(fd) == 0) {
    errno = EBADF;
    return -1;
  }
  *funcs = I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL;
  return 0;
}

int EmulatedI2cDevFile::ioctl_rdwr(int fd, i2c_rdwr_ioctl_data* data) {
  std::shared_ptr<EmulatedI2cBus> bus;
  {
    std::lock_guard<std::mutex> lock(m_);
    ++ioctls_;
    auto it = open_.find(fd);
    if (it == open_.end()) {
      errno = EBADF;
      return -1;
    }
    bus = it->second;
    if (fault_p_ > 0.0) {
      rng_ = rng_ * 6364136223846793005ULL + 1442695040888963407ULL;
      if (static_cast<double>(rng_ >> 11) * 0x1.0p-53 < fault_p_) {
        ++faults_;
        errno = fault_errno_;
        return -1;
      }
    }
  }
  // The kernel's checks (drivers/i2c/i2c-dev.c, i2c-core).
  if (data == nullptr || data->msgs == nullptr || data->nmsgs == 0 || data->nmsgs > I2C_RDWR_IOCTL_MAX_MSGS) {
    errno = EINVAL;
    return -1;
  }
  std::vector<I2cSegment> segs(data->nmsgs);
  for (std::uint32_t i = 0; i < data->nmsgs; ++i) {
    const i2c_msg& m = data->msgs[i];
    if (m.len > 8192 || (m.len > 0 && m.buf == nullptr) || ((m.flags & I2C_M_TEN) == 0 && m.addr > 0x7F)) {
      errno = EINVAL;
      return -1;
    }
    segs[i] = {static_cast<std::uint8_t>(m.addr), (m.flags & I2C_M_RD) != 0, m.buf, m.len};
  }
  if (!bus->transfer(segs.data(), segs.size())) {
    errno = nack_errno_;
    return -1;
  }
  return static_cast<int>(data->nmsgs);
}

int EmulatedI2cDevFile::close(int fd) {
  std::lock_guard<std::mutex> lock(m_);
  if (open_.erase(fd) == 0) {
    errno = EBADF;
    return -1;
  }
  return 0;
}

}  // namespace stend::emu
