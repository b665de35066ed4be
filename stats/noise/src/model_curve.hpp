// The model curve of the noise fit (internal to stend_noise): the AVAR per unit coefficient² of
// each term at τ — σ²(τ) = 3Q²/τ² + N²·w(m) + (2 ln2/π)B² + K²τ/3 + R²τ²/2 + σ_G²·g(τ/τc) —
// with the sensor's output low-pass in the white term w.
#pragma once

#include <array>
#include <vector>

#include "stend/noise/noise_model.hpp"

namespace stend::noise {

inline constexpr int kTerms = 6;  // Q N B K R G (linear in their squares at fixed τc)
inline constexpr int kGm = 5;     // index of the Gauss–Markov term
inline constexpr int kRamp = 4;   // index of the rate ramp R

// The noise type of term j's EDF and correlations.
NoiseType noise_of_term(int j);

// AVAR per unit N² of the white-noise term at m samples per cluster, rate fs [Hz]: sampled white
// noise of variance N²·fs (AVAR N²/τ unfiltered) through the output filter of impulse response h:
// AVAR(m) = fs/(2m²) · Σ_d r(d)·R_g(d), r the autocorrelation of h, R_g that of the second
// difference of m-sums (2m − 3|d| for |d| ≤ m, −(2m − |d|) for m < |d| < 2m).
class WhiteTerm {
 public:
  WhiteTerm(double rate_hz, double lowpass_hz);
  // Independent values per sample of the filtered white noise, r(0)²/Σ_d r(d)² (the effective
  // sample size of a variance estimate from correlated Gaussian values); 1 without a filter.
  double independent() const { return independent_; }
  // AVAR per unit N² at m samples per cluster.
  double operator()(double m) const;

 private:
  double fs_;
  double independent_ = 1.0;
  std::vector<double> r_;  // empty: no filter
};

// The six terms' AVAR per unit coefficient² at τ [s], m samples per cluster, Gauss–Markov τc [s]
// (0: no G).
std::array<double, kTerms> basis(double tau, double m, const WhiteTerm& white, double tc);
// Its last element alone: G's AVAR per unit σ_G² at τ [s] for τc [s] (0: no G).
double gm_basis(double tau, double tc);

}  // namespace stend::noise
