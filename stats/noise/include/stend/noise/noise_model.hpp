// The noise model of one channel from its Allan curve (library stend_noise; the allan estimator
// and the gap diagnosis' noise stage use it):
//
//   curve      overlapping ADEV at octave τ from the streaming estimator (allan_stream.hpp), with
//              χ² confidence intervals from the equivalent degrees of freedom (edf.hpp)
//   model      the IEEE Std 952 / 1554 terms plus a first-order Gauss–Markov bias,
//                σ²(τ) = 3Q²/τ² + N²·w(m) + (2 ln2/π) B² + K²τ/3 + R²τ²/2 + σ_G²·g(τ/τc),
//              with the sensor's output low-pass in the white term w; terms chosen by penalised
//              likelihood, one verdict per coefficient (identified ± σ, upper bound, failed)
//   read-offs  the textbook slope lines: N = σ(1 s) on the −1/2 line, K = σ(3 s) on the +1/2
//              line, B = σ_min / 0.664 at the flat minimum
//
// Units: for an accelerometer channel in m/s²: N [m/s²/√Hz] (velocity random walk), K [m/s³/√Hz]
// (acceleration random walk), B [m/s²], Q [m/s], R [m/s³]; for a gyroscope in rad/s: N
// [rad/s/√Hz] (angle random walk), K [rad/s²/√Hz] (rate random walk), B [rad/s], Q [rad],
// R [rad/s²].
#pragma once

#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "stend/noise/allan_stream.hpp"
#include "stend/noise/edf.hpp"
#include "stend/sdk.hpp"

namespace stend::noise {

// √(2 ln 2 / π): the flicker (bias-instability) floor of the ADEV is 0.664·B.
inline constexpr double kFlickerFloor = 0.66428200410814707;

enum class Instrument { kAccelerometer, kGyroscope, kOther };
const char* to_string(Instrument i);  // "accelerometer" | "gyroscope" | "other"

// Unit strings of one channel and of its noise coefficients.
struct Units {
  std::string signal;        // "m/s^2", "rad/s"
  std::string quantization;  // Q: signal·s
  std::string white;         // N: signal/√Hz
  std::string bias;          // B: signal
  std::string random_walk;   // K: signal/s/√Hz
  std::string ramp;          // R: signal/s
  std::string gauss_markov;  // σ of the Gauss–Markov bias: signal
};
// Accelerometer → m/s², gyroscope → rad/s; kOther uses `signal_unit` as given.
Units units_for(Instrument instrument, const std::string& signal_unit = {});

struct ChannelInfo {
  std::string name;  // "ax", "gz", …
  Instrument instrument = Instrument::kOther;
  std::string unit;  // signal unit; empty = the instrument's SI unit
};

// How one channel's curve is made and its noise model fitted (analyze, fit_noise_model).
struct AnalysisOptions {
  std::uint64_t max_m = OverlappingAllanStream::kDefaultMaxM;  // largest averaging factor
  double confidence = stats::kOneSigma;  // two-sided level of the ADEV intervals
  // EDF from the noise type that dominates the fitted model at each τ (true), or white noise
  // everywhere (false).
  bool edf_from_model = true;
  double slope_tolerance = 0.15;  // |local slope − target| for the read-off regions, in (0, 0.5)
  double min_readoff_edf = 3.0;   // points with fewer EDF are not used for read-offs
  int min_readoff_points = 2;     // a slope region needs at least this many points (1 … 64)
  // The sensor's output low-pass (second-order Butterworth, as core/model/output_stage.hpp runs
  // it) at the record's rate, cutoff [Hz]: NaN = not stated (points at the short-τ end that such
  // a filter flattens are left out of the fit, see fit_noise_model), 0 = no filter, > 0 = the
  // filter is part of the model curve of the white-noise term.
  double lowpass_hz = kNaN;

