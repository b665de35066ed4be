// The model curve of the noise fit. See model_curve.hpp.
#include "model_curve.hpp"

#include <stend/model/noise.hpp>
#include <stend/model/output_stage.hpp>

#include <algorithm>
#include <cmath>

namespace stend::noise {

NoiseType noise_of_term(int j) {
  switch (j) {
    case 0: return NoiseType::kQuantization;
    case 1: return NoiseType::kWhite;
    case 2: return NoiseType::kFlicker;
    case kGm: return NoiseType::kFlicker;  // the GM plateau (EDF between white and random walk)
    default: return NoiseType::kRandomWalk;  // K, and the ramp R (closest EDF model)
  }
}

WhiteTerm::WhiteTerm(double rate_hz, double lowpass_hz) : fs_(rate_hz) {
  if (!(lowpass_hz > 0.0) || !(lowpass_hz < 0.5 * rate_hz)) return;
  model::Biquad f = model::Biquad::butterworth_lowpass(lowpass_hz, rate_hz);
  std::vector<double> h;
  double peak = 0.0;
  for (int n = 0; n < (1 << 16); ++n) {
    const double v = f(n == 0 ? 1.0 : 0.0);
    h.push_back(v);
    peak = std::max(peak, std::abs(v));
    if (n > 16 && std::abs(v) < 1e-13 * peak && std::abs(h[h.size() - 2]) < 1e-13 * peak) break;
  }
  r_.assign(h.size(), 0.0);
  for (std::size_t d = 0; d < h.size(); ++d)
    for (std::size_t n = 0; n + d < h.size(); ++n) r_[d] += h[n] * h[n + d];
  double r2 = r_[0] * r_[0];
  for (std::size_t d = 1; d < r_.size(); ++d) r2 += 2.0 * r_[d] * r_[d];
  independent_ = r_[0] * r_[0] / r2;
}

double WhiteTerm::operator()(double m) const {
  if (r_.empty()) return fs_ / m;
  double s = 2.0 * m * r_[0];
  const auto mm = static_cast<std::size_t>(m);
  for (std::size_t d = 1; d < r_.size() && d < 2 * mm; ++d) {
    const double dd = static_cast<double>(d);
    s += 2.0 * r_[d] * (d <= mm ? 2.0 * m - 3.0 * dd : -(2.0 * m - dd));
  }
  return fs_ * s / (2.0 * m * m);
}

double gm_basis(double tau, double tc) { return tc > 0.0 ? model::allan::gauss_markov(1.0, tc, tau) : 0.0; }

std::array<double, kTerms> basis(double tau, double m, const WhiteTerm& white, double tc) {
  return {3.0 / (tau * tau), white(m), kFlickerFloor * kFlickerFloor, tau / 3.0, tau * tau / 2.0, gm_basis(tau, tc)};
}

}  // namespace stend::noise
