// Tail probabilities for the gap diagnoser's tests: F (partial F test on segment means) and χ²
// (held-out errors against the noise floor). Regularized incomplete beta and gamma functions by
// continued fractions / series (Numerical Recipes §6.2, §6.4), double precision.
#pragma once

#include <cmath>

namespace stend::diagnosis::stats {

// Regularized lower incomplete gamma P(a, x).
inline double gamma_p(double a, double x) {
  if (x <= 0) return 0.0;
  const double gln = std::lgamma(a);
  if (x < a + 1) {
    double ap = a, sum = 1.0 / a, del = sum;
    for (int n = 0; n < 1000; ++n) {
      ap += 1;
      del *= x / ap;
      sum += del;
      if (std::abs(del) < std::abs(sum) * 1e-15) break;
    }
    return sum * std::exp(-x + a * std::log(x) - gln);
  }
  double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-15) break;
  }
  return 1.0 - std::exp(-x + a * std::log(x) - gln) * h;
}

// P(χ²_ν > x).
inline double chi2_sf(double x, double nu) { return x <= 0 ? 1.0 : 1.0 - gamma_p(0.5 * nu, 0.5 * x); }

namespace detail {
inline double betacf(double a, double b, double x) {
  const double qab = a + b, qap = a + 1, qam = a - 1;
  double c = 1, d = 1 - qab * x / qap;
  if (std::abs(d) < 1e-300) d = 1e-300;
  d = 1 / d;
  double h = d;
  for (int m = 1; m < 1000; ++m) {
    const int m2 = 2 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1 + aa * d;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = 1 + aa / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1 + aa * d;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = 1 + aa / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-15) break;
  }
  return h;
}
}  // namespace detail

// Regularized incomplete beta I_x(a, b).
inline double beta_i(double a, double b, double x) {
  if (x <= 0) return 0.0;
  if (x >= 1) return 1.0;
  const double bt = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log(1 - x));
  if (x < (a + 1) / (a + b + 2)) return bt * detail::betacf(a, b, x) / a;
  return 1.0 - bt * detail::betacf(b, a, 1 - x) / b;
}

// P(F_{d1,d2} > f).
inline double f_sf(double f, double d1, double d2) {
  if (!(f > 0)) return 1.0;
  return beta_i(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

}  // namespace stend::diagnosis::stats
