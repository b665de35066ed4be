// Statistics for Allan deviation confidence intervals (header-only):
//   - regularized incomplete gamma P(a, x), normal and chi-squared quantiles;
//   - equivalent degrees of freedom (EDF) of the fully overlapping Allan variance for the
//     power-law noise types, by Greenhall's algorithm (C. A. Greenhall, W. J. Riley,
//     "Uncertainty of stability variances based on finite differences", PTTI 2003), with the
//     simple closed forms of NIST SP 1065 (Table 5) as an alternative;
//   - the chi-squared confidence interval of a deviation with a given EDF.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace stend::allan {

// Power-law noise of the *rate* signal y (gyro rate, acceleration), S_y(f) ∝ f^α. The names are
// the inertial-sensor terms; in frequency-stability terms α = 2 white PM, 1 flicker PM,
// 0 white FM, −1 flicker FM, −2 random-walk FM.
enum class NoiseType {
  kQuantization = 2,      // white PM: ADEV slope −1 (quantization noise, Q)
  kFlickerPhase = 1,      // flicker PM: slope ≈ −1
  kWhite = 0,             // white FM: slope −1/2 (angle / velocity random walk, N)
  kFlicker = -1,          // flicker FM: slope 0 (bias instability, B)
  kRandomWalk = -2,       // random-walk FM: slope +1/2 (rate random walk, K)
};

inline int alpha_of(NoiseType t) { return static_cast<int>(t); }

inline const char* to_string(NoiseType t) {
  switch (t) {
    case NoiseType::kQuantization: return "quantization (white PM)";
    case NoiseType::kFlickerPhase: return "flicker PM";
    case NoiseType::kWhite: return "white (white FM)";
    case NoiseType::kFlicker: return "flicker (flicker FM)";
    case NoiseType::kRandomWalk: return "random walk (RW FM)";
  }
  return "?";
}

namespace stats {

// Regularized lower incomplete gamma function P(a, x), a > 0, x ≥ 0.
inline double gamma_p(double a, double x) {
  if (!(a > 0.0) || x < 0.0 || std::isnan(x)) {
    throw std::domain_error("gamma_p: need a > 0 and x ≥ 0");
  }
  if (x == 0.0) return 0.0;
  if (std::isinf(x)) return 1.0;
  const double log_prefactor = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0) {
    // Series: P = e^{−x} x^a / Γ(a+1) · Σ x^n / ((a+1)…(a+n)).
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 100000000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-17) break;
    }
    return std::min(1.0, sum * std::exp(log_prefactor));
  }
  // Continued fraction for Q (modified Lentz).
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-16) break;
  }
  return std::max(0.0, 1.0 - std::exp(log_prefactor) * h);
}

// Chi-squared CDF with nu degrees of freedom (nu > 0, not necessarily an integer).
inline double chi2_cdf(double x, double nu) { return x <= 0.0 ? 0.0 : gamma_p(0.5 * nu, 0.5 * x); }

// Standard normal quantile: rational start (Abramowitz–Stegun 26.2.23) refined by Newton steps
// on erfc, accurate to a few ulp for 1e-300 < p < 1 − 1e-16.
inline double normal_quantile(double p) {
  if (!(p > 0.0 && p < 1.0)) throw std::domain_error("normal_quantile: p must be in (0, 1)");
  const double q = p < 0.5 ? p : 1.0 - p;
  const double t = std::sqrt(-2.0 * std::log(q));
  double z = t - (2.515517 + 0.802853 * t + 0.010328 * t * t) /
                     (1.0 + 1.432788 * t + 0.189269 * t * t + 0.001308 * t * t * t);
  if (p < 0.5) z = -z;
  for (int i = 0; i < 8; ++i) {
    const double cdf = 0.5 * std::erfc(-z / std::sqrt(2.0));
    const double pdf = std::exp(-0.5 * z * z) / std::sqrt(2.0 * std::numbers::pi);
    if (pdf <= 0.0) break;
    const double step = (cdf - p) / pdf;
    z -= step;
    if (std::abs(step) < 1e-15 * std::max(1.0, std::abs(z))) break;
  }
  return z;
}

