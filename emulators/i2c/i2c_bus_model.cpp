#include "i2c_bus_model.hpp"

#include <chrono>

namespace stend::emu {

EmulatedI2cBus::EmulatedI2cBus() {
  const auto t0 = std::chrono::steady_clock::now();
  clock_ = [t0] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
}

void EmulatedI2cBus::attach(std::uint8_t address, std::shared_ptr<I2cTarget> target) {
  std::lock_guard<std::mutex> lock(m_);
  targets_[address] = std::move(target);
}

void EmulatedI2cBus::detach(std::uint8_t address) {
  std::lock_guard<std::mutex> lock(m_);
  targets_.erase(address);
}

void EmulatedI2cBus::set_clock(std::function<double()> now_s) {
  std::lock_guard<std::mutex> lock(m_);
  clock_ = std::move(now_s);
}

double EmulatedI2cBus::now() const {
  std::lock_guard<std::mutex> lock(m_);
  return clock_();
}

bool EmulatedI2cBus::transfer(I2cSegment* segments, std::size_t n) {
  std::lock_guard<std::mutex> lock(m_);
  ++stats_.transactions;
  const double t = clock_();
  for (std::size_t i = 0; i < n; ++i) {
    I2cSegment& s = segments[i];
    auto it = targets_.find(s.address);
    if (it == targets_.end()) {
      ++stats_.nacks;
      return false;
    }
    if (s.read) {
      it->second->i2c_read(s.data, s.len, t);
    } else {
      it->second->i2c_write(s.data, s.len, t);
    }
    stats_.bytes += s.len;
  }
  return true;
}

I2cBusStats EmulatedI2cBus::stats() const {
  std::lock_guard<std::mutex> lock(m_);
  return stats_;
}

}  // namespace stend::emu
