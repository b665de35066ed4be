// Register protocols of the five chips (see README.md for the maps and the sources).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <thread>

#include "i2c_imu.hpp"
#include "stend/physics/units.hpp"

namespace stend::i2c_imu {
namespace {

using transport::I2cDevice;
using transport::I2cError;
using transport::i2c_hex;

std::int32_t le16(const std::uint8_t* p) { return static_cast<std::int16_t>(p[0] | (p[1] << 8)); }
std::int32_t be16(const std::uint8_t* p) { return static_cast<std::int16_t>((p[0] << 8) | p[1]); }

void sleep_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// "a, b, c" with %g.
std::string list(const double* v, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v[i]);
    s += (s.empty() ? "" : ", ") + std::string(b);
  }
  return s;
}
std::string list(std::initializer_list<double> v) { return list(v.begin(), v.size()); }

// Index of `value` in `allowed`, or throws naming the allowed values.
template <std::size_t N>
int pick(const char* plugin, const char* key, double value, const double (&allowed)[N]) {
  for (std::size_t i = 0; i < N; ++i) {
    if (std::abs(allowed[i] - value) <= 1e-9 * std::max(1.0, std::abs(value))) return static_cast<int>(i);
  }
  throw std::invalid_argument(std::string(plugin) + ": " + key + " must be one of " + list(allowed, N) + " (got " +
                              list({value}) + ")");
}

// One write of a chip's register sequence (configure, FIFO set-up), as the datasheet gives it.
struct RegWrite {
  std::uint8_t reg;
  std::uint8_t value;
  std::uint8_t verify_mask;  // bits that must read back as written; kNoReadBack: commands, resets
  const char* name;          // the datasheet's register name, for messages
  int wait_ms;               // [ms] after the write (and its read-back): reset or start-up time
};
constexpr std::uint8_t kAllBits = 0xFF, kNoReadBack = 0x00;

// Writes `seq` in order, reading back every register with a verify_mask: a register that does not
// keep its value means a wrong or broken part (I2cError naming plugin, bus/address, register,
// expected and actual value).
void apply(I2cDevice& d, const char* plugin, std::initializer_list<RegWrite> seq) {
  for (const RegWrite& w : seq) {
    d.write_reg(w.reg, w.value);
    if (w.verify_mask != kNoReadBack) {
      const std::uint8_t got = d.read_reg(w.reg);
      if ((got & w.verify_mask) != (w.value & w.verify_mask)) {
        throw I2cError(std::string(plugin) + ": " + d.where() + ": " + w.name + " (" + i2c_hex(w.reg) + ") reads back " +
                           i2c_hex(got) + " after writing " + i2c_hex(w.value) +
                           (w.verify_mask == kAllBits ? std::string() : " (bits " + i2c_hex(w.verify_mask) + ")") +
                           "; the device is not the configured part or is faulty",
                       I2cError::Kind::kProtocol);
      }
    }
    if (w.wait_ms > 0) sleep_ms(w.wait_ms);
  }
}

// What identifies a part on the bus: the ChipDriver getters of every chip below.
struct ChipIdentity {
  const char* plugin;            // "mpu6050_i2c"
  const char* vendor;
  const char* model;
  std::uint8_t default_address;  // 7-bit
  std::uint8_t id_register;
  const char* id_register_name;  // "WHO_AM_I"
  std::uint8_t expected_id;
};

class IdentifiedChip : public ChipDriver {
 public:
  explicit IdentifiedChip(const ChipIdentity& id) : id_(id) {}
  const char* plugin() const override { return id_.plugin; }
  const char* vendor() const override { return id_.vendor; }
  const char* model() const override { return id_.model; }
  std::uint8_t default_address() const override { return id_.default_address; }
  std::uint8_t id_register() const override { return id_.id_register; }
  const char* id_register_name() const override { return id_.id_register_name; }
  std::uint8_t expected_id() const override { return id_.expected_id; }

 private:
  ChipIdentity id_;
};

