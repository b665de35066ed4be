// The gap diagnoser on data whose truth is known: the segment-level generator, the simulated
// bench end to end (run_experiment with the sim plugins), and the real imucal session.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "stend/core/experiment.hpp"
#include "stend/diagnosis/gap.hpp"
#include "stend/diagnosis/input.hpp"
#include "stend/diagnosis/validate.hpp"
#include "stend/io/importers.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/core/runner.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/sim_bench.hpp"

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::diagnosis;

namespace {

// Runs an experiment (path relative to the source tree) on the simulated bench with the real
// runner, reads the run folder back and builds the gap input for a diagnosis/examples model.
GapInput sim_input(const std::string& experiment, const std::string& model) {
  const stend::testing::TempDir tmp("gap");
  const RunResult run = stend::testing::run_in_process(stend::testing::source_path(experiment), tmp.path());
  if (run.status != stend::RunStatus::kComplete) throw std::runtime_error(experiment + ": run " + std::string(stend::to_string(run.status)) + ": " + run.message);
  return build_input(Recording::open(run.dir),
                     estimation::load_model_spec(stend::testing::source_path("diagnosis/examples/" + model)));
}

Planted with_term(const model::TermSpec& t, const Eigen::VectorXd& th) {
  Planted p;
  p.model = validation_model().model;
  p.theta = Eigen::VectorXd(6 + th.size());
  p.theta << 0.05, -0.03, 0.02, 0.002, -0.001, 0.0007, th;
  p.model.terms.push_back(t);
  return p;
}

}  // namespace

TEST(Gap, PlantedCrossAxisIsNamedAndTheHeldOutGapShrinksToTheFloor) {
  const ValidationDesign d = default_design();
  Eigen::VectorXd cross(6);
  cross << 0.003, -0.002, 0.001, 0.004, -0.003, 0.002;  // ≈ 20–40 mg at 1 g, far above a 0.06 mg floor
  const GapInput in = generate(d, validation_model(), with_term({model::TermKind::kCrossAxis, 1, 25}, cross), 42);
  const GapReport r = diagnose(in);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_FALSE(r.selected.empty());
  EXPECT_EQ(r.selected.front(), "cross_axis");
  EXPECT_EQ(r.explanation, "cross_axis");
  EXPECT_TRUE(r.at_floor) << r.statement;
  ASSERT_GE(r.steps.size(), 2u);
  EXPECT_LT(r.steps[1].heldout_rms, 0.1 * r.steps[0].heldout_rms);
  // The recovered size covers the planted value of the parameter it reports.
  const CandidateResult& c = r.candidates.front();
  EXPECT_EQ(c.term, "cross_axis");
  EXPECT_TRUE(c.significant);
  const auto info = model::param_info({model::TermKind::kCrossAxis, 1, 25}, model::Instrument::kAccelerometer);
  for (std::size_t k = 0; k < info.size(); ++k)
    if (info[k].name == c.size_param) {
      EXPECT_LE(c.ci_lo, cross[static_cast<Eigen::Index>(k)]);
      EXPECT_GE(c.ci_hi, cross[static_cast<Eigen::Index>(k)]);
    }
}

TEST(Gap, NullDataNamesNothing) {
  int named = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const GapReport r = diagnose(generate(default_design(), validation_model(), with_term({model::TermKind::kCrossAxis, 1, 25},
                                                                                       Eigen::VectorXd::Zero(6)),
                                          seed));
    ASSERT_TRUE(r.ok) << r.message;
    named += r.selected.empty() ? 0 : 1;
  }
  EXPECT_LE(named, 1);
}

