// The samples summarised a block at a time (Observer), and the alignment's options. See align.hpp.
#include "stend/alignment/align.hpp"

#include <cmath>

namespace stend::alignment {

bool AlignOptions::IsValid(std::string* error) const {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(block_s)) return invalid(error, "block_s must be > 0");
  if (!(positive(min_stretch_s) && min_stretch_s >= 2.0 * block_s)) return invalid(error, "min_stretch_s must be at least two blocks");
  if (!(min_still_s >= min_stretch_s)) return invalid(error, "min_still_s must be at least min_stretch_s");
  if (!positive(max_still_rate_dps)) return invalid(error, "max_still_rate_dps must be > 0");
  if (!(positive(noise_factor) && noise_factor >= 1.0)) return invalid(error, "noise_factor must be >= 1");
  if (!(positive(min_accel_std_mps2) && positive(min_gyro_std_radps))) return invalid(error, "the minimum stds must be > 0");
  if (!positive(rate_steadiness)) return invalid(error, "rate_steadiness must be > 0");
  if (!positive(split_deg)) return invalid(error, "split_deg must be > 0");
  if (!(positive(face_tolerance_deg) && face_tolerance_deg < 90.0)) return invalid(error, "face_tolerance_deg must be in (0, 90)");
  if (!(positive(turn_tolerance) && turn_tolerance < 1.0)) return invalid(error, "turn_tolerance must be in (0, 1)");
  if (!(positive(rate_tolerance) && rate_tolerance < 1.0)) return invalid(error, "rate_tolerance must be in (0, 1)");
  return true;
}

double Block::accel_var() const { return ((accel_sq - accel_sum.cwiseProduct(accel_sum) / n) / n).cwiseMax(0.0).sum(); }
double Block::gyro_var() const { return ((gyro_sq - gyro_sum.cwiseProduct(gyro_sum) / n) / n).cwiseMax(0.0).sum(); }

Observer::Observer(AlignOptions options) : options_(options) { require_valid(options_, "alignment options"); }

void Observer::add(const ImuSample* samples, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) add_one(samples[i]);
}

// The sample joins the open block; the previous sample's rate is integrated up to this one's time
// (Δt to the next sample), and a block closes once it spans block_s.
void Observer::add_one(const ImuSample& s) {
  if (have_prev_) {
    const double dt = s.t_s - prev_.t_s;
    if (dt > 0.0 && std::isfinite(dt)) {
      open_.gyro_dt += prev_.gyro_radps * dt;
      open_.dt_sum += dt;
    }
    if (open_.n > 0 && s.t_s - open_.t0_s >= options_.block_s) {
      blocks_.push_back(open_);
      open_ = Block{};
    }
  }
  if (open_.n == 0) open_.t0_s = s.t_s;
  open_.t1_s = s.t_s;
  open_.n += 1.0;
  open_.accel_sum += s.accel_mps2;
  open_.accel_sq += s.accel_mps2.cwiseProduct(s.accel_mps2);
  open_.gyro_sum += s.gyro_radps;
  open_.gyro_sq += s.gyro_radps.cwiseProduct(s.gyro_radps);
  prev_ = s;
  have_prev_ = true;
}

const std::vector<Block>& Observer::finish() {
  if (open_.n > 0) {
    blocks_.push_back(open_);
    open_ = Block{};
  }
  return blocks_;
}

}  // namespace stend::alignment