// SensorInfo of an accelerometer + gyroscope part with 16-bit outputs: full scale = range, so one
// LSB is range / 32768. Rate [Hz], ranges [g] and [deg/s] as configured, temperature [°C/LSB].
SensorInfo full_scale_info(double rate_hz, double accel_range_g, double gyro_range_dps, double temperature_lsb_c) {
  SensorInfo i;
  i.output_rate_hz = rate_hz;
  i.accel_range_mps2 = accel_range_g * physics::kStandardGravity;
  i.gyro_range_radps = gyro_range_dps * physics::kDegPerSecond;
  i.accel_lsb_mps2 = i.accel_range_mps2 / 32768.0;
  i.gyro_lsb_radps = i.gyro_range_radps / 32768.0;
  i.temperature_lsb_c = temperature_lsb_c;
  return i;
}

// ---------------------------------------------------------------------------------------------
// InvenSense MPU-6050 (register map RM-MPU-6000A-00 rev 4.2)
class Mpu6050 final : public IdentifiedChip {
 public:
  Mpu6050() : IdentifiedChip({"mpu6050_i2c", "InvenSense", "MPU-6050", 0x68, 0x75, "WHO_AM_I", 0x68}) {}
  std::string id_hint(std::uint8_t a) const override {
    switch (a) {
      case 0x70: return "0x70 is an MPU-6500";
      case 0x71: return "0x71 is an MPU-9250";
      case 0x73: return "0x73 is an MPU-9255";
      case 0x47: return "0x47 is an ICM-42688-P: use the icm42688p plugin";
      case 0x12: return "0x12 is an ICM-20602";
      default: return "";
    }
  }
  void validate(const I2cImuConfig& c) override {
    static constexpr double kA[] = {2, 4, 8, 16}, kW[] = {250, 500, 1000, 2000}, kD[] = {0, 184, 94, 44, 21, 10, 5};
    afs_ = pick(plugin(), "accel_range_g", c.accel_range_g, kA);
    fs_ = pick(plugin(), "gyro_range_dps", c.gyro_range_dps, kW);
    dlpf_ = pick(plugin(), "dlpf_hz", c.dlpf_hz, kD);
    const double base = dlpf_ == 0 ? 8000.0 : 1000.0;
    const double div = std::round(base / c.output_rate_hz - 1.0);
    if (!(div >= 0.0 && div <= 255.0 && std::abs(base / (1.0 + div) - c.output_rate_hz) <= 1e-6 * c.output_rate_hz)) {
      throw std::invalid_argument(std::string(plugin()) + ": output_rate_hz " + list({c.output_rate_hz}) + " is not " +
                                  list({base}) + "/(1 + SMPLRT_DIV) for an integer SMPLRT_DIV 0..255 with dlpf_hz " +
                                  std::to_string(c.dlpf_hz) + "; nearest: " + list({base / (1.0 + std::clamp(div, 0.0, 255.0))}) + " Hz");
    }
    div_ = static_cast<int>(div);
    rate_ = base / (1.0 + div);
  }
  SensorInfo info() const override {
    return full_scale_info(rate_, 2.0 * (1 << afs_), 250.0 * (1 << fs_), 1.0 / 340.0);
  }
  double temperature_offset_c() const override { return 36.53; }  // T = raw/340 + 36.53 °C
  void configure(I2cDevice& d) override {
    apply(d, plugin(), {
        {0x6B, 0x80, kNoReadBack, "PWR_MGMT_1", 100},  // DEVICE_RESET; datasheet: wait for the reset to finish
        {0x6B, 0x01, kNoReadBack, "PWR_MGMT_1", 0},    // wake, clock = PLL with the X gyro
        {0x19, static_cast<std::uint8_t>(div_), kAllBits, "SMPLRT_DIV", 0},
        {0x1A, static_cast<std::uint8_t>(dlpf_), kAllBits, "CONFIG", 0},
        {0x1B, static_cast<std::uint8_t>(fs_ << 3), kAllBits, "GYRO_CONFIG", 0},
        {0x1C, static_cast<std::uint8_t>(afs_ << 3), kAllBits, "ACCEL_CONFIG", 0},
    });
    const std::uint8_t pwr = d.read_reg(0x6B);
    if (pwr & 0x40) throw I2cError(std::string(plugin()) + ": " + d.where() + ": still asleep after wake (PWR_MGMT_1 " + i2c_hex(pwr) + ")", I2cError::Kind::kProtocol);
  }
  void stop(I2cDevice& d) override { d.write_reg(0x6B, 0x40); }  // sleep
  bool poll(I2cDevice& d, RawSample& s) override {
    std::uint8_t b[15];  // INT_STATUS (0x3A) then ACCEL_XOUT_H .. GYRO_ZOUT_L in one burst
    d.read_regs(0x3A, b, sizeof b);
    if ((b[0] & 0x01) == 0) return false;  // DATA_RDY_INT
    decode_frame(b + 1, s);
    return true;
  }
  bool supports_fifo() const override { return true; }
  void fifo_start(I2cDevice& d) override {
    d.write_reg(0x6A, 0x04);  // USER_CTRL.FIFO_RESET
    d.write_reg(0x23, 0xF8);  // FIFO_EN: TEMP, XG, YG, ZG, ACCEL → 14-byte frames in register order
    d.write_reg(0x6A, 0x40);  // USER_CTRL.FIFO_EN
    d.read_reg(0x3A);         // clear INT_STATUS
  }
  void fifo_reset(I2cDevice& d) override {
    d.write_reg(0x6A, 0x44);  // reset, keep enabled
    d.read_reg(0x3A);
  }
  std::size_t fifo_frames(I2cDevice& d, bool& overflow) override {
    overflow = (d.read_reg(0x3A) & 0x10) != 0;  // FIFO_OFLOW_INT
    std::uint8_t c[2];
    d.read_regs(0x72, c, 2);  // FIFO_COUNTH, FIFO_COUNTL
    return static_cast<std::size_t>((c[0] << 8) | c[1]) / 14;
  }
  std::size_t frame_bytes() const override { return 14; }
  void fifo_read(I2cDevice& d, std::uint8_t* buf, std::size_t frames) override {
    d.read_regs(0x74, buf, frames * 14, /*advance=*/false);  // FIFO_R_W
  }
  void decode_frame(const std::uint8_t* p, RawSample& s) const override {
    for (int a = 0; a < 3; ++a) {
      s.accel[a] = be16(p + 2 * a);
      s.gyro[a] = be16(p + 8 + 2 * a);
    }
    s.temperature = be16(p + 6);
  }

