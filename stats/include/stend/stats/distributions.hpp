// Distribution functions of the tests and intervals Stend states: normal, Student t, χ², F, and
// the Wilson interval of a binomial fraction. Each defined once; every estimator, the Allan
// intervals and the gap diagnosis use these. Probabilities outside (0, 1) and non-positive degrees
// of freedom throw std::domain_error.
#pragma once

#include <limits>

namespace stend::stats {

// Standard normal.
double normal_cdf(double x);
// Rational start (Abramowitz–Stegun 26.2.23) refined by Newton steps on erfc: a few ulp for
// 1e-300 < p < 1 − 1e-16.
double normal_quantile(double p);

// Student t with dof > 0 degrees of freedom (dof = ∞ is the normal).
double student_t_cdf(double t, double dof);
double student_t_quantile(double p, double dof);  // by bisection on the cdf, relative 1e-15

// χ² with nu > 0 degrees of freedom (not necessarily an integer).
double chi2_cdf(double x, double nu);
// P(χ²_ν > x) = 1 − chi2_cdf (absolute accuracy ≈ 1e-16: tails below that read 0).
double chi2_sf(double x, double nu);
// x with chi2_cdf(x, nu) = p: Wilson–Hilferty start, then safeguarded Newton steps on the
// regularized gamma function (bisection when a step leaves the bracket). For nu > 1e7 the
// Wilson–Hilferty value itself (relative error < 1e-9).
double chi2_quantile(double p, double nu);

// F with (d1, d2) degrees of freedom: P(F > f) (1 for f ≤ 0 or NaN).
double f_sf(double f, double d1, double d2);
// The upper quantile: f with P(F > f) = q, by bisection on ln f over [1e-6, 1e6].
double f_upper_quantile(double q, double d1, double d2);

// The one-sigma level of a two-sided interval, erf(1/√2).
inline constexpr double kOneSigma = 0.682689492137085897;
// z of a two-sided 95 % interval, normal_quantile(0.975).
inline constexpr double kZ95 = 1.959963984540054;

// A two-sided interval [lo, hi]; NaN bounds when there is none.
struct Interval {
  double lo = std::numeric_limits<double>::quiet_NaN();
  double hi = std::numeric_limits<double>::quiet_NaN();
};
// Wilson score interval of a binomial fraction k/n at normal quantile z (n > 0), clipped to
// [0, 1]; no interval when n ≤ 0.
Interval wilson_interval(double k, double n, double z);

}  // namespace stend::stats
