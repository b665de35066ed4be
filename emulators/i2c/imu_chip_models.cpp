#include "imu_chip_models.hpp"

#include <stend/physics/units.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace stend::emu {
namespace {

class FnTruth final : public TruthSource {
 public:
  explicit FnTruth(const TruthFn& f) : f_(f) {}
  BenchTruth at(double t_s) const override {
    BenchTruth b = f_(t_s);
    b.t_s = t_s;
    return b;
  }

 private:
  const TruthFn& f_;
};

void put_le(std::uint8_t* p, std::int32_t v) {
  const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(v));
  p[0] = static_cast<std::uint8_t>(u & 0xFF);
  p[1] = static_cast<std::uint8_t>(u >> 8);
}
void put_be(std::uint8_t* p, std::int32_t v) {
  const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(v));
  p[0] = static_cast<std::uint8_t>(u >> 8);
  p[1] = static_cast<std::uint8_t>(u & 0xFF);
}

}  // namespace

TruthFn static_truth(const BenchTruth& t) {
  return [t](double) { return t; };
}

// ---------------------------------------------------------------------------------------------
void Mpu6050I2c::i2c_write(const std::uint8_t* data, std::size_t n, double now_s) {
  m_.advance(now_s, {});
  if (n == 0) return;
  ptr_ = data[0];
  for (std::size_t i = 1; i < n; ++i) m_.write(ptr_++, data[i]);
}

void Mpu6050I2c::i2c_read(std::uint8_t* data, std::size_t n, double now_s) {
  m_.advance(now_s, {});
  m_.i2c_read(ptr_, data, n);
}

// ---------------------------------------------------------------------------------------------
void RegisterImuModel::advance(double t_s) {
  if (t_s <= now_s_) return;
  if (!running()) {
    imu_.reset();
    now_s_ = t_s;
    return;
  }
  if (!imu_) {
    imu_ = std::make_unique<sim::SimImu>(output_config(physics_));
    imu_->start(now_s_);
  }
  const FnTruth truth(truth_);
  std::vector<ImuSample> samples;
  imu_->acquire(t_s, truth, samples);
  now_s_ = t_s;
  for (const ImuSample& s : samples) latch(s, s.t_s);
}

void RegisterImuModel::i2c_write(const std::uint8_t* data, std::size_t n, double now_s) {
  advance(now_s);
  if (n == 0) return;
  ptr_ = data[0];
  for (std::size_t i = 1; i < n; ++i) {
    const std::uint8_t reg = ptr_;
    if (writable(reg)) {
      regs_[reg] = data[i];
      on_write(reg, data[i]);
      if (restarts(reg)) restart();
    }
    if (auto_increment()) ptr_ = static_cast<std::uint8_t>(ptr_ + 1);
  }
}

void RegisterImuModel::i2c_read(std::uint8_t* data, std::size_t n, double now_s) {
  advance(now_s);
  const std::uint8_t first = ptr_;
  for (std::size_t i = 0; i < n; ++i) {
    data[i] = on_read(ptr_);
    if (auto_increment() && !fifo_port(ptr_)) ptr_ = next_register(ptr_);
  }
  after_read(first, n);
}

// ---------------------------------------------------------------------------------------------
// ADXL345
Adxl345Model::Adxl345Model(sim::SimImuConfig physics, TruthFn truth, int devid)
    : RegisterImuModel(std::move(physics), std::move(truth)), devid_(devid) {
  reset_registers();
}

void Adxl345Model::reset_registers() {
  regs_.fill(0);
  regs_[0x00] = static_cast<std::uint8_t>(devid_);
  regs_[0x2C] = 0x0A;  // 100 Hz
  regs_[0x30] = 0x02;
  fifo_.clear();
}

bool Adxl345Model::writable(std::uint8_t reg) const {
  return (reg >= 0x1D && reg <= 0x2A) || (reg >= 0x2C && reg <= 0x2F) || reg == 0x31 || reg == 0x38;
}

