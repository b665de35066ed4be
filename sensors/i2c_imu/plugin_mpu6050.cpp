// Plugin entry of mpu6050_i2c: its field table (the shared route keys, then the chip's) and the factory.
#include "i2c_imu.hpp"
#include "plugin_common.hpp"

namespace {

using namespace stend::i2c_imu;

const stend::fields::Table<I2cImuConfig>& mpu6050_fields() {
  using C = I2cImuConfig;
  // The address default is the chip's own 0x68 (AD0 low); 0x69 with AD0 high.
  static const stend::fields::Table<I2cImuConfig> table = chip_table(*make_mpu6050(), 1000.0, {
          ChipField("accel_range_g", &C::accel_range_g, "g", "accelerometer full scale: 2, 4, 8 or 16 (±g)").range(2, 16),
          ChipField("gyro_range_dps", &C::gyro_range_dps, "deg/s", "gyroscope full scale: 250, 500, 1000 or 2000 (±°/s)")
              .range(250, 2000),
          ChipField("dlpf_hz", &C::dlpf_hz, "Hz",
                    "DLPF (CONFIG.DLPF_CFG): 0 = off (260 Hz, 8 kHz gyro rate), 184, 94, 44, 21, 10, 5")
              .range(0, 260),
          ChipField("output_rate_hz", &C::output_rate_hz, "Hz",
                    "8000/(1+n) with dlpf_hz 0, else 1000/(1+n), n = SMPLRT_DIV 0..255")
              .range(3.9, 8000),
          mode_field("fifo: every sample through the 1024-byte FIFO; poll: the latest sample per acquire"),
      });
  return table;
}

class Mpu6050I2cSensor final : public I2cImuSensor {
 public:
  explicit Mpu6050I2cSensor(const stend::Params& p) : I2cImuSensor(make_mpu6050(), mpu6050_fields().read(p)) {}
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "mpu6050_i2c", "0.1.0",
                    "InvenSense MPU-6050 over I2C (i2c-dev, MCP2221A, CP2112 or the bench MCU window)",
                    mpu6050_fields(), Mpu6050I2cSensor)
