// Plugin entry of icm42688p.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {
const stend_param_spec kParams[] = {
    STEND_I2C_ROUTE_PARAMS("104"),  // 0x68 (AP_AD0 low); 0x69 with it high
    {"accel_range_g", "integer", "g", "2", 2, 16, nullptr, "accelerometer full scale: 2, 4, 8 or 16 (±g)"},
    {"gyro_range_dps", "integer", "deg/s", "250", 125, 2000, nullptr, "gyroscope full scale: 125, 250, 500, 1000 or 2000 (±°/s)"},
    {"output_rate_hz", "number", "Hz", "100", 12.5, 8000, nullptr, "output data rate (accelerometer and gyroscope): 12.5, 25, 50, 100, 200, 500, 1000, 2000, 4000, 8000"},
    {"mode", "string", "", "fifo", NAN, NAN, "fifo|poll", "fifo: stream mode, 16-byte packets, 2 KiB (temperature then 1 °C/2.07 LSB); poll: the latest sample per acquire"},
};
class Icm42688pSensor final : public stend::i2c_imu::I2cImuSensor {
 public:
  explicit Icm42688pSensor(const stend::Params& p)
      : I2cImuSensor(stend::i2c_imu::make_icm42688p(), stend::i2c_imu::I2cImuConfig::from(p)) {}
};
}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "icm42688p", "0.1.0", "TDK InvenSense ICM-42688-P over I2C", kParams, Icm42688pSensor)