void Adxl345Model::on_write(std::uint8_t reg, std::uint8_t /*value*/) {
  if (reg == 0x38) {  // a mode change (e.g. through bypass) clears the FIFO
    fifo_.clear();
    regs_[0x39] = 0;
  }
}

std::uint8_t Adxl345Model::on_read(std::uint8_t reg) {
  if (reg == 0x30) {
    const std::uint8_t v = regs_[0x30];
    regs_[0x30] = static_cast<std::uint8_t>(v & ~0x01);  // Overrun cleared by reading
    return v;
  }
  return regs_[reg];
}

void Adxl345Model::show_front() {  // FIFO and stream modes: the oldest entry sits in DATAX0..DATAZ1
  if (!fifo_.empty()) std::copy(fifo_.front().begin(), fifo_.front().end(), &regs_[0x32]);
  regs_[0x39] = static_cast<std::uint8_t>(std::min<std::size_t>(fifo_.size(), 32));
  if (fifo_.empty()) {
    regs_[0x30] = static_cast<std::uint8_t>(regs_[0x30] & ~0x80);
  } else {
    regs_[0x30] |= 0x80;  // DATA_READY
  }
}

void Adxl345Model::after_read(std::uint8_t first, std::size_t n) {
  const unsigned last = first + static_cast<unsigned>(n) - 1;
  if (first > 0x37 || last < 0x37) return;  // a read through DATAZ1 completes a data read
  if ((regs_[0x38] >> 6) == 0) {
    regs_[0x30] = static_cast<std::uint8_t>(regs_[0x30] & ~0x80);
    return;
  }
  if (!fifo_.empty()) fifo_.pop_front();
  show_front();
}

sim::SimImuConfig Adxl345Model::output_config(sim::SimImuConfig c) const {
  const int code = regs_[0x2C] & 0x0F;
  const int range = regs_[0x31] & 0x03;
  c.accel_range_g = 2.0 * (1 << range);
  if (regs_[0x31] & 0x08) {  // FULL_RES: 3.9 mg/LSB (1/256 g), 10 + range bits
    c.accel_lsb_mps2 = physics::kStandardGravity / 256.0;
    c.output_bits = 10 + range;
  } else {  // 10-bit at every range
    c.accel_lsb_mps2 = 2.0 * c.accel_range_g * physics::kStandardGravity / 1024.0;
    c.output_bits = 10;
  }
  c.gyro_lsb_radps = 0.0;
  c.output_rate_hz = 3200.0 / std::ldexp(1.0, 15 - code);
  c.lowpass_hz = 0.0;  // the part's bandwidth is ODR/2: nothing to add at the sample instants
  return c;
}

void Adxl345Model::latch(const ImuSample& s, double /*t_s*/) {
  std::array<std::uint8_t, 6> b{};
  for (int i = 0; i < 3; ++i) put_le(&b[static_cast<std::size_t>(2 * i)], s.accel_counts[i]);
  const int mode = regs_[0x38] >> 6;
  if (mode == 0) {
    std::copy(b.begin(), b.end(), &regs_[0x32]);
    regs_[0x30] |= 0x80;  // DATA_READY
    return;
  }
  if (fifo_.size() >= 32) {
    if (mode == 2) {  // stream: the oldest is overwritten
      fifo_.pop_front();
      fifo_.push_back(b);
    }
    regs_[0x30] |= 0x01;  // Overrun
  } else {
    fifo_.push_back(b);
  }
  show_front();
}

// ---------------------------------------------------------------------------------------------
// LSM6DSO
namespace {
constexpr double kLsmOdr[11] = {0.0, 12.5, 26.0, 52.0, 104.0, 208.0, 416.0, 833.0, 1666.0, 3332.0, 6664.0};
}

Lsm6dsoModel::Lsm6dsoModel(sim::SimImuConfig physics, TruthFn truth, int who_am_i)
    : RegisterImuModel(std::move(physics), std::move(truth)), who_(who_am_i) {
  reset_registers();
}

