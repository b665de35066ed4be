// MODBUS TCP client (see stend/devices/modbus_tcp.hpp).
#include <stend/devices/modbus_tcp.hpp>

#include <modbus.h>

#include <cerrno>
#include <cstdint>
#include <utility>

namespace stend::transport {
namespace {
modbus_t* ctx_of(void* p) { return static_cast<modbus_t*>(p); }
}  // namespace

bool ModbusTcpConfig::IsValid(std::string* error) const {
  if (host.empty()) return invalid(error, "host must not be empty");
  if (!(port >= 1 && port <= 65535)) return invalid(error, "port must be 1..65535");
  if (!(unit_id >= 0 && unit_id <= 255)) return invalid(error, "unit_id must be 0..255");
  if (!(response_timeout_ms > 0)) return invalid(error, "response_timeout_ms must be > 0");
  if (!(retries >= 0 && backoff_initial_ms >= 0)) return invalid(error, "retries and backoff_initial_ms must be >= 0");
  return true;
}

ModbusTcpClient::ModbusTcpClient(ModbusTcpConfig config)
    : ModbusClient("MODBUS TCP", config.retries, config.backoff_initial_ms),
      c_(require_valid(config, "MODBUS TCP")) {
  modbus_t* ctx = modbus_new_tcp(c_.host.c_str(), c_.port);
  if (ctx == nullptr) {
    throw ModbusError("MODBUS TCP: cannot create a context for " + c_.host + ":" + std::to_string(c_.port) + ": " +
                          modbus_strerror(errno),
                      ModbusError::Kind::kOpen);
  }
  if (modbus_set_slave(ctx, c_.unit_id) != 0) {
    const std::string why = modbus_strerror(errno);
    modbus_free(ctx);
    throw ModbusError("MODBUS TCP: invalid unit id " + std::to_string(c_.unit_id) + " for " + c_.host + ": " + why,
                      ModbusError::Kind::kOpen);
  }
  const int ms = c_.response_timeout_ms;
  modbus_set_response_timeout(ctx, static_cast<uint32_t>(ms / 1000), static_cast<uint32_t>((ms % 1000) * 1000));
  set_context(ctx);
  if (c_.connect_now) {
    const std::string why = connect();
    if (!why.empty()) {
      modbus_free(ctx);
      set_context(nullptr);
      throw ModbusError("MODBUS TCP: cannot connect to " + c_.host + ":" + std::to_string(c_.port) + " (" + why +
                            "); check the address, the port and that the controller is powered and on the network",
                        ModbusError::Kind::kOpen);
    }
  } else {
    // Make the first transaction fail fast (and reconnect) instead of writing to no socket.
    modbus_set_socket(ctx, -1);
  }
}

ModbusTcpClient::~ModbusTcpClient() {
  if (context() != nullptr) {
    if (connected_) modbus_close(ctx_of(context()));
    modbus_free(ctx_of(context()));
    set_context(nullptr);
  }
}

std::string ModbusTcpClient::where() const {
  return "host " + c_.host + ":" + std::to_string(c_.port) + ", unit " + std::to_string(c_.unit_id);
}

std::string ModbusTcpClient::connect() {
  // A signal during libmodbus's wait for the connection (a stop request, a timer) fails it with
  // EINTR, the socket closed: that is no answer from the controller, so try again.
  int rc = 0;
  do rc = modbus_connect(ctx_of(context()));
  while (rc != 0 && errno == EINTR);
  if (rc != 0) {
    connected_ = false;
    return modbus_strerror(errno);
  }
  connected_ = true;
  return "";
}

std::string ModbusTcpClient::recover(int err) {
  // A time-out or a corrupt reply leaves a TCP stream out of step (a late reply would be read as
  // the answer to the next request), and a reset/closed socket is dead: start a new connection.
  (void)err;
  if (connected_) modbus_close(ctx_of(context()));
  connected_ = false;
  const std::string why = connect();
  return why.empty() ? "" : "reconnect failed: " + why;
}

}  // namespace stend::transport
