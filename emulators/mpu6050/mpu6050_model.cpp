#include "mpu6050_model.hpp"

#include <algorithm>
#include <vector>

namespace stend::emu {
namespace {

class FnTruth final : public TruthSource {
 public:
  explicit FnTruth(const Mpu6050Model::TruthFn& f) : f_(f) {}
  BenchTruth at(double t_s) const override {
    BenchTruth b = f_(t_s);
    b.t_s = t_s;
    return b;
  }

 private:
  const Mpu6050Model::TruthFn& f_;
};

void put16(std::uint8_t* p, std::int32_t v) {
  const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(v));
  p[0] = static_cast<std::uint8_t>(u >> 8);
  p[1] = static_cast<std::uint8_t>(u & 0xFF);
}

}  // namespace

Mpu6050Model::Mpu6050Model(sim::SimImuConfig physics, BenchTruth truth, std::uint8_t who_am_i)
    : Mpu6050Model(std::move(physics), TruthFn([truth](double) { return truth; }), who_am_i) {}

Mpu6050Model::Mpu6050Model(sim::SimImuConfig physics, TruthFn truth, std::uint8_t who_am_i)
    : physics_(std::move(physics)), truth_(std::move(truth)), who_am_i_(who_am_i) {
  reset_registers();
}

void Mpu6050Model::reset_registers() {
  regs_.fill(0);
  regs_[mpu6050::kWhoAmI] = who_am_i_;
  regs_[mpu6050::kPwrMgmt1] = mpu6050::kSleep;  // power-on reset value: asleep
  fifo_.clear();
  imu_.reset();
}

std::uint8_t Mpu6050Model::read(std::uint8_t reg) const {
  reg &= 0x7F;
  if (reg == mpu6050::kFifoCountH) return static_cast<std::uint8_t>(fifo_.size() >> 8);
  if (reg == mpu6050::kFifoCountL) return static_cast<std::uint8_t>(fifo_.size() & 0xFF);
  if (reg == mpu6050::kFifoRW) return fifo_.empty() ? 0 : fifo_.front();
  return regs_[reg];
}

void Mpu6050Model::read_burst(std::uint8_t reg, std::uint8_t* out, std::size_t n) const {
  for (std::size_t i = 0; i < n; ++i) out[i] = read(static_cast<std::uint8_t>((reg + i) & 0x7F));  // auto-increment
}

void Mpu6050Model::i2c_read(std::uint8_t& reg, std::uint8_t* out, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    reg &= 0x7F;
    if (reg == mpu6050::kFifoRW) {
      if (fifo_.empty()) {
        out[i] = 0xFF;  // reading an empty FIFO returns the last byte again on the part; 0xFF here
      } else {
        out[i] = fifo_.front();
        fifo_.pop_front();
      }
      continue;  // the pointer stays on FIFO_R_W
    }
    out[i] = read(reg);
    if (reg == mpu6050::kIntStatus) regs_[mpu6050::kIntStatus] = 0;  // cleared by reading
    reg = static_cast<std::uint8_t>(reg + 1);
  }
}

void Mpu6050Model::write(std::uint8_t reg, std::uint8_t value) {
  reg &= 0x7F;
  if (reg == mpu6050::kWhoAmI || reg == mpu6050::kIntStatus || reg == mpu6050::kFifoCountH ||
      reg == mpu6050::kFifoCountL || reg == mpu6050::kFifoRW ||
      (reg >= mpu6050::kAccelXoutH && reg <= mpu6050::kGyroZoutL)) {
    return;  // read-only (FIFO_R_W writes are not modelled)
  }
  if (reg == mpu6050::kPwrMgmt1 && (value & mpu6050::kDeviceReset)) {
    reset_registers();
    return;
  }
  if (reg == mpu6050::kUserCtrl && (value & mpu6050::kUserFifoReset)) {
    fifo_.clear();
    value = static_cast<std::uint8_t>(value & ~mpu6050::kUserFifoReset);  // self-clearing
  }
  regs_[reg] = value;
  if (reg == mpu6050::kPwrMgmt1 || reg == mpu6050::kSmplrtDiv || reg == mpu6050::kConfig ||
      reg == mpu6050::kGyroConfig || reg == mpu6050::kAccelConfig) {
    imu_.reset();  // the next advance() restarts the signal chain with the new settings
  }
}

