// A recording aligned to the procedure that produced it: the experiment file's observed steps
// (faces, turns, rate_legs, still — stend/core/experiment.hpp) found in a log made elsewhere, in
// order, and written as segments and truth exactly as a bench run writes them — so that every
// known-truth estimator, gap, apply and compare work on an imported log.
//
// The samples are summarised as they stream (Observer: one summary per block of `block_s`; memory
// grows with blocks, not samples); align() then classifies the blocks as still, steady rate or
// motion, joins them into stretches and matches the steps to them in time order:
//   faces      the next still stretch whose measured gravity direction is within
//              face_tolerance_deg of the stated one, for each face: truth f = g·up, ω = the Earth
//              rate's vertical component when the site's latitude is known;
//   still      the next still stretch(es), any direction: f unknown (NaN), ω the Earth rate's
//              vertical component along the measured gravity direction;
//   turns      the next motion between two stills whose angle integrated about the axis (bias
//              from the stills beside it) is the stated angle within turn_tolerance: truth the
//              turn's rotation vector, its sign taken from the data unless stated;
//   rate_legs  the next steady-rate stretch whose rate about the axis is the stated rate within
//              rate_tolerance: truth ω = rate·axis, f = g·up and the Earth rate's vertical
//              component added to ω when `up` is stated.
// Stills no step names stay as `detected` segments (bias, noise), with ω as for a still. A step that finds no match is an
// AlignmentError naming the step (file:line:col), what it expected and what the recording holds.
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/errors.hpp>
#include <stend/recording/recording.hpp>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace stend::alignment {

// How blocks are classified and stretches matched; each default written once, here.
struct AlignOptions {
  double block_s = 0.1;             // length of one summary block [s]
  double min_stretch_s = 0.3;       // shorter stills and steady rates count as motion [s]
  double min_still_s = 1.0;         // shortest face, still or rate leg matched, unless record_s asks more [s]
  double max_still_rate_dps = 3.0;  // a still block turns slower than this, after the gyro bias [deg/s]
  double noise_factor = 4.0;        // still: block std within this factor of the quietest blocks' std
  double min_accel_std_mps2 = 0.003;   // … or below this accelerometer std [m/s²] (quantised data)
  double min_gyro_std_radps = 3e-4;    // … and below this gyro std [rad/s]
  double rate_steadiness = 0.03;    // steady rate: gyro std within this fraction of the rate (plus noise)
  double split_deg = 5.0;           // a still stretch ends where gravity moves by more than this [deg]
  double face_tolerance_deg = 30.0; // a still matches a face within this of the stated up direction [deg]
  double turn_tolerance = 0.25;     // a turn matches within this fraction of its stated angle
  double rate_tolerance = 0.2;      // a rate leg matches within this fraction of its stated rate

  bool IsValid(std::string* error) const;
};

// One block's summary: sums over its samples (SI: m/s², rad/s, s).
struct Block {
  double t0_s = 0.0, t1_s = 0.0;  // first and last sample time
  double n = 0.0;
  Eigen::Vector3d accel_sum = Eigen::Vector3d::Zero(), accel_sq = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_sum = Eigen::Vector3d::Zero(), gyro_sq = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_dt = Eigen::Vector3d::Zero();  // Σ ω·Δt over the block [rad] (Δt to the next sample)
  double dt_sum = 0.0;                                // Σ Δt [s]

  Eigen::Vector3d accel_mean() const { return accel_sum / n; }
  Eigen::Vector3d gyro_mean() const { return gyro_sum / n; }
  double accel_var() const;  // summed over the axes [(m/s²)²]
  double gyro_var() const;   // [(rad/s)²]
};

// Summarises samples as they come (in time order), a block at a time.
class Observer {
 public:
  explicit Observer(AlignOptions options = {});
  void add(const ImuSample* samples, std::size_t count);
  // The blocks so far, the last one closed (call once, after the last sample).
  const std::vector<Block>& finish();
  const AlignOptions& options() const { return options_; }

 private:
  void add_one(const ImuSample& s);
  AlignOptions options_;
  std::vector<Block> blocks_;
  Block open_;
  bool have_prev_ = false;
  ImuSample prev_{};
};

// What the alignment writes into the recording.
struct Alignment {
  std::vector<std::string> truth_columns;  // kSpecificForceColumns, kRateColumns, kTurnColumns
  std::vector<double> truth_t;
  std::vector<std::vector<double>> truth;
  std::vector<Segment> segments;           // in time order, numbered
  std::vector<std::string> notes;          // what was matched, skipped and assumed (import events)
  std::string summary() const;             // one line: steps matched, segments, stills kept
};

// Thrown when a step does not match: at the step in the experiment file, with what was found.
class AlignmentError : public ExperimentError {
 public:
  using ExperimentError::ExperimentError;
};

// The truth columns an aligned recording has (what Observer's caller puts in the header before
// the first sample is written).
std::vector<std::string> aligned_truth_columns();

// Aligns the steps of `exp` to the blocks: the observed ones; a record step as a still at an
// unstated orientation; set_temperature, wait and set_vibration are not looked for (noted).
// Table steps (orientations, rates) must have been turned into faces and rate legs first
// (stend/core/procedure_geometry.hpp). Throws AlignmentError.
Alignment align(const Experiment& exp, const std::vector<Block>& blocks, const AlignOptions& options);

// What an aligned recording states before its first sample: the aligned truth columns, the site's g
// and its latitude when known (what a streaming import writes into the header before the samples).
void align_header(RecordingHeader& header, const Experiment& exp);

// The alignment's segments, truth and notes in place of whatever the importer made (the notes and a
// summary as import events).
void apply_alignment(Recording& rec, const Experiment& exp, Alignment a);

// A recording read whole (or through its sample source) aligned to the procedure: the blocks
// observed, aligned, the header, segments, truth and the experiment (its processing: section, the
// procedure fingerprint) replaced — what `stend fit LOG --experiment FILE` fits. Throws
// AlignmentError.
void align_recording(Recording& rec, const Experiment& exp, const AlignOptions& options = {});

}  // namespace stend::alignment
