// Plugin entry of adxl345: its field table (the shared route keys, then the chip's) and the factory.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {

using namespace stend::i2c_imu;

const stend::fields::Table<I2cImuConfig>& adxl345_fields() {
  using C = I2cImuConfig;
  // The address default is the chip's own 0x53 (ALT ADDRESS low); 0x1D with it high.
  static const stend::fields::Table<I2cImuConfig> table = chip_table(*make_adxl345(), 100.0, {
          ChipField("accel_range_g", &C::accel_range_g, "g", "full scale: 2, 4, 8 or 16 (±g); full resolution, 3.9 mg/LSB")
              .range(2, 16),
          ChipField("output_rate_hz", &C::output_rate_hz, "Hz",
                    "BW_RATE: 6.25, 12.5, 25, 50, 100, 200, 400, 800, 1600, 3200")
              .range(6.25, 3200),
          mode_field("fifo: stream mode, 32 entries; poll: the latest sample per acquire"),
      });
  return table;
}

class Adxl345Sensor final : public I2cImuSensor {
 public:
  explicit Adxl345Sensor(const stend::Params& p) : I2cImuSensor(make_adxl345(), adxl345_fields().read(p)) {}
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "adxl345", "0.1.0",
                    "Analog Devices ADXL345 accelerometer over I2C",
                    adxl345_fields(), Adxl345Sensor)
