// Butterworth low-pass filters as cascades of second-order sections (SOS), forward and
// zero-phase (forward-backward) filtering.
//
// Design: analog Butterworth prototype of order N, cutoff pre-warped Ωc = tan(π fc / fs), bilinear
// transform. Each conjugate pole pair of the prototype becomes one biquad
//     H_k(z) = (b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²),
// an odd order adds one first-order section (b2 = a2 = 0). Every section has unit gain at DC, so
// the cascade does, and the magnitude response is exactly
//     |H(e^{jω})|² = 1 / (1 + (tan(ω/2) / tan(ωc/2))^{2N}),   ω = 2π f / fs,
// i.e. −3.0103 dB at f = fc for every order.
//
// Sections run in transposed direct form II (numerically the preferred form for SOS).
#pragma once

#include <complex>
#include <span>
#include <vector>

namespace stend::processing {

// One second-order section, a0 normalised to 1.
struct Biquad {
  double b0 = 1.0, b1 = 0.0, b2 = 0.0;
  double a1 = 0.0, a2 = 0.0;
};

struct SosFilter {
  int order = 0;
  double cutoff_hz = 0.0;
  double sample_rate_hz = 0.0;
  std::vector<Biquad> sections;

  // Complex frequency response of the cascade at f_hz.
  std::complex<double> response(double f_hz) const;
  double magnitude(double f_hz) const { return std::abs(response(f_hz)); }
  double dc_gain() const;
  // Largest pole radius over all sections; < 1 means stable.
  double max_pole_radius() const;
  bool stable() const { return max_pole_radius() < 1.0; }
};

// N-th order Butterworth low-pass for a cutoff (−3 dB) and sample rate, both in Hz.
// Throws std::invalid_argument unless 1 ≤ order ≤ 20 and 0 < cutoff_hz < sample_rate_hz / 2.
SosFilter butterworth_lowpass(int order, double cutoff_hz, double sample_rate_hz);

enum class InitialState {
  kZero,         // filter starts at rest (a step at the start shows the full transient)
  kSteadyState,  // filter starts as if the first sample had been applied forever (scipy lfilter_zi)
};

// Causal (forward) filtering.
std::vector<double> filter(const SosFilter& f, std::span<const double> x,
                           InitialState init = InitialState::kSteadyState);

// Zero-phase filtering: forward then backward through the same cascade (|H|², no delay), with an
// odd reflection of 3·(2·sections + 1) samples at each end (clipped to the signal length − 1) and
// steady-state initial conditions, as scipy.signal.sosfiltfilt does. Requires x.size() ≥ 2.
std::vector<double> filtfilt(const SosFilter& f, std::span<const double> x);

}  // namespace stend::processing
