#include "mpu6050_model.hpp"

#include <algorithm>
#include <vector>

namespace stend::emu {
namespace {

class StaticTruth final : public TruthSource {
 public:
  explicit StaticTruth(const BenchTruth& t) : t_(t) {}
  BenchTruth at(double t_s) const override {
    BenchTruth b = t_;
    b.t_s = t_s;
    return b;
  }

 private:
  BenchTruth t_;
};

void put16(std::uint8_t* p, std::int32_t v) {
  const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(v));
  p[0] = static_cast<std::uint8_t>(u >> 8);
  p[1] = static_cast<std::uint8_t>(u & 0xFF);
}

}  // namespace

Mpu6050Model::Mpu6050Model(sim::SimImuConfig physics, BenchTruth truth, std::uint8_t who_am_i)
    : physics_(std::move(physics)), truth_(truth) {
  regs_[mpu6050::kWhoAmI] = who_am_i;
  regs_[mpu6050::kPwrMgmt1] = mpu6050::kSleep;  // power-on reset value: asleep
}

void Mpu6050Model::read_burst(std::uint8_t reg, std::uint8_t* out, std::size_t n) const {
  for (std::size_t i = 0; i < n; ++i) out[i] = regs_[(reg + i) & 0x7F];  // auto-increment
}

void Mpu6050Model::write(std::uint8_t reg, std::uint8_t value) {
  reg &= 0x7F;
  if (reg == mpu6050::kWhoAmI || (reg >= mpu6050::kAccelXoutH && reg <= mpu6050::kGyroZoutL)) return;  // read-only
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
  const StaticTruth truth(truth_);
  std::vector<ImuSample> samples;
  imu_->acquire(t_s, truth, samples);
  now_s_ = t_s;
  for (const ImuSample& s : samples) {
    std::uint8_t* p = &regs_[mpu6050::kAccelXoutH];
    for (int i = 0; i < 3; ++i) put16(p + 2 * i, s.accel_counts[i]);
    put16(p + 6, s.temperature_counts);
    for (int i = 0; i < 3; ++i) put16(p + 8 + 2 * i, s.gyro_counts[i]);
    if (data_ready) data_ready();
  }
}

}  // namespace stend::emu
