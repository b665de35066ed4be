// Plugin entry of adxl345.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {
const stend_param_spec kParams[] = {
    STEND_I2C_ROUTE_PARAMS("83"),  // 0x53 (ALT ADDRESS low); 0x1D with it high
    {"accel_range_g", "integer", "g", "2", 2, 16, nullptr, "full scale: 2, 4, 8 or 16 (±g); full resolution, 3.9 mg/LSB"},
    {"output_rate_hz", "number", "Hz", "100", 6.25, 3200, nullptr, "BW_RATE: 6.25, 12.5, 25, 50, 100, 200, 400, 800, 1600, 3200"},
    {"mode", "string", "", "fifo", NAN, NAN, "fifo|poll", "fifo: stream mode, 32 entries; poll: the latest sample per acquire"},
};
class Adxl345Sensor final : public stend::i2c_imu::I2cImuSensor {
 public:
  explicit Adxl345Sensor(const stend::Params& p)
      : I2cImuSensor(stend::i2c_imu::make_adxl345(), stend::i2c_imu::I2cImuConfig::from(p)) {}
};
}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "adxl345", "0.1.0", "Analog Devices ADXL345 accelerometer over I2C", kParams, Adxl345Sensor)
