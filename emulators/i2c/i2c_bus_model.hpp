// An emulated I2C bus: targets (register-level sensor models) at 7-bit addresses, a clock, and
// combined transactions (write segment, repeated start, read segment). A missing address NACKs.
// Thread-safe: bridges, the i2c-dev emulator and the bench MCU emulator may share one bus.
#pragma once

#include <stend/sdk.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "truth_cell.hpp"

namespace stend::emu {

// A device on the bus. `now_s` is the bus clock (seconds since the bus was created), so models
// produce the samples that fell due before the access.
class I2cTarget {
 public:
  virtual ~I2cTarget() = default;
  virtual void i2c_write(const std::uint8_t* data, std::size_t n, double now_s) = 0;  // after the address byte
  virtual void i2c_read(std::uint8_t* data, std::size_t n, double now_s) = 0;
};

struct I2cSegment {
  std::uint8_t address = 0;
  bool read = false;
  std::uint8_t* data = nullptr;
  std::size_t len = 0;
};

struct I2cBusStats {
  std::uint64_t transactions = 0, nacks = 0, bytes = 0;
};

class EmulatedI2cBus {
 public:
  EmulatedI2cBus();  // clock: steady clock since construction
  void attach(std::uint8_t address, std::shared_ptr<I2cTarget> target);
  void detach(std::uint8_t address);  // the device "disappears": its address NACKs
  // Replace the clock (e.g. a simulated one for deterministic tests).
  void set_clock(std::function<double()> now_s);
  double now() const;

  // One combined transaction. Returns false when a segment's address is not acknowledged
  // (nothing of that segment or later ones is executed), true otherwise.
  bool transfer(I2cSegment* segments, std::size_t n);
  I2cBusStats stats() const;

 private:
  mutable std::mutex m_;
  std::map<std::uint8_t, std::shared_ptr<I2cTarget>> targets_;
  std::function<double()> clock_;
  I2cBusStats stats_;
};

}  // namespace stend::emu