 private:
  int afs_ = 0, fs_ = 0, dlpf_ = 0, div_ = 0;
  double rate_ = 1000.0;
};

// ---------------------------------------------------------------------------------------------
// Analog Devices ADXL345 (datasheet rev. E)
class Adxl345 final : public IdentifiedChip {
 public:
  Adxl345() : IdentifiedChip({"adxl345", "Analog Devices", "ADXL345", 0x53, 0x00, "DEVID", 0xE5}) {}
  void validate(const I2cImuConfig& c) override {
    static constexpr double kA[] = {2, 4, 8, 16};
    static constexpr double kOdr[] = {6.25, 12.5, 25, 50, 100, 200, 400, 800, 1600, 3200};
    range_ = pick(plugin(), "accel_range_g", c.accel_range_g, kA);
    rate_code_ = 6 + pick(plugin(), "output_rate_hz", c.output_rate_hz, kOdr);
    rate_ = kOdr[rate_code_ - 6];
    fifo_ = c.mode == "fifo";
  }
  SensorInfo info() const override {
    SensorInfo i;
    i.output_rate_hz = rate_;
    i.accel_range_mps2 = 2.0 * (1 << range_) * physics::kStandardGravity;
    i.accel_lsb_mps2 = physics::kStandardGravity / 256.0;  // FULL_RES: 3.9 mg/LSB at every range
    i.has_gyro = false;
    i.has_temperature = false;
    return i;
  }
  void configure(I2cDevice& d) override {
    apply(d, plugin(), {
        {0x2D, 0x00, kNoReadBack, "POWER_CTL", 0},  // standby while configuring
        {0x31, static_cast<std::uint8_t>(0x08 | range_), kAllBits, "DATA_FORMAT", 0},  // FULL_RES, right-justified
        {0x2C, static_cast<std::uint8_t>(rate_code_), kAllBits, "BW_RATE", 0},
        {0x38, 0x00, kNoReadBack, "FIFO_CTL", 0},  // bypass (fifo_start() switches to stream)
        {0x2D, 0x08, kAllBits, "POWER_CTL", 0},    // Measure
    });
  }
  void stop(I2cDevice& d) override { d.write_reg(0x2D, 0x00); }
  bool poll(I2cDevice& d, RawSample& s) override {
    if ((d.read_reg(0x30) & 0x80) == 0) return false;  // INT_SOURCE.DATA_READY
    std::uint8_t b[6];
    d.read_regs(0x32, b, 6);
    decode_frame(b, s);
    return true;
  }
  bool supports_fifo() const override { return true; }
  void fifo_start(I2cDevice& d) override {
    d.write_reg(0x38, 0x80 | 16);  // FIFO_CTL: stream mode, watermark 16
    d.read_reg(0x30);              // clear Overrun
  }
  void fifo_reset(I2cDevice& d) override {
    d.write_reg(0x38, 0x00);  // through bypass: clears the FIFO
    fifo_start(d);
  }
  std::size_t fifo_frames(I2cDevice& d, bool& overflow) override {
    overflow = (d.read_reg(0x30) & 0x01) != 0;  // INT_SOURCE.Overrun: stream mode overwrote unread entries
    return d.read_reg(0x39) & 0x3F;             // FIFO_STATUS.Entries (a burst through 0x32..0x37 would pop one)
  }
  std::size_t frame_bytes() const override { return 6; }
  void fifo_read(I2cDevice& d, std::uint8_t* buf, std::size_t frames) override {
    for (std::size_t i = 0; i < frames; ++i) d.read_regs(0x32, buf + 6 * i, 6);  // each 6-byte read pops one entry
  }
  void decode_frame(const std::uint8_t* p, RawSample& s) const override {
    for (int a = 0; a < 3; ++a) s.accel[a] = le16(p + 2 * a);
  }

