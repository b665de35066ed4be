// Opens an I2C route from its YAML-level description (the `bus:` key of the I2C sensor plugins).
#pragma once

#include <stend/devices/hid.hpp>
#include <stend/devices/i2c.hpp>
#include <stend/devices/i2c_dev.hpp>

#include <memory>
#include <string>

namespace stend::transport {

struct I2cRouteConfig {
  std::string bus = "i2c-dev";  // i2c-dev | mcp2221a | cp2112 | bench_mcu
  std::string device;           // i2c-dev: "/dev/i2c-1"; bench_mcu: serial port; HID bridges: unused
  std::string serial;           // HID bridges: USB serial number ("" = the only one attached)
  int speed_hz = 400000;        // HID bridges: SCL clock
  int baud = 921600;            // bench_mcu: line rate
  int slave_id = 1;             // bench_mcu: MODBUS address
  int timeout_ms = 100;         // per exchange (HID report, MODBUS reply)
  int retries = 3;              // bench_mcu: MODBUS-level retries

  // Seams (null = the real system): tests put emulated peers here.
  std::shared_ptr<I2cDevFile> i2c_dev_file;
  std::shared_ptr<HidBackend> hid_backend;

  // A known bus, with `device` where the bus needs one; a positive clock, rate and time-out, no
  // negative retries.
  bool IsValid(std::string* error = nullptr) const;
};

// Throws I2cError (kOpen) naming the route, or std::invalid_argument for an unknown `bus`.
std::shared_ptr<I2cBus> open_i2c_bus(const I2cRouteConfig& c);

}  // namespace stend::transport
