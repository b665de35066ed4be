// I2C bus abstraction shared by every sensor driver: a route (adapter) that performs combined
// transactions, and a device at one address with register access, retries and back-off.
//
// Routes (one class each): Linux i2c-dev (stend/devices/i2c_dev.hpp), USB-HID bridges MCP2221A
// and CP2112 (stend/devices/i2c_hid.hpp), the bench microcontroller's MODBUS RTU I2C window
// (stend/devices/i2c_bench_mcu.hpp). open_i2c_bus() (stend/devices/i2c_route.hpp) picks one
// from a YAML-level description.
//
// Every failure is an I2cError whose text names the bus, the 7-bit address and, where there is
// one, the register ("no ACK from 0x68 on /dev/i2c-1 (register 0x75)").
#pragma once

#include <stend/errors.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

namespace stend::transport {

class I2cError : public IoError {
 public:
  enum class Kind {
    kOpen,      // the adapter could not be opened / found
    kNack,      // no ACK: address (device absent) or data byte
    kTimeout,   // the adapter or the bridge did not finish in time (SCL held, bridge silent)
    kBus,       // arbitration lost, bus error, I/O error of the adapter
    kProtocol,  // unexpected answer from a bridge, unsupported transfer
  };
  I2cError(const std::string& what, Kind kind) : IoError(what), kind_(kind) {}
  Kind kind() const { return kind_; }
  // Worth another attempt: a NACK may be a glitch (an absent device NACKs every attempt, which
  // costs only the back-off), time-outs and bus errors usually are.
  bool transient() const { return kind_ == Kind::kNack || kind_ == Kind::kTimeout || kind_ == Kind::kBus; }

 private:
  Kind kind_;
};

// One route to an I2C bus.
class I2cBus {
 public:
  virtual ~I2cBus() = default;
  // Human-readable bus name used in every error: "/dev/i2c-1", "MCP2221A /dev/hidraw3 (serial
  // 0001234)", "bench MCU device /dev/ttyUSB0, slave 1".
  virtual std::string name() const = 0;
  // One combined transaction with the 7-bit `address`: START, write `wlen` bytes (if any); if
  // rlen > 0, a repeated START and read `rlen` bytes; STOP. wlen == 0 is a plain read.
  // No retries here; throws I2cError naming the bus and address (the caller adds the register).
  virtual void write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen,
                          std::uint8_t* r, std::size_t rlen) = 0;
  // Largest read / write (bytes) the route moves in one transaction.
  virtual std::size_t max_read() const = 0;
  virtual std::size_t max_write() const = 0;
};

struct I2cRetryPolicy {
  int retries = 3;             // extra attempts after a transient fault
  int backoff_initial_ms = 1;  // wait before the first retry; doubles each retry
};

// Counters since construction (or reset_stats()).
struct I2cStats {
  std::uint64_t transactions = 0;   // successful
  std::uint64_t retries = 0;
  std::uint64_t nacks = 0, timeouts = 0, bus_errors = 0;
  std::uint64_t failures = 0;       // operations that threw after all retries
  std::uint64_t bytes_read = 0, bytes_written = 0;  // payload, successful transactions
  std::string last_error;
};

// A device at one 7-bit address on a bus, with register-pointer access (the register address is
// the first byte written; reads use a repeated start). Bursts longer than the route's max_read()
// are split into several transactions, each starting at the register where the previous stopped
// (`advance` = false keeps the start register, for FIFO data ports).
class I2cDevice {
 public:
  I2cDevice(std::shared_ptr<I2cBus> bus, std::uint8_t address, I2cRetryPolicy policy = {});

  std::uint8_t read_reg(std::uint8_t reg);
  void read_regs(std::uint8_t reg, std::uint8_t* out, std::size_t n, bool advance = true);
  void write_reg(std::uint8_t reg, std::uint8_t value);

  I2cBus& bus() const { return *bus_; }
  std::uint8_t address() const { return address_; }
  // "/dev/i2c-1, address 0x68"
  std::string where() const;
  const I2cStats& stats() const { return stats_; }
  void reset_stats() { stats_ = {}; }
  I2cRetryPolicy& policy() { return policy_; }

 private:
  void transact(std::uint8_t reg, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r, std::size_t rlen);

  std::shared_ptr<I2cBus> bus_;
  std::uint8_t address_;
  I2cRetryPolicy policy_;
  I2cStats stats_;
};

// "0x68"
std::string i2c_hex(unsigned v);

}  // namespace stend::transport
