// MODBUS RTU client over a serial device (libmodbus), with retries and exponential back-off.
// ModbusClient is the part shared with MODBUS TCP (stend/devices/modbus_tcp.hpp).
//
// Every failure is a ModbusError whose text names the device path (or host:port), the slave id, the function,
// the register address and libmodbus's reason (CRC error, time-out, slave exception code).
// Transient faults (CRC, time-out, bad framing) are retried `retries` times, the wait doubling
// from `backoff_initial_ms`; slave exceptions are not retried (the slave answered, definitively).
#pragma once

#include <stend/errors.hpp>

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
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

  // A line libmodbus can open (baud > 0, parity N/E/O, 5..8 data bits, 1 or 2 stop bits), a slave
  // address 0..247, a positive time-out, no negative retries or back-off.
  bool IsValid(std::string* error = nullptr) const;
};

class ModbusError : public IoError {
 public:
  enum class Kind { kOpen, kTimeout, kCrc, kException, kOther };
  ModbusError(const std::string& what, Kind kind, int exception_code = 0)
      : IoError(what), kind_(kind), exception_code_(exception_code) {}
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

// The MODBUS client shared by RTU and TCP: one retry/back-off loop and one error vocabulary.
// Not thread-safe (one bus master per client).
class ModbusClient {
 public:
  virtual ~ModbusClient();
  ModbusClient(const ModbusClient&) = delete;
  ModbusClient& operator=(const ModbusClient&) = delete;

  std::vector<std::uint16_t> read_input_registers(int address, int count);    // FC 04
  std::vector<std::uint16_t> read_holding_registers(int address, int count);  // FC 03
  void write_register(int address, std::uint16_t value);                      // FC 06
  void write_registers(int address, const std::vector<std::uint16_t>& values);  // FC 16

  const ModbusStats& stats() const { return stats_; }
  void reset_stats() { stats_ = {}; }
  // "device /dev/pts/3, slave 1" (RTU) or "host 127.0.0.1:1502, unit 1" (TCP)
  virtual std::string where() const = 0;

 protected:
  // `protocol` ("MODBUS RTU" / "MODBUS TCP") starts every error text.
  ModbusClient(std::string protocol, int retries, int backoff_initial_ms)
      : protocol_(std::move(protocol)), retries_(retries), backoff_initial_ms_(backoff_initial_ms) {}
  // After a transient fault, before the retry: RTU drops a late reply, TCP reconnects when the
  // connection broke. Returns "" or why recovery failed (the retry then fails the same way).
  virtual std::string recover(int err) = 0;
  void set_context(void* ctx) { ctx_ = ctx; }
  void* context() const { return ctx_; }
  // Frame overhead of one request / reply beyond the PDU (RTU: address + CRC = 3; TCP: MBAP = 7).
  virtual std::size_t frame_overhead() const = 0;

 private:
  template <class F>
  void transact(const char* function, int address, int count, std::size_t req_pdu, std::size_t rep_pdu, F&& f);

  std::string protocol_;
  int retries_;
  int backoff_initial_ms_;
  void* ctx_ = nullptr;  // modbus_t*, owned by the derived class
  ModbusStats stats_;
};

class ModbusRtuClient final : public ModbusClient {
 public:
  explicit ModbusRtuClient(ModbusRtuConfig config);  // opens the device; throws ModbusError
  ~ModbusRtuClient() override;

  const ModbusRtuConfig& config() const { return c_; }
  std::string where() const override;

 private:
  std::string recover(int err) override;
  std::size_t frame_overhead() const override { return 3; }
  ModbusRtuConfig c_;
};

}  // namespace stend::transport