TEST(Gap, AliasesFollowFromTheDesign) {
  // With scale in the model, a wrong local g (δg·up = δg/g·f) is exactly a common scale error:
  // not assessable. In a six-position design, K3 and odd-quadratic (±g³, ±g²) alias with scale too.
  ValidationDesign d = default_design();
  d.positions.resize(6);  // the six axis-up/down positions only
  const GapReport r = diagnose(generate(d, validation_model(), with_term({model::TermKind::kCrossAxis, 1, 25},
                                                                         Eigen::VectorXd::Zero(6)), 3));
  ASSERT_TRUE(r.ok);
  for (const auto& c : r.candidates) {
    if (c.term == "gravity_error" || c.term == "nonlinear_k3" || c.term == "odd_quadratic") {
      EXPECT_FALSE(c.evaluated) << c.term;
      EXPECT_FALSE(c.aliases.empty()) << c.term;
      bool scale = false;
      for (const auto& a : c.aliases) scale = scale || a.find("scale") != std::string::npos;
      EXPECT_TRUE(scale) << c.term;
    }
    if (c.term == "lever_arm") {
      EXPECT_FALSE(c.evaluated);  // no rate segments: not excited
    }
  }
  // In the 14-position design K3 is separable from scale.
  const GapReport r14 = diagnose(generate(default_design(), validation_model(),
                                          with_term({model::TermKind::kCrossAxis, 1, 25}, Eigen::VectorXd::Zero(6)), 3));
  for (const auto& c : r14.candidates)
    if (c.term == "nonlinear_k3") {
      EXPECT_TRUE(c.evaluated);
    }
}

TEST(Gap, JsonHasTheDocumentedShape) {
  Eigen::VectorXd k2(3);
  k2 << 0.0, 0.0, 4e-4;
  const GapReport r = diagnose(generate(default_design(), validation_model(), with_term({model::TermKind::kNonlinearK2, 1, 25}, k2), 9));
  const nlohmann::json j = nlohmann::json::parse(to_json(r));
  EXPECT_EQ(j["schema"], "stend.gap/1");
  EXPECT_TRUE(j["model"].is_string());
  EXPECT_EQ(j["noise_floor"]["static_mean_mps2"].size(), 3u);
  EXPECT_TRUE(j["noise_floor"]["source"].is_string());
  for (const char* k : {"static_rms_mps2", "static_rms_over_floor", "noise_ratio"}) EXPECT_EQ(j["gap"][k].size(), 3u);
  ASSERT_FALSE(j["segments"].empty());
  for (const char* k : {"id", "label", "axis_residual_mps2", "temperature_c", "orientation", "time_since_change_s"})
    EXPECT_TRUE(j["segments"][0].contains(k)) << k;
  ASSERT_FALSE(j["where"].empty());
  for (const char* k : {"dimension", "place", "share", "rms_mps2"}) EXPECT_TRUE(j["where"][0].contains(k)) << k;
  ASSERT_FALSE(j["candidates"].empty());
  for (const char* k : {"term", "axis", "heldout_improvement", "delta_bic", "p_value", "size", "size_unit", "ci95",
                        "aliases", "significant"})
    EXPECT_TRUE(j["candidates"][0].contains(k)) << k;
  EXPECT_EQ(j["candidates"][0]["term"], "nonlinear_k2");
  EXPECT_EQ(j["candidates"][0]["axis"], "z");
  ASSERT_GE(j["steps"].size(), 2u);
  EXPECT_TRUE(j["steps"][0]["added"].is_null());
  EXPECT_EQ(j["steps"][1]["added"], "nonlinear_k2");
  for (const char* k : {"heldout_rms_mps2", "in_sample_rms_mps2", "noise_floor_mps2"}) EXPECT_TRUE(j["steps"][0].contains(k));
  for (const char* k : {"heldout_rms_mps2", "over_floor", "statement"}) EXPECT_TRUE(j["unexplained"].contains(k));
  // Shares of one dimension add up to 1.
  double axis_share = 0;
  for (const auto& w : j["where"])
    if (w["dimension"] == "axis") axis_share += w["share"].get<double>();
  EXPECT_NEAR(axis_share, 1.0, 1e-9);
}