void Lsm6dsoModel::reset_registers() {
  regs_.fill(0);
  regs_[0x0F] = static_cast<std::uint8_t>(who_);
  regs_[0x12] = 0x04;  // IF_INC
  fifo_.clear();
}

void Lsm6dsoModel::on_write(std::uint8_t reg, std::uint8_t value) {
  if (reg == 0x12 && (value & 0x01)) {  // SW_RESET
    reset_registers();
    restart();
  }
  if (reg == 0x0A && (value & 0x07) == 0) {  // bypass: FIFO emptied
    fifo_.clear();
    regs_[0x3B] = 0;
  }
}

void Lsm6dsoModel::show_word() {  // the oldest word in FIFO_DATA_OUT_TAG..Z_H, the count in FIFO_STATUS1/2
  if (!fifo_.empty()) std::copy(fifo_.front().begin(), fifo_.front().end(), &regs_[0x78]);
  regs_[0x3A] = static_cast<std::uint8_t>(fifo_.size() & 0xFF);
  regs_[0x3B] = static_cast<std::uint8_t>((regs_[0x3B] & 0xC0) | ((fifo_.size() >> 8) & 0x03));
}

void Lsm6dsoModel::after_read(std::uint8_t first, std::size_t n) {
  if (first <= 0x3B && first + n > 0x3B) regs_[0x3B] = static_cast<std::uint8_t>(regs_[0x3B] & ~0x40);  // FIFO_OVR_IA: cleared by reading
}

std::uint8_t Lsm6dsoModel::on_read(std::uint8_t reg) {
  if (reg >= 0x78 && reg <= 0x7E) {
    const std::uint8_t v = fifo_.empty() ? 0 : fifo_.front()[static_cast<std::size_t>(reg - 0x78)];
    if (reg == 0x7E && !fifo_.empty()) {  // the last byte of a word: next word
      fifo_.pop_front();
      show_word();
    }
    return v;
  }
  const std::uint8_t v = regs_[reg];
  if (reg == 0x21) regs_[0x1E] = static_cast<std::uint8_t>(regs_[0x1E] & ~0x04);  // TDA
  if (reg == 0x27) regs_[0x1E] = static_cast<std::uint8_t>(regs_[0x1E] & ~0x02);  // GDA
  if (reg == 0x2D) regs_[0x1E] = static_cast<std::uint8_t>(regs_[0x1E] & ~0x01);  // XLDA
  return v;
}

sim::SimImuConfig Lsm6dsoModel::output_config(sim::SimImuConfig c) const {
  static constexpr double kXlFs[4] = {2.0, 16.0, 4.0, 8.0};
  static constexpr double kXlSens[4] = {0.061, 0.488, 0.122, 0.244};  // mg/LSB
  static constexpr double kGFs[4] = {250.0, 500.0, 1000.0, 2000.0};
  static constexpr double kGSens[4] = {8.75, 17.5, 35.0, 70.0};  // mdps/LSB
  const int xl = (regs_[0x10] >> 2) & 3, g = (regs_[0x11] >> 2) & 3;
  const bool fs125 = (regs_[0x11] & 0x02) != 0;
  c.accel_range_g = kXlFs[xl];
  c.accel_lsb_mps2 = kXlSens[xl] * physics::kMilliG;
  c.gyro_range_dps = fs125 ? 125.0 : kGFs[g];
  c.gyro_lsb_radps = (fs125 ? 4.375 : kGSens[g]) * 1e-3 * physics::kDegPerSecond;
  c.output_bits = 16;
  const int odr = std::max(std::min(regs_[0x10] >> 4, 10), std::min(regs_[0x11] >> 4, 10));
  c.output_rate_hz = kLsmOdr[odr];
  c.lowpass_hz = 0.0;
  c.temperature_offset_c = 25.0;
  c.temperature_counts_per_c = 256.0;
  return c;
}

