// The processing stage: a recording → static points. Every estimator and the diagnosis take their
// static data from here, so the rules are written once:
//   1. intervals: the recording's segments of the requested kinds, or intervals detected in the
//      samples (ProcessingOptions::intervals);
//   2. a segment is skipped when it is incomplete (the run stopped inside it) or unsettled
//      (fixtures / chamber not settled for the whole segment);
//   3. each requested axis is reduced by extract_static (low-pass, settle_s discarded at each
//      end, mean; at least 8 samples in the interval and 2 in the kept window);
//   4. an interval with a saturated sample of a requested instrument inside the kept window is
//      skipped; gaps there (kGapBefore) are noted, not skipped;
//   5. the truth over the kept window (stend/processing/truth.hpp): the means of the requested
//      truth columns — an interval without any truth snapshot inside or before is skipped —, and
//      as the error model reads it (StaticPoint::stimulus, stend/model/terms.hpp) the requested
//      true input and specific force, the temperature — the die truth (column die_c) and its
//      slope, else the sensor's reading — and the window's mid-time.
// Every skip comes back typed (SkipReason) with a human note.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "stend/model/terms.hpp"
#include "stend/processing/options.hpp"
#include "stend/processing/skip.hpp"
#include "stend/processing/static_detector.hpp"
#include "stend/recording/recording.hpp"

namespace stend::processing {

inline constexpr const char* kDieTemperatureColumn = "die_c";  // truth column, degC

// Truth columns whose window means make StaticPoint::stimulus, per axis x, y, z: the instrument's
// true input (f_<axis>_mps2 for an accelerometer, w_<axis>_radps for a gyroscope) and the
// specific force. An empty name leaves that value 0.
struct StimulusColumns {
  std::array<std::string, 3> input;
  std::array<std::string, 3> specific_force;
};

// What the caller needs from each interval.
struct Request {
  bool accel = true;  // extract the accelerometer axes (their saturation flag skips an interval)
  bool gyro = true;   // extract the gyroscope axes (likewise)
  // Mean of each over every point's window, in this order (StaticPoint::truth).
  std::vector<std::string> truth_columns;
  // The truth the error model reads (StaticPoint::stimulus).
  StimulusColumns stimulus;
  // Every column named above must be a truth column of the recording; when any is named, an
  // interval without truth is skipped.
};

// One instrument's three axes over a point's kept window, in the recording's SI unit.
struct AxesValue {
  Eigen::Vector3d mean = Eigen::Vector3d::Constant(kNaN);        // the static value (filtered)
  Eigen::Vector3d sample_std = Eigen::Vector3d::Constant(kNaN);  // of the raw samples
  // sample_std / √n: the standard error of the mean if the noise is white (coloured noise makes
  // the true error larger).
  Eigen::Vector3d std_error = Eigen::Vector3d::Constant(kNaN);
  // The standard error of the raw mean allowing for correlation between nearby samples
  // (StaticValue::correlated_std_error).
  Eigen::Vector3d correlated_std_error = Eigen::Vector3d::Constant(kNaN);
};

enum class TemperatureSource { kDie, kSensor };

// A held mean: a row of a table of means, held as a segment (the held-mean truth columns of
// stend/recording/truth_columns.hpp mark the recording). Its samples repeat the mean, so their
// spread is zero by construction; what the table states of the mean's noise instead:
struct HeldMean {
  double n = kNaN;                                          // samples averaged; NaN: not stated
  Eigen::Vector3d sigma = Eigen::Vector3d::Constant(kNaN);  // their standard deviation per axis (SI); NaN: not stated

