// Plugin entry of bmi160.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {
const stend_param_spec kParams[] = {
    STEND_I2C_ROUTE_PARAMS("104"),  // 0x68 (SDO low); 0x69 with SDO high
    {"accel_range_g", "integer", "g", "2", 2, 16, nullptr, "accelerometer full scale: 2, 4, 8 or 16 (±g)"},
    {"gyro_range_dps", "integer", "deg/s", "250", 125, 2000, nullptr, "gyroscope full scale: 125, 250, 500, 1000 or 2000 (±°/s)"},
    {"output_rate_hz", "number", "Hz", "100", 12.5, 8000, nullptr, "output data rate (accelerometer and gyroscope): 25, 50, 100, 200, 400, 800, 1600"},
    {"mode", "string", "", "fifo", NAN, NAN, "fifo|poll", "fifo: headerless gyro + accel frames, 1 KiB; poll: the latest sample per acquire"},
};
class Bmi160Sensor final : public stend::i2c_imu::I2cImuSensor {
 public:
  explicit Bmi160Sensor(const stend::Params& p)
      : I2cImuSensor(stend::i2c_imu::make_bmi160(), stend::i2c_imu::I2cImuConfig::from(p)) {}
};
}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "bmi160", "0.1.0", "Bosch BMI160 over I2C", kParams, Bmi160Sensor)
