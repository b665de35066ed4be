// Normal, Student t, χ² and F distribution functions. See stend/stats/distributions.hpp.
#include "stend/stats/distributions.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "stend/stats/special_functions.hpp"

namespace stend::stats {

namespace {

void require_probability(double p, const char* what) {
  if (!(p > 0.0 && p < 1.0)) throw std::domain_error(std::string(what) + ": probability must lie in (0, 1)");
}

// Bisection for a monotone increasing cdf on (−∞, ∞), symmetric about 0.
template <class Cdf>
double symmetric_quantile(double p, Cdf cdf) {
  if (p == 0.5) return 0.0;
  const double q = p > 0.5 ? p : 1.0 - p;
  double lo = 0.0, hi = 1.0;
  while (cdf(hi) < q && hi < 1e300) hi *= 2.0;
  for (int i = 0; i < 400 && hi - lo > 1e-15 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cdf(mid) < q ? lo : hi) = mid;
  }
  const double x = 0.5 * (lo + hi);
  return p > 0.5 ? x : -x;
}

}  // namespace

double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

double normal_quantile(double p) {
  require_probability(p, "normal_quantile");
  const double q = p < 0.5 ? p : 1.0 - p;
  const double t = std::sqrt(-2.0 * std::log(q));
  double z = t - (2.515517 + 0.802853 * t + 0.010328 * t * t) /
                     (1.0 + 1.432788 * t + 0.189269 * t * t + 0.001308 * t * t * t);
  if (p < 0.5) z = -z;
  for (int i = 0; i < 8; ++i) {
    const double pdf = std::exp(-0.5 * z * z) / std::sqrt(2.0 * std::numbers::pi);
    if (pdf <= 0.0) break;
    const double step = (normal_cdf(z) - p) / pdf;
    z -= step;
    if (std::abs(step) < 1e-15 * std::max(1.0, std::abs(z))) break;
  }
  return z;
}

double student_t_cdf(double t, double dof) {
  if (!(dof > 0.0)) throw std::domain_error("Student t: degrees of freedom must be > 0");
  if (std::isinf(dof)) return normal_cdf(t);
  if (std::isinf(t)) return t > 0 ? 1.0 : 0.0;
  const double x = dof / (dof + t * t);
  const double tail = 0.5 * beta_i(0.5 * dof, 0.5, x);
  return t > 0 ? 1.0 - tail : tail;
}

double student_t_quantile(double p, double dof) {
  if (!(dof > 0.0)) throw std::domain_error("Student t: degrees of freedom must be > 0");
  require_probability(p, "student_t_quantile");
  if (std::isinf(dof)) return normal_quantile(p);
  return symmetric_quantile(p, [dof](double x) { return student_t_cdf(x, dof); });
}

double chi2_cdf(double x, double nu) { return x <= 0.0 ? 0.0 : gamma_p(0.5 * nu, 0.5 * x); }

double chi2_sf(double x, double nu) { return x <= 0.0 ? 1.0 : 1.0 - gamma_p(0.5 * nu, 0.5 * x); }

double chi2_quantile(double p, double nu) {
  require_probability(p, "chi2_quantile");
  if (!(nu > 0.0) || std::isinf(nu)) throw std::domain_error("chi2_quantile: nu must be > 0");
  const double z = normal_quantile(p);
  const double h = 2.0 / (9.0 * nu);
  const double wh = nu * std::pow(std::max(0.0, 1.0 - h + z * std::sqrt(h)), 3);
  if (nu > 1e7) return wh;
  const double a = 0.5 * nu;
  // Work in s = x/2 with P(a, s) = p.
  double lo = 0.0, hi = std::max(1.0, 2.0 * a);
  while (gamma_p(a, hi) < p) {
    lo = hi;
    hi *= 2.0;
  }
  double s = 0.5 * wh;
  if (!(s > lo && s < hi)) {
    // Small-s asymptote P ≈ s^a / Γ(a+1) for the lower tail, else the bracket midpoint.
    s = std::exp((std::log(p) + std::lgamma(a + 1.0)) / a);
    if (!(s > lo && s < hi)) s = 0.5 * (lo + hi);
  }
  for (int it = 0; it < 200; ++it) {
    const double f = gamma_p(a, s) - p;
    if (f == 0.0) break;
    if (f < 0.0) lo = s; else hi = s;
    const double pdf = std::exp((a - 1.0) * std::log(s) - s - std::lgamma(a));
    double next = (pdf > 0.0 && std::isfinite(pdf)) ? s - f / pdf : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - s) <= 1e-14 * s || hi - lo <= 1e-15 * hi) {
      s = next;
      break;
    }
    s = next;
  }
  return 2.0 * s;
}

double f_sf(double f, double d1, double d2) {
  if (!(f > 0)) return 1.0;
  return beta_i(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

double f_upper_quantile(double q, double d1, double d2) {
  require_probability(q, "f_upper_quantile");
  double lo = 1e-6, hi = 1e6;
  for (int i = 0; i < 200; ++i) {
    const double mid = std::sqrt(lo * hi);
    (f_sf(mid, d1, d2) > q ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
}

Interval wilson_interval(double k, double n, double z) {
  if (!(n > 0)) return {};
  const double p = k / n, z2 = z * z;
  const double c = (p + z2 / (2 * n)) / (1 + z2 / n);
  const double h = z * std::sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n);
  return {std::max(0.0, c - h), std::min(1.0, c + h)};
}

}  // namespace stend::stats