double Mpu6050Model::sample_rate_hz() const {
  const int dlpf = regs_[mpu6050::kConfig] & 0x07;
  const double gyro_rate = (dlpf == 0 || dlpf == 7) ? 8000.0 : 1000.0;
  return gyro_rate / (1.0 + regs_[mpu6050::kSmplrtDiv]);
}

void Mpu6050Model::rebuild(double t_s) {
  static constexpr double kDlpfHz[8] = {0.0, 184.0, 94.0, 44.0, 21.0, 10.0, 5.0, 0.0};
  sim::SimImuConfig c = physics_;
  c.accel_range_g = 2.0 * (1 << ((regs_[mpu6050::kAccelConfig] >> 3) & 3));
  c.gyro_range_dps = 250.0 * (1 << ((regs_[mpu6050::kGyroConfig] >> 3) & 3));
  c.accel_lsb_mps2 = 0.0;  // full scale / 32768, as the part
  c.gyro_lsb_radps = 0.0;
  c.output_bits = 16;
  c.output_rate_hz = sample_rate_hz();
  c.lowpass_hz = kDlpfHz[regs_[mpu6050::kConfig] & 0x07];
  c.temperature_offset_c = 36.53;
  c.temperature_counts_per_c = 340.0;
  imu_ = std::make_unique<sim::SimImu>(c);
  imu_->start(t_s);
}

void Mpu6050Model::advance(double t_s, const std::function<void()>& data_ready) {
  if (t_s <= now_s_) return;
  if (asleep()) {
    imu_.reset();
    now_s_ = t_s;
    return;
  }
  if (!imu_) rebuild(now_s_);
  const FnTruth truth(truth_);
  std::vector<ImuSample> samples;
  imu_->acquire(t_s, truth, samples);
  now_s_ = t_s;
  const std::uint8_t fifo_en = regs_[mpu6050::kFifoEn];
  const bool fifo_on = (regs_[mpu6050::kUserCtrl] & mpu6050::kUserFifoEn) != 0 && fifo_en != 0;
  for (const ImuSample& s : samples) {
    std::uint8_t* p = &regs_[mpu6050::kAccelXoutH];
    for (int i = 0; i < 3; ++i) put16(p + 2 * i, s.accel_counts[i]);
    put16(p + 6, s.temperature_counts);
    for (int i = 0; i < 3; ++i) put16(p + 8 + 2 * i, s.gyro_counts[i]);
    regs_[mpu6050::kIntStatus] |= mpu6050::kIntDataRdy;
    if (fifo_on) {
      auto push = [&](int offset, int bytes) {
        for (int b = 0; b < bytes; ++b) fifo_.push_back(p[offset + b]);
      };
      if (fifo_en & 0x08) push(0, 6);   // ACCEL_FIFO_EN
      if (fifo_en & 0x80) push(6, 2);   // TEMP_FIFO_EN
      if (fifo_en & 0x40) push(8, 2);   // XG_FIFO_EN
      if (fifo_en & 0x20) push(10, 2);  // YG_FIFO_EN
      if (fifo_en & 0x10) push(12, 2);  // ZG_FIFO_EN
      if (fifo_.size() > mpu6050::kFifoBytes) {
        fifo_.erase(fifo_.begin(), fifo_.begin() + static_cast<std::ptrdiff_t>(fifo_.size() - mpu6050::kFifoBytes));
        regs_[mpu6050::kIntStatus] |= mpu6050::kIntFifoOflow;
      }
    }
    if (data_ready) data_ready();
  }
}

}  // namespace stend::emu
