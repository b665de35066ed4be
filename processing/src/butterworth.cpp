// Butterworth low-pass design (bilinear transform, pre-warped cutoff) as second-order sections,
// causal and zero-phase filtering. See stend/processing/butterworth.hpp.
#include "stend/processing/butterworth.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace stend::processing {

namespace {

// State of one transposed-direct-form-II section.
struct SectionState {
  double z1 = 0.0, z2 = 0.0;
};

double section_dc_gain(const Biquad& s) { return (s.b0 + s.b1 + s.b2) / (1.0 + s.a1 + s.a2); }

// Initial states that make the cascade's output constant for a constant input `level`.
std::vector<SectionState> steady_state(const SosFilter& f, double level) {
  std::vector<SectionState> st(f.sections.size());
  double v = level;
  for (std::size_t i = 0; i < f.sections.size(); ++i) {
    const Biquad& s = f.sections[i];
    const double y = section_dc_gain(s) * v;
    st[i].z2 = s.b2 * v - s.a2 * y;
    st[i].z1 = s.b1 * v - s.a1 * y + st[i].z2;
    v = y;
  }
  return st;
}

void run(const SosFilter& f, std::vector<SectionState>& st, std::vector<double>& x) {
  for (double& sample : x) {
    double v = sample;
    for (std::size_t i = 0; i < f.sections.size(); ++i) {
      const Biquad& s = f.sections[i];
      SectionState& z = st[i];
      const double y = s.b0 * v + z.z1;
      z.z1 = s.b1 * v - s.a1 * y + z.z2;
      z.z2 = s.b2 * v - s.a2 * y;
      v = y;
    }
    sample = v;
  }
}

}  // namespace

SosFilter butterworth_lowpass(int order, double cutoff_hz, double sample_rate_hz) {
  if (order < 1 || order > 20)
    throw std::invalid_argument("Butterworth order " + std::to_string(order) +
                                " is outside 1..20");
  if (!(sample_rate_hz > 0.0) || !std::isfinite(sample_rate_hz))
    throw std::invalid_argument("Butterworth: sample rate must be positive, got " +
                                std::to_string(sample_rate_hz) + " Hz");
  if (!(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_rate_hz))
    throw std::invalid_argument("Butterworth: cutoff " + std::to_string(cutoff_hz) +
                                " Hz must lie in (0, fs/2) = (0, " +
                                std::to_string(0.5 * sample_rate_hz) + ") Hz");
  SosFilter f;
  f.order = order;
  f.cutoff_hz = cutoff_hz;
  f.sample_rate_hz = sample_rate_hz;
  const double K = std::tan(std::numbers::pi * cutoff_hz / sample_rate_hz);
  const double K2 = K * K;
  if (order % 2 == 1) {  // real pole s = −1 of the prototype
    Biquad s;
    s.a1 = (K - 1.0) / (K + 1.0);
    s.a2 = 0.0;
    // b0 = K/(1+K) = (1 + a1)/2; written this way the stored coefficients have a DC gain of
    // exactly 1 (1 + a1 is exact by Sterbenz' lemma), however low the cutoff.
    s.b0 = 0.5 * (1.0 + s.a1);
    s.b1 = s.b0;
    s.b2 = 0.0;
    f.sections.push_back(s);
  }
  // Conjugate pairs s² + 2 sin(θ_k) s + 1, θ_k = π(2k+1)/(2N); lowest Q (largest damping) first.
  for (int k = order / 2 - 1; k >= 0; --k) {
    const double theta = std::numbers::pi * (2.0 * k + 1.0) / (2.0 * order);
    const double a = 2.0 * std::sin(theta);
    const double norm = 1.0 + a * K + K2;
    Biquad s;
    s.a1 = 2.0 * (K2 - 1.0) / norm;
    s.a2 = (1.0 - a * K + K2) / norm;
    // b0 = K²/norm = (1 + a1 + a2)/4 mathematically; the second form makes the DC gain of the
    // stored coefficients exactly 1 (for low cutoffs K²/norm and 1 + a1 + a2 would otherwise
    // disagree by rounding in a1, a2 — 1e-9 relative at fc = 1e-4·fs).
    s.b0 = 0.25 * (1.0 + s.a1 + s.a2);
    s.b1 = 2.0 * s.b0;
    s.b2 = s.b0;
    f.sections.push_back(s);
  }
  return f;
}

std::complex<double> SosFilter::response(double f_hz) const {
  const double w = 2.0 * std::numbers::pi * f_hz / sample_rate_hz;
  const std::complex<double> zi = std::polar(1.0, -w);  // z⁻¹
  const std::complex<double> zi2 = zi * zi;
  std::complex<double> h = 1.0;
  for (const Biquad& s : sections) h *= (s.b0 + s.b1 * zi + s.b2 * zi2) / (1.0 + s.a1 * zi + s.a2 * zi2);
  return h;
}

double SosFilter::dc_gain() const {
  double g = 1.0;
  for (const Biquad& s : sections) g *= section_dc_gain(s);
  return g;
}

double SosFilter::max_pole_radius() const {
  double r = 0.0;
  for (const Biquad& s : sections) {
    // Roots of z² + a1 z + a2 (a first-order section has a2 = 0: roots 0 and −a1).
    const double disc = s.a1 * s.a1 - 4.0 * s.a2;
    if (disc < 0.0) {
      r = std::max(r, std::sqrt(s.a2));
    } else {
      const double sq = std::sqrt(disc);
      r = std::max({r, std::abs((-s.a1 + sq) / 2.0), std::abs((-s.a1 - sq) / 2.0)});
    }
  }
  return r;
}

std::vector<double> filter(const SosFilter& f, std::span<const double> x, InitialState init) {
  std::vector<double> y(x.begin(), x.end());
  if (y.empty()) return y;
  std::vector<SectionState> st = init == InitialState::kSteadyState
                                     ? steady_state(f, y.front())
                                     : std::vector<SectionState>(f.sections.size());
  run(f, st, y);
  return y;
}

std::vector<double> filtfilt(const SosFilter& f, std::span<const double> x) {
  const std::size_t n = x.size();
  if (n < 2) throw std::invalid_argument("filtfilt needs at least 2 samples");
  std::size_t first_order = 0;
  for (const Biquad& s : f.sections)
    if (s.b2 == 0.0 && s.a2 == 0.0) ++first_order;
  std::size_t edge = 3 * (2 * f.sections.size() + 1 - first_order);
  edge = std::min(edge, n - 1);
  // Odd extension about each end point.
  std::vector<double> ext;
  ext.reserve(n + 2 * edge);
  for (std::size_t i = edge; i >= 1; --i) ext.push_back(2.0 * x[0] - x[i]);
  ext.insert(ext.end(), x.begin(), x.end());
  for (std::size_t i = 1; i <= edge; ++i) ext.push_back(2.0 * x[n - 1] - x[n - 1 - i]);

  std::vector<SectionState> st = steady_state(f, ext.front());
  run(f, st, ext);
  std::reverse(ext.begin(), ext.end());
  st = steady_state(f, ext.front());
  run(f, st, ext);
  std::reverse(ext.begin(), ext.end());
  return std::vector<double>(ext.begin() + static_cast<std::ptrdiff_t>(edge),
                             ext.begin() + static_cast<std::ptrdiff_t>(edge + n));
}

}  // namespace stend::processing
