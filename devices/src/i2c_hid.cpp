// I2C over the MCP2221A and CP2112 USB-HID bridges (see stend/devices/i2c_hid.hpp for the
// report formats).
#include <stend/devices/i2c_hid.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>

namespace stend::transport {
namespace {

constexpr std::uint8_t kMcpStatus = 0x10, kMcpCancel = 0x10, kMcpSetSpeed = 0x20, kMcpWrite = 0x90, kMcpRead = 0x91,
                       kMcpReadRepStart = 0x93, kMcpWriteNoStop = 0x94, kMcpGetData = 0x40;
constexpr std::uint8_t kMcpStateAddrNack = 0x25, kMcpAddrNackMask = 0x40;
constexpr std::uint8_t kMcpStartTout = 0x12, kMcpStopTout = 0x62, kMcpWrAddrTout = 0x23, kMcpWrDataTout = 0x44;

constexpr std::uint8_t kCpSmbusConfig = 0x06, kCpReadRequest = 0x10, kCpWriteReadRequest = 0x11, kCpReadForceSend = 0x12,
                       kCpReadResponse = 0x13, kCpWriteRequest = 0x14, kCpStatusRequest = 0x15, kCpStatusResponse = 0x16,
                       kCpCancel = 0x17;

using Clock = std::chrono::steady_clock;

}  // namespace

// ----------------------------------------------------------------------------------------------
// MCP2221A

Mcp2221Bus::Mcp2221Bus(std::unique_ptr<HidDevice> device, HidBridgeConfig config)
    : dev_(std::move(device)), c_(require_valid(config, "MCP2221A")) {
  const int divider = std::clamp(12000000 / std::max(1, c_.speed_hz) - 3, 0, 255);
  std::uint8_t rep[64];
  status(rep, false, divider);
  if (rep[3] != kMcpSetSpeed) {  // engine busy (a transfer left hanging): cancel, then set again
    status(rep, true, -1);
    status(rep, false, divider);
  }
  if (rep[3] != kMcpSetSpeed) {
    throw I2cError("I2C: " + name() + " refused the SCL speed " + std::to_string(c_.speed_hz) + " Hz (I2C engine state " +
                       i2c_hex(rep[8]) + "); unplug and replug the bridge",
                   I2cError::Kind::kOpen);
  }
}

std::string Mcp2221Bus::name() const { return "MCP2221A " + dev_->path(); }

void Mcp2221Bus::fail(std::uint8_t address, const std::string& why, I2cError::Kind kind) {
  std::uint8_t rep[64];
  try {
    status(rep, true, -1);  // cancel: frees the bus for the next transfer
  } catch (const I2cError&) {
  }
  throw I2cError("I2C: " + why + " " + i2c_hex(address) + " on " + name(), kind);
}

void Mcp2221Bus::exchange(const std::uint8_t* cmd, std::size_t n, std::uint8_t* reply, const char* what) {
  std::uint8_t out[65] = {};  // report ID 0 (the MCP2221A has none), then the 64-byte report
  std::memcpy(out + 1, cmd, std::min<std::size_t>(n, 64));
  dev_->write(out, sizeof out);
  const auto deadline = Clock::now() + std::chrono::milliseconds(c_.timeout_ms);
  do {
    const int left = static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count());
    const std::size_t k = dev_->read(reply, 64, std::max(left, 0));
    if (k > 0 && reply[0] == cmd[0]) return;  // a stale reply to an earlier command is skipped
  } while (Clock::now() < deadline);
  throw I2cError("I2C: " + name() + " did not answer " + what + " (command " + i2c_hex(cmd[0]) + ") within " +
                     std::to_string(c_.timeout_ms) + " ms",
                 I2cError::Kind::kTimeout);
}

void Mcp2221Bus::status(std::uint8_t* reply, bool cancel, int divider) {
  std::uint8_t cmd[8] = {kMcpStatus, 0, static_cast<std::uint8_t>(cancel ? kMcpCancel : 0),
                         static_cast<std::uint8_t>(divider >= 0 ? kMcpSetSpeed : 0),
                         static_cast<std::uint8_t>(divider >= 0 ? divider : 0), 0, 0, 0};
  exchange(cmd, sizeof cmd, reply, "status/set parameters");
}

