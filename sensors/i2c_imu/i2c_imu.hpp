// I2C inertial sensors over any I2C route (Linux i2c-dev, MCP2221A / CP2112 USB-HID bridges, the
// bench microcontroller's MODBUS RTU window): one generic Sensor (identity check, configuration,
// FIFO or polled acquisition, retries, gap marking) and one ChipDriver per part — MPU-6050,
// ADXL345, LSM6DSO, BMI160, ICM-42688-P. See README.md.
#pragma once

#include <stend/sdk.hpp>
#include <stend/devices/i2c.hpp>
#include <stend/devices/i2c_route.hpp>

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

namespace stend::i2c_imu {

// One I2C sensor's settings. A chip's plugin reads them from its Params through its field table
// (plugin_common.hpp: chip_table), whose defaults are these with the chip's own.
struct I2cImuConfig {
  transport::I2cRouteConfig route;  // bus, device, serial, speed_hz, baud, slave_id, timeout_ms
  int address = -1;                 // 7-bit; -1 = the chip's default
  int accel_range_g = 2;
  int gyro_range_dps = 250;
  double output_rate_hz = 100.0;
  int dlpf_hz = 0;                  // MPU-6050 only
  std::string mode = "poll";        // "fifo" or "poll" (the plugins default to fifo)
  int retries = 3;                  // I2C-level retries after a NACK, time-out or bus error

  // A 7-bit address (or −1), a known bus with the device it needs, a known mode, no negative
  // retries, a time-out of at least 1 ms, a positive rate. What one chip accepts (ranges, rates,
  // FIFO) its ChipDriver checks.
  bool IsValid(std::string* error = nullptr) const;
};

// Counts of one sample as the chip delivers them.
struct RawSample {
  std::int32_t accel[3] = {0, 0, 0};
  std::int32_t gyro[3] = {0, 0, 0};
  std::int32_t temperature = 0;
};

// One chip's register protocol. The generic sensor calls validate() at construction (no bus
// access), then identity check, configure(), and either the FIFO calls or poll().
class ChipDriver {
 public:
  virtual ~ChipDriver() = default;
  virtual const char* plugin() const = 0;  // "mpu6050_i2c"
  virtual const char* vendor() const = 0;
  virtual const char* model() const = 0;
  virtual std::uint8_t default_address() const = 0;
  virtual std::uint8_t id_register() const = 0;
  virtual const char* id_register_name() const = 0;  // "WHO_AM_I"
  virtual std::uint8_t expected_id() const = 0;
  // A word on what a wrong identity value suggests ("0x70 is an MPU-6500"), or "".
  virtual std::string id_hint(std::uint8_t actual) const;
  // Throws std::invalid_argument for settings the part cannot make (naming the possible ones).
  virtual void validate(const I2cImuConfig& c) = 0;
  virtual SensorInfo info() const = 0;
  virtual double temperature_offset_c() const { return 0.0; }  // T = offset + counts · lsb
  virtual void configure(transport::I2cDevice& d) = 0;  // after the identity check
  virtual void stop(transport::I2cDevice& /*d*/) {}
  // Polled mode: true when a new sample was read into `s`.
  virtual bool poll(transport::I2cDevice& d, RawSample& s) = 0;
  // FIFO mode (supports_fifo()).
  virtual bool supports_fifo() const { return false; }
  virtual void fifo_start(transport::I2cDevice& /*d*/) {}
  virtual void fifo_reset(transport::I2cDevice& /*d*/) {}
  // Complete frames waiting; `overflow` set when the chip dropped samples since the last call.
  virtual std::size_t fifo_frames(transport::I2cDevice& /*d*/, bool& overflow) { return overflow = false, 0; }
  virtual std::size_t frame_bytes() const { return 0; }
  virtual void fifo_read(transport::I2cDevice& /*d*/, std::uint8_t* /*buf*/, std::size_t /*frames*/) {}
  virtual void decode_frame(const std::uint8_t* /*p*/, RawSample& /*s*/) const {}
};

std::unique_ptr<ChipDriver> make_mpu6050();
std::unique_ptr<ChipDriver> make_adxl345();
std::unique_ptr<ChipDriver> make_lsm6dso();
std::unique_ptr<ChipDriver> make_bmi160();
std::unique_ptr<ChipDriver> make_icm42688p();

struct I2cLinkReport {
  std::uint64_t samples = 0, samples_lost = 0, gaps = 0;
  std::uint64_t fifo_reads = 0;      // FIFO burst transactions
  std::uint64_t payload_bytes = 0;   // sample bytes delivered
  transport::I2cStats bus;           // retries, NACKs, time-outs, bytes
  std::vector<std::string> events;   // one line per retried fault, gap or failure
};

class I2cImuSensor : public Sensor {
 public:
  I2cImuSensor(std::unique_ptr<ChipDriver> chip, I2cImuConfig c);
  ~I2cImuSensor() override;

  SensorIdentity identity() const override;
  SensorInfo info() const override { return chip_->info(); }
  void start(double t0_s) override;
  void acquire(double t_s, const TruthSource& truth, std::vector<ImuSample>& out) override;
  void stop() override;

  const I2cLinkReport& report() const;
  const I2cImuConfig& config() const { return c_; }
  // "mpu6050_i2c: /dev/i2c-1, address 0x68"
  std::string where() const;

 private:
  ImuSample convert(const RawSample& r, double t_s) const;
  void read_fifo(double t_s);

  std::unique_ptr<ChipDriver> chip_;
  I2cImuConfig c_;
  std::unique_ptr<transport::I2cDevice> dev_;
  std::string who_am_i_;
  double t0_ = 0.0, period_s_ = 0.01;
  std::uint64_t next_seq_ = 0;
  double last_poll_t_ = 0.0;  // polled mode: time of the last sample delivered
  bool gap_pending_ = false;
  std::chrono::steady_clock::time_point started_{};
  std::deque<ImuSample> pending_;
  std::uint64_t faults_seen_ = 0;
  mutable I2cLinkReport report_;
};

}  // namespace stend::i2c_imu
