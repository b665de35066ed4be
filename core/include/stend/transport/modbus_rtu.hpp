// MODBUS RTU client over a serial device (libmodbus), with retries and exponential back-off.
//
// Every failure is a ModbusError whose text names the device path, the slave id, the function,
// the register address and libmodbus's reason (CRC error, time-out, slave exception code).
// Transient faults (CRC, time-out, bad framing) are retried `retries` times, the wait doubling
// from `backoff_initial_ms`; slave exceptions are not retried (the slave answered, definitively).
#pragma once

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace stend::transport {

struct ModbusRtuConfig {
  std::string device;          // "/dev/ttyUSB0"
  int baud = 921600;
  char parity = 'N';           // 'N', 'E', 'O'
  int data_bits = 8;
  int stop_bits = 1;
  int slave_id = 1;
  int response_timeout_ms = 100;
  int retries = 3;             // extra attempts after the first
  int backoff_initial_ms = 5;  // wait before the first retry; doubles each retry
};

class ModbusError : public std::runtime_error {
 public:
  enum class Kind { kOpen, kTimeout, kCrc, kException, kOther };
  ModbusError(const std::string& what, Kind kind, int exception_code = 0)
      : std::runtime_error(what), kind_(kind), exception_code_(exception_code) {}
  Kind kind() const { return kind_; }
  int exception_code() const { return exception_code_; }  // MODBUS exception, 0 if none
  bool transient() const { return kind_ == Kind::kTimeout || kind_ == Kind::kCrc || kind_ == Kind::kOther; }

 private:
  Kind kind_;
  int exception_code_;
};

// Counters since open (or reset_stats()).
struct ModbusStats {
  std::uint64_t transactions = 0;    // successful
  std::uint64_t retries = 0;         // attempts repeated after a transient fault
  std::uint64_t crc_errors = 0;
  std::uint64_t timeouts = 0;
  std::uint64_t exceptions = 0;      // slave exception replies
  std::uint64_t failures = 0;        // transactions that threw after all retries
  std::uint64_t request_bytes = 0;   // RTU frames, successful transactions
  std::uint64_t reply_bytes = 0;
  std::string last_error;            // text of the last fault seen, retried or not
};

class ModbusRtuClient {
 public:
  explicit ModbusRtuClient(ModbusRtuConfig config);  // opens the device; throws ModbusError
  ~ModbusRtuClient();
  ModbusRtuClient(const ModbusRtuClient&) = delete;
  ModbusRtuClient& operator=(const ModbusRtuClient&) = delete;

  std::vector<std::uint16_t> read_input_registers(int address, int count);    // FC 04
  std::vector<std::uint16_t> read_holding_registers(int address, int count);  // FC 03
  void write_register(int address, std::uint16_t value);                      // FC 06

  const ModbusRtuConfig& config() const { return c_; }
  const ModbusStats& stats() const { return stats_; }
  void reset_stats() { stats_ = {}; }
  // "device /dev/pts/3, slave 1"
  std::string where() const;

 private:
  template <class F>
  void transact(const char* function, int address, int count, std::size_t req_bytes,
                std::size_t rep_bytes, F&& f);

  ModbusRtuConfig c_;
  void* ctx_ = nullptr;  // modbus_t*
  ModbusStats stats_;
};

}  // namespace stend::transport
