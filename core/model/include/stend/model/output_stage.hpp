// Output stage of the error-model vocabulary: what happens to a sensor's analog value between the
// error terms (terms.hpp) plus noise (noise.hpp) and the digital word it reports.
//
//   y_analog ─► low-pass (optional, the sensor's digital low-pass filter) ─► saturation at full
//            scale (flagged) ─► quantization to an LSB, rounded to nearest, clamped to the word
//
// Streaming, one sample at a time, no allocation. Offline (whole-record, zero-phase) filtering
// belongs to stend/processing/butterworth.hpp; the biquad here is the same bilinear Butterworth design
// run causally, as a sensor's own filter runs.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "stend/model/noise.hpp"

namespace stend::model {

// ---------------------------------------------------------------------------------------------
// Quantization to an integer count of `lsb`, rounded to nearest (a tie rounds up:
// floor(x/lsb + ½)), clamped to [min_count, max_count]. NaN input gives min_count and reports
// clamping.
class Quantizer {
 public:
  Quantizer() = default;
  // A signed two's-complement word of `bits` bits (2…32): counts in [−2^(bits−1), 2^(bits−1)−1].
  Quantizer(double lsb, int bits) {
    if (!(bits >= 2 && bits <= 32)) throw std::invalid_argument("quantizer: word length must be 2..32 bits");
    const std::int64_t half = std::int64_t{1} << (bits - 1);
    init(lsb, -half, half - 1);
  }
  Quantizer(double lsb, std::int64_t min_count, std::int64_t max_count) { init(lsb, min_count, max_count); }

  double lsb() const { return lsb_; }
  std::int64_t min_count() const { return min_; }
  std::int64_t max_count() const { return max_; }

  // Counts for value x; *clamped (if given) is set true when the word limits were hit.
  std::int32_t counts(double x, bool* clamped = nullptr) const {
    const double v = x * inv_lsb_ + 0.5;  // counts = floor(v)
    if (!(v >= min_d_)) {                 // also NaN
      if (clamped) *clamped = true;
      return static_cast<std::int32_t>(min_);
    }
    if (v >= max_d_ + 1.0) {
      if (clamped) *clamped = true;
      return static_cast<std::int32_t>(max_);
    }
    auto t = static_cast<std::int64_t>(v);  // truncation, then floor without a branch (the sign of
    t -= static_cast<std::int64_t>(static_cast<double>(t) > v);  // v is random for a zero input)
    return static_cast<std::int32_t>(t);
  }
  double value(std::int64_t counts) const { return static_cast<double>(counts) * lsb_; }
  double quantize(double x, bool* clamped = nullptr) const { return value(counts(x, clamped)); }

 private:
  void init(double lsb, std::int64_t min_count, std::int64_t max_count) {
    if (!(std::isfinite(lsb) && lsb > 0.0)) throw std::invalid_argument("quantizer: LSB must be > 0");
    if (!(min_count < max_count) || min_count < std::numeric_limits<std::int32_t>::min() ||
        max_count > std::numeric_limits<std::int32_t>::max())
      throw std::invalid_argument("quantizer: count range must be a non-empty part of int32");
    lsb_ = lsb;
    inv_lsb_ = 1.0 / lsb;
    min_ = min_count;
    max_ = max_count;
    min_d_ = static_cast<double>(min_count);
    max_d_ = static_cast<double>(max_count);
  }
  double lsb_ = 1.0, inv_lsb_ = 1.0;
  std::int64_t min_ = std::numeric_limits<std::int32_t>::min(), max_ = std::numeric_limits<std::int32_t>::max();
  double min_d_ = static_cast<double>(std::numeric_limits<std::int32_t>::min());
  double max_d_ = static_cast<double>(std::numeric_limits<std::int32_t>::max());
};

// ---------------------------------------------------------------------------------------------
// Saturation at ±full_scale (an analog front end / ADC input range). apply() clamps and reports
// whether it did; |x| == full_scale is not saturated. NaN saturates (to +full_scale).
class Saturation {
 public:
  Saturation() = default;  // infinite full scale: never saturates
  explicit Saturation(double full_scale) : fs_(full_scale) {
    if (!(full_scale > 0.0)) throw std::invalid_argument("saturation: full scale must be > 0");
  }
  double full_scale() const { return fs_; }
  double apply(double x, bool& saturated) const {
    if (x > fs_ || std::isnan(x)) {
      saturated = true;
      return fs_;
    }
    if (x < -fs_) {
      saturated = true;
      return -fs_;
    }
    return x;
  }

 private:
  double fs_ = std::numeric_limits<double>::infinity();
};

// ---------------------------------------------------------------------------------------------
// Second-order IIR section, a0 = 1, transposed direct form II.
class Biquad {
 public:
  Biquad() = default;  // identity (b0 = 1)
  Biquad(double b0, double b1, double b2, double a1, double a2) : b0_(b0), b1_(b1), b2_(b2), a1_(a1), a2_(a2) {}

