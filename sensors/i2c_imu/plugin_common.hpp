// What the five I2C sensor plugins share: the route keys of their field tables and the defaults
// a chip's plugin starts from.
#pragma once

#include <stend/fields.hpp>
#include <stend/sdk.hpp>

#include <string>
#include <utility>
#include <vector>

#include "i2c_imu.hpp"

namespace stend::i2c_imu {

using ChipField = fields::Field<I2cImuConfig>;

// How the sensor is reached: bus, device, serial, address, speed_hz, baud, slave_id, timeout_ms, retries.
inline std::vector<ChipField> route_fields() {
  using C = I2cImuConfig;
  using R = transport::I2cRouteConfig;
  constexpr auto route = &C::route;
  return {
      ChipField("bus", route, &R::bus, "",
                "I2C route: Linux i2c-dev, a USB-HID bridge (MCP2221A, CP2112) or the bench microcontroller's MODBUS "
                "window")
          .choices("i2c-dev|mcp2221a|cp2112|bench_mcu"),
      ChipField("device", route, &R::device, "",
                "i2c-dev: the adapter node, e.g. /dev/i2c-1; bench_mcu: the serial port, e.g. /dev/ttyUSB0; bridges: "
                "unused"),
      ChipField("serial", route, &R::serial, "", "HID bridges: USB serial number; empty = the only one attached"),
      ChipField("address", &C::address, "", "7-bit I2C address of the sensor").range(3, 119),
      ChipField("speed_hz", route, &R::speed_hz, "Hz", "HID bridges: SCL clock").range(10000, 1000000),
      ChipField("baud", route, &R::baud, "1/s", "bench_mcu: line rate, 8N1").range(1200, 4000000),
      ChipField("slave_id", route, &R::slave_id, "", "bench_mcu: MODBUS address of the microcontroller").range(1, 247),
      ChipField("timeout_ms", route, &R::timeout_ms, "ms", "per exchange with the adapter, bridge or MCU")
          .range(1, 10000),
      ChipField("retries", &C::retries, "", "extra attempts after a NACK, time-out or bus error (back-off 1 ms, doubling)")
          .range(0, 20),
  };
}

// The `mode` key; `doc` says what FIFO mode means on the chip.
inline ChipField mode_field(std::string doc) {
  return ChipField("mode", &I2cImuConfig::mode, "", std::move(doc)).choices("fifo|poll");
}

// A chip plugin's field table: the route keys, then the chip's own. Defaults are I2cImuConfig's
// with the chip's own address, the plugin's output rate [Hz] and FIFO mode.
inline fields::Table<I2cImuConfig> chip_table(const ChipDriver& chip, double output_rate_hz,
                                              std::vector<ChipField> chip_fields) {
  I2cImuConfig defaults;
  defaults.address = chip.default_address();
  defaults.output_rate_hz = output_rate_hz;
  defaults.mode = "fifo";
  return {chip.plugin(), fields::join(route_fields(), std::move(chip_fields)), std::move(defaults)};
}

}  // namespace stend::i2c_imu
