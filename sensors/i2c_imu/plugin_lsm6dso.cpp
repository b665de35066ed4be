// Plugin entry of lsm6dso.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {
const stend_param_spec kParams[] = {
    STEND_I2C_ROUTE_PARAMS("106"),  // 0x6A (SA0 low); 0x6B with SA0 high
    {"accel_range_g", "integer", "g", "2", 2, 16, nullptr, "accelerometer full scale: 2, 4, 8 or 16 (±g)"},
    {"gyro_range_dps", "integer", "deg/s", "250", 125, 2000, nullptr, "gyroscope full scale: 125, 250, 500, 1000 or 2000 (±°/s)"},
    {"output_rate_hz", "number", "Hz", "104", 12.5, 8000, nullptr, "output data rate (accelerometer and gyroscope): 12.5, 26, 52, 104, 208, 416, 833, 1666, 3332, 6664"},
    {"mode", "string", "", "fifo", NAN, NAN, "fifo|poll", "fifo: continuous mode, gyro + accel words (3 KiB); poll: the latest sample per acquire"},
};
class Lsm6dsoSensor final : public stend::i2c_imu::I2cImuSensor {
 public:
  explicit Lsm6dsoSensor(const stend::Params& p)
      : I2cImuSensor(stend::i2c_imu::make_lsm6dso(), stend::i2c_imu::I2cImuConfig::from(p)) {}
};
}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "lsm6dso", "0.1.0", "STMicroelectronics LSM6DSO over I2C", kParams, Lsm6dsoSensor)