void Mcp2221Bus::write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r, std::size_t rlen) {
  if (wlen > max_write() || rlen > max_read()) {
    throw I2cError("I2C: " + name() + ": transfer of " + std::to_string(wlen) + " + " + std::to_string(rlen) +
                       " bytes exceeds the bridge's limits (60 written, 1020 read)",
                   I2cError::Kind::kProtocol);
  }
  std::uint8_t rep[64];
  auto state_error = [&](std::uint8_t state) {
    if (state == kMcpStartTout || state == kMcpStopTout || state == kMcpWrAddrTout || state == kMcpWrDataTout) {
      fail(address, "time-out (engine state " + i2c_hex(state) + ") talking to", I2cError::Kind::kTimeout);
    }
  };
  if (wlen > 0) {
    std::uint8_t cmd[64] = {static_cast<std::uint8_t>(rlen > 0 ? kMcpWriteNoStop : kMcpWrite), static_cast<std::uint8_t>(wlen & 0xFF),
                            static_cast<std::uint8_t>(wlen >> 8), static_cast<std::uint8_t>(address << 1)};
    std::memcpy(cmd + 4, w, wlen);
    exchange(cmd, 4 + wlen, rep, "I2C write");
    if (rep[1] != 0) fail(address, "I2C engine busy (state " + i2c_hex(rep[2]) + ") writing to", I2cError::Kind::kBus);
    if (rlen == 0) {
      status(rep, false, -1);
      if (rep[20] & kMcpAddrNackMask || rep[8] == kMcpStateAddrNack) fail(address, "no ACK from", I2cError::Kind::kNack);
      state_error(rep[8]);
      return;
    }
  }
  std::uint8_t cmd[4] = {static_cast<std::uint8_t>(wlen > 0 ? kMcpReadRepStart : kMcpRead), static_cast<std::uint8_t>(rlen & 0xFF),
                         static_cast<std::uint8_t>(rlen >> 8), static_cast<std::uint8_t>((address << 1) | 1)};
  exchange(cmd, sizeof cmd, rep, "I2C read");
  if (rep[1] != 0) fail(address, "I2C engine busy (state " + i2c_hex(rep[2]) + ") reading from", I2cError::Kind::kBus);
  std::size_t got = 0;
  int empty_polls = 0;
  while (got < rlen) {
    const std::uint8_t get[1] = {kMcpGetData};
    exchange(get, 1, rep, "get I2C data");
    if (rep[2] == kMcpStateAddrNack) fail(address, "no ACK from", I2cError::Kind::kNack);
    state_error(rep[2]);
    if (rep[1] != 0 || rep[3] == 127) fail(address, "read error (engine state " + i2c_hex(rep[2]) + ") from", I2cError::Kind::kBus);
    const std::size_t k = std::min<std::size_t>(rep[3], rlen - got);
    if (k == 0) {
      if (++empty_polls > 100) fail(address, "no data arrived reading from", I2cError::Kind::kTimeout);
      continue;
    }
    std::memcpy(r + got, rep + 4, k);
    got += k;
  }
}

// ----------------------------------------------------------------------------------------------
// CP2112

Cp2112Bus::Cp2112Bus(std::unique_ptr<HidDevice> device, HidBridgeConfig config)
    : dev_(std::move(device)), c_(require_valid(config, "CP2112")) {
  const auto hz = static_cast<std::uint32_t>(c_.speed_hz);
  const auto to = static_cast<std::uint16_t>(std::clamp(c_.timeout_ms, 0, 1000));
  const std::uint8_t cfg[14] = {kCpSmbusConfig,
                                static_cast<std::uint8_t>(hz >> 24), static_cast<std::uint8_t>(hz >> 16),
                                static_cast<std::uint8_t>(hz >> 8), static_cast<std::uint8_t>(hz),
                                0x02,  // the bridge's own address
                                0x00,  // auto send read off: the host asks with "read force send"
                                static_cast<std::uint8_t>(to >> 8), static_cast<std::uint8_t>(to),  // write time-out, ms
                                static_cast<std::uint8_t>(to >> 8), static_cast<std::uint8_t>(to),  // read time-out, ms
                                0x00,  // SCL low time-out off
                                0x00, 0x01};  // retry an address NACK once inside the bridge
  dev_->send_feature_report(cfg, sizeof cfg);
}

std::string Cp2112Bus::name() const { return "CP2112 " + dev_->path(); }