// Chi-squared quantile: x with chi2_cdf(x, nu) = p. Wilson–Hilferty start, then safeguarded
// Newton iterations on the regularized gamma function (bisection when a step leaves the
// bracket). For nu > 1e7 the Wilson–Hilferty value itself is returned (relative error < 1e-9).
inline double chi2_quantile(double p, double nu) {
  if (!(p > 0.0 && p < 1.0)) throw std::domain_error("chi2_quantile: p must be in (0, 1)");
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
    const double log_pdf = (a - 1.0) * std::log(s) - s - std::lgamma(a);
    const double pdf = std::exp(log_pdf);
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

namespace greenhall {

inline long double sw(long double t, int alpha) {
  const long double at = std::fabs(t);
  switch (alpha) {
    case 2: return -at;
    case 1: return t == 0 ? 0.0L : t * t * std::log(at);
    case 0: return at * at * at;
    case -1: return t == 0 ? 0.0L : t * t * t * t * std::log(at);
    case -2: return at * at * at * at * at;
    case -3: return t == 0 ? 0.0L : t * t * t * t * t * t * std::log(at);
    case -4: return at * at * at * at * at * at * at;
    default: throw std::domain_error("greenhall: alpha out of range");
  }
}
// F = 0 stands for F = ∞.
inline long double sx(long double t, long double F, int alpha) {
  if (F == 0) return sw(t, alpha + 2);
  return F * F * (2 * sw(t, alpha) - sw(t - 1 / F, alpha) - sw(t + 1 / F, alpha));
}
// Difference order d: 1 first difference, 2 Allan, 3 Hadamard (Greenhall–Riley eq. 9).
inline long double sz(long double t, long double F, int alpha, int d = 2) {
  auto pair = [&](long double k) { return sx(t - k, F, alpha) + sx(t + k, F, alpha); };
  switch (d) {
    case 1: return 2 * sx(t, F, alpha) - pair(1);
    case 2: return 6 * sx(t, F, alpha) - 4 * pair(1) + pair(2);
    case 3: return 20 * sx(t, F, alpha) - 15 * pair(1) + 6 * pair(2) - pair(3);
    default: throw std::domain_error("greenhall: d must be 1, 2 or 3");
  }
}
inline long double basic_sum(long double J, long double M, long double S, long double F,
                             int alpha, int d = 2) {
  const long double s0 = sz(0, F, alpha, d);
  long double sum = s0 * s0;
  const long double sJ = sz(J / S, F, alpha, d);
  sum += (1 - J / M) * sJ * sJ;
  for (long double j = 1; j < J; j += 1) {
    const long double v = sz(j / S, F, alpha, d);
    sum += 2 * (1 - j / M) * v * v;
  }
  return sum;
}

// Greenhall–Riley tables (a0, a1) by noise α (row 2 … −4) and d (column 1 … 3); {0, 0} where
// the variance does not converge (α + 2d ≤ 1).
struct A01 {
  long double a0, a1;
};
inline A01 table1(int alpha, int d) {  // modified variances (F = 1)
  static constexpr A01 t[7][3] = {
      {{2.0L / 3, 1.0L / 3}, {7.0L / 9, 0.5L}, {22.0L / 25, 2.0L / 3}},
      {{0.840L, 0.345L}, {0.997L, 0.616L}, {1.141L, 0.843L}},
      {{1.079L, 0.368L}, {1.033L, 0.607L}, {1.184L, 0.848L}},
      {{0, 0}, {1.048L, 0.534L}, {1.180L, 0.816L}},
      {{0, 0}, {1.302L, 0.535L}, {1.175L, 0.777L}},
      {{0, 0}, {0, 0}, {1.194L, 0.703L}},
      {{0, 0}, {0, 0}, {1.489L, 0.702L}}};
  return t[2 - alpha][d - 1];
}
inline A01 table2(int alpha, int d) {  // unmodified variances (F = m)
  static constexpr A01 t[7][3] = {
      {{1.5L, 0.5L}, {35.0L / 18, 1.0L}, {231.0L / 100, 1.5L}},
      {{78.6L, 25.2L}, {790.0L, 410.0L}, {9950.0L, 6520.0L}},
      {{2.0L / 3, 1.0L / 6}, {2.0L / 3, 1.0L / 3}, {7.0L / 9, 0.5L}},
      {{0, 0}, {0.852L, 0.375L}, {0.997L, 0.617L}},
      {{0, 0}, {1.079L, 0.368L}, {1.033L, 0.607L}},
      {{0, 0}, {0, 0}, {1.053L, 0.553L}},
      {{0, 0}, {0, 0}, {1.302L, 0.535L}}};
  return t[2 - alpha][d - 1];
}
inline A01 table3(int d) {  // α = 1, unmodified: (b0, b1)
  static constexpr A01 t[3] = {{6.0L, 4.0L}, {15.23L, 12.0L}, {47.8L, 40.0L}};
  return t[d - 1];
}

}  // namespace greenhall

// EDF of a d-th difference variance (d = 1 first difference, 2 Allan, 3 Hadamard) at
// averaging factor m from N phase points, by Greenhall's algorithm exactly as in C. A. Greenhall,
// W. J. Riley, "Uncertainty of stability variances based on finite differences" (PTTI 2003),
// the algorithm Stable32 uses: overlapping → stride S = m (else 1); modified → filter factor
// F = 1 (else F = m, with F = ∞ when m(d+1) > 100 for α ≤ 0). NaN where the variance has no
// term or the noise does not converge (α + 2d ≤ 1).
inline double edf_greenhall(int alpha, int d, double m, double n_phase, bool overlapping,
                            bool modified) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (d < 1 || d > 3 || alpha > 2 || alpha < -4 || alpha + 2 * d <= 1) return kNaN;
  using namespace greenhall;
  const long double N = n_phase, mm = m;
  const long double F = modified ? 1 : mm;
  const long double S = overlapping ? mm : 1;
  const long double L = mm / F + mm * d;
  if (!(N >= L)) return kNaN;
  const long double M = 1 + std::floor(S * (N - L) / mm);
  const long double J = std::min(M, (d + 1) * S);
  constexpr long double J_max = 100;
  const long double r = M / S;
  constexpr long double kInf = 0;  // F = 0 stands for F = ∞ in sx()
  long double inv = 0;
  auto direct = [&](long double Fz) {
    const long double s0 = sz(0, Fz, alpha, d);
    return basic_sum(J, M, S, Fz, alpha, d) / (s0 * s0 * M);
  };
  if (modified) {
    if (J <= J_max) {
      inv = direct(1);
    } else if (r > d + 1) {
      const A01 a = table1(alpha, d);
      inv = (a.a0 - a.a1 / r) / r;
    } else {
      const long double mp = J_max / r, s0 = sz(0, 1, alpha, d);
      inv = basic_sum(J_max, J_max, mp, 1, alpha, d) / (s0 * s0 * J_max);
    }
  } else if (alpha <= 0) {
    if (J <= J_max) {
      inv = direct(mm * (d + 1) <= J_max ? mm : kInf);
    } else if (r > d + 1) {
      const A01 a = table2(alpha, d);
      inv = (a.a0 - a.a1 / r) / r;
    } else {
      const long double mp = J_max / r, s0 = sz(0, kInf, alpha, d);
      inv = basic_sum(J_max, J_max, mp, kInf, alpha, d) / (s0 * s0 * J_max);
    }
  } else if (alpha == 1) {
    const A01 b = table3(d);
    const long double bl = b.a0 + b.a1 * std::log(mm);
    if (J <= J_max) {
      inv = direct(mm);
    } else if (r > d + 1) {
      const A01 a = table2(1, d);
      inv = (a.a0 - a.a1 / r) / (bl * bl * r);
    } else {
      const long double mp = J_max / r;
      inv = basic_sum(J_max, J_max, mp, mp, 1, d) / (bl * bl * J_max);
    }
  } else {  // α = 2, unmodified
    if (std::ceil(r) <= d) return kNaN;
    const A01 a = table2(2, d);
    inv = (a.a0 - a.a1 / r) / M;
  }
  return inv > 0 ? static_cast<double>(1 / inv) : kNaN;
}