TEST(Gap, OutOfVocabularyEffectStaysUnexplained) {
  ValidationDesign d = default_design();
  Planted p = with_term({model::TermKind::kCrossAxis, 1, 25}, Eigen::VectorXd::Zero(6));
  const std::size_t per = d.positions.size();
  p.extra.assign(per * d.setpoints_c.size(), Eigen::Vector3d::Zero());
  for (std::size_t s = 0; s < p.extra.size(); ++s)
    if (s % per == 9) p.extra[s][2] = 8 * 6.2e-4;  // z jumps at one table position only
  const GapReport r = diagnose(generate(d, validation_model(), p, 5));
  ASSERT_TRUE(r.ok);
  EXPECT_TRUE(r.explanation.empty()) << "named " << r.explanation << ": " << r.statement;
  EXPECT_FALSE(r.at_floor);
  EXPECT_NE(r.statement.find("UNEXPLAINED"), std::string::npos) << r.statement;
}

// End to end through the simulated bench: sim_imu with a planted cross-axis matrix, run by the
// real runner into a run folder, read back, diagnosed with a model that lacks cross_axis.
TEST(GapSimBench, PlantedCrossAxisInTheSimulatorIsNamedFirst) {
  const GapInput in = sim_input("diagnosis/examples/six_position_cross_axis.yaml", "bias_scale.yaml");
  EXPECT_EQ(in.segments.size(), 10u);
  // The three-axis table chain reproduces the truth: table candidates are excited.
  EXPECT_GT(in.segments[2].point.stimulus.table_df_dangle[2].norm(), 1.0);
  const GapReport r = diagnose(in);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_FALSE(r.selected.empty()) << r.statement;
  EXPECT_EQ(r.selected.front(), "cross_axis");
  EXPECT_LT(r.steps[1].heldout_rms, 0.3 * r.steps[0].heldout_rms);
  EXPECT_GT(r.gap_rms.maxCoeff(), 5 * r.floor.maxCoeff());
  // The simulator's own noise settings are the twin noise: the ratio is near 1.
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.noise_ratio[a], 1.0, 0.2);
}

// The run folder read whole or streamed from its store: the same report to the last digit (the
// static points, the batch fit, the noise evidence and the Allan window of the longest segment).
TEST(GapSimBench, SameReportFromARunInMemoryOrStreamed) {
  const stend::testing::TempDir tmp("gap-stream");
  const RunResult run = stend::testing::run_in_process(stend::testing::source_path("configs/temperature_sweep.yaml"), tmp.path());
  ASSERT_EQ(run.status, stend::RunStatus::kComplete) << run.message;
  const auto spec = estimation::load_model_spec(stend::testing::source_path("diagnosis/examples/bias_scale.yaml"));
  const Recording streamed = Recording::open(run.dir, SampleLoading::kStream);
  ASSERT_TRUE(streamed.samples.empty());
  ASSERT_GT(streamed.sample_count(), 0u);
  const GapReport a = diagnose(build_input(Recording::open(run.dir), spec));
  const GapReport b = diagnose(build_input(streamed, spec));
  ASSERT_TRUE(a.ok) << a.message;
  EXPECT_EQ(to_json(a), to_json(b));
}

TEST(GapSimBench, SixPositionWithTheRightModelHasNoGapToExplain) {
  const GapReport r = diagnose(sim_input("configs/six_position.yaml", "bias_scale.yaml"));
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_TRUE(r.selected.empty()) << r.statement;
}

// Real data: imucal's six-position session fitted without cross-axis terms.
TEST(GapRealData, ImucalWithoutCrossAxisNamesCrossAxisFirst) {
  const fs::path csv = stend::testing::shared_data("imucal/annotated_session.csv");
  STEND_SKIP_IF_ABSENT(csv) << "; real-data check skipped";
  const Recording rec = io::import_imucal_session(csv);
  const estimation::ModelSpec spec =
      estimation::load_model_spec(stend::testing::source_path("diagnosis/examples/imucal_bias_scale.yaml"));
  const GapInput in = build_input(rec, spec);
  ASSERT_EQ(in.segments.size(), 6u);
  const GapReport r = diagnose(in);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_FALSE(r.candidates.empty());
  EXPECT_EQ(r.candidates.front().term, "cross_axis");
  EXPECT_LT(r.candidates.front().heldout_rms, r.candidates.front().heldout_rms_before);
}