  // Ceres style: false, with "KEY: what is wrong" in *why, when a value is out of range.
  bool IsValid(std::string* why = nullptr) const;
};

struct AllanPoint {
  double tau_s = 0.0;
  std::uint64_t m = 0;      // averaging factor
  std::uint64_t terms = 0;  // second differences used
  double avar = 0.0;        // signal unit²
  double adev = 0.0;        // signal unit
  double edf = kNaN;        // equivalent degrees of freedom
  NoiseType noise = NoiseType::kWhite;  // noise type the EDF assumes
  double adev_lo = kNaN;    // confidence interval (AllanCurve::confidence)
  double adev_hi = kNaN;
};

struct AllanCurve {
  ChannelInfo channel;
  Units units;
  double rate_hz = 0.0;
  std::uint64_t samples = 0;
  double confidence = stats::kOneSigma;
  std::vector<AllanPoint> points;
};

// The verdict on one coefficient, the same in every output (text, JSON, report, exports):
//   kIdentified  the term is in the selected model: value ± sigma, 95 % interval [lo, hi]
//   kUpperBound  the data do not carry it: only upper_bound (the largest value whose term alone
//                stays below every measured ADEV upper limit)
//   kFailed      the fit failed: no number at all
enum class Verdict { kIdentified, kUpperBound, kFailed };
const char* to_string(Verdict v);  // "identified" | "upper_bound" | "failed"

// One coefficient of the model. It is `identified` when model selection (see fit_noise_model)
// keeps its term: the data carry the information, whatever the term's relative size.
struct Coefficient {
  const char* symbol = "";  // "Q", "N", "B", "K", "R", "G" (Gauss–Markov σ), "Tc" (its τc)
  const char* name = "";    // "quantization", "white noise", …
  std::string unit;
  double value = kNaN;
  double sigma = kNaN;          // 1-σ from the fit's Fisher information
  double lo = kNaN, hi = kNaN;  // 95 % interval of value (value ∓ 1.96 σ, clipped at 0)
  double fitted = 0.0;          // the estimate of the full model, whether identified or not
  double fitted_sigma = kNaN;   // its 1-σ (NaN when the term is not in the model)
  bool dominates = false;       // the term dominates the model somewhere in [τ_min, τ_max]
  bool identified = false;      // kept by model selection
  double tau_lo_s = kNaN;       // where it dominates
  double tau_hi_s = kNaN;
  double upper_bound = kNaN;
  bool failed = false;          // the fit failed (no value, no bound)

  Verdict verdict() const {
    return failed ? Verdict::kFailed : identified ? Verdict::kIdentified : Verdict::kUpperBound;
  }
};

// Datasheet units of a coefficient: the factor from its SI unit and the unit name, e.g. N of a
// gyroscope in deg/√h. Empty for coefficients and instruments without a common datasheet unit.
struct Conversion {
  double factor = 1.0;
  std::string unit;
};
std::vector<Conversion> datasheet_units(const Coefficient& c, Instrument instrument);

// A slope-line read-off.
struct Readoff {
  const char* name = "";
  std::string unit;
  bool found = false;
  double value = kNaN;  // when found; for B not found, an upper bound (see note)
  double lo = kNaN, hi = kNaN;  // interval at the curve's confidence
  double tau_lo_s = kNaN, tau_hi_s = kNaN;  // points used (B: τ of the minimum)
  std::string note;
};

inline Coefficient named(const char* symbol, const char* name) {
  Coefficient c;
  c.symbol = symbol;
  c.name = name;
  return c;
}
inline Readoff named_readoff(const char* name) {
  Readoff r;
  r.name = name;
  return r;
}

struct NoiseModel {
  Coefficient quantization = named("Q", "quantization");
  Coefficient white = named("N", "white noise density");
  Coefficient bias_instability = named("B", "bias instability");
  Coefficient random_walk = named("K", "random walk density");
  Coefficient rate_ramp = named("R", "rate ramp");
  // First-order Gauss–Markov bias (core/model/noise.hpp): stationary σ and correlation time τc.
  Coefficient gauss_markov = named("G", "Gauss-Markov bias sigma");
  Coefficient correlation_time = named("Tc", "Gauss-Markov correlation time");
  Readoff white_line = named_readoff("N (-1/2 line at 1 s)");
  Readoff random_walk_line = named_readoff("K (+1/2 line at 3 s)");
  Readoff bias_floor = named_readoff("B (minimum / 0.664)");
  bool ok = false;
  std::string message;        // why the fit failed / warnings
  std::string selection;      // the selected terms and the criterion, e.g. "N+G (BIC …)"
  double tau_fit_min_s = kNaN;  // the τ range fitted (may start after tau_min_s, see lowpass_hz,
  double tau_fit_max_s = kNaN;  // and end before tau_max_s: points over fewer than 4 clusters)
  double lowpass_hz = kNaN;     // output low-pass in the model curve (0 none, NaN not stated)
  double chi2_reduced = kNaN;  // weighted residual χ² per degree of freedom
  int dof = 0;
  double tau_min_s = kNaN, tau_max_s = kNaN;