 private:
  int range_ = 0, rate_code_ = 10;
  double rate_ = 100.0;
  bool fifo_ = false;
};

// ---------------------------------------------------------------------------------------------
// STMicroelectronics LSM6DSO (datasheet DS12140 rev 2)
class Lsm6dso final : public IdentifiedChip {
 public:
  Lsm6dso() : IdentifiedChip({"lsm6dso", "STMicroelectronics", "LSM6DSO", 0x6A, 0x0F, "WHO_AM_I", 0x6C}) {}
  std::string id_hint(std::uint8_t a) const override {
    if (a == 0x69) return "0x69 is an LSM6DS3";
    if (a == 0x6A) return "0x6A is an LSM6DSL";
    if (a == 0x6B) return "0x6B is an LSM6DSR/ISM330DHCX";
    return "";
  }
  void validate(const I2cImuConfig& c) override {
    static constexpr double kA[] = {2, 4, 8, 16}, kW[] = {125, 250, 500, 1000, 2000};
    static constexpr double kOdr[] = {12.5, 26, 52, 104, 208, 416, 833, 1666, 3332, 6664};
    static constexpr int kFsXl[] = {0, 2, 3, 1};          // FS_XL codes for 2, 4, 8, 16 g
    static constexpr double kXlSens[] = {0.061, 0.122, 0.244, 0.488};  // mg/LSB
    static constexpr double kGSens[] = {4.375, 8.75, 17.5, 35.0, 70.0};  // mdps/LSB
    const int a = pick(plugin(), "accel_range_g", c.accel_range_g, kA);
    const int w = pick(plugin(), "gyro_range_dps", c.gyro_range_dps, kW);
    odr_ = 1 + pick(plugin(), "output_rate_hz", c.output_rate_hz, kOdr);
    ctrl1_ = static_cast<std::uint8_t>((odr_ << 4) | (kFsXl[a] << 2));
    ctrl2_ = static_cast<std::uint8_t>((odr_ << 4) | (w == 0 ? 0x02 : (w - 1) << 2));
    info_ = {};
    info_.output_rate_hz = kOdr[odr_ - 1];
    info_.accel_range_mps2 = kA[a] * physics::kStandardGravity;
    info_.gyro_range_radps = kW[w] * physics::kDegPerSecond;
    info_.accel_lsb_mps2 = kXlSens[a] * physics::kMilliG;
    info_.gyro_lsb_radps = kGSens[w] * 1e-3 * physics::kDegPerSecond;
    info_.temperature_lsb_c = 1.0 / 256.0;
  }
  SensorInfo info() const override { return info_; }
  double temperature_offset_c() const override { return 25.0; }  // 0 LSB = 25 °C, 256 LSB/°C
  void configure(I2cDevice& d) override {
    apply(d, plugin(), {
        {0x12, 0x01, kNoReadBack, "CTRL3_C", 1},  // SW_RESET
        {0x12, 0x44, kAllBits, "CTRL3_C", 0},     // BDU, IF_INC
        {0x10, ctrl1_, kAllBits, "CTRL1_XL", 0},  // ODR_XL, FS_XL
        {0x11, ctrl2_, kAllBits, "CTRL2_G", 0},   // ODR_G, FS_G / FS_125
    });
  }
  void stop(I2cDevice& d) override {
    d.write_reg(0x10, 0x00);
    d.write_reg(0x11, 0x00);
  }
  bool poll(I2cDevice& d, RawSample& s) override {
    std::uint8_t b[16];  // STATUS_REG 0x1E, 0x1F, OUT_TEMP 0x20, OUTX_L_G 0x22.., OUTX_L_A 0x28..0x2D
    d.read_regs(0x1E, b, sizeof b);
    if ((b[0] & 0x01) == 0) return false;  // XLDA
    s.temperature = le16(b + 2);
    for (int a = 0; a < 3; ++a) {
      s.gyro[a] = le16(b + 4 + 2 * a);
      s.accel[a] = le16(b + 10 + 2 * a);
    }
    return true;
  }
  // FIFO: continuous mode, gyro and accel batched at the ODR; a frame is one gyro and one accel
  // word (tag + 6 bytes each); the temperature (not batched) is read once per drain.
  bool supports_fifo() const override { return true; }
  void fifo_start(I2cDevice& d) override {
    apply(d, plugin(), {{0x09, static_cast<std::uint8_t>((odr_ << 4) | odr_), kAllBits, "FIFO_CTRL3", 0}});  // BDR_GY, BDR_XL
    fifo_reset(d);
  }
  void fifo_reset(I2cDevice& d) override {
    d.write_reg(0x0A, 0x00);  // FIFO_CTRL4: bypass empties the FIFO
    d.write_reg(0x0A, 0x06);  // continuous mode
  }
  std::size_t fifo_frames(I2cDevice& d, bool& overflow) override {
    std::uint8_t st[2];
    d.read_regs(0x3A, st, 2);  // FIFO_STATUS1/2
    overflow = (st[1] & 0x40) != 0;  // FIFO_OVR_IA
    std::uint8_t t[2];
    d.read_regs(0x20, t, 2);
    temperature_ = le16(t);
    return static_cast<std::size_t>(st[0] | ((st[1] & 0x03) << 8)) / 2;
  }
  std::size_t frame_bytes() const override { return 14; }
  void fifo_read(I2cDevice& d, std::uint8_t* buf, std::size_t frames) override {
    d.read_regs(0x78, buf, frames * 14, /*advance=*/false);  // words roll over 0x7E → 0x78
    for (std::size_t i = 0; i < 2 * frames; ++i) {
      const int tag = buf[7 * i] >> 3;
      if (tag != 0x01 && tag != 0x02) {
        throw I2cError(std::string(plugin()) + ": " + d.where() + ": FIFO word " + std::to_string(i) + " has tag " +
                           i2c_hex(static_cast<unsigned>(tag)) + " (expected gyro 0x01 or accel 0x02)",
                       I2cError::Kind::kProtocol);
      }
    }
  }
  void decode_frame(const std::uint8_t* p, RawSample& s) const override {
    for (int w = 0; w < 2; ++w) {
      const std::uint8_t* q = p + 7 * w;
      std::int32_t* dst = (q[0] >> 3) == 0x01 ? s.gyro : s.accel;
      for (int a = 0; a < 3; ++a) dst[a] = le16(q + 1 + 2 * a);
    }
    s.temperature = temperature_;
  }

