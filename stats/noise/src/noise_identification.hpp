// Stable32's noise identification per averaging factor (internal to stend_noise, used by
// DeviationStream; see stend/noise/deviations.hpp): the lag-1 autocorrelation of the decimated
// phase, differenced until ρ < 0.25 (Riley, Greenhall 2004), else Barnes' B1 ratio with R(n).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

namespace stend::noise {

namespace noise_id {

// Expected B1 ratio for n averages and bias exponent μ (Barnes 1974; Howe et al. 1981).
inline double b1_theory(double n, int mu) {
  switch (mu) {
    case 2: return n * (n + 1.0) / 6.0;
    case 1: return n / 2.0;
    case 0: return n * std::log(n) / (2.0 * (n - 1.0) * std::log(2.0));
    case -1: return 1.0;
    case -2: return (n * n - 1.0) / (1.5 * n * (n - 1.0));
    default: return n * (1.0 - std::pow(n, mu)) / (2.0 * (n - 1.0) * (1.0 - std::pow(2.0, mu)));
  }
}
inline int mu_of_alpha(int alpha) { return alpha >= 1 ? -2 : -1 - alpha; }
// Expected R(n) = MVAR/AVAR for white PM (α = 2), flicker PM (α = 1), else 1.
inline double rn_theory(double m, int alpha) {
  constexpr double pi2 = std::numbers::pi * std::numbers::pi;
  if (alpha == 2) return 1.0 / m;
  if (alpha == 1) {
    const double avar = (1.038 + 3.0 * std::log(std::numbers::pi * m)) / (4.0 * pi2);
    const double mvar = 3.0 * std::log(256.0 / 27.0) / (8.0 * pi2);
    return mvar / avar;
  }
  return 1.0;
}

// α from the B1 ratio of n m-averages (and R(n) between white and flicker PM): the type whose
// theoretical B1 is nearest on a geometric scale, walking from random walk FM up.
inline int from_b1(double b1, double rn, double n, double m) {
  for (int alpha = -2; alpha < 1; ++alpha) {
    const double hi = b1_theory(n, mu_of_alpha(alpha));
    const double lo = b1_theory(n, mu_of_alpha(alpha + 1));
    if (b1 > std::sqrt(hi * lo)) return alpha;
  }
  return rn > std::sqrt(rn_theory(m, 1) * rn_theory(m, 2)) ? 1 : 2;
}

// α from lag-1 autocorrelations r1[d] of the d-times differenced decimated phase.
inline int from_acf(const std::array<double, 4>& r1, int dmax) {
  for (int d = 0;; ++d) {
    const double rho = r1[static_cast<std::size_t>(d)] / (1.0 + r1[static_cast<std::size_t>(d)]);
    if (!std::isfinite(rho)) return 0;  // a constant series: no type to tell, white FM
    if (rho < 0.25 || d >= dmax) {
      return std::clamp(static_cast<int>(-std::round(2.0 * rho)) - 2 * d + 2, -2, 2);
    }
  }
}

// Running sums for the lag-1 autocorrelation (about the mean) of one series, values shifted
// by the first one for precision (double sums: only the rounded noise type depends on them).
struct Lag1 {
  std::uint64_t n = 0;
  double shift = 0.0, first = 0.0, last = 0.0;
  double s = 0, s2 = 0, s11 = 0;
  void add(double v) {
    if (n == 0) shift = v;
    v -= shift;
    if (n == 0) first = v; else s11 += last * v;
    s += v;
    s2 += v * v;
    last = v;
    ++n;
  }
  double r1() const {
    if (n < 3) return std::numeric_limits<double>::quiet_NaN();
    const long double nn = static_cast<long double>(n), mu = s / nn;
    const long double den = s2 - nn * mu * mu;
    const long double num = s11 - mu * (2 * s - first - last) + (nn - 1) * mu * mu;
    return den > 0 ? static_cast<double>(num / den) : std::numeric_limits<double>::quiet_NaN();
  }
  double variance() const {  // sample variance (n − 1)
    if (n < 2) return std::numeric_limits<double>::quiet_NaN();
    const long double nn = static_cast<long double>(n), mu = s / nn;
    return static_cast<double>((s2 - nn * mu * mu) / (nn - 1));
  }
};

}  // namespace noise_id

}  // namespace stend::noise
