// Schema rows shared by the five I2C sensor plugins (defaults must equal I2cImuConfig's and the
// chip's; tests/i2c_imu_test.cpp checks them).
#pragma once

#include <stend/sdk.hpp>

#include <cmath>

#define STEND_I2C_ROUTE_PARAMS(DEFAULT_ADDRESS)                                                                       \
  {"bus", "string", "", "i2c-dev", NAN, NAN, "i2c-dev|mcp2221a|cp2112|bench_mcu",                                     \
   "I2C route: Linux i2c-dev, a USB-HID bridge (MCP2221A, CP2112) or the bench microcontroller's MODBUS window"},    \
      {"device", "string", "", "\"\"", NAN, NAN, nullptr,                                                             \
       "i2c-dev: the adapter node, e.g. /dev/i2c-1; bench_mcu: the serial port, e.g. /dev/ttyUSB0; bridges: unused"}, \
      {"serial", "string", "", "\"\"", NAN, NAN, nullptr, "HID bridges: USB serial number; empty = the only one attached"}, \
      {"address", "integer", "", DEFAULT_ADDRESS, 3, 119, nullptr, "7-bit I2C address of the sensor"},                \
      {"speed_hz", "integer", "Hz", "400000", 10000, 1000000, nullptr, "HID bridges: SCL clock"},                     \
      {"baud", "integer", "1/s", "921600", 1200, 4000000, nullptr, "bench_mcu: line rate, 8N1"},                      \
      {"slave_id", "integer", "", "1", 1, 247, nullptr, "bench_mcu: MODBUS address of the microcontroller"},         \
      {"timeout_ms", "integer", "ms", "100", 1, 10000, nullptr, "per exchange with the adapter, bridge or MCU"},      \
      {"retries", "integer", "", "3", 0, 20, nullptr, "extra attempts after a NACK, time-out or bus error (back-off 1 ms, doubling)"}
