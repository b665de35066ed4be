// The MODBUS RTU reply path: the shared client (ModbusClient: transaction, counts, error
// vocabulary) over libmodbus's RTU framing, with the slave's reply taken from the input.
// Input: byte 0 = request (bits 0–1: FC 04 / 03 / 06 / 16; bit 7: append the frame's correct CRC so
// the fuzzer reaches what follows the CRC check), byte 1 = register count (1–32), the rest = the
// bytes the slave sends back, after which the line closes. The client either returns or throws
// ModbusError naming where, the function and the reason.
#include <stend/devices/modbus_rtu.hpp>
#include <stend/emulators/crc16.hpp>

#include <modbus.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_support.hpp"

namespace {

// An RTU context on one end of a socket pair instead of a serial device.
class SocketRtuClient final : public stend::transport::ModbusClient {
 public:
  explicit SocketRtuClient(int fd) : ModbusClient("MODBUS RTU", /*retries=*/0, /*backoff_initial_ms=*/0) {
    modbus_t* ctx = modbus_new_rtu("/dev/null", 115200, 'N', 8, 1);
    modbus_set_slave(ctx, 1);
    modbus_set_socket(ctx, fd);
    modbus_set_response_timeout(ctx, 0, 20000);
    modbus_set_byte_timeout(ctx, 0, 20000);
    set_context(ctx);
  }
  ~SocketRtuClient() override { modbus_free(static_cast<modbus_t*>(context())); }
  std::string where() const override { return "socket pair, slave 1"; }

 private:
  std::string recover(int) override { return ""; }
  std::size_t frame_overhead() const override { return 3; }
};

void transact(stend::transport::ModbusClient& client, int request, int count) {
  constexpr int kAddress = 0x10;
  switch (request) {
    case 0: (void)client.read_input_registers(kAddress, count); break;
    case 1: (void)client.read_holding_registers(kAddress, count); break;
    case 2: client.write_register(kAddress, 0x1234); break;
    default: client.write_registers(kAddress, std::vector<std::uint16_t>(static_cast<std::size_t>(count), 7)); break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2 || size > 1024) return 0;  // an RTU frame is at most 256 bytes
  std::vector<std::uint8_t> reply(data + 2, data + size);
  if ((data[0] & 0x80) != 0) {
    const std::uint16_t crc = stend::emu::modbus_crc16(reply.data(), reply.size());
    reply.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    reply.push_back(static_cast<std::uint8_t>(crc >> 8));
  }
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM, 0, fds) != 0) return 0;
  if (!reply.empty() && ::write(fds[1], reply.data(), reply.size()) != static_cast<ssize_t>(reply.size())) {
    ::close(fds[0]);
    ::close(fds[1]);
    return 0;
  }
  ::shutdown(fds[1], SHUT_WR);  // end of the reply: the client sees the line close
  try {
    SocketRtuClient client(fds[0]);
    transact(client, data[0] & 0x03, 1 + data[1] % 32);
  } catch (const stend::transport::ModbusError&) {
  }
  ::close(fds[0]);
  ::close(fds[1]);
  return 0;
}