void Lsm6dsoModel::latch(const ImuSample& s, double /*t_s*/) {
  put_le(&regs_[0x20], s.temperature_counts);
  for (int i = 0; i < 3; ++i) put_le(&regs_[static_cast<std::size_t>(0x22 + 2 * i)], s.gyro_counts[i]);
  for (int i = 0; i < 3; ++i) put_le(&regs_[static_cast<std::size_t>(0x28 + 2 * i)], s.accel_counts[i]);
  regs_[0x1E] |= 0x07;
  if ((regs_[0x0A] & 0x07) == 6) {  // continuous mode
    auto push = [&](std::uint8_t tag, std::size_t from, bool batched) {
      if (!batched) return;
      std::array<std::uint8_t, 7> w{};
      w[0] = static_cast<std::uint8_t>(tag << 3);
      std::copy(&regs_[from], &regs_[from] + 6, w.begin() + 1);
      if (fifo_.size() >= 438) {
        fifo_.pop_front();
        regs_[0x3B] |= 0x40;  // FIFO_OVR_IA
      }
      fifo_.push_back(w);
    };
    push(0x01, 0x22, (regs_[0x09] >> 4) != 0);   // gyroscope, BDR_GY
    push(0x02, 0x28, (regs_[0x09] & 0x0F) != 0); // accelerometer, BDR_XL
    show_word();
  }
}

// ---------------------------------------------------------------------------------------------
// BMI160
Bmi160Model::Bmi160Model(sim::SimImuConfig physics, TruthFn truth, int chip_id)
    : RegisterImuModel(std::move(physics), std::move(truth)), chip_id_(chip_id) {
  reset_registers();
}

void Bmi160Model::reset_registers() {
  regs_.fill(0);
  regs_[0x00] = static_cast<std::uint8_t>(chip_id_);
  regs_[0x40] = 0x28;  // 100 Hz, normal filter
  regs_[0x41] = 0x03;  // ±2 g
  regs_[0x42] = 0x28;
  regs_[0x43] = 0x00;  // ±2000 °/s
  fifo_.clear();
}

void Bmi160Model::on_write(std::uint8_t reg, std::uint8_t value) {
  if (reg != 0x7E) return;
  std::uint8_t& pmu = regs_[0x03];
  switch (value) {
    case 0x11: pmu = static_cast<std::uint8_t>((pmu & ~0x30) | 0x10); restart(); break;  // accel normal
    case 0x10: pmu = static_cast<std::uint8_t>(pmu & ~0x30); restart(); break;            // accel suspend
    case 0x15: pmu = static_cast<std::uint8_t>((pmu & ~0x0C) | 0x04); break;             // gyro normal
    case 0x14: pmu = static_cast<std::uint8_t>(pmu & ~0x0C); break;                      // gyro suspend
    case 0xB0: fifo_.clear(); break;                                                      // FIFO flush
    case 0xB6: reset_registers(); restart(); break;                                       // soft reset
    default: break;
  }
  regs_[0x7E] = 0;
}

std::uint8_t Bmi160Model::on_read(std::uint8_t reg) {
  if (reg == 0x22) return static_cast<std::uint8_t>(fifo_.size() & 0xFF);
  if (reg == 0x23) return static_cast<std::uint8_t>((fifo_.size() >> 8) & 0x07);
  if (reg == 0x24) {
    if (fifo_.empty()) return 0x80;  // over-read: the part returns 0x8000 words
    const std::uint8_t b = fifo_.front();
    fifo_.pop_front();
    return b;
  }
  if (reg == 0x1D) {
    const std::uint8_t v = regs_[0x1D];
    regs_[0x1D] = 0;  // cleared by reading (non-latched interrupt mode)
    return v;
  }
  const std::uint8_t v = regs_[reg];
  if (reg == 0x17) regs_[0x1B] = static_cast<std::uint8_t>(regs_[0x1B] & ~0x80);  // drdy_acc
  if (reg == 0x11) regs_[0x1B] = static_cast<std::uint8_t>(regs_[0x1B] & ~0x40);  // drdy_gyr
  return v;
}