// Magnitude form (orientations unknown, only |g|): the same generator, the truth directions thrown
// away. A planted cross-axis is named; only its symmetric half (3 of 6 parameters) is visible, the
// rotation half being what an unknown orientation absorbs; null data name nothing.
// Absent is absent: points without a temperature (NaN) form no temperature level, spread nothing,
// and the diagnosis then offers no term that reads the temperature and no "temperature" place.
TEST(Gap, NoTemperatureRecordedOffersNoTemperatureCandidate) {
  std::vector<double> levels;
  EXPECT_EQ(temperature_group(levels, kNaN), -1);
  EXPECT_TRUE(levels.empty());
  const auto reads_temperature = [](const std::vector<Candidate>& cs) {
    return std::any_of(cs.begin(), cs.end(), [](const Candidate& c) { return model::reads_temperature(c.term.kind); });
  };
  EXPECT_TRUE(reads_temperature(default_candidates(validation_model().model, true)));
  EXPECT_FALSE(reads_temperature(default_candidates(validation_model().model, false)));

  const ValidationDesign d = default_design();
  GapInput in = generate(d, validation_model(), with_term({model::TermKind::kCrossAxis, 1, 25}, Eigen::VectorXd::Zero(6)), 3);
  ASSERT_TRUE(has_temperature_spread(in.segments));  // the design's sweep
  for (auto& s : in.segments) {
    s.point.stimulus.temperature_c = kNaN;
    s.setpoint_c = kNaN;
    s.temperature_group = -1;
  }
  EXPECT_FALSE(has_temperature_spread(in.segments));
  const GapReport r = diagnose(in);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_FALSE(r.candidates.empty());
  for (const auto& c : r.candidates) EXPECT_FALSE(model::reads_temperature(c.spec.kind)) << c.term;
  for (const auto& p : r.where) EXPECT_NE(p.dimension, "temperature") << p.place;
}

TEST(GapMagnitude, PlantedCrossAxisIsNamedAndOnlyItsSymmetricPartIsSeen) {
  const ValidationDesign d = many_positions_design(40);
  Eigen::VectorXd cross(6);
  cross << 0.003, -0.002, 0.001, 0.004, -0.003, 0.002;
  GapInput in = generate(d, validation_model(), with_term({model::TermKind::kCrossAxis, 1, 25}, cross), 7);
  const GapInput mag = magnitude_form(in, d.gravity);
  ASSERT_TRUE(mag.magnitude);
  // The estimated directions are the true ones to well within the planted errors (≈ 0.3 %).
  for (std::size_t s = 0; s < mag.segments.size(); ++s)
    EXPECT_LT((mag.segments[s].point.stimulus.specific_force.normalized() -
               in.segments[s].point.stimulus.specific_force.normalized()).norm(), 0.01);
  const GapReport r = diagnose(mag);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_TRUE(r.magnitude);
  ASSERT_FALSE(r.selected.empty()) << r.statement;
  EXPECT_EQ(r.selected.front(), "cross_axis");
  for (const auto& c : r.candidates)
    if (c.term == "cross_axis") {
      EXPECT_EQ(c.added_rank, 3);
      EXPECT_EQ(c.axis, "|f|");
    }
  ASSERT_GE(r.steps.size(), 2u);
  EXPECT_LT(r.steps[1].heldout_rms, 0.2 * r.steps[0].heldout_rms);
  int named = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const GapReport n = diagnose(magnitude_form(
        generate(d, validation_model(), with_term({model::TermKind::kCrossAxis, 1, 25}, Eigen::VectorXd::Zero(6)), seed),
        d.gravity));
    ASSERT_TRUE(n.ok) << n.message;
    named += n.selected.empty() ? 0 : 1;
  }
  EXPECT_LE(named, 1);
}

