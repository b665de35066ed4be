// Plugin entry of lsm6dso: its field table (the shared route keys, then the chip's) and the factory.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {

using namespace stend::i2c_imu;

const stend::fields::Table<I2cImuConfig>& lsm6dso_fields() {
  using C = I2cImuConfig;
  // The address default is the chip's own 0x6A (SA0 low); 0x6B with SA0 high.
  static const stend::fields::Table<I2cImuConfig> table = chip_table(*make_lsm6dso(), 104.0, {
          ChipField("accel_range_g", &C::accel_range_g, "g", "accelerometer full scale: 2, 4, 8 or 16 (±g)").range(2, 16),
          ChipField("gyro_range_dps", &C::gyro_range_dps, "deg/s",
                    "gyroscope full scale: 125, 250, 500, 1000 or 2000 (±°/s)")
              .range(125, 2000),
          ChipField("output_rate_hz", &C::output_rate_hz, "Hz",
                    "output data rate (accelerometer and gyroscope): 12.5, 26, 52, 104, 208, 416, 833, 1666, 3332, 6664")
              .range(12.5, 8000),
          mode_field("fifo: continuous mode, gyro + accel words (3 KiB); poll: the latest sample per acquire"),
      });
  return table;
}

class Lsm6dsoSensor final : public I2cImuSensor {
 public:
  explicit Lsm6dsoSensor(const stend::Params& p) : I2cImuSensor(make_lsm6dso(), lsm6dso_fields().read(p)) {}
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "lsm6dso", "0.1.0",
                    "STMicroelectronics LSM6DSO over I2C",
                    lsm6dso_fields(), Lsm6dsoSensor)
