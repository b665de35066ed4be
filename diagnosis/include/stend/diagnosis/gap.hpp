// Sim-to-real gap diagnosis (`stend gap`): where the recording and its digital twin disagree, which
// unmodelled effect of the error-model vocabulary explains it, and how far the gap shrinks on data
// not used to fit.
//
// Procedure (diagnosis/README.md, docs/gap-diagnosis.md):
//   1. static points per segment by batch_lsq's extraction (Butterworth, settle, average); truth
//      from the recording's truth columns (for imported data the importer builds them from the
//      dataset's annotations, e.g. imucal x_p … z_a);
//   2. fit the model (batch_lsq::fit_points, the shared SVD solver), replay every segment through
//      the twin: ErrorModel::measure(θ̂, recorded truth stimulus) — the simulator's code path;
//   3. gap = measured − twin per segment and axis [m/s² | rad/s], against the noise floor of a
//      segment mean (batch means inside each segment, or the scatter of repeated segments);
//   4. where: shares of the squared gap by axis, orientation, temperature, time since the last
//      change, averaging time;
//   5. which: every vocabulary term the model lacks, scored by leave-one-group-out held-out RMS
//      (groups: orientations, temperatures or ramp directions), ΔBIC, a partial F test on segment
//      means (Bonferroni over the candidates), the effect size with a 95 % interval, and aliases
//      from the rank of the joint design;
//   6. how far: forward selection on the held-out gap until no candidate is significant or the
//      held-out gap is at the noise floor; what remains is stated plainly.
// Everything about a term's formula comes from stend/model/terms.hpp (regressor / measure).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <iosfwd>
#include <limits>
#include <string>
#include <vector>

#include "stend/batch_lsq/batch_lsq.hpp"
#include "stend/model/terms.hpp"
#include "stend/recording/recording.hpp"

