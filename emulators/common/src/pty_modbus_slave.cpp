#include "stend/emulators/pty_modbus_slave.hpp"

#include <stend/errors.hpp>

#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "stend/emulators/crc16.hpp"
#include "stend/emulators/splitmix.hpp"

namespace stend::emu {

PtyModbusRtu::PtyModbusRtu(const char* who, int baud, int slave_id, int indication_timeout_us) {
  char name[256] = {};
  if (openpty(&master_fd_, &slave_fd_, name, nullptr, nullptr) != 0)
    throw IoError(std::string(who) + ": openpty failed: " + std::strerror(errno));
  device_path_ = name;
  termios t{};
  tcgetattr(slave_fd_, &t);
  cfmakeraw(&t);
  tcsetattr(slave_fd_, TCSANOW, &t);
  // The context's device name is never opened: the slave talks on the pty's master end.
  ctx_ = modbus_new_rtu(device_path_.c_str(), baud, 'N', 8, 1);
  if (ctx_ == nullptr) {
    ::close(master_fd_);
    ::close(slave_fd_);
    throw IoError(std::string(who) + ": libmodbus allocation failed");
  }
  modbus_set_slave(ctx_, slave_id);
  modbus_set_socket(ctx_, master_fd_);
  modbus_set_indication_timeout(ctx_, 0, static_cast<std::uint32_t>(indication_timeout_us));
}

PtyModbusRtu::~PtyModbusRtu() {
  modbus_free(ctx_);
  ::close(master_fd_);
  ::close(slave_fd_);
}

int PtyModbusRtu::receive(std::uint8_t* req) {
  const int rc = modbus_receive(ctx_, req);
  const int err = errno;
  if (rc > 0) return rc;
  if (rc < 0 && err != ETIMEDOUT) {
    modbus_flush(ctx_);  // broken frame: drop what is left of it
    return -1;
  }
  return 0;
}

void write_corrupted_read_reply(int fd, int slave_id, int fc, const std::uint16_t* registers, int address,
                                int count, std::uint64_t& rng) {
  std::vector<std::uint8_t> frame{static_cast<std::uint8_t>(slave_id), static_cast<std::uint8_t>(fc),
                                  static_cast<std::uint8_t>(2 * count)};
  for (int i = 0; i < count; ++i) {
    frame.push_back(static_cast<std::uint8_t>(registers[address + i] >> 8));
    frame.push_back(static_cast<std::uint8_t>(registers[address + i] & 0xFF));
  }
  const std::uint16_t crc = modbus_crc16(frame.data(), frame.size());
  frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  frame.push_back(static_cast<std::uint8_t>(crc >> 8));
  frame[3 + splitmix64(rng) % static_cast<std::uint64_t>(2 * count)] ^= 0x5A;  // line noise on a data byte
  const ssize_t w = ::write(fd, frame.data(), frame.size());
  (void)w;
}

}  // namespace stend::emu