sim::SimImuConfig Bmi160Model::output_config(sim::SimImuConfig c) const {
  const int r = regs_[0x41] & 0x0F;
  c.accel_range_g = r == 0x05 ? 4.0 : r == 0x08 ? 8.0 : r == 0x0C ? 16.0 : 2.0;
  c.gyro_range_dps = 2000.0 / (1 << std::min(regs_[0x43] & 0x07, 4));
  c.accel_lsb_mps2 = 0.0;  // full scale / 32768
  c.gyro_lsb_radps = 0.0;
  c.output_bits = 16;
  c.output_rate_hz = 100.0 * std::ldexp(1.0, (regs_[0x40] & 0x0F) - 8);
  c.lowpass_hz = 0.0;
  c.temperature_offset_c = 23.0;
  c.temperature_counts_per_c = 512.0;
  return c;
}

void Bmi160Model::latch(const ImuSample& s, double t_s) {
  const bool gyro_on = (regs_[0x03] & 0x0C) == 0x04;
  for (int i = 0; i < 3; ++i) put_le(&regs_[static_cast<std::size_t>(0x0C + 2 * i)], gyro_on ? s.gyro_counts[i] : 0);
  for (int i = 0; i < 3; ++i) put_le(&regs_[static_cast<std::size_t>(0x12 + 2 * i)], s.accel_counts[i]);
  const auto ticks = static_cast<std::uint32_t>(t_s / 39.0625e-6);  // SENSORTIME: 39.0625 µs per LSB
  regs_[0x18] = static_cast<std::uint8_t>(ticks & 0xFF);
  regs_[0x19] = static_cast<std::uint8_t>((ticks >> 8) & 0xFF);
  regs_[0x1A] = static_cast<std::uint8_t>((ticks >> 16) & 0xFF);
  put_le(&regs_[0x20], s.temperature_counts);
  regs_[0x1B] = static_cast<std::uint8_t>(regs_[0x1B] | 0x80 | (gyro_on ? 0x40 : 0));
  const std::uint8_t cfg = regs_[0x47];
  if ((cfg & 0xC0) != 0 && (cfg & 0x10) == 0) {  // headerless FIFO with gyro and/or accel
    std::vector<std::uint8_t> frame;
    if (cfg & 0x80) frame.insert(frame.end(), &regs_[0x0C], &regs_[0x0C] + 6);
    if (cfg & 0x40) frame.insert(frame.end(), &regs_[0x12], &regs_[0x12] + 6);
    while (fifo_.size() + frame.size() > 1024) {
      fifo_.erase(fifo_.begin(), fifo_.begin() + static_cast<std::ptrdiff_t>(frame.size()));  // overwrite the oldest
      if (regs_[0x51] & 0x20) regs_[0x1D] |= 0x20;                                           // ffull
    }
    fifo_.insert(fifo_.end(), frame.begin(), frame.end());
  }
}

// ---------------------------------------------------------------------------------------------
// ICM-42688-P
namespace {
double icm_odr(int code) {
  static constexpr double kOdr[16] = {0, 32000, 16000, 8000, 4000, 2000, 1000, 200, 100, 50, 25, 12.5, 0, 0, 0, 500};
  return kOdr[code & 0x0F];
}
}  // namespace

Icm42688Model::Icm42688Model(sim::SimImuConfig physics, TruthFn truth, int who_am_i)
    : RegisterImuModel(std::move(physics), std::move(truth)), who_(who_am_i) {
  reset_registers();
}

void Icm42688Model::reset_registers() {
  regs_.fill(0);
  regs_[0x75] = static_cast<std::uint8_t>(who_);
  regs_[0x4F] = 0x06;  // ±2000 °/s, 1 kHz
  regs_[0x50] = 0x06;  // ±16 g, 1 kHz
  regs_[0x2D] = 0x10;  // RESET_DONE
  regs_[0x4C] = 0x30;  // INTF_CONFIG0: FIFO count and sensor data big-endian
  fifo_.clear();
}

