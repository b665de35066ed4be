// MODBUS TCP client (libmodbus modbus_new_tcp), sharing the retry loop, counters and error texts
// of the RTU client (stend/devices/modbus_rtu.hpp: ModbusClient, ModbusError, ModbusStats).
//
// Errors name "MODBUS TCP host H:P, unit U", the function, the register and the reason. A broken
// connection (peer closed, reset, refused) is transient: before each retry the client closes the
// socket and connects again, so a peer that restarts is picked up without rebuilding the client.
#pragma once

#include <stend/devices/modbus_rtu.hpp>

#include <string>

namespace stend::transport {

struct ModbusTcpConfig {
  std::string host = "127.0.0.1";
  int port = 502;
  int unit_id = 1;              // MODBUS unit identifier (the slave id behind a gateway)
  int response_timeout_ms = 500;
  int retries = 3;              // extra attempts after the first
  int backoff_initial_ms = 20;  // wait before the first retry; doubles each retry
  bool connect_now = true;      // false: the first transaction connects (a peer not up yet is a
                                // transient fault, not a constructor error)

  // A host, a port 1..65535, a unit id 0..255, a positive time-out, no negative retries or back-off.
  bool IsValid(std::string* error = nullptr) const;
};

class ModbusTcpClient final : public ModbusClient {
 public:
  explicit ModbusTcpClient(ModbusTcpConfig config);  // connects (unless connect_now is false)
  ~ModbusTcpClient() override;

  const ModbusTcpConfig& config() const { return c_; }
  std::string where() const override;  // "host 127.0.0.1:1502, unit 1"
  bool connected() const { return connected_; }

 private:
  std::string recover(int err) override;
  std::size_t frame_overhead() const override { return 7; }  // MBAP header
  std::string connect();  // "" on success, else why

  ModbusTcpConfig c_;
  bool connected_ = false;
};

}  // namespace stend::transport
