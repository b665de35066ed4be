// MODBUS RTU client (see stend/transport/modbus_rtu.hpp). Lives in sensors/mpu6050 until
// stend_core links libmodbus; then it moves to core/src/transport_modbus_rtu.cpp unchanged.
#include <stend/transport/modbus_rtu.hpp>

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

ModbusRtuClient::ModbusRtuClient(ModbusRtuConfig config) : c_(std::move(config)) {
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
  ctx_ = ctx;
}

ModbusRtuClient::~ModbusRtuClient() {
  if (ctx_ != nullptr) {
    modbus_close(ctx_of(ctx_));
    modbus_free(ctx_of(ctx_));
  }
}

std::string ModbusRtuClient::where() const {
  return "device " + c_.device + ", slave " + std::to_string(c_.slave_id);
}

template <class F>
void ModbusRtuClient::transact(const char* function, int address, int count, std::size_t req_bytes,
                               std::size_t rep_bytes, F&& f) {
  int wait_ms = c_.backoff_initial_ms;
  for (int attempt = 0;; ++attempt) {
    errno = 0;
    const int rc = f();
    if (rc >= 0) {
      ++stats_.transactions;
      stats_.request_bytes += req_bytes;
      stats_.reply_bytes += rep_bytes;
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
    std::string what = "MODBUS RTU " + where() + ": " + function + " at register " + hex4(address) +
                       " (count " + std::to_string(count) + ") failed: " + modbus_strerror(err);
    if (kind == ModbusError::Kind::kException) {
      what += " (slave exception code " + std::to_string(exception_code) + ")";
    }
    const bool transient = kind != ModbusError::Kind::kException;
    if (transient && attempt < c_.retries) {
      stats_.last_error = what + " — retrying";
      ++stats_.retries;
      std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
      wait_ms *= 2;
      modbus_flush(ctx_of(ctx_));  // drop a late or partial reply before the retry
      continue;
    }
    if (transient) what += " after " + std::to_string(attempt + 1) + " attempts";
    stats_.last_error = what;
    ++stats_.failures;
    throw ModbusError(what, kind, exception_code);
  }
}

std::vector<std::uint16_t> ModbusRtuClient::read_input_registers(int address, int count) {
  std::vector<std::uint16_t> out(static_cast<std::size_t>(count));
  transact("read input registers (FC 04)", address, count, 8, 5 + 2 * static_cast<std::size_t>(count),
           [&] { return modbus_read_input_registers(ctx_of(ctx_), address, count, out.data()); });
  return out;
}

std::vector<std::uint16_t> ModbusRtuClient::read_holding_registers(int address, int count) {
  std::vector<std::uint16_t> out(static_cast<std::size_t>(count));
  transact("read holding registers (FC 03)", address, count, 8, 5 + 2 * static_cast<std::size_t>(count),
           [&] { return modbus_read_registers(ctx_of(ctx_), address, count, out.data()); });
  return out;
}

void ModbusRtuClient::write_register(int address, std::uint16_t value) {
  transact("write register (FC 06)", address, 1, 8, 8,
           [&] { return modbus_write_register(ctx_of(ctx_), address, value); });
}

}  // namespace stend::transport