  // σ² of the fitted model (all fitted terms, identified or not) at τ.
  // (at m = τ·rate samples per cluster; rate_hz for the output stage)
  double rate_hz = 0.0;
  double avar(double tau_s) const;
  NoiseType dominant(double tau_s) const;
  // Q N B K R G Tc in a row; the first six are AVAR terms, Tc is the correlation time of G.
  static constexpr int kCoefficients = 7;
  const Coefficient* coefficients() const { return &quantization; }
  Coefficient* coefficients() { return &quantization; }
};

// Curve from the stream's octaves; EDF and intervals assume white noise until a model is fitted.
// Throws std::invalid_argument unless rate_hz > 0.
AllanCurve make_curve(const std::vector<OctaveVariance>& octaves, std::uint64_t samples,
                      double rate_hz, const ChannelInfo& channel, double confidence);
// Fills edf / noise / adev_lo / adev_hi of every point; the noise type from `model` (dominant
// term at τ) or white noise when model is null.
void assign_intervals(AllanCurve& curve, const NoiseModel* model);
// Fits the model to the curve and makes the read-offs. Does not change the curve.
//   model curve   AVAR(τ) = 3Q²/τ² + N²·w(m) + (2 ln2/π)B² + K²τ/3 + R²τ²/2 + σ_G²·g(τ/τc), with
//                 w(m) = 1/τ without an output filter and, with options.lowpass_hz > 0, the exact
//                 AVAR per unit N² of sampled white noise run through the sensor's Butterworth
//                 low-pass; g the first-order Gauss–Markov AVAR (model::allan::gauss_markov).
//   τ range       all points when the filter is stated (lowpass_hz ≥ 0); when it is not (NaN), the
//                 leading points with m ≤ 32 whose slope to the next point is flatter than
//                 −½ + slope_tolerance (a filter's flattening) are left out; points over fewer
//                 than 4 clusters (N/m < 4) are never fitted.
//   likelihood    each AVAR point is σ²·χ²_ν/ν with ν its EDF (Var ≈ 2σ⁴/EDF): Gamma deviance
//                 D = Σ ν (r − 1 − ln r), r = AVAR/model, minimised by Fisher scoring (IRLS) in
//                 generalized least squares with the correlation of the overlapping points.
//   selection     every subset of the six terms (τc profiled on a grid, then refined); the one
//                 with the least D + 6.63·(parameters) is kept (6.63 = χ²₁ at 99 %: a term enters
//                 only when it lowers D by more than a 1 % likelihood-ratio test would allow);
//                 a plateau (B or G) without K is kept over K in its place only when it lowers D
//                 by more than 10.83 (χ²₁ at 99.9 %).
//   uncertainty   σ from the inverse Fisher information of the selected model, scaled by
//                 √max(1, D/dof); the other coefficients get upper bounds (the largest value whose
//                 term alone stays below every point's 95 % upper limit).
// Fewer than 3 usable points (constant, too short) → ok = false, every coefficient kFailed.
NoiseModel fit_noise_model(const AllanCurve& curve, const AnalysisOptions& options = {});

struct ChannelResult {
  AllanCurve curve;
  NoiseModel model;
};

// One channel, one pass: the stream, the curve, the fit, the intervals from the fitted model.
ChannelResult analyze(const double* y, std::size_t n, std::size_t stride, double rate_hz,
                      const ChannelInfo& channel, const AnalysisOptions& options = {});
// From a stream that has already seen the data.
ChannelResult analyze(const OverlappingAllanStream& stream, double rate_hz,
                      const ChannelInfo& channel, const AnalysisOptions& options = {});

// Text: a point, the curve as a table, a coefficient's verdict, a read-off, the model, both.
std::ostream& operator<<(std::ostream& os, const AllanPoint& p);
std::ostream& operator<<(std::ostream& os, const AllanCurve& c);
std::ostream& operator<<(std::ostream& os, const Coefficient& c);
std::ostream& operator<<(std::ostream& os, const Readoff& r);
std::ostream& operator<<(std::ostream& os, const NoiseModel& m);
std::ostream& operator<<(std::ostream& os, const ChannelResult& r);

}  // namespace stend::noise