// Real data with unknown orientations (hand-held MPU-6050, only |g| known), fitted with biases
// alone (nominal 16384 LSB/g): the magnitude form names the scale factor first, the held-out gap
// shrinks, and the recovered scale matches that project's own calibration (z: −2.1 % in its
// m/s² per count, i.e. the reading is 2.15 % high).
TEST(GapRealData, Mpu6050MultiposWithoutScaleNamesScaleInTheMagnitudeForm) {
  const fs::path csv = stend::testing::shared_data("mpu6050_multipos/calibration_session.csv");
  STEND_SKIP_IF_ABSENT(csv);
  const Recording rec = io::import_mpu6050_multipos(csv);
  const estimation::ModelSpec spec =
      estimation::load_model_spec(stend::testing::source_path("diagnosis/examples/mpu6050_multipos_bias.yaml"));
  const GapInput in = build_input(rec, spec);
  EXPECT_TRUE(in.magnitude);
  EXPECT_GE(in.segments.size(), 8u);
  const GapReport r = diagnose(in);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_FALSE(r.selected.empty()) << r.statement;
  EXPECT_EQ(r.selected.front(), "scale");
  ASSERT_GE(r.steps.size(), 2u);
  EXPECT_LT(r.steps[1].heldout_rms, 0.5 * r.steps[0].heldout_rms);
  const CandidateResult& c = r.candidates.front();
  ASSERT_EQ(c.term, "scale");
  ASSERT_EQ(c.size_param, "scale_z");
  const double reference = 9.80665 / 16384.0 / 5.859241382355084718e-04 - 1.0;  // reference_params_acc.csv
  EXPECT_LT(std::abs(c.size - reference), 0.002) << c.size << " vs " << reference;
  // A gyroscope has no |g| to lean on: refused with the reason.
  estimation::ModelSpec gyro = spec;
  gyro.model.instrument = model::Instrument::kGyroscope;
  try {
    (void)build_input(rec, gyro);
    ADD_FAILURE() << "expected a refusal";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("rate truth"), std::string::npos) << e.what();
  }
}

// The paper-style temperature sweep (configs/temperature_sweep.yaml: sim bias and scale temperature
// polynomials of order 2 and 1) diagnosed with a bias + scale model: the temperature terms are
// found in that order, held out by temperature, and the held-out gap falls by > 90 %.
TEST(GapSimBench, TemperatureSweepNamesTheTemperaturePolynomials) {
  const GapReport r = diagnose(sim_input("configs/temperature_sweep.yaml", "bias_scale.yaml"));
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.fold_by, FoldBy::kTemperature);
  ASSERT_GE(r.selected.size(), 2u) << r.statement;
  EXPECT_EQ(r.selected[0].rfind("bias_temperature", 0), 0u) << r.selected[0];
  EXPECT_EQ(r.selected[1].rfind("scale_temperature", 0), 0u) << r.selected[1];
  EXPECT_LT(r.unexplained_heldout_rms, 0.1 * r.steps[0].heldout_rms);
  // Where: the coldest step carries the largest share of the temperature dimension.
  for (const auto& p : r.where)
    if (p.dimension == "temperature") {
      EXPECT_EQ(p.place.rfind("-20", 0), 0u) << p.place;
      break;
    }
}

