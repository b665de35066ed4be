// Sim-to-real gap diagnosis (`stend gap`): where the recording and its digital twin disagree, which
// unmodelled effect of the error-model vocabulary explains it, and how far the gap shrinks on data
// not used to fit.
//
// Procedure (diagnosis/README.md, docs/gap-diagnosis.md):
//   1. static points per segment by the processing stage, their truth (stend/diagnosis/input.hpp);
//   2. fit the model (estimation::fit_static_points, the shared SVD solver), replay every segment
//      through the twin: ErrorModel::measure(θ̂, recorded truth stimulus) — the simulator's code
//      path;
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
#include <array>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "stend/diagnosis/input.hpp"
#include "stend/estimation/static_fit.hpp"
#include "stend/model/terms.hpp"

namespace stend::diagnosis {

inline constexpr const char* kGapSchema = "stend.gap/1";

// A candidate effect: one vocabulary term (settings included) the model lacks.
struct Candidate {
  std::string name;  // "cross_axis", "bias_temperature(order 2)" …
  model::TermSpec term;
};

// All vocabulary terms (except those the model has) as candidates for this instrument; the
// temperature polynomials are offered at the next orders above what the model has, up to 3.
std::vector<Candidate> default_candidates(const model::ErrorModel& model, bool temperature_spread = true);

// How the held-out folds are formed: by the segments' orientation, temperature level or ramp
// direction, one segment each (leave-one-segment-out), or contiguous blocks of segments in time.
// auto = the first scheme of (temperature with ≥ 3 levels, orientation, segment, time) whose
// training folds determine every held-out row (see choose_folds in diagnosis/src/steps.hpp).
enum class FoldBy { kAuto, kOrientation, kTemperature, kRamp, kSegment, kTime };
// The one name table: the key (`stend gap --fold-by`) and the name the report and JSON use.
struct FoldByName {
  FoldBy value;
  const char* key;
  const char* name;
};
inline constexpr std::array<FoldByName, 6> kFoldByNames = {{{FoldBy::kAuto, "auto", "auto"},
                                                           {FoldBy::kOrientation, "orientation", "orientation"},
                                                           {FoldBy::kTemperature, "temperature", "temperature"},
                                                           {FoldBy::kRamp, "ramp", "ramp direction"},
                                                           {FoldBy::kSegment, "segment", "segment (leave-one-segment-out)"},
                                                           {FoldBy::kTime, "time", "blocks in time"}}};
const char* to_string(FoldBy f);  // the name
std::optional<FoldBy> fold_by_from_key(std::string_view key);

// The rule over the candidate family of a selection step (the unused candidates with a p value).
// Benjamini–Yekutieli: false discovery rate at alpha under any dependence between the tests (with
// no real effect, the chance of naming any). Bonferroni: p < alpha / m, the family-wise rate under
// any dependence (the rule before issue 40; kept to measure what BY costs or gains).
enum class FamilyRule { kBenjaminiYekutieli, kBonferroni };
struct FamilyRuleName {
  FamilyRule value;
  const char* key;
  const char* name;
};
inline constexpr std::array<FamilyRuleName, 2> kFamilyRuleNames = {
    {{FamilyRule::kBenjaminiYekutieli, "by", "Benjamini-Yekutieli (FDR under any dependence)"},
     {FamilyRule::kBonferroni, "bonferroni", "Bonferroni (family-wise)"}}};
const char* to_string(FamilyRule r);  // the name
std::optional<FamilyRule> family_rule_from_key(std::string_view key);

struct GapOptions {
  FoldBy fold_by = FoldBy::kAuto;   // auto: the first scheme whose folds fit the design (FoldBy)
  // Level of the candidate family: false discovery rate by Benjamini–Yekutieli over the assessed
  // candidates (valid under any dependence; with no real effect, the chance of naming any), in (0, 1).
  double alpha = 0.05;
  FamilyRule family_rule = FamilyRule::kBenjaminiYekutieli;
  int max_steps = 4;                // forward-selection steps (0: the candidates ranked, none added)
  // A candidate is named as *the* explanation only when it also closes at least this fraction of
  // the held-out squared gap above the floor; otherwise it is reported as partial. In [0, 1].
  double explain_fraction = 0.5;
  bool check_aliases = true;        // pairwise candidate alias analysis (joint-design rank)
  // Held-out folds: every group its own fold up to this many; more groups are dealt round-robin
  // into max_folds folds. 0 = always one fold per group (strict leave-one-group-out).
  int max_folds = 12;
  std::vector<Candidate> candidates;  // empty: default_candidates(model)