 private:
  std::int32_t temperature_ = 0;
  int odr_ = 4;
  std::uint8_t ctrl1_ = 0, ctrl2_ = 0;
  SensorInfo info_;
};

// ---------------------------------------------------------------------------------------------
// Bosch BMI160 (datasheet BST-BMI160-DS000 rev 0.9)
class Bmi160 final : public IdentifiedChip {
 public:
  Bmi160() : IdentifiedChip({"bmi160", "Bosch Sensortec", "BMI160", 0x68, 0x00, "CHIP_ID", 0xD1}) {}
  std::string id_hint(std::uint8_t a) const override {
    if (a == 0x00) return "0x00 at register 0x00 with an address of 0x68/0x69 is typical of an InvenSense part (MPU-6050: use mpu6050_i2c)";
    if (a == 0xD8) return "0xD8 is a BMI270? (BMI270 CHIP_ID is 0x24); check the part";
    return "";
  }
  void validate(const I2cImuConfig& c) override {
    static constexpr double kA[] = {2, 4, 8, 16}, kW[] = {125, 250, 500, 1000, 2000};
    static constexpr double kOdr[] = {25, 50, 100, 200, 400, 800, 1600};
    static constexpr int kAcc[] = {0x03, 0x05, 0x08, 0x0C};
    const int a = pick(plugin(), "accel_range_g", c.accel_range_g, kA);
    const int w = pick(plugin(), "gyro_range_dps", c.gyro_range_dps, kW);
    const int o = pick(plugin(), "output_rate_hz", c.output_rate_hz, kOdr);
    acc_range_ = static_cast<std::uint8_t>(kAcc[a]);
    gyr_range_ = static_cast<std::uint8_t>(4 - w);  // 0 = ±2000 … 4 = ±125
    odr_ = static_cast<std::uint8_t>(6 + o);       // 100·2^(odr−8) Hz
    info_ = full_scale_info(kOdr[o], kA[a], kW[w], 1.0 / 512.0);
  }
  SensorInfo info() const override { return info_; }
  double temperature_offset_c() const override { return 23.0; }  // 0x0000 = 23 °C, 1/512 K/LSB
  void configure(I2cDevice& d) override {
    apply(d, plugin(), {
        {0x7E, 0xB6, kNoReadBack, "CMD", 1},   // soft reset
        {0x7E, 0x11, kNoReadBack, "CMD", 4},   // accelerometer normal mode
        {0x7E, 0x15, kNoReadBack, "CMD", 80},  // gyroscope normal mode (start-up up to 80 ms)
    });
    const std::uint8_t pmu = d.read_reg(0x03);
    if ((pmu & 0x3C) != 0x14) {
      throw I2cError(std::string(plugin()) + ": " + d.where() + ": PMU_STATUS reads " + i2c_hex(pmu) +
                         " after the normal-mode commands, expected accel and gyro normal (0x14)",
                     I2cError::Kind::kProtocol);
    }
    apply(d, plugin(), {
        {0x40, static_cast<std::uint8_t>(0x20 | odr_), kAllBits, "ACC_CONF", 0},  // acc_bwp normal, acc_odr
        {0x41, acc_range_, kAllBits, "ACC_RANGE", 0},
        {0x42, static_cast<std::uint8_t>(0x20 | odr_), kAllBits, "GYR_CONF", 0},  // gyr_bwp normal, gyr_odr
        {0x43, gyr_range_, kAllBits, "GYR_RANGE", 0},
    });
  }
  void stop(I2cDevice& d) override {
    d.write_reg(0x7E, 0x14);
    d.write_reg(0x7E, 0x10);
  }
  bool poll(I2cDevice& d, RawSample& s) override {
    if ((d.read_reg(0x1B) & 0x80) == 0) return false;  // STATUS.drdy_acc
    std::uint8_t b[12];
    d.read_regs(0x0C, b, sizeof b);  // gyro x y z, accel x y z (little-endian)
    std::uint8_t t[2];
    d.read_regs(0x20, t, 2);         // TEMPERATURE
    for (int a = 0; a < 3; ++a) {
      s.gyro[a] = le16(b + 2 * a);
      s.accel[a] = le16(b + 6 + 2 * a);
    }
    s.temperature = le16(t);
    return true;
  }
  // FIFO: headerless, gyro + accel, 12-byte frames; the temperature (not in the FIFO) is read
  // once per drain and given to every frame of it.
  bool supports_fifo() const override { return true; }
  void fifo_start(I2cDevice& d) override {
    apply(d, plugin(), {
        {0x51, 0x20, kAllBits, "INT_EN_1", 0},       // ffull: report overflows in INT_STATUS_1
        {0x47, 0xC0, kAllBits, "FIFO_CONFIG_1", 0},  // gyro and accel, no header
    });
    fifo_reset(d);
  }
  void fifo_reset(I2cDevice& d) override {
    d.write_reg(0x7E, 0xB0);  // CMD: FIFO flush
    d.read_reg(0x1D);         // clear INT_STATUS_1
  }
  std::size_t fifo_frames(I2cDevice& d, bool& overflow) override {
    overflow = (d.read_reg(0x1D) & 0x20) != 0;  // INT_STATUS_1.ffull_int
    std::uint8_t n[2];
    d.read_regs(0x22, n, 2);  // FIFO_LENGTH, bytes
    std::uint8_t t[2];
    d.read_regs(0x20, t, 2);
    temperature_ = le16(t);
    return static_cast<std::size_t>(n[0] | ((n[1] & 0x07) << 8)) / 12;
  }
  std::size_t frame_bytes() const override { return 12; }
  void fifo_read(I2cDevice& d, std::uint8_t* buf, std::size_t frames) override {
    d.read_regs(0x24, buf, frames * 12, /*advance=*/false);  // FIFO_DATA
  }
  void decode_frame(const std::uint8_t* p, RawSample& s) const override {
    for (int a = 0; a < 3; ++a) {
      s.gyro[a] = le16(p + 2 * a);
      s.accel[a] = le16(p + 6 + 2 * a);
    }
    s.temperature = temperature_;
  }

