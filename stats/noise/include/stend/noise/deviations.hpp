// All frequency-stability deviations of one signal in one streaming pass, with Stable32's
// equivalent degrees of freedom, noise identification and chi-squared intervals.
//
// Kinds (NIST SP 1065 §5, N phase points x_0 … x_{N−1}, τ = m·τ0, d2_k(m) = x_k − 2x_{k−m} + x_{k−2m},
// d3_k(m) = d2_k(m) − d2_{k−m}(m)):
//   ADEV   non-overlapped Allan:   Σ_{k ≡ 0 mod m, k ≥ 2m} d2_k² / (2τ² terms)
//   OADEV  overlapping Allan:      Σ_{k ≥ 2m} d2_k² / (2τ² (N − 2m))
//   MDEV   modified Allan:         Σ_{k ≥ 3m−1} (Σ_{j=k−m+1}^{k} d2_j)² / (2m²τ² (N − 3m + 1))
//   TDEV   time deviation:         τ·MDEV/√3
//   HDEV   non-overlapped Hadamard: Σ_{k ≡ 0 mod m, k ≥ 3m} d3_k² / (6τ² terms)
//   OHDEV  overlapping Hadamard:   Σ_{k ≥ 3m} d3_k² / (6τ² (N − 3m))
//   TOTDEV total deviation:        Σ_{c=1}^{N−2} (x*_{c−m} − 2x_c + x*_{c+m})² / (2τ² (N − 2)),
//          x* the record reflected at both ends: x*_{−j} = 2x_0 − x_j, x*_{N−1+j} = 2x_{N−1} − x_{N−1−j}.
// TOTDEV is the OADEV sum plus the centres within m of either end; those need the first 2m
// points (a head buffer) and the last 2m points (a tail ring), evaluated at the end.
//
// Octave factors (m = 2^l) come from one pyramid of MDEV windows V^m (DeviationStream::Level):
// each level is a few vector operations per point on its own ring buffer, and every kind at m
// is a difference of V^m at lags 1 and m. Other factors (all τ, log-spaced) are evaluated on
// the phase history, factor by factor.
//
// Input: phase x (time error, s) with add_phase, or rate y (the sensor's output: ω, a, or
// fractional frequency) with add_rate, integrated to x_{k+1} = x_k + (y_k − y_0)·τ0 internally
// (subtracting y_0 removes a linear phase ramp that every kind above ignores, and keeps the
// integrated phase small). Deviations are in the unit of y: for phase input, x/τ0 is the rate.
// TDEV is in the unit of x (s for phase input, unit of y × s for rate input).
//
// Memory, whatever N is: the pyramid's rings (2m + 4096 values per octave level, ≈ 4·max_m in
// all), the first and the last 2·max_m + 1 phase values, and for factors that are not powers of
// two the last 3·m + 1 phase values twice over (a linear history shifted once per block):
// ≈ 8·8·max_m bytes for octaves.
//
// Noise identification per averaging factor (the "Alpha" column of Stable32): the lag-1
// autocorrelation of the phase decimated by m, differenced d = 0, 1, … times until
// ρ = r1/(1 + r1) < 0.25 (W. J. Riley, C. A. Greenhall, "Power law noise identification using
// the lag 1 autocorrelation", 2004), α = 2 − 2(ρ + d) rounded, when at least 30 decimated points
// exist; otherwise Barnes' B1 ratio (standard over Allan variance of the m-averages) against its
// theoretical value, with R(n) = MVAR/AVAR separating white from flicker PM, while at least
// b1_min_averages averages exist; beyond that the type of the next shorter factor is kept. The autocorrelation
// of the d-th difference is taken about its mean (differencing removes the trends that
// Riley's recipe removes by a polynomial fit), from running sums over the first 2^16 decimated
// points of each factor: bounded memory and time.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "stend/stats/distributions.hpp"

namespace stend::noise {

enum class DeviationKind { kAdev, kOadev, kMdev, kTdev, kHdev, kOhdev, kTotdev };
inline constexpr std::array<DeviationKind, 7> kAllDeviationKinds = {
    DeviationKind::kAdev, DeviationKind::kOadev, DeviationKind::kMdev, DeviationKind::kTdev,
    DeviationKind::kHdev, DeviationKind::kOhdev, DeviationKind::kTotdev};

const char* to_string(DeviationKind k);  // "adev", "oadev", …

// One deviation at one averaging factor.
struct DeviationPoint {
  std::uint64_t m = 0;        // averaging factor (samples)
  double tau_s = 0.0;         // m·τ0
  std::uint64_t terms = 0;    // Stable32's "#": differences (or windows) summed
  int alpha = 0;              // identified power-law noise of y (S_y ∝ f^α), 2 … −2
  double dev = 0.0;           // the deviation (see the header for its unit)
  double edf = 0.0;           // equivalent degrees of freedom (NaN when undefined)
  double lo = std::numeric_limits<double>::quiet_NaN();  // confidence bounds of dev
  double hi = std::numeric_limits<double>::quiet_NaN();
};

// EDF of `kind` at factor m from N phase points for noise α (Stable32's choices: Greenhall's
// algorithm with d = 2 for the Allan kinds, modified for MDEV/TDEV, d = 3 for Hadamard; SP 1065
// Table 7 for TOTDEV).
double deviation_edf(DeviationKind kind, int alpha, double m, double n_phase);

// Largest factor reported: N phase points / this (Stable32's stop ratios, W. J. Riley,
// "Evolution of frequency stability analysis software", Table III).
std::uint64_t stop_ratio(DeviationKind kind);

struct DeviationOptions {
  std::vector<std::uint64_t> factors;  // averaging factors m; empty = octaves 1, 2, 4, … ≤ max_m
  std::uint64_t max_m = 1ull << 20;    // largest factor kept in memory (fixes the memory)
  double tau0_s = 1.0;                 // sample interval
  double confidence = stats::kOneSigma;
  // Noise identification: lag-1 autocorrelation from this many decimated points on, B1 below.
  std::uint64_t acf_min_points = 30;
  // Fewer m-averages than this: the noise type of the next shorter factor is kept (with 7
  // averages B1 cannot tell white FM from PM noise; Stable32 keeps white FM on PHASE.DAT there).
  std::uint64_t b1_min_averages = 10;

  // Ceres style: false, with what is wrong in *why, when a value is out of range.
  bool IsValid(std::string* why = nullptr) const;
};

// Every factor 1 … max_m (all τ), or about `per_decade` log-spaced factors per decade. The cost
// is O(N · factors): all τ suits short records, log-spaced ones long records.
std::vector<std::uint64_t> all_factors(std::uint64_t max_m);
std::vector<std::uint64_t> log_factors(std::uint64_t max_m, int per_decade);

class DeviationStream {
 public:
  // Throws std::invalid_argument naming the option when options.IsValid() fails.
  explicit DeviationStream(DeviationOptions options = {});
  ~DeviationStream();
  DeviationStream(DeviationStream&&) noexcept;
  DeviationStream& operator=(DeviationStream&&) noexcept;

  // Phase samples (time error, s).
  void add_phase(const double* x, std::size_t n);
  // Rate samples (the sensor's unit), integrated to phase.
  void add_rate(const double* y, std::size_t n);

  std::uint64_t phase_points() const;
  std::size_t state_bytes() const;
  const DeviationOptions& options() const;

  // The deviations of `kind` at every factor up to N / stop_ratio(kind) (Stable32's limits),
  // with noise type, EDF and interval.
  std::vector<DeviationPoint> result(DeviationKind kind);

 private:
  class State;
  std::unique_ptr<State> state_;
};

}  // namespace stend::noise