  // Ceres style: false, with "KEY: what is wrong" in *why, when a value is out of range.
  bool IsValid(std::string* why = nullptr) const;
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
  // Held-out rows scored (the others are not determined by their training folds) and all rows.
  int heldout_rows = 0, rows = 0;
};

struct Place {
  std::string dimension, place;
  double share = 0.0;  // of the squared gap
  double rms = 0.0;    // [unit]
  int rows = 0;
};

// Placement of hand-placed faces (nominal orientations, no table angles): each face's stated
// orientation off by a small rotation, δf = δθ_face × f (3 parameters a face, the 2 across f seen),
// fitted with the final model. Per-face parameters cannot be predicted from the other faces, so
// held-out evidence is impossible by construction: the evidence is in-sample (partial F test when
// degrees of freedom remain) and where the remaining gap lies (across the stated gravity
// directions, where a rotation acts, or along them, where it cannot).
struct PlacementResult {
  bool assessed = false;
  std::string reason;            // why not assessed / what the evidence is
  int faces = 0, added_rank = 0, dof = 0;
  double p_value = kNaN, delta_bic = kNaN;
  double across_share = kNaN;    // share of the remaining squared gap across the stated gravity directions
  double rms_deg = kNaN, max_deg = kNaN;  // fitted rotations across f [deg], RMS over faces and largest
  std::string max_face;
  std::vector<std::pair<std::string, double>> face_deg;  // per face [deg]
  double in_sample_after = kNaN;  // in-sample RMS with placement [unit]
  bool significant = false;       // partial F test at alpha, angles plausible
  bool consistent = false;        // untestable (no dof) but the gap lies across f and the angles are plausible
  // Sensor terms that lie within the per-face rotations on this design (with the model as given):
  // the named ones, and cross_axis (a misalignment is one setting of the per-face rotations when
  // no face is seen at two orientations). The data cannot tell them from a placement error.
  std::vector<std::string> aliases;
};

struct GapReport {
  bool ok = false;
  std::string message;
  bool magnitude = false;          // one row per segment (|f|): see GapInput::magnitude
  std::string model_name, source, unit, display_unit;
  double display_per_unit = 1.0;   // mg per m/s² (or deg/s per rad/s): estimation::display_unit
  estimation::StaticFit fit;       // the model as given
  std::string floor_source;
  Eigen::Vector3d floor = Eigen::Vector3d::Constant(kNaN);         // RMS mean std error
  Eigen::Vector3d gap_rms = Eigen::Vector3d::Constant(kNaN);       // in-sample, per axis
  Eigen::Vector3d noise_ratio = Eigen::Vector3d::Constant(kNaN);   // segment std / twin std
  std::vector<Eigen::Vector3d> residual;  // per segment (NaN for axes not fitted)
  std::vector<SegmentData> segments;
  std::vector<Place> where;
  FoldBy fold_by = FoldBy::kAuto;  // the grouping the held-out folds used (never kAuto once diagnosed)
  int folds = 0;
  std::string fold_reason;         // why this scheme: what the schemes tried before it left undetermined
  int heldout_dropped = 0;         // rows of the model as given not predicted held out (aliased or extrapolated)
  // Near-collinear candidates on this design (after projecting out the model), resolved: the term
  // named stands for its aliases; why that one (what the experiment excites) and how to separate.
  std::vector<std::string> alias_resolution;
  PlacementResult placement;       // hand-placed faces (assessed when the model leaves a gap)
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
