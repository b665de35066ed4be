// Plugin entry of mpu6050_modbus: the configuration schema and the factory.
#include <stend/sdk.hpp>

#include <cmath>

#include "mpu6050_modbus.hpp"

namespace {

// Defaults must equal Mpu6050ModbusConfig's (tests/mpu6050_modbus_test.cpp checks it).
const stend_param_spec kParams[] = {
    {"device", "string", "", nullptr, NAN, NAN, nullptr,
     "serial port of the USB–RS-485 converter the bench microcontroller hangs on, e.g. /dev/ttyUSB0"},
    {"baud", "integer", "1/s", "921600", 1200, 4000000, nullptr, "line rate, 8N1"},
    {"slave_id", "integer", "", "1", 1, 247, nullptr, "MODBUS address of the bench microcontroller"},
    {"accel_range_g", "integer", "g", "2", 2, 16, nullptr, "accelerometer full scale: 2, 4, 8 or 16 (±g)"},
    {"gyro_range_dps", "integer", "deg/s", "250", 250, 2000, nullptr, "gyroscope full scale: 250, 500, 1000 or 2000 (±°/s)"},
    {"dlpf_hz", "integer", "Hz", "0", 0, 260, nullptr,
     "MPU-6050 digital low-pass (CONFIG.DLPF_CFG): 0 = off (260 Hz, 8 kHz gyro rate), 184, 94, 44, 21, 10, 5"},
    {"output_rate_hz", "number", "Hz", "1000", 3.9, 8000, nullptr,
     "sample rate; must be 8000/(1+n) with dlpf_hz 0, else 1000/(1+n), n = SMPLRT_DIV 0..255"},
    {"timeout_ms", "integer", "ms", "100", 1, 10000, nullptr, "MODBUS response time-out per attempt"},
    {"retries", "integer", "", "3", 0, 20, nullptr,
     "extra attempts after a CRC error or time-out (back-off 5 ms, doubling)"},
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "mpu6050_modbus", "0.1.0",
                    "InvenSense MPU-6050 via the bench microcontroller, MODBUS RTU over a serial port",
                    kParams, stend::mpu6050::Mpu6050Modbus)