  // n and sigma both stated: the standard error of the mean is known, sigma/√n.
  bool absolute() const { return std::isfinite(n) && sigma.allFinite(); }
  // Either stated: the rows' weights are known relative to each other.
  bool weighted() const { return std::isfinite(n) || sigma.allFinite(); }
  // sigma/√n per axis with a factor not stated taken as 1: the standard error when absolute(),
  // else proportional to it (by a factor common to the table, which a fit's residuals set). The
  // one place this rule is written.
  Eigen::Vector3d std_error() const {
    const Eigen::Vector3d s = sigma.allFinite() ? sigma : Eigen::Vector3d(Eigen::Vector3d::Ones());
    return s / std::sqrt(std::isfinite(n) ? n : 1.0);
  }
};

struct StaticPoint {
  // The interval: a segment of the recording, or a detected interval (kind SegmentKind::kDetected, id =
  // its index among the detected ones, label "static_<id>").
  Segment segment;
  std::size_t first = 0, last = 0;        // the kept window: sample indices, inclusive
  double t_start_s = 0.0, t_end_s = 0.0;  // times of its first and last samples
  std::size_t samples_used = 0;
  std::size_t gaps = 0;  // samples flagged kGapBefore inside the kept window (after its first)
  AxesValue accel;       // m/s^2; NaN unless requested
  AxesValue gyro;        // rad/s; NaN unless requested
  // The truth over the kept window as the error model reads it: input and specific_force from
  // Request::stimulus (0 where not requested), temperature_c [°C] (see temperature_source; NaN
  // when the recording has no temperature, header.info.has_temperature false) and
  // temperature_rate_cps [°C/s] (the slope of the die truth over the window, 0 otherwise),
  // time_s the window's mid-time [s]. The other fields are the caller's (the gap diagnosis').
  model::Stimulus<double> stimulus;
  TemperatureSource temperature_source = TemperatureSource::kSensor;
  std::vector<double> truth;  // means of Request::truth_columns
  // Set for a held mean (a table of means' row). Its accelerometer's noise is then the table's:
  // accel.sample_std = sigma (NaN: not stated), accel.std_error and correlated_std_error = sigma/√n
  // when both are stated, else NaN (unknown: never the zero spread of the held samples).
  std::optional<HeldMean> held;

  // The instrument's axes: accel for an accelerometer, else gyro.
  const AxesValue& axes(model::Instrument instrument) const;
  AxesValue& axes(model::Instrument instrument);
};

struct Skip {
  Segment segment;
  SkipReason reason = SkipReason::kTooFewSamples;
  std::string note;  // "skipped segment 3 (orientation, …): the fixtures/chamber were not settled"
};

struct Extraction {
  ProcessingOptions options;  // as used: the caller's, completed by the experiment's section
  std::vector<StaticPoint> points;
  std::vector<Skip> skipped;
  // Every remark in order: data-source remarks, each skip's note, gaps in kept windows, no
  // segment of the requested kinds.
  std::vector<std::string> notes;
  // How the intervals were detected and what the detector rejected (when they were detected).
  std::optional<DetectionSummary> detection;
  std::size_t count(SkipReason reason) const;  // skips with that reason
  // Which rule took the intervals, counted per reason — for a message when too few points came
  // out: "6 interval(s), 1 kept; skipped: 3 unsettled, 2 saturated; the detector rejected 4 still
  // run(s): 3 too_short, 1 gap" (or "0 interval(s): no segment of kind orientation").
  std::string tally() const;
};

// Whether `rec` is a table of means (its rows held as orientation segments: the held-mean truth
// columns). Its static points are its segments whatever ProcessingOptions::intervals says: held
// values do not vary, so there is nothing to detect stillness in.
bool holds_means(const Recording& rec);

// The stage. `options` are resolved against the recording's experiment (resolve()). Throws
// std::invalid_argument when the resolved options are invalid, nothing is requested, or a
// requested truth column is missing; InputError when the sample times do not strictly increase;
// ExperimentError for a bad experiment `processing:` section.
Extraction extract(const Recording& rec, const ProcessingOptions& options, const Request& request);

// "segment 3 (orientation 'x up', orientation 1/6, 12–20 s)", as the notes name a segment.
std::string describe(const Segment& segment);
// A point's short name in tables and messages: its segment's label, else "orientation 3" for an
// orientation (kind and 1-based number), else describe(segment).
std::string label(const Segment& segment);

}  // namespace stend::processing