void Cp2112Bus::fail(std::uint8_t address, const std::string& why, I2cError::Kind kind) {
  const std::uint8_t cancel[64] = {kCpCancel, 0x01};
  try {
    dev_->write(cancel, sizeof cancel);
  } catch (const I2cError&) {
  }
  throw I2cError("I2C: " + why + " " + i2c_hex(address) + " on " + name(), kind);
}

std::size_t Cp2112Bus::read_report(std::uint8_t id, std::uint8_t* buf, std::uint8_t address) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(c_.timeout_ms);
  do {
    const int left = static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count());
    const std::size_t k = dev_->read(buf, 64, std::max(left, 0));
    if (k > 0 && buf[0] == id) return k;
  } while (Clock::now() < deadline);
  fail(address, "bridge did not send report " + i2c_hex(id) + " within " + std::to_string(c_.timeout_ms) + " ms while talking to",
       I2cError::Kind::kTimeout);
}

void Cp2112Bus::wait_complete(std::uint8_t address) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(c_.timeout_ms);
  std::uint8_t rep[64];
  while (true) {
    const std::uint8_t req[64] = {kCpStatusRequest, 0x01};
    dev_->write(req, sizeof req);
    read_report(kCpStatusResponse, rep, address);
    const std::uint8_t status0 = rep[1], status1 = rep[2];
    if (status0 == 2) return;  // complete
    if (status0 == 3) {
      switch (status1) {
        case 0: fail(address, "no ACK (address NACKed or time-out) from", I2cError::Kind::kNack);
        case 1: fail(address, "time-out, bus not free, talking to", I2cError::Kind::kTimeout);
        case 2: fail(address, "arbitration lost talking to", I2cError::Kind::kBus);
        case 3: fail(address, "read incomplete from", I2cError::Kind::kBus);
        case 4: fail(address, "write incomplete to", I2cError::Kind::kBus);
        default: fail(address, "transfer error " + i2c_hex(status1) + " with", I2cError::Kind::kBus);
      }
    }
    if (Clock::now() >= deadline) fail(address, "transfer still busy after " + std::to_string(c_.timeout_ms) + " ms with", I2cError::Kind::kTimeout);
  }
}

void Cp2112Bus::write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r, std::size_t rlen) {
  if ((rlen > 0 && wlen > 16) || wlen > max_write() || rlen > max_read()) {
    throw I2cError("I2C: " + name() + ": transfer of " + std::to_string(wlen) + " + " + std::to_string(rlen) +
                       " bytes exceeds the bridge's limits (16 address bytes before a read, 61 written, 512 read)",
                   I2cError::Kind::kProtocol);
  }
  std::uint8_t req[64] = {};
  const auto a8 = static_cast<std::uint8_t>(address << 1);
  if (wlen > 0 && rlen > 0) {
    req[0] = kCpWriteReadRequest;
    req[1] = a8;
    req[2] = static_cast<std::uint8_t>(rlen >> 8);
    req[3] = static_cast<std::uint8_t>(rlen & 0xFF);
    req[4] = static_cast<std::uint8_t>(wlen);
    std::memcpy(req + 5, w, wlen);
  } else if (rlen == 0) {
    req[0] = kCpWriteRequest;
    req[1] = a8;
    req[2] = static_cast<std::uint8_t>(wlen);
    std::memcpy(req + 3, w, wlen);
  } else {
    req[0] = kCpReadRequest;
    req[1] = a8;
    req[2] = static_cast<std::uint8_t>(rlen >> 8);
    req[3] = static_cast<std::uint8_t>(rlen & 0xFF);
  }
  dev_->write(req, sizeof req);
  wait_complete(address);
  std::size_t got = 0;
  std::uint8_t rep[64];
  while (got < rlen) {
    const std::size_t n = std::min<std::size_t>(61, rlen - got);
    const std::uint8_t force[64] = {kCpReadForceSend, static_cast<std::uint8_t>(n >> 8), static_cast<std::uint8_t>(n & 0xFF)};
    dev_->write(force, sizeof force);
    read_report(kCpReadResponse, rep, address);
    const std::size_t k = std::min<std::size_t>({rep[2], 61, rlen - got});
    if (k == 0) fail(address, "read response without data (status " + i2c_hex(rep[1]) + ") from", I2cError::Kind::kBus);
    std::memcpy(r + got, rep + 3, k);
    got += k;
  }
}

}  // namespace stend::transport