// Issue 40 — folds that fit the design. A hand-held six-face session (faces near the axes, each
// placed 5 times; magnitude form; model bias + scale): holding out a whole face leaves bias and
// scale of its axis to the opposite face alone, so the orientation folds cannot determine the
// held-out rows; the diagnosis re-folds (leave-one-segment-out), says why, names nothing on null
// data and keeps the held-out gap near the floor. Forced orientation folds say how many rows
// they could not predict.
TEST(GapFolds, HandHeldFacesAreReFoldedAndTheReasonIsGiven) {
  const estimation::ModelSpec bs = validation_model();
  Planted truth;
  truth.model = bs.model;
  truth.theta = Eigen::VectorXd(6);
  truth.theta << 0.05, -0.03, 0.02, 0.002, -0.001, 0.0007;
  const GapInput in = magnitude_form(generate_hand_faces(5, 3.0, bs, truth, 11), physics::kStandardGravity);
  const GapReport r = diagnose(in);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_NE(r.fold_by, FoldBy::kOrientation);
  EXPECT_NE(r.fold_reason.find("orientation"), std::string::npos) << r.fold_reason;
  EXPECT_TRUE(r.selected.empty()) << r.statement;
  ASSERT_FALSE(r.steps.empty());
  EXPECT_LT(r.steps[0].heldout_rms, 2.0 * r.steps[0].floor_rms);
  GapOptions forced;
  forced.fold_by = FoldBy::kOrientation;
  const GapReport f = diagnose(in, forced);
  EXPECT_EQ(f.fold_by, FoldBy::kOrientation);
  EXPECT_GT(f.heldout_dropped, 0);
  // One segment per face and a model that needs them all: no scheme can test it — refused, with
  // the experiment that would make it testable.
  const GapInput once = magnitude_form(generate_hand_faces(1, 3.0, bs, truth, 12), physics::kStandardGravity);
  const GapReport n = diagnose(once);
  EXPECT_FALSE(n.ok);
  EXPECT_NE(n.message.find("repeat each orientation"), std::string::npos) << n.message;
}

// Issue 40 — aliases resolved by what the experiment excites, and the false discovery rate over
// the candidate family: the design cases of `stend gap validate` (fold, alias, placement) at a
// reduced, deterministic seed count; each planted case passes in >= 90 % of its runs and each
// null case fails in <= 5 %.
// The 100 runs a case (~10 s): a null case may fail 5 times (<= 5 %), a planted one 10
// (>= 90 %). With a handful of runs a null case would have to be perfect, which a 5 % rule does not
// promise: the fold null case, "a term marked significant" counted as a failure, fails in 1.25 %
// of 400 runs, 3 of them among the first 40 of this seed.
TEST(GapDesignCases, FoldAliasAndPlacementCasesMeetTheirTargets) {
  const std::vector<DesignCase> cases = run_design_cases(100, 3);
  ASSERT_EQ(cases.size(), 6u);
  for (const auto& c : cases) {
    std::string named;
    for (const auto& [n, k] : c.named) named += n + " " + std::to_string(k) + "; ";
    EXPECT_TRUE(design_case_met(c)) << c.name << ": " << c.passed << "/" << c.runs << " — " << named;
  }
}