// EDF of the fully overlapping Allan variance at averaging factor m from N *phase* points
// (N rate samples give N + 1 phase points), for noise type `type`: Greenhall's algorithm as
// Stable32 uses it (edf_greenhall with d = 2, overlapping, unmodified). NaN when no difference
// exists.
inline double edf_overlapping_adev(NoiseType type, double n_phase, double m) {
  return edf_greenhall(alpha_of(type), 2, m, n_phase, true, false);
}

// EDF of the total variance (NIST SP 1065 Table 7: b·N/m − c) for white, flicker and
// random-walk FM (α = 0, −1, −2); N phase points. NaN for other noise types.
inline double edf_totdev(int alpha, double m, double n_phase) {
  static constexpr double b[3] = {1.50, 1.17, 0.93}, c[3] = {0.0, 0.22, 0.36};
  if (alpha > 0 || alpha < -2) return std::numeric_limits<double>::quiet_NaN();
  return b[-alpha] * n_phase / m - c[-alpha];
}

// The simple closed forms of NIST SP 1065 Table 5 (Howe, Allan, Barnes 1981) for the
// overlapping Allan variance; N phase points, averaging factor m.
inline double edf_overlapping_adev_simple(NoiseType type, double N, double m) {
  switch (type) {
    case NoiseType::kQuantization: return (N + 1) * (N - 2 * m) / (2 * (N - m));
    case NoiseType::kFlickerPhase:
      return std::exp(std::sqrt(std::log((N - 1) / (2 * m)) * std::log((2 * m + 1) * (N - 1) / 4)));
    case NoiseType::kWhite:
      return (3 * (N - 1) / (2 * m) - 2 * (N - 2) / N) * (4 * m * m) / (4 * m * m + 5);
    case NoiseType::kFlicker:
      return m == 1 ? 2 * (N - 2) / (2.3 * N - 4.9) : 5 * N * N / (4 * m * (N + 3 * m));
    case NoiseType::kRandomWalk:
      return (N - 2) / (m * (N - 3) * (N - 3)) * ((N - 1) * (N - 1) - 3 * m * (N - 1) + 4 * m * m);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Two-sided confidence interval of a deviation `dev` estimated with `edf` degrees of freedom:
// dev·sqrt(edf/χ²_{(1+c)/2}) … dev·sqrt(edf/χ²_{(1−c)/2}) (NIST SP 1065 eq. 45).
struct Interval {
  double lo = std::numeric_limits<double>::quiet_NaN();
  double hi = std::numeric_limits<double>::quiet_NaN();
};
inline Interval deviation_interval(double dev, double edf, double confidence) {
  if (!(confidence > 0.0 && confidence < 1.0)) {
    throw std::domain_error("deviation_interval: confidence must be in (0, 1)");
  }
  Interval out;
  if (!(edf > 0.0) || !std::isfinite(edf) || !std::isfinite(dev)) return out;
  const double tail = 0.5 * (1.0 - confidence);
  out.lo = dev * std::sqrt(edf / chi2_quantile(1.0 - tail, edf));
  out.hi = dev * std::sqrt(edf / chi2_quantile(tail, edf));
  return out;
}

// Correlation of the fully overlapping Allan variance estimates at averaging factors m1 and m2 of
// a long record of one noise type. With d_m(i) the difference of adjacent m-sample means starting
// at sample i, Cov(Â_m1, Â_m2) ∝ Σ_s C(s)², C(s) = Cov(d_m1(0), d_m2(s)) (Gaussian fourth
// moments), so the correlation is Σ C12² / √(Σ C11² · Σ C22²). C is computed in discrete time
// from the noise's (generalized) autocovariance G(l) of the rate samples: white PM 2, −1 at
// |l| = 1; white FM δ(l); flicker FM −∫(1−|u|)·ln|l+u| du over u ∈ [−1, 1] (sample means of a
// 1/f process); random-walk FM −|l|/2 (exact for kernels that sum to zero). The smaller factor is
// taken as 2^b with b ≤ kAvarCorrelationBase (larger factors use the continuous-time limit at
// 2^kAvarCorrelationBase), the ratio as 2^k; ratios above 2^kAvarCorrelationOctaves are taken as
// uncorrelated (random-walk FM ≈ 0.04 there, the others < 0.001). With the record's length
// n_samples > 0, pairs whose larger factor exceeds n/kAvarCorrelationFiniteRecord, where the few
// second differences lower the correlation (random-walk FM 0.79 instead of 0.89 at m = n/8, n/4),
// and at most 2^kAvarCorrelationFiniteOctaves apart, are computed for that record.
inline constexpr int kAvarCorrelationBase = 3;
inline constexpr double kAvarCorrelationFiniteRecord = 64.0;
inline constexpr int kAvarCorrelationFiniteOctaves = 4;
inline constexpr int kAvarCorrelationOctaves = 10;

namespace detail {

inline double generalized_autocovariance(NoiseType type, long l) {
  const double a = std::abs(static_cast<double>(l));
  switch (type) {
    case NoiseType::kQuantization:
    case NoiseType::kFlickerPhase: return l == 0 ? 2.0 : (a == 1.0 ? -1.0 : 0.0);
    case NoiseType::kWhite: return l == 0 ? 1.0 : 0.0;
    case NoiseType::kRandomWalk: return -0.5 * a;
    case NoiseType::kFlicker: {
      if (a > 8.0) return -std::log(a) + 1.0 / (12.0 * a * a);  // the integral's expansion
      static const std::array<double, 9> near = [] {
        std::array<double, 9> g{};
        constexpr int kNodes = 2000;  // midpoint rule over u ∈ [−1, 1]
        for (int lag = 0; lag <= 8; ++lag) {
          double s = 0.0;
          for (int q = 0; q < kNodes; ++q) {
            const double u = -1.0 + (q + 0.5) * 2.0 / kNodes;
            s += (1.0 - std::abs(u)) * std::log(std::abs(lag + u));
          }
          g[static_cast<std::size_t>(lag)] = -s * 2.0 / kNodes;
        }
        return g;
      }();
      return near[static_cast<std::size_t>(a)];
    }
  }
  return 0.0;
}

// Σ_s w(s)·C12(s)² for d_m1 and d_m2 (m1 ≤ m2) of one noise type, w(s) the share of the pairs of
// second differences at lag s in a record of n samples (M_i = n + 1 − 2·m_i of them each:
// w(s) = #{i < M1 : 0 ≤ i + s < M2} / (M1·M2)); n = 0: a long record, w = 1. Each kernel is ±1/m
// on two boxes of m samples, so C12(s) is four box-box sums Σ_{t<n1} Σ_{u<n2} G(x + u − t), each
// four values of the second cumulative sum of G: O(1) per lag.
inline double avar_cross_moment(NoiseType type, long m1, long m2, long n = 0) {
  const long reach = (type == NoiseType::kFlicker ? 8 : 1) * 2 * (m1 + m2) + 2;  // C12 ≈ 0 beyond
  const long y0 = -(reach + 3 * m1 + 2 * m2 + 2), y1 = reach + 3 * m2 + 2;
  std::vector<long double> q(static_cast<std::size_t>(y1 - y0 + 2));
  long double p = 0.0L;  // q[y − y0] = Σ_{z<y} P(z), P(z) = Σ_{y0≤v<z} G(v)
  for (long y = y0; y <= y1; ++y) {
    q[static_cast<std::size_t>(y - y0 + 1)] = q[static_cast<std::size_t>(y - y0)] + p;
    p += generalized_autocovariance(type, y);
  }
  auto Q = [&](long y) { return q[static_cast<std::size_t>(y - y0)]; };
  auto box = [&](long x) { return Q(x + m2 + 1) - Q(x + m2 - m1 + 1) - Q(x + 1) + Q(x - m1 + 1); };
  const long M1 = n + 1 - 2 * m1, M2 = n + 1 - 2 * m2;
  auto weight = [&](long s) -> long double {
    if (n == 0) return 1.0L;
    const long pairs = std::min(M1, M2 - s) - std::max(0L, -s);
    return pairs > 0 ? static_cast<long double>(pairs) / (static_cast<long double>(M1) * M2) : 0.0L;
  };
  long double sum = 0.0L;
  for (long s = -reach; s <= reach; ++s) {
    const long double c = box(s) - box(s + m2) - box(s - m1) + box(s + m2 - m1);
    sum += weight(s) * c * c;
  }
  return static_cast<double>(sum / (static_cast<long double>(m1 * m1) * static_cast<long double>(m2 * m2)));
}

// The correlation in a record of n samples, computed directly (see avar_correlation).
inline double avar_correlation_finite(NoiseType type, long m1, long m2, long n) {
  return avar_cross_moment(type, m1, m2, n) /
         std::sqrt(avar_cross_moment(type, m1, m1, n) * avar_cross_moment(type, m2, m2, n));
}

}  // namespace detail

// The long-record correlations per noise type, smaller factor 2^b and ratio 2^k. Rows: random-walk
// FM, flicker FM, white FM, white PM (row min(alpha + 2, 3): flicker PM shares white PM's
// autocovariance, generalized_autocovariance).
using AvarCorrelationTable =
    std::array<std::array<std::array<double, kAvarCorrelationOctaves + 1>, kAvarCorrelationBase + 1>, 4>;

inline std::size_t avar_correlation_row(NoiseType type) {
  return static_cast<std::size_t>(std::min(alpha_of(type) + 2, 3));
}

namespace detail {
// The table from avar_cross_moment (kAvarCorrelation below holds its output).
inline AvarCorrelationTable compute_avar_correlation_table() {
  AvarCorrelationTable t{};
  for (const NoiseType type : {NoiseType::kRandomWalk, NoiseType::kFlicker, NoiseType::kWhite, NoiseType::kQuantization}) {
    std::array<double, kAvarCorrelationBase + kAvarCorrelationOctaves + 1> self{};
    for (std::size_t j = 0; j < self.size(); ++j) self[j] = avar_cross_moment(type, 1L << j, 1L << j);
    for (int b = 0; b <= kAvarCorrelationBase; ++b) {
      for (int k = 0; k <= kAvarCorrelationOctaves; ++k) {
        t[avar_correlation_row(type)][b][k] = avar_cross_moment(type, 1L << b, 1L << (b + k)) /
            std::sqrt(self[static_cast<std::size_t>(b)] * self[static_cast<std::size_t>(b + k)]);
      }
    }
  }
  return t;
}
}  // namespace detail

// detail::compute_avar_correlation_table()'s output, kept so that no process pays its ≈ 0.15 s
// (allan_stats_test recomputes it).
inline constexpr AvarCorrelationTable kAvarCorrelation = {{
    {{  // random-walk FM: b = 0 … 3, k = 0 … 10
        {1, 0.71713716560063612, 0.48913049448252938, 0.34184226467778478,
         0.24097335021568247, 0.17026062025391145, 0.12036881620464548, 0.085109427374796112,
         0.060180714399358966, 0.04255406063319217, 0.030090241750778946},
        {1, 0.85833250775998859, 0.63923712243562658, 0.45819744198917312,
         0.32512944836444341, 0.23010541083599806, 0.16274549898936619, 0.11508490826244037,
         0.081378463827401756, 0.057543466197188892, 0.040689410991505734},
        {1, 0.88131956077162332, 0.66763728262811994, 0.48115848312786885,
         0.34193943396725462, 0.24209912931742167, 0.17124581247014198, 0.12109902540188346,
         0.085631707415702835, 0.06055107363830841, 0.042816130095250725},
        {1, 0.88614957451641962, 0.67398436028466846, 0.48637224678318408,
         0.34577337100662431, 0.24483787441056357, 0.17318745496252586, 0.12247288159512933,
         0.086603332099449828, 0.061238144724313485, 0.043301967799323646},
    }},
    {{  // flicker FM: b = 0 … 3, k = 0 … 10
        {1, 0.62709824921060753, 0.27455495333054336, 0.10616092478207638,
         0.039128338558412766, 0.014115382865266554, 0.0050402854153616082, 0.0017908063672161868,
         0.00063470133185199217, 0.00022467594202662299, 7.9483601472431713e-05},
        {1, 0.68269266637981774, 0.30554197157121171, 0.11935271764199243,
         0.044198732686013098, 0.015980358193906793, 0.0057124526287437791, 0.0020307152345217516,
         0.00071992150273455927, 0.0002548764039310284, 9.0173544400550565e-05},
        {1, 0.68871882207353607, 0.30896654176801364, 0.12080850389810641,
         0.044757955180706036, 0.016185981657252657, 0.0057865466660298043, 0.0020571570761030839,
         0.00072931333086110434, 0.00025820452153942319, 9.1351549558028682e-05},
        {1, 0.68935210467469887, 0.30933218927380662, 0.12096386540394009,
         0.044817568507844685, 0.016207877867244577, 0.005794430239828556, 0.0020599688899531035,
         0.00073031169233398092, 0.00025855822556385106, 9.1476728524041064e-05},
    }},
    {{  // white FM: b = 0 … 3, k = 0 … 10
        {1, 0.46291004988627571, 0.18057877962865379, 0.065653216429861272,
         0.023380488239570611, 0.0082813545958943663, 0.002929240567456325, 0.0010357614385940422,
         0.00036620744509030441, 0.0001294748099338323, 4.5776339902683341e-05},
        {1, 0.50155039131781753, 0.18234920215644923, 0.064938377864070682,
         0.0230011336146684, 0.0081358493832606599, 0.002876786275259093, 0.0010171266400528704,
         0.00035961114435291831, 0.00012714196672777356, 4.4951493518165608e-05},
        {1, 0.52164541887041027, 0.18576888147064513, 0.065799223890344927,
         0.023274182224040374, 0.0082296076089801631, 0.0029096889151147146, 0.0010287377395021471,
         0.00036371436620169224, 0.00012859250486336554, 4.5464321180357541e-05},
        {1, 0.52804146359215431, 0.18703196257213767, 0.066156038342916876,
         0.023392368044815377, 0.0082706876478546628, 0.0029241505752675601, 0.0010338451991432308,
         0.00036551963890552112, 0.00012923072210613125, 4.5689961246002537e-05},
    }},
    {{  // white PM (and flicker PM): b = 0 … 3, k = 0 … 10
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
    }},
}};


inline double avar_correlation(NoiseType type, double m1, double m2, double n_samples = 0.0) {
  const AvarCorrelationTable& tables = kAvarCorrelation;
  if (m1 > m2) std::swap(m1, m2);
  const int k = static_cast<int>(std::lround(std::log2(m2 / m1)));
  if (k > kAvarCorrelationOctaves) return 0.0;
  if (n_samples > 0.0 && m2 * kAvarCorrelationFiniteRecord > n_samples && k <= kAvarCorrelationFiniteOctaves) {
    // Near the record's length: direct, scaled so that m1 is at most 2^kAvarCorrelationBase.
    const double scale = std::min(1.0, std::ldexp(1.0, kAvarCorrelationBase) / m1);
    const long a = std::lround(m1 * scale), b = std::lround(m2 * scale), n = std::lround(n_samples * scale);
    if (n + 1 > 2 * b) return detail::avar_correlation_finite(type, a, b, n);
  }
  const int b = std::clamp(static_cast<int>(std::lround(std::log2(m1))), 0, kAvarCorrelationBase);
  return tables[avar_correlation_row(type)][static_cast<std::size_t>(b)][static_cast<std::size_t>(k)];
}

// The one-sigma confidence level, erf(1/√2).
inline constexpr double kOneSigma = 0.682689492137085897;

}  // namespace stats
}  // namespace stend::allan
