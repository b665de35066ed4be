// What `stend gap` diagnoses: the static segments of a recording (or of a generator) with their
// truth, groups and noise evidence — step 1 of the diagnosis (stend/diagnosis/gap.hpp).
//   - static points by the processing stage (estimation::extract_static_points: Butterworth,
//     settle, average; the truth stimulus from the recording's truth columns — for imported data
//     the importer builds them from the dataset's annotations, e.g. imucal x_p … z_a);
//   - the stimulus fields of the bench-side candidates (gravity_up; the table derivatives of the
//     sim three-axis table's angle columns; temperature_direction);
//   - groups of the held-out folds (orientation, temperature level, ramp direction);
//   - the noise floor of a segment mean (batch means inside each kept window) and the noise-stage
//     evidence from the raw samples (within-segment ANOVA, value lattice, clipping, Allan).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "stend/estimation/model_spec.hpp"
#include "stend/model/terms.hpp"
#include "stend/processing/static_points.hpp"
#include "stend/recording/recording.hpp"

namespace stend::diagnosis {

// One static segment as the diagnoser sees it.
struct SegmentData {
  // The processing stage's point: the fitted instrument's mean and its white standard error
  // (point.axes(instrument)), its window and segment, and the truth stimulus with the gap's
  // fields filled.
  processing::StaticPoint point;
  int orientation = -1;          // index of the distinct orientation (gravity direction) group
  std::string orientation_name;  // "+z up", "-x up", "f=(0.71,0,0.71)g"
  double setpoint_c = kNaN;      // chamber setpoint, NaN when none
  int temperature_group = -1;    // index of the distinct temperature level (setpoint or die, 2 °C); −1: none
  int ramp_direction = 0;        // +1 approached by heating, −1 by cooling, 0 unknown / first
  double time_since_change_s = kNaN;  // since the last orientation or temperature change
  double averaging_s = 0.0;           // kept window length
  // Noise floor of the mean [unit], per axis: standard error from batch means inside the kept
  // window (robust to short-term correlation), never below the white-noise standard error.
  Eigen::Vector3d mean_std_error = Eigen::Vector3d::Constant(kNaN);
  Eigen::Vector3d raw_std = Eigen::Vector3d::Constant(kNaN);  // sample std in the window
  // Noise-stage evidence from the raw samples of the kept window (build_input), per axis.
  // Within-segment white-noise test: the window cut into 64 sub-blocks in 8 groups of 8; sums of
  // squares of the sub-block means between the 8 groups (7 dof) and within them (56 dof), each
  // times the sub-block length [unit²·samples] so that segments of different length pool. Under
  // white noise (also low-passed white noise, sub-blocks ≫ the filter's memory) the ratio
  // (between/7)/(within/56) is F(7, 56); noise correlated over seconds inflates it.
  Eigen::Vector3d ss_between = Eigen::Vector3d::Constant(kNaN);
  Eigen::Vector3d ss_within = Eigen::Vector3d::Constant(kNaN);
  Eigen::Vector3d distinct_values = Eigen::Vector3d::Constant(kNaN);  // distinct sample values
  Eigen::Vector3d value_step = Eigen::Vector3d::Constant(kNaN);  // smallest non-zero spacing [unit]
  std::size_t raw_samples = 0;  // samples in the kept window
};

struct GapInput {
  estimation::ModelSpec spec;
  std::vector<SegmentData> segments;
  std::string source;       // run folder or dataset file
  std::string truth_source; // "truth columns" | the magnitude form's statement
  std::string floor_source; // how the noise floor was obtained
  double lsb = 0.0;         // one count of the instrument [unit], 0 unknown
  double range = 0.0;       // full scale [unit], 0 unknown
  std::size_t saturated_segments = 0;  // skipped by processing for saturated samples (SkipReason)
  std::vector<std::string> notes;
  // Twin noise: the white-noise std of one sample the twin would produce, per axis [unit]; NaN
  // when the model file gives none (then the recording's median segment std is the reference).
  Eigen::Vector3d twin_sample_std = Eigen::Vector3d::Constant(kNaN);
  // Magnitude form: only |g| is known (orientations not recorded, e.g. a hand-held IMU-TK style
  // session). Each segment is ONE row: the measured mean projected on the estimated gravity
  // direction û (stimulus.specific_force = g·û, see magnitude_form); the other two directions are
  // taken up by the unknown orientation, so rotations of the sensor frame are not seen.
  bool magnitude = false;
  // Output-stage evidence over every sample of the static segments (extracted or skipped), per
  // axis: samples clipped (the saturation flag when the recording sets it, else |value| within
  // LSB/2 of the range, or — range unknown — a run of ≥ 3 identical samples at the window's extreme
  // value within 2.5 std of its mean).
  Eigen::Vector3d clipped_samples = Eigen::Vector3d::Zero();
  Eigen::Vector3d static_samples = Eigen::Vector3d::Zero();
  // Long static stretch (the longest kept window, when ≥ 100 s): overlapping Allan deviation per
  // axis (stend/noise/noise_model.hpp, 95 % EDF intervals). NaN when there is none.
  double allan_window_s = 0.0;
  Eigen::Vector3d allan_white = Eigen::Vector3d::Constant(kNaN);         // N fitted [unit/√Hz]
  Eigen::Vector3d allan_random_walk = Eigen::Vector3d::Constant(kNaN);   // K fitted [unit/√s]
  Eigen::Vector3d allan_random_walk_se = Eigen::Vector3d::Constant(kNaN);
  // Flat part: the largest Allan deviation above the white part / 0.664 (the flicker floor), [unit],
  // with its 95 % interval from that point's EDF.
  Eigen::Vector3d allan_bias_instability = Eigen::Vector3d::Constant(kNaN);
  Eigen::Vector3d allan_bias_instability_lo = Eigen::Vector3d::Constant(kNaN);
  Eigen::Vector3d allan_bias_instability_hi = Eigen::Vector3d::Constant(kNaN);
  // Log-log slope of the Allan variance above white over the last four octaves of τ, and its
  // standard error: +1 random walk, 0 flat (bias instability), < 0 a Gauss–Markov past its peak.
  Eigen::Vector3d allan_slope = Eigen::Vector3d::Constant(kNaN);
  Eigen::Vector3d allan_slope_se = Eigen::Vector3d::Constant(kNaN);
};

// Gravity through the three-axis table chain on a tilted base (stend/physics), f = M·R_top_from_base
// (az, h, δ)·tilted_base(εx, εy)·[0, 0, g] (angles in rad, M = R_sensor_from_mount): returns f and
// fills the stimulus's table_df_dangle (∂f/∂az, ∂f/∂h, ∂f/∂δ) and table_df_dtilt (∂f/∂εx, ∂f/∂εy)
// at εx = εy = 0.
Eigen::Vector3d table_stimulus(model::Stimulus<double>& st, double az, double h, double delta,
                               const Eigen::Matrix3d& mount, double g);

// Builds the input from a recording: extraction, truth (truth columns; without them the
// magnitude form), stimulus fields for the bench-side candidates (gravity_up; table derivatives for
// the sim three-axis table's tilt/rotation/azimuth columns; temperature_direction), groups, noise
// floor. Throws InputError when no static point can be made (says why).
GapInput build_input(const Recording& recording, const estimation::ModelSpec& spec);

// Magnitude form of an input whose truth directions are unknown: every segment's truth becomes
// g·û, û the direction that the model as given (fitted on |f| rows, linearized about û) maps onto
// the measured mean; fit and direction are iterated to a fixed point. Sets input.magnitude.
// `gravity` [m/s²] is the local g the session assumes. Accelerometer models only (InputError).
GapInput magnitude_form(GapInput input, double gravity);

// From a recording with no truth columns and no orientation annotations: static intervals by the
// sliding-variance detector (the processing stage's, IMU-TK style), extraction on them, the
// noise floor as build_input, then magnitude_form. Throws InputError saying why when no usable
// interval is found or the instrument is a gyroscope (no rate truth to compare with).
GapInput build_magnitude_input(const Recording& recording, const estimation::ModelSpec& spec);

// Die temperatures closer than this are one temperature level [°C]; static points that do not
// span two levels have no temperature spread, and no term that reads the temperature is assessed
// on them (no temperature candidate, no fold by temperature).
inline constexpr double kTemperatureLevel_c = 2.0;

// The groups of the held-out folds, shared by the recording input and the validation generators:
// the index of the orientation group named `name` (a new group when unseen), and of the
// temperature level within kTemperatureLevel_c of t_c [°C] (the last such; a new level when none;
// −1 when t_c is NaN: no temperature recorded).
int orientation_group(std::map<std::string, int>& groups, const std::string& name);
int temperature_group(std::vector<double>& levels_c, double t_c);
// Whether the segments span two temperature levels or more (see kTemperatureLevel_c).
bool has_temperature_spread(const std::vector<SegmentData>& segments);

}  // namespace stend::diagnosis