// Issue 40 on real data: imucal's hand-placed six faces with bias + scale. The sensor terms leave
// a gap of ~80x the floor; a rotation per face (placement) accounts for it, and the verdict says
// so instead of "unexplained" (untestable here: 18 rows, 18 parameters; cross_axis lies within
// the per-face rotations and the statement says so). Scale withheld (bias only): imucal's own
// calibration (example_cal.json) has a 2.8 % z scale error *and* misalignments of 1-2 %; on six
// segments neither scale nor cross_axis alone leaves a residual small enough to be significant
// (the other stays in it), so nothing is named — but never a third term, and the placement
// family, which acts across f only, is not significant: the gap left lies along f (the scale).
TEST(GapRealData, ImucalHandPlacedFacesNamePlacementAndScaleWhenWithheld) {
  const fs::path csv = stend::testing::shared_data("imucal/annotated_session.csv");
  STEND_SKIP_IF_ABSENT(csv) << "; real-data check skipped";
  const Recording rec = io::import_imucal_session(csv);
  estimation::ModelSpec spec =
      estimation::load_model_spec(stend::testing::source_path("diagnosis/examples/imucal_bias_scale.yaml"));
  const GapReport r = diagnose(build_input(rec, spec));
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_TRUE(r.placement.assessed) << r.placement.reason;
  EXPECT_TRUE(r.placement.significant || r.placement.consistent) << r.placement.reason;
  EXPECT_NE(r.statement.find("PLACEMENT"), std::string::npos) << r.statement;
  EXPECT_LT(r.placement.max_deg, 5.0);
  EXPECT_NE(std::find(r.placement.aliases.begin(), r.placement.aliases.end(), "cross_axis"), r.placement.aliases.end());
  EXPECT_EQ(r.statement.find("UNEXPLAINED"), std::string::npos) << r.statement;
  spec.model.terms = {model::TermSpec{model::TermKind::kBias, 1, 25.0}};
  const GapReport b = diagnose(build_input(rec, spec));
  ASSERT_TRUE(b.ok) << b.message;
  EXPECT_TRUE(b.selected.empty() || b.selected.front() == "scale" || b.selected.front() == "cross_axis")
      << b.statement;
  EXPECT_TRUE(b.placement.assessed) << b.placement.reason;
  EXPECT_FALSE(b.placement.significant) << b.placement.reason;
}

// Issue 40 on real data: the hand-held MPU-6050 session (magnitude form). Scale withheld → scale
// named first (its near-collinear aliases listed), the held-out gap after it near the floor;
// cross-axis withheld (bias + scale) → cross_axis named, or not testable on these ten segments
// (not assessable, or no row determined held out) — that project's own misalignments are
// ~1e-5 rad, far below the floor, so nothing else may be named either. In every case a held-out
// gap over 3x the in-sample one comes with its reason in the notes.
TEST(GapRealData, Mpu6050HeldOutGapIsExplainedWhenFarAboveInSample) {
  const fs::path csv = stend::testing::shared_data("mpu6050_multipos/calibration_session.csv");
  STEND_SKIP_IF_ABSENT(csv);
  const Recording rec = io::import_mpu6050_multipos(csv);
  estimation::ModelSpec spec =
      estimation::load_model_spec(stend::testing::source_path("diagnosis/examples/mpu6050_multipos_bias.yaml"));
  const auto ratio_explained = [](const GapReport& r) {
    for (const auto& s : r.steps)
      if (s.heldout_rms > 3.0 * s.in_sample_rms) {
        bool noted = false;
        for (const auto& n : r.notes) noted = noted || n.find("x the in-sample gap") != std::string::npos;
        if (!noted) return false;
      }
    return true;
  };
  const GapReport b = diagnose(build_input(rec, spec));
  ASSERT_TRUE(b.ok) << b.message;
  ASSERT_FALSE(b.selected.empty()) << b.statement;
  EXPECT_EQ(b.selected.front(), "scale");
  EXPECT_FALSE(b.alias_resolution.empty());
  ASSERT_GE(b.steps.size(), 2u);
  EXPECT_LT(b.steps[1].heldout_rms, 2.5 * b.steps[1].floor_rms);
  EXPECT_TRUE(ratio_explained(b));
  spec.model.terms.push_back(model::TermSpec{model::TermKind::kScale, 1, 25.0});
  const GapReport s = diagnose(build_input(rec, spec));
  if (!s.ok) {
    EXPECT_NE(s.message.find("no fold scheme"), std::string::npos) << s.message;
    return;
  }
  EXPECT_TRUE(ratio_explained(s));
  bool cross_named = !s.selected.empty() && s.selected.front() == "cross_axis", cross_untestable = false;
  for (const auto& c : s.candidates)
    if (c.term == "cross_axis")
      cross_untestable = !c.evaluated || c.reason.find("cannot be tested held out") != std::string::npos;
  EXPECT_TRUE(cross_named || cross_untestable || s.at_floor) << s.statement;
  EXPECT_TRUE(s.selected.empty() || cross_named) << s.statement;
}
