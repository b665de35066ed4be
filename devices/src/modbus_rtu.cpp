// MODBUS client shared by RTU and TCP (retry loop, error texts, counters) and the RTU client
// (see stend/devices/modbus_rtu.hpp; the TCP client is in transport_modbus_tcp.cpp).
#include <stend/devices/modbus_rtu.hpp>

#include <modbus.h>

#include <cerrno>
#include <cstdio>
#include <thread>
#include <utility>

namespace stend::transport {
namespace {

modbus_t* ctx_of(void* p) { return static_cast<modbus_t*>(p); }

std::string hex4(int v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%04X", static_cast<unsigned>(v) & 0xFFFFu);
  return b;
}

}  // namespace

bool ModbusRtuConfig::IsValid(std::string* error) const {
  if (!(baud > 0)) return invalid(error, "baud must be > 0");
  if (parity != 'N' && parity != 'E' && parity != 'O') return invalid(error, "parity must be N, E or O");
  if (!(data_bits >= 5 && data_bits <= 8 && (stop_bits == 1 || stop_bits == 2)))
    return invalid(error, "data_bits must be 5..8 and stop_bits 1 or 2");
  if (!(slave_id >= 0 && slave_id <= 247)) return invalid(error, "slave_id must be 0..247");
  if (!(response_timeout_ms > 0)) return invalid(error, "response_timeout_ms must be > 0");
  if (!(retries >= 0 && backoff_initial_ms >= 0)) return invalid(error, "retries and backoff_initial_ms must be >= 0");
  return true;
}

ModbusRtuClient::ModbusRtuClient(ModbusRtuConfig config)
    : ModbusClient("MODBUS RTU", config.retries, config.backoff_initial_ms),
      c_(require_valid(config, "MODBUS RTU")) {
  modbus_t* ctx = modbus_new_rtu(c_.device.c_str(), c_.baud, c_.parity, c_.data_bits, c_.stop_bits);
  if (ctx == nullptr) {
    throw ModbusError("MODBUS RTU: cannot create a context for device " + c_.device + " at " +
                          std::to_string(c_.baud) + " baud: " + modbus_strerror(errno),
                      ModbusError::Kind::kOpen);
  }
  if (modbus_set_slave(ctx, c_.slave_id) != 0) {
    const std::string why = modbus_strerror(errno);
    modbus_free(ctx);
    throw ModbusError("MODBUS RTU: invalid slave id " + std::to_string(c_.slave_id) + " for device " +
                          c_.device + ": " + why,
                      ModbusError::Kind::kOpen);
  }
  if (modbus_connect(ctx) != 0) {
    const std::string why = modbus_strerror(errno);
    modbus_free(ctx);
    throw ModbusError("MODBUS RTU: cannot open device " + c_.device + " (" + why +
                          "); check the path, permissions (dialout group) and that the USB "
                          "converter is plugged in",
                      ModbusError::Kind::kOpen);
  }
  const int ms = c_.response_timeout_ms;
  modbus_set_response_timeout(ctx, static_cast<uint32_t>(ms / 1000), static_cast<uint32_t>((ms % 1000) * 1000));
  set_context(ctx);
}

ModbusRtuClient::~ModbusRtuClient() {
  if (context() != nullptr) {
    modbus_close(ctx_of(context()));
    modbus_free(ctx_of(context()));
    set_context(nullptr);
  }
}

std::string ModbusRtuClient::where() const {
  return "device " + c_.device + ", slave " + std::to_string(c_.slave_id);
}

std::string ModbusRtuClient::recover(int /*err*/) {
  modbus_flush(ctx_of(context()));  // drop a late or partial reply before the retry
  return "";
}

ModbusClient::~ModbusClient() = default;

template <class F>
void ModbusClient::transact(const char* function, int address, int count, std::size_t req_pdu, std::size_t rep_pdu,
                            F&& f) {
  int wait_ms = backoff_initial_ms_;
  for (int attempt = 0;; ++attempt) {
    errno = 0;
    const int rc = f();
    if (rc >= 0) {
      ++stats_.transactions;
      stats_.request_bytes += req_pdu + frame_overhead();
      stats_.reply_bytes += rep_pdu + frame_overhead();
      return;
    }
    const int err = errno;
    ModbusError::Kind kind = ModbusError::Kind::kOther;
    int exception_code = 0;
    if (err == ETIMEDOUT) {
      kind = ModbusError::Kind::kTimeout;
      ++stats_.timeouts;
    } else if (err == EMBBADCRC) {
      kind = ModbusError::Kind::kCrc;
      ++stats_.crc_errors;
    } else if (err > MODBUS_ENOBASE && err <= MODBUS_ENOBASE + MODBUS_EXCEPTION_GATEWAY_TARGET) {
      kind = ModbusError::Kind::kException;
      exception_code = err - MODBUS_ENOBASE;
      ++stats_.exceptions;
    }
    std::string what = protocol_ + " " + where() + ": " + function + " at register " + hex4(address) +
                       " (count " + std::to_string(count) + ") failed: " + modbus_strerror(err);
    if (kind == ModbusError::Kind::kException) {
      what += " (slave exception code " + std::to_string(exception_code) + ")";
    }
    const bool transient = kind != ModbusError::Kind::kException;
    if (transient && attempt < retries_) {
      stats_.last_error = what + " — retrying";
      ++stats_.retries;
      std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
      wait_ms *= 2;
      const std::string why = recover(err);
      if (!why.empty()) stats_.last_error += " (" + why + ")";
      continue;
    }
    if (transient) what += " after " + std::to_string(attempt + 1) + " attempts";
    if (transient) (void)recover(err);  // leave the link usable for the next call
    stats_.last_error = what;
    ++stats_.failures;
    throw ModbusError(what, kind, exception_code);
  }
}

std::vector<std::uint16_t> ModbusClient::read_input_registers(int address, int count) {
  std::vector<std::uint16_t> out(static_cast<std::size_t>(count));
  transact("read input registers (FC 04)", address, count, 5, 2 + 2 * static_cast<std::size_t>(count),
           [&] { return modbus_read_input_registers(ctx_of(ctx_), address, count, out.data()); });
  return out;
}

std::vector<std::uint16_t> ModbusClient::read_holding_registers(int address, int count) {
  std::vector<std::uint16_t> out(static_cast<std::size_t>(count));
  transact("read holding registers (FC 03)", address, count, 5, 2 + 2 * static_cast<std::size_t>(count),
           [&] { return modbus_read_registers(ctx_of(ctx_), address, count, out.data()); });
  return out;
}

void ModbusClient::write_register(int address, std::uint16_t value) {
  transact("write register (FC 06)", address, 1, 5, 5,
           [&] { return modbus_write_register(ctx_of(ctx_), address, value); });
}

void ModbusClient::write_registers(int address, const std::vector<std::uint16_t>& values) {
  const int n = static_cast<int>(values.size());
  transact("write registers (FC 16)", address, n, 6 + 2 * values.size(), 5,
           [&] { return modbus_write_registers(ctx_of(ctx_), address, n, values.data()); });
}

}  // namespace stend::transport
