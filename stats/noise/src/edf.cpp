// Equivalent degrees of freedom and intervals of the Allan-type variances. See stend/noise/edf.hpp.
#include "stend/noise/edf.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "stend/sdk.hpp"

namespace stend::noise {

namespace {

// Greenhall–Riley's sw, sx, sz, the basic sum and tables 1–3.
long double sw(long double t, int alpha) {
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
long double sx(long double t, long double F, int alpha) {
  if (F == 0) return sw(t, alpha + 2);
  return F * F * (2 * sw(t, alpha) - sw(t - 1 / F, alpha) - sw(t + 1 / F, alpha));
}
// Difference order d: 1 first difference, 2 Allan, 3 Hadamard (Greenhall–Riley eq. 9).
long double sz(long double t, long double F, int alpha, int d = 2) {
  auto pair = [&](long double k) { return sx(t - k, F, alpha) + sx(t + k, F, alpha); };
  switch (d) {
    case 1: return 2 * sx(t, F, alpha) - pair(1);
    case 2: return 6 * sx(t, F, alpha) - 4 * pair(1) + pair(2);
    case 3: return 20 * sx(t, F, alpha) - 15 * pair(1) + 6 * pair(2) - pair(3);
    default: throw std::domain_error("greenhall: d must be 1, 2 or 3");
  }
}
long double basic_sum(long double J, long double M, long double S, long double F,
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
A01 table1(int alpha, int d) {  // modified variances (F = 1)
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
A01 table2(int alpha, int d) {  // unmodified variances (F = m)
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
A01 table3(int d) {  // α = 1, unmodified: (b0, b1)
  static constexpr A01 t[3] = {{6.0L, 4.0L}, {15.23L, 12.0L}, {47.8L, 40.0L}};
  return t[d - 1];
}

}  // namespace

const char* to_string(NoiseType t) {
  switch (t) {
    case NoiseType::kQuantization: return "quantization (white PM)";
    case NoiseType::kFlickerPhase: return "flicker PM";
    case NoiseType::kWhite: return "white (white FM)";
    case NoiseType::kFlicker: return "flicker (flicker FM)";
    case NoiseType::kRandomWalk: return "random walk (RW FM)";
  }
  return "?";
}

double edf_greenhall(int alpha, int d, double m, double n_phase, bool overlapping, bool modified) {
  if (d < 1 || d > 3 || alpha > 2 || alpha < -4 || alpha + 2 * d <= 1) return kNaN;
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

double edf_overlapping_adev(NoiseType type, double n_phase, double m) {
  return edf_greenhall(alpha_of(type), 2, m, n_phase, true, false);
}

double edf_totdev(int alpha, double m, double n_phase) {
  static constexpr double b[3] = {1.50, 1.17, 0.93}, c[3] = {0.0, 0.22, 0.36};
  if (alpha > 0 || alpha < -2) return kNaN;
  return b[-alpha] * n_phase / m - c[-alpha];
}

double edf_overlapping_adev_simple(NoiseType type, double N, double m) {
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
  return kNaN;
}

stats::Interval deviation_interval(double dev, double edf, double confidence) {
  if (!(confidence > 0.0 && confidence < 1.0)) {
    throw std::domain_error("deviation_interval: confidence must be in (0, 1)");
  }
  stats::Interval out;
  if (!(edf > 0.0) || !std::isfinite(edf) || !std::isfinite(dev)) return out;
  const double tail = 0.5 * (1.0 - confidence);
  out.lo = dev * std::sqrt(edf / stats::chi2_quantile(1.0 - tail, edf));
  out.hi = dev * std::sqrt(edf / stats::chi2_quantile(tail, edf));
  return out;
}

}  // namespace stend::noise
