// Plugin entry of bmi160: its field table (the shared route keys, then the chip's) and the factory.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {

using namespace stend::i2c_imu;

const stend::fields::Table<I2cImuConfig>& bmi160_fields() {
  using C = I2cImuConfig;
  // The address default is the chip's own 0x68 (SDO low); 0x69 with SDO high.
  static const stend::fields::Table<I2cImuConfig> table = chip_table(*make_bmi160(), 100.0, {
          ChipField("accel_range_g", &C::accel_range_g, "g", "accelerometer full scale: 2, 4, 8 or 16 (±g)").range(2, 16),
          ChipField("gyro_range_dps", &C::gyro_range_dps, "deg/s",
                    "gyroscope full scale: 125, 250, 500, 1000 or 2000 (±°/s)")
              .range(125, 2000),
          ChipField("output_rate_hz", &C::output_rate_hz, "Hz",
                    "output data rate (accelerometer and gyroscope): 25, 50, 100, 200, 400, 800, 1600")
              .range(12.5, 8000),
          mode_field("fifo: headerless gyro + accel frames, 1 KiB; poll: the latest sample per acquire"),
      });
  return table;
}

class Bmi160Sensor final : public I2cImuSensor {
 public:
  explicit Bmi160Sensor(const stend::Params& p) : I2cImuSensor(make_bmi160(), bmi160_fields().read(p)) {}
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "bmi160", "0.1.0",
                    "Bosch BMI160 over I2C",
                    bmi160_fields(), Bmi160Sensor)
