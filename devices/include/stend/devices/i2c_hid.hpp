// I2C over USB-HID bridges (stend/devices/hid.hpp):
//
// MCP2221A (Microchip, 04d8:00dd; datasheet DS20005565): 64-byte reports without report ID.
//   0x10 status / set parameters (byte 2 = 0x10 cancel, byte 3 = 0x20 set speed, byte 4 = divider
//   12 MHz / f − 3; reply byte 8 = I2C engine state, byte 20 bit 6 = address NACK),
//   0x90 write, 0x94 write without STOP, 0x91 read, 0x93 read with repeated START (bytes 1–2 =
//   length little-endian, byte 3 = 8-bit address, write data from byte 4, ≤ 60 per report),
//   0x40 get I2C data (reply byte 1 = 0 ok, byte 2 = engine state: 0x55 read complete, 0x54
//   partial, 0x25 address NACK; byte 3 = count ≤ 60 or 127 on error; data from byte 4).
// CP2112 (Silicon Labs, 10c4:ea90; AN495): numbered reports.
//   0x06 SMBus configuration (feature), 0x10 data read request, 0x11 data write-read request
//   (≤ 16 address bytes, then repeated START and ≤ 512 bytes read), 0x12 data read force send,
//   0x13 data read response (status, count ≤ 61, data), 0x14 data write (≤ 61 bytes),
//   0x15 transfer status request, 0x16 transfer status response (status0: 0 idle, 1 busy,
//   2 complete, 3 error; status1 on error: 0 address NACK / time-out, 1 bus not free, 2
//   arbitration lost, 3 read incomplete, 4 write incomplete), 0x17 cancel transfer.
#pragma once

#include <stend/devices/hid.hpp>
#include <stend/devices/i2c.hpp>

#include <memory>
#include <string>

namespace stend::transport {

inline constexpr std::uint16_t kMcp2221Vid = 0x04D8, kMcp2221Pid = 0x00DD;
inline constexpr std::uint16_t kCp2112Vid = 0x10C4, kCp2112Pid = 0xEA90;

struct HidBridgeConfig {
  int speed_hz = 400000;   // SCL clock
  int timeout_ms = 100;    // per report exchange

  bool IsValid(std::string* error = nullptr) const {  // both > 0
    return speed_hz > 0 && timeout_ms > 0 ? true : invalid(error, "speed_hz and timeout_ms must be > 0");
  }
};

class Mcp2221Bus final : public I2cBus {
 public:
  // Sets the SCL speed (cancelling a stuck transfer first if the engine is busy).
  Mcp2221Bus(std::unique_ptr<HidDevice> device, HidBridgeConfig config = {});
  std::string name() const override;
  void write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r,
                  std::size_t rlen) override;
  std::size_t max_read() const override { return 1020; }
  std::size_t max_write() const override { return 60; }

 private:
  void exchange(const std::uint8_t* cmd, std::size_t n, std::uint8_t* reply, const char* what);
  void status(std::uint8_t* reply, bool cancel, int divider);
  [[noreturn]] void fail(std::uint8_t address, const std::string& why, I2cError::Kind kind);

  std::unique_ptr<HidDevice> dev_;
  HidBridgeConfig c_;
};

class Cp2112Bus final : public I2cBus {
 public:
  // Writes the SMBus configuration (clock, time-outs, no auto-send-read).
  Cp2112Bus(std::unique_ptr<HidDevice> device, HidBridgeConfig config = {});
  std::string name() const override;
  void write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r,
                  std::size_t rlen) override;
  std::size_t max_read() const override { return 512; }
  std::size_t max_write() const override { return 61; }

 private:
  void wait_complete(std::uint8_t address);
  std::size_t read_report(std::uint8_t id, std::uint8_t* buf, std::uint8_t address);
  [[noreturn]] void fail(std::uint8_t address, const std::string& why, I2cError::Kind kind);

  std::unique_ptr<HidDevice> dev_;
  HidBridgeConfig c_;
};

}  // namespace stend::transport