 private:
  std::int32_t temperature_ = 0;
  std::uint8_t acc_range_ = 3, gyr_range_ = 0, odr_ = 8;
  SensorInfo info_;
};

// ---------------------------------------------------------------------------------------------
// TDK InvenSense ICM-42688-P (datasheet DS-000347 rev 1.7), user bank 0
class Icm42688p final : public IdentifiedChip {
 public:
  Icm42688p() : IdentifiedChip({"icm42688p", "TDK InvenSense", "ICM-42688-P", 0x68, 0x75, "WHO_AM_I", 0x47}) {}
  std::string id_hint(std::uint8_t a) const override {
    if (a == 0x68) return "0x68 is an MPU-6050: use the mpu6050_i2c plugin";
    if (a == 0x42) return "0x42 is an ICM-42605";
    if (a == 0x6F) return "0x6F is an ICM-42670-P";
    return "";
  }
  void validate(const I2cImuConfig& c) override {
    static constexpr double kA[] = {16, 8, 4, 2}, kW[] = {2000, 1000, 500, 250, 125};
    static constexpr double kOdr[] = {12.5, 25, 50, 100, 200, 500, 1000, 2000, 4000, 8000};
    static constexpr int kOdrCode[] = {11, 10, 9, 8, 7, 15, 6, 5, 4, 3};
    const int a = pick(plugin(), "accel_range_g", c.accel_range_g, kA);
    const int w = pick(plugin(), "gyro_range_dps", c.gyro_range_dps, kW);
    const int o = pick(plugin(), "output_rate_hz", c.output_rate_hz, kOdr);
    gyro0_ = static_cast<std::uint8_t>((w << 5) | kOdrCode[o]);
    accel0_ = static_cast<std::uint8_t>((a << 5) | kOdrCode[o]);
    info_ = full_scale_info(kOdr[o], kA[a], kW[w], 1.0 / 132.48);
  }
  SensorInfo info() const override { return info_; }
  double temperature_offset_c() const override { return 25.0; }  // T = raw/132.48 + 25 °C
  void configure(I2cDevice& d) override {
    apply(d, plugin(), {
        {0x76, 0x00, kNoReadBack, "REG_BANK_SEL", 0},  // bank 0
        {0x11, 0x01, kNoReadBack, "DEVICE_CONFIG", 1},  // soft reset
        {0x4F, gyro0_, kAllBits, "GYRO_CONFIG0", 0},    // GYRO_FS_SEL, GYRO_ODR
        {0x50, accel0_, kAllBits, "ACCEL_CONFIG0", 0},  // ACCEL_FS_SEL, ACCEL_ODR
        {0x4E, 0x0F, kAllBits, "PWR_MGMT0", 45},        // gyro and accel low-noise mode; gyro start-up
    });
  }
  void stop(I2cDevice& d) override { d.write_reg(0x4E, 0x00); }
  bool poll(I2cDevice& d, RawSample& s) override {
    if ((d.read_reg(0x2D) & 0x08) == 0) return false;  // INT_STATUS.DATA_RDY_INT
    std::uint8_t b[14];
    d.read_regs(0x1D, b, sizeof b);  // TEMP_DATA1/0, ACCEL_DATA_X1.., GYRO_DATA_X1.. (big-endian)
    s.temperature = be16(b);
    for (int a = 0; a < 3; ++a) {
      s.accel[a] = be16(b + 2 + 2 * a);
      s.gyro[a] = be16(b + 8 + 2 * a);
    }
    return true;
  }
  // FIFO: stream mode, packet 3 (16 bytes: header, accel, gyro, int8 temperature, timestamp).
  bool supports_fifo() const override { return true; }
  void fifo_start(I2cDevice& d) override {
    apply(d, plugin(), {
        {0x16, 0x00, kNoReadBack, "FIFO_CONFIG", 0},  // bypass while configuring
        {0x5F, 0x07, kAllBits, "FIFO_CONFIG1", 0},    // accel, gyro, temperature
        {0x16, 0x40, kAllBits, "FIFO_CONFIG", 0},     // stream-to-FIFO
    });
    fifo_reset(d);
  }
  void fifo_reset(I2cDevice& d) override {
    d.write_reg(0x4B, 0x02);  // SIGNAL_PATH_RESET.FIFO_FLUSH
    d.read_reg(0x2D);         // clear INT_STATUS
  }
  std::size_t fifo_frames(I2cDevice& d, bool& overflow) override {
    overflow = (d.read_reg(0x2D) & 0x02) != 0;  // INT_STATUS.FIFO_FULL_INT: packets were dropped
    std::uint8_t c[2];
    d.read_regs(0x2E, c, 2);  // FIFO_COUNTH/L, bytes, big-endian (INTF_CONFIG0 reset value)
    return static_cast<std::size_t>((c[0] << 8) | c[1]) / 16;
  }
  std::size_t frame_bytes() const override { return 16; }
  void fifo_read(I2cDevice& d, std::uint8_t* buf, std::size_t frames) override {
    d.read_regs(0x30, buf, frames * 16, /*advance=*/false);  // FIFO_DATA
    for (std::size_t i = 0; i < frames; ++i) {
      const std::uint8_t h = buf[16 * i];
      if ((h & 0x80) != 0 || (h & 0x60) != 0x60) {
        throw I2cError(std::string(plugin()) + ": " + d.where() + ": FIFO packet " + std::to_string(i) + " has header " + i2c_hex(h) +
                           " (expected accel + gyro, 0x68); FIFO out of step, resetting it",
                       I2cError::Kind::kProtocol);
      }
    }
  }
  void decode_frame(const std::uint8_t* p, RawSample& s) const override {
    for (int a = 0; a < 3; ++a) {
      s.accel[a] = be16(p + 1 + 2 * a);
      s.gyro[a] = be16(p + 7 + 2 * a);
    }
    s.temperature = static_cast<std::int8_t>(p[13]) * 64;  // FIFO: raw/2.07 + 25 °C = (64·raw)/132.48 + 25
  }

 private:
  std::uint8_t gyro0_ = 0x06, accel0_ = 0x06;
  SensorInfo info_;
};

}  // namespace

std::unique_ptr<ChipDriver> make_mpu6050() { return std::make_unique<Mpu6050>(); }
std::unique_ptr<ChipDriver> make_adxl345() { return std::make_unique<Adxl345>(); }
std::unique_ptr<ChipDriver> make_lsm6dso() { return std::make_unique<Lsm6dso>(); }
std::unique_ptr<ChipDriver> make_bmi160() { return std::make_unique<Bmi160>(); }
std::unique_ptr<ChipDriver> make_icm42688p() { return std::make_unique<Icm42688p>(); }

}  // namespace stend::i2c_imu
