// How much a deviation estimate can be trusted: the power-law noise types, the equivalent degrees
// of freedom (EDF) of the Allan-type variances, their χ² confidence intervals, and the correlation
// of overlapping Allan variance estimates at two averaging factors.
//   - EDF by Greenhall's algorithm (C. A. Greenhall, W. J. Riley, "Uncertainty of stability
//     variances based on finite differences", PTTI 2003), as Stable32 uses it; the closed forms of
//     NIST SP 1065 (Table 5, Table 7) as alternatives;
//   - the interval dev·sqrt(edf/χ²_{(1±c)/2}) (NIST SP 1065 eq. 45).
#pragma once

#include <array>
#include <cstddef>

#include "stend/stats/distributions.hpp"

namespace stend::noise {

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
const char* to_string(NoiseType t);

// EDF of a d-th difference variance (d = 1 first difference, 2 Allan, 3 Hadamard) at averaging
// factor m from N phase points, by Greenhall's algorithm exactly as in Greenhall and Riley (PTTI
// 2003), the algorithm Stable32 uses: overlapping → stride S = m (else 1); modified → filter
// factor F = 1 (else F = m, with F = ∞ when m(d+1) > 100 for α ≤ 0). NaN where the variance has
// no term or the noise does not converge (α + 2d ≤ 1).
double edf_greenhall(int alpha, int d, double m, double n_phase, bool overlapping, bool modified);

// EDF of the fully overlapping Allan variance at averaging factor m from N *phase* points (N rate
// samples give N + 1 phase points), for noise type `type`: edf_greenhall with d = 2, overlapping,
// unmodified. NaN when no difference exists.
double edf_overlapping_adev(NoiseType type, double n_phase, double m);

// EDF of the total variance (NIST SP 1065 Table 7: b·N/m − c) for white, flicker and random-walk
// FM (α = 0, −1, −2); N phase points. NaN for other noise types.
double edf_totdev(int alpha, double m, double n_phase);

// The simple closed forms of NIST SP 1065 Table 5 (Howe, Allan, Barnes 1981) for the overlapping
// Allan variance; N phase points, averaging factor m.
double edf_overlapping_adev_simple(NoiseType type, double N, double m);

// Two-sided confidence interval of a deviation `dev` estimated with `edf` degrees of freedom:
// dev·sqrt(edf/χ²_{(1+c)/2}) … dev·sqrt(edf/χ²_{(1−c)/2}); no interval (NaN) when edf or dev is
// not finite and positive. Throws std::domain_error unless 0 < confidence < 1.
stats::Interval deviation_interval(double dev, double edf, double confidence);

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
double avar_correlation(NoiseType type, double m1, double m2, double n_samples = 0.0);

// The long-record correlations per noise type, smaller factor 2^b and ratio 2^k. Rows: random-walk
// FM, flicker FM, white FM, white PM (row min(alpha + 2, 3): flicker PM shares white PM's
// autocovariance).
using AvarCorrelationTable =
    std::array<std::array<std::array<double, kAvarCorrelationOctaves + 1>, kAvarCorrelationBase + 1>, 4>;
std::size_t avar_correlation_row(NoiseType type);
// The table avar_correlation reads (computed once and kept in the source: no process pays the
// ≈ 0.15 s of computing it), and the computation itself (for the test that they agree).
const AvarCorrelationTable& avar_correlation_table();
AvarCorrelationTable compute_avar_correlation_table();

}  // namespace stend::noise