void Icm42688Model::on_write(std::uint8_t reg, std::uint8_t value) {
  if (reg == 0x11 && (value & 0x01)) {  // DEVICE_CONFIG.SOFT_RESET_CONFIG
    reset_registers();
    restart();
  }
  if (reg == 0x4B && (value & 0x02)) {  // SIGNAL_PATH_RESET.FIFO_FLUSH
    fifo_.clear();
    regs_[0x4B] = 0;
  }
  if (reg == 0x16 && (value >> 6) == 0) fifo_.clear();  // bypass
}

std::uint8_t Icm42688Model::on_read(std::uint8_t reg) {
  if (reg == 0x2E) return static_cast<std::uint8_t>(fifo_.size() >> 8);
  if (reg == 0x2F) return static_cast<std::uint8_t>(fifo_.size() & 0xFF);
  if (reg == 0x30) {
    if (fifo_.empty()) return 0xFF;  // an empty-FIFO header
    const std::uint8_t b = fifo_.front();
    fifo_.pop_front();
    return b;
  }
  const std::uint8_t v = regs_[reg];
  if (reg == 0x2D) regs_[0x2D] = 0;  // cleared by reading
  return v;
}

sim::SimImuConfig Icm42688Model::output_config(sim::SimImuConfig c) const {
  c.gyro_range_dps = 2000.0 / (1 << (regs_[0x4F] >> 5));
  c.accel_range_g = 16.0 / (1 << std::min(regs_[0x50] >> 5, 3));
  c.accel_lsb_mps2 = 0.0;
  c.gyro_lsb_radps = 0.0;
  c.output_bits = 16;
  c.output_rate_hz = icm_odr(regs_[0x50] & 0x0F) > 0 ? icm_odr(regs_[0x50] & 0x0F) : icm_odr(regs_[0x4F] & 0x0F);
  c.lowpass_hz = 0.0;
  c.temperature_offset_c = 25.0;
  c.temperature_counts_per_c = 132.48;
  return c;
}

void Icm42688Model::latch(const ImuSample& s, double t_s) {
  const bool gyro_on = ((regs_[0x4E] >> 2) & 0x03) == 3;
  put_be(&regs_[0x1D], s.temperature_counts);
  for (int i = 0; i < 3; ++i) put_be(&regs_[static_cast<std::size_t>(0x1F + 2 * i)], s.accel_counts[i]);
  for (int i = 0; i < 3; ++i) put_be(&regs_[static_cast<std::size_t>(0x25 + 2 * i)], gyro_on ? s.gyro_counts[i] : 0);
  regs_[0x2D] |= 0x08;  // DATA_RDY_INT
  const std::uint8_t en = regs_[0x5F] & 0x03;
  if ((regs_[0x16] >> 6) != 0 && en != 0) {  // FIFO: packet 3, accel and gyro (both fields always present)
    std::uint8_t p[16] = {0x68};
    std::copy(&regs_[0x1F], &regs_[0x1F] + 6, p + 1);
    std::copy(&regs_[0x25], &regs_[0x25] + 6, p + 7);
    p[13] = static_cast<std::uint8_t>(static_cast<std::int8_t>(std::clamp(std::lround(s.temperature_counts / 64.0), -128L, 127L)));
    const auto ts = static_cast<std::uint16_t>(std::lround(t_s * 1e6));  // µs, wraps
    p[14] = static_cast<std::uint8_t>(ts >> 8);
    p[15] = static_cast<std::uint8_t>(ts & 0xFF);
    if (fifo_.size() + 16 > 2048) {
      if ((regs_[0x16] >> 6) == 1) {  // stream: drop the oldest packet
        fifo_.erase(fifo_.begin(), fifo_.begin() + 16);
        fifo_.insert(fifo_.end(), p, p + 16);
      }
      regs_[0x2D] |= 0x02;  // FIFO_FULL_INT
    } else {
      fifo_.insert(fifo_.end(), p, p + 16);
    }
  }
}

}  // namespace stend::emu