  // Low-pass of quality factor q, −3 dB at cutoff_hz for q = 1/√2, bilinear transform with the
  // cutoff pre-warped (K = tan(π·fc/fs)). Throws unless 0 < cutoff_hz < sample_rate_hz/2.
  static Biquad lowpass(double cutoff_hz, double sample_rate_hz, double q) {
    if (!(sample_rate_hz > 0.0 && cutoff_hz > 0.0 && cutoff_hz < 0.5 * sample_rate_hz))
      throw std::invalid_argument("low-pass: cutoff must be in (0, sample rate / 2)");
    if (!(q > 0.0)) throw std::invalid_argument("low-pass: quality factor must be > 0");
    const double k = std::tan(std::numbers::pi * cutoff_hz / sample_rate_hz);
    const double k2 = k * k;
    const double norm = 1.0 / (1.0 + k / q + k2);
    const double b0 = k2 * norm;
    return Biquad(b0, 2.0 * b0, b0, 2.0 * (k2 - 1.0) * norm, (1.0 - k / q + k2) * norm);
  }
  // 2nd-order Butterworth low-pass (q = 1/√2): |H(f)|² = 1 / (1 + (tan(πf/fs)/tan(πfc/fs))⁴).
  static Biquad butterworth_lowpass(double cutoff_hz, double sample_rate_hz) {
    return lowpass(cutoff_hz, sample_rate_hz, 0.70710678118654752440);
  }

  double operator()(double x) {
    const double y = b0_ * x + s1_;
    s1_ = b1_ * x - a1_ * y + s2_;
    s2_ = b2_ * x - a2_ * y;
    return y;
  }
  // State as if the input had been x forever (output = DC gain · x). Avoids a start-up transient.
  void reset(double x = 0.0) {
    const double y = dc_gain() * x;
    s2_ = b2_ * x - a2_ * y;
    s1_ = b1_ * x - a1_ * y + s2_;
  }
  double dc_gain() const { return (b0_ + b1_ + b2_) / (1.0 + a1_ + a2_); }
  // |H| at frequency f_hz for sample rate fs_hz.
  double magnitude(double f_hz, double fs_hz) const {
    const double w = 2.0 * std::numbers::pi * f_hz / fs_hz;
    const double c1 = std::cos(w), s1 = std::sin(w), c2 = std::cos(2 * w), s2 = std::sin(2 * w);
    const double nr = b0_ + b1_ * c1 + b2_ * c2, ni = -(b1_ * s1 + b2_ * s2);
    const double dr = 1.0 + a1_ * c1 + a2_ * c2, di = -(a1_ * s1 + a2_ * s2);
    return std::sqrt((nr * nr + ni * ni) / (dr * dr + di * di));
  }
  // Noise gain Σ h[n]² (h the impulse response): the output variance for unit-variance white
  // input. Exact, from the stationary autocorrelations r0, r1, r2 of y + a1·y₋₁ + a2·y₋₂ =
  // b0·x + b1·x₋₁ + b2·x₋₂ (E[y y₋k] for k = 0, 1, 2, with E[x₋j y₋k] = h[j−k]).
  double noise_gain() const {
    const double h0 = b0_, h1 = b1_ - a1_ * h0, h2 = b2_ - a1_ * h1 - a2_ * h0;
    Eigen::Matrix3d A;
    A << 1.0, a1_, a2_, a1_, 1.0 + a2_, 0.0, a2_, a1_, 1.0;
    const Eigen::Vector3d rhs(b0_ * h0 + b1_ * h1 + b2_ * h2, b1_ * h0 + b2_ * h1, b2_ * h0);
    return A.partialPivLu().solve(rhs)[0];
  }
  double b0() const { return b0_; }
  double b1() const { return b1_; }
  double b2() const { return b2_; }
  double a1() const { return a1_; }
  double a2() const { return a2_; }

 private:
  double b0_ = 1.0, b1_ = 0.0, b2_ = 0.0, a1_ = 0.0, a2_ = 0.0;
  double s1_ = 0.0, s2_ = 0.0;
};

// ---------------------------------------------------------------------------------------------
// Standard deviation of a sensor's white noise at its output [unit]: one-sided density N
// [unit/√Hz] sampled at rate_hz, then the output stage's 2nd-order Butterworth low-pass at
// lowpass_hz (0 = none): σ = σ_white·√(Σh²), σ_white = N·√(rate_hz/2) (WhiteNoise). Throws as
// Biquad::butterworth_lowpass does unless 0 < lowpass_hz < rate_hz/2.
inline double white_noise_output_sigma(double density, double rate_hz, double lowpass_hz) {
  const double sigma = WhiteNoise::sigma_from_density(density, 1.0 / rate_hz);
  if (!(lowpass_hz > 0.0)) return sigma;
  return sigma * std::sqrt(Biquad::butterworth_lowpass(lowpass_hz, rate_hz).noise_gain());
}

}  // namespace stend::model
