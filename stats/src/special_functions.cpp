// Regularized incomplete gamma and beta functions. See stend/stats/special_functions.hpp.
#include "stend/stats/special_functions.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace stend::stats {

namespace {

constexpr double kTiny = 1e-300;  // keeps the Lentz recursions off zero

// Σ x^n / ((a+1)…(a+n)) · 1/a: P(a, x) = e^{−x} x^a / Γ(a) times this (converges for x < a + 1).
double gamma_series(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 100000000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-17) break;
  }
  return sum;
}

// Continued fraction of Q(a, x) = e^{−x} x^a / Γ(a) times this (converges for x ≥ a + 1).
double gamma_continued_fraction(double a, double x) {
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-16) break;
  }
  return h;
}

// Continued fraction of I_x(a, b) (converges fast for x < (a + 1)/(a + b + 2)).
double beta_continued_fraction(double a, double b, double x) {
  constexpr double eps = 1e-16;
  const double qab = a + b, qap = a + 1.0, qam = a - 1.0;
  double c = 1.0, d = 1.0 - qab * x / qap;
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 1000; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < eps) break;
  }
  return h;
}

}  // namespace

double gamma_p(double a, double x) {
  if (!(a > 0.0) || x < 0.0 || std::isnan(x)) throw std::domain_error("gamma_p: need a > 0 and x ≥ 0");
  if (x == 0.0) return 0.0;
  if (std::isinf(x)) return 1.0;
  const double prefactor = std::exp(a * std::log(x) - x - std::lgamma(a));
  if (x < a + 1.0) return std::min(1.0, gamma_series(a, x) * prefactor);
  return std::max(0.0, 1.0 - gamma_continued_fraction(a, x) * prefactor);
}

double beta_i(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double front =
      std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x));
  if (x < (a + 1.0) / (a + b + 2.0)) return front * beta_continued_fraction(a, b, x) / a;
  return 1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b;
}

}  // namespace stend::stats
