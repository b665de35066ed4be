// Plugin entry of mpu6050_i2c.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {
const stend_param_spec kParams[] = {
    STEND_I2C_ROUTE_PARAMS("104"),  // 0x68 (AD0 low); 0x69 with AD0 high
    {"accel_range_g", "integer", "g", "2", 2, 16, nullptr, "accelerometer full scale: 2, 4, 8 or 16 (±g)"},
    {"gyro_range_dps", "integer", "deg/s", "250", 250, 2000, nullptr, "gyroscope full scale: 250, 500, 1000 or 2000 (±°/s)"},
    {"dlpf_hz", "integer", "Hz", "0", 0, 260, nullptr, "DLPF (CONFIG.DLPF_CFG): 0 = off (260 Hz, 8 kHz gyro rate), 184, 94, 44, 21, 10, 5"},
    {"output_rate_hz", "number", "Hz", "1000", 3.9, 8000, nullptr, "8000/(1+n) with dlpf_hz 0, else 1000/(1+n), n = SMPLRT_DIV 0..255"},
    {"mode", "string", "", "fifo", NAN, NAN, "fifo|poll", "fifo: every sample through the 1024-byte FIFO; poll: the latest sample per acquire"},
};
class Mpu6050I2cSensor final : public stend::i2c_imu::I2cImuSensor {
 public:
  explicit Mpu6050I2cSensor(const stend::Params& p)
      : I2cImuSensor(stend::i2c_imu::make_mpu6050(), stend::i2c_imu::I2cImuConfig::from(p)) {}
};
}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "mpu6050_i2c", "0.1.0",
                    "InvenSense MPU-6050 over I2C (i2c-dev, MCP2221A, CP2112 or the bench MCU window)", kParams,
                    Mpu6050I2cSensor)
