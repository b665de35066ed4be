// How well a calibration holds on a recording it was not fitted to: each check PASS, FAIL or
// NOT CHECKED against a stated limit.
//
//   static:    the static intervals the processing stage detects in the calibrated recording;
//              for each, |mean a| − g before and after calibration (mean, RMS, max over the
//              intervals [m/s^2]) beside the noise floor (RMS over the intervals of the standard
//              error of |mean a|: white noise, and the calibration's own from its parameters'
//              standard errors); and the gravity direction's stability inside each
//              interval: the angle between the mean directions of its two halves (RMS, max [deg]).
//              PASS when the calibrated RMS is at most kStaticLimitNoiseFloors × the noise floor;
//              NOT CHECKED without an accelerometer calibration of the three axes (|a| needs them)
//              or without a static interval.
//   rotation:  for each stated turn (`x:90`), the motions between consecutive static intervals
//              that turn about the stated axis by more than half the stated angle: the calibrated
//              rate integrated over the detected turn — from kTurnMarginS before the end of one
//              static interval to kTurnMarginS after the start of the next (rotation vectors
//              composed sample by sample) — its angle about the stated axis against the stated
//              angle (sign ignored: a turn and its return both count), with the uncertainty (1σ)
//              from the gyro's white noise over the window (σ_w·√(N)·dt, σ_w from the static
//              intervals), the bias uncertainty × duration (the fit's, or the re-estimated bias's),
//              and the scale uncertainty × angle. PASS when the error lies inside the interval at
//              `confidence`; NOT CHECKED when no motion turns by that much.
//   rebias:    with rebias_from_start_s > 0, the gyro bias left after calibration is re-estimated as
//              the mean calibrated rate over the recording's first seconds (they must be still) and
//              removed before integrating.
//
// The validation passes when no check FAILs and at least one was made, and every stated turn was
// found.
#pragma once

#include <stend/calibration/calibration.hpp>
#include <stend/processing/options.hpp>

#include <Eigen/Core>
#include <iosfwd>
#include <string>
#include <vector>

namespace stend::calibration {

// The static check's limit: the calibrated RMS of |a| − g over the intervals, in noise floors.
inline constexpr double kStaticLimitNoiseFloors = 3.0;
// Still kept on each side of a detected turn in its window [s]: the slow start and end of a turn
// that the detector counts as still are inside it; more would add only noise and bias.
inline constexpr double kTurnMarginS = 1.0;

// A check's outcome against its limit.
enum class CheckVerdict { kPass, kFail, kNotChecked };
const char* to_string(CheckVerdict v);  // "PASS", "FAIL", "NOT CHECKED"

struct ExpectedRotation {
  int axis = 0;          // sensor axis 0 = x, 1 = y, 2 = z
  double angle_deg = 0;  // stated angle [deg]
};
// "x:90", "z:-180" → the expectation; throws std::invalid_argument with what was expected.
ExpectedRotation parse_expected_rotation(const std::string& text);

// Detected static intervals, plain means, nothing dropped beyond the detector's trim.
processing::ProcessingOptions validation_interval_options();

struct ValidationOptions {
  processing::ProcessingOptions intervals = validation_interval_options();
  double gravity_mps2 = 0.0;  // 0: the recording header's, else the calibration's, else standard
  std::vector<ExpectedRotation> rotations;
  double rebias_from_start_s = 0.0;  // 0: keep the calibration's gyro bias
  double confidence = 0.95;

  bool IsValid(std::string* error = nullptr) const;
};

struct StaticCheck {
  int intervals = 0;
  double gravity_mps2 = 0.0;
  // |mean a| − g over the intervals [m/s^2]: raw and calibrated.
  double mean_before = NAN, rms_before = NAN, max_before = NAN;
  double mean_after = NAN, rms_after = NAN, max_after = NAN;
  double noise_floor = NAN;  // RMS over the intervals of the standard error of |mean a| (noise, calibration) [m/s^2]
  double direction_rms_deg = NAN, direction_max_deg = NAN;  // half-to-half gravity direction change
  double limit_mps2 = NAN;  // kStaticLimitNoiseFloors × noise_floor
  CheckVerdict verdict = CheckVerdict::kNotChecked;
  std::string not_checked;  // why, when not checked
};

struct TurnCheck {
  ExpectedRotation expected;
  double t_start_s = 0.0, t_end_s = 0.0;
  double measured_deg = NAN;  // integrated angle about the stated axis (signed)
  double error_deg = NAN;     // |measured| − |stated|
  double sigma_deg = NAN;     // 1σ: noise, bias, scale combined
  double sigma_noise_deg = NAN, sigma_bias_deg = NAN, sigma_scale_deg = NAN;
  double bound_deg = NAN;     // the interval's half width at the confidence level: the limit of |error|
  CheckVerdict verdict = CheckVerdict::kNotChecked;  // not checked: no motion turns by half the angle
};

struct ValidationReport {
  bool ok = false;       // no check failed, one at least was made, every stated turn was found
  std::string message;   // why not, or ""
  std::string calibration;  // Calibration::source
  double confidence = 0.95;
  StaticCheck statics;
  bool rebiased = false;
  Eigen::Vector3d rebias_radps = Eigen::Vector3d::Constant(NAN);     // removed [rad/s]
  Eigen::Vector3d rebias_se_radps = Eigen::Vector3d::Constant(NAN);  // its standard error
  std::vector<TurnCheck> turns;  // a stated turn that no motion matches: one entry, not checked
  std::vector<std::string> notes;

  // PASS when ok; FAIL when a check failed; else NOT CHECKED (a stated turn not found, or nothing
  // could be checked).
  CheckVerdict verdict() const;
  void print(std::ostream& os) const;
  std::string to_json() const;
};

// Throws std::invalid_argument when the options are invalid or ask for what the calibration cannot
// give (a rotation check or a gyro re-bias without a gyroscope calibration). validate() calls it;
// call it before reading a recording to fail early.
void check_applicable(const Calibration& cal, const ValidationOptions& options);

// `raw` is the recording as read, `calibrated` = apply_calibration(raw, cal). Throws
// std::invalid_argument when the options ask for what the calibration cannot give (a rotation
// without a gyroscope calibration) or are invalid.
ValidationReport validate(const Recording& raw, const Recording& calibrated, const Calibration& cal,
                          const ValidationOptions& options);

}  // namespace stend::calibration