namespace stend::diagnosis {

inline constexpr const char* kGapSchema = "stend.gap/1";
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One static segment as the diagnoser sees it.
struct SegmentData {
  batch_lsq::StaticPoint point;  // measured mean, truth stimulus (with the gap fields filled)
  int orientation = -1;          // index of the distinct orientation (gravity direction) group
  std::string orientation_name;  // "+z up", "-x up", "f=(0.71,0,0.71)g"
  double setpoint_c = kNaN;      // chamber setpoint, NaN when none
  int temperature_group = -1;    // index of the distinct temperature level (setpoint or die, 2 °C)
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

// A candidate effect: one vocabulary term (settings included) the model lacks.
struct Candidate {
  std::string name;  // "cross_axis", "bias_temperature(order 2)" …
  model::TermSpec term;
};

// All vocabulary terms (except those the model has) as candidates for this instrument; the
// temperature polynomials are offered at the next orders above what the model has, up to 3.
std::vector<Candidate> default_candidates(const model::ErrorModel& model);

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
  // axis (estimators/allan, 95 % EDF intervals). NaN when there is none.
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
// floor. Throws std::runtime_error when no static point can be made (says why).
GapInput build_input(const Recording& recording, const estimation::ModelSpec& spec);

// Magnitude form of an input whose truth directions are unknown: every segment's truth becomes
// g·û, û the direction that the model as given (fitted on |f| rows, linearized about û) maps onto
// the measured mean; fit and direction are iterated to a fixed point. Sets input.magnitude.
// `gravity` [m/s²] is the local g the session assumes. Accelerometer models only.
GapInput magnitude_form(GapInput input, double gravity);

// From a recording with no truth columns and no orientation annotations: static intervals by the
// sliding-variance detector (the processing stage's, IMU-TK style), extraction on them, the
// noise floor as build_input, then magnitude_form. Throws std::runtime_error saying why when no
// usable interval is found or the instrument is a gyroscope (no rate truth to compare with).
GapInput build_magnitude_input(const Recording& recording, const estimation::ModelSpec& spec);

// How the held-out folds are formed.
enum class FoldBy { kAuto, kOrientation, kTemperature, kRamp };

struct GapOptions {
  FoldBy fold_by = FoldBy::kAuto;   // auto: temperature when ≥ 3 levels, else orientation
  double alpha = 0.05;              // family-wise level (Bonferroni over candidates)
  int max_steps = 4;                // forward-selection steps
  // A candidate is named as *the* explanation only when it also closes at least this fraction of
  // the held-out squared gap above the floor; otherwise it is reported as partial.
  double explain_fraction = 0.5;
  bool check_aliases = true;        // pairwise candidate alias analysis (joint-design rank)
  // Held-out folds: every group its own fold up to this many; more groups are dealt round-robin
  // into max_folds folds. 0 = always one fold per group (strict leave-one-group-out).
  int max_folds = 12;
  std::vector<Candidate> candidates;  // empty: default_candidates(model)
};

struct CandidateResult {
  std::string term;
  model::TermSpec spec;
  std::string axis = "-";           // the axis the effect is largest on ("x", "y", "z", "all")
  bool evaluated = false;           // false: not excited by this experiment (zero columns)
  std::string reason;               // why not evaluated / remarks
  double heldout_rms = kNaN;        // held-out RMS with the candidate [unit]
  double heldout_rms_before = kNaN; // same rows, without it
  double heldout_improvement = kNaN;  // 1 − heldout_rms/heldout_rms_before
  double delta_bic = kNaN;          // BIC(with) − BIC(without): negative favours it
  double f_stat = kNaN, p_value = kNaN;
  int added_rank = 0;               // rank the candidate adds beyond the model
  double size = kNaN;               // its largest identifiable parameter (by |value|/se)
  std::string size_param, size_unit;
  double ci_lo = kNaN, ci_hi = kNaN;
  std::vector<std::string> aliases;   // other candidates or model terms it cannot be told from
  std::vector<std::string> separate;  // what experiment would separate them
  bool significant = false;
  bool noise_stage = false;         // quantization / saturation / coloured noise
};

struct Step {
  int step = 0;
  std::string added;                // empty = the model as given (step 0)
  double heldout_rms = kNaN, in_sample_rms = kNaN, floor_rms = kNaN;
};

struct Place {
  std::string dimension, place;
  double share = 0.0;  // of the squared gap
  double rms = 0.0;    // [unit]
  int rows = 0;
};

struct GapReport {
  bool ok = false;
  std::string message;
  bool magnitude = false;          // one row per segment (|f|): see GapInput::magnitude
  std::string model_name, source, unit, display_unit;
  double display_per_unit = 1.0;   // mg per m/s² (or deg/h per rad/s)
  batch_lsq::FitResult fit;        // the model as given
  std::string floor_source;
  Eigen::Vector3d floor = Eigen::Vector3d::Constant(kNaN);         // RMS mean std error
  Eigen::Vector3d gap_rms = Eigen::Vector3d::Constant(kNaN);       // in-sample, per axis
  Eigen::Vector3d noise_ratio = Eigen::Vector3d::Constant(kNaN);   // segment std / twin std
  std::vector<Eigen::Vector3d> residual;  // per segment (NaN for axes not fitted)
  std::vector<SegmentData> segments;
  std::vector<Place> where;
  std::string fold_by;
  int folds = 0;
  std::vector<CandidateResult> candidates;  // ranked
  std::vector<Step> steps;
  std::vector<std::string> selected;        // terms added by the forward selection
  double unexplained_heldout_rms = kNaN, unexplained_over_floor = kNaN;
  bool at_floor = false;
  std::string explanation;  // the named effect, or empty
  std::string statement;
  std::vector<std::string> notes;
};

GapReport diagnose(const GapInput& input, const GapOptions& options = {});

void print_report(std::ostream& os, const GapReport& report);
std::string to_json(const GapReport& report, int indent = 2);

// A fixed advice table: what experiment separates two terms that this design cannot.
std::string separating_experiment(model::TermKind a, model::TermKind b);

}  // namespace stend::diagnosis
