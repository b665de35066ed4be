// Plugin entry of icm42688p: its field table (the shared route keys, then the chip's) and the factory.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {

using namespace stend::i2c_imu;

const stend::fields::Table<I2cImuConfig>& icm42688p_fields() {
  using C = I2cImuConfig;
  // The address default is the chip's own 0x68 (AP_AD0 low); 0x69 with it high.
  static const stend::fields::Table<I2cImuConfig> table = chip_table(*make_icm42688p(), 100.0, {
          ChipField("accel_range_g", &C::accel_range_g, "g", "accelerometer full scale: 2, 4, 8 or 16 (±g)").range(2, 16),
          ChipField("gyro_range_dps", &C::gyro_range_dps, "deg/s",
                    "gyroscope full scale: 125, 250, 500, 1000 or 2000 (±°/s)")
              .range(125, 2000),
          ChipField("output_rate_hz", &C::output_rate_hz, "Hz",
                    "output data rate (accelerometer and gyroscope): 12.5, 25, 50, 100, 200, 500, 1000, 2000, 4000, "
                    "8000")
              .range(12.5, 8000),
          mode_field("fifo: stream mode, 16-byte packets, 2 KiB (temperature then 1 °C/2.07 LSB); poll: the latest "
                     "sample per acquire"),
      });
  return table;
}

class Icm42688pSensor final : public I2cImuSensor {
 public:
  explicit Icm42688pSensor(const stend::Params& p) : I2cImuSensor(make_icm42688p(), icm42688p_fields().read(p)) {}
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "icm42688p", "0.1.0",
                    "TDK InvenSense ICM-42688-P over I2C",
                    icm42688p_fields(), Icm42688pSensor)
