// Tests of the gyroscope methods that read what was applied from the recording's truth: turns by
// known angles (Ferraris), the Earth rate in up/down positions, and the rate table with an unknown
// specific force. Recordings come from a small generator with PLANTED gyro errors
// (turn_recording.hpp); the real-data check uses imucal's Ferraris session (../shared/data/imucal).
#include "turn_recording.hpp"

#include <stend/ceres_nonlinear/estimator.hpp>
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/io/importers.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/truth_columns.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <numeric>
#include <random>
#include <string>
#include <vector>

using namespace stend;
using namespace stend::ceres_nonlinear;
namespace tr = stend::ceres_nonlinear::turn_record;

namespace {

// Planted gyro errors: bias [rad/s], scale, cross (xy xz yx yz zx zy), G row-major [(rad/s)/(m/s²)].
std::vector<double> planted(bool gsens) {
  std::vector<double> t = {0.01, -0.015, 0.02, 0.01, -0.008, 0.012, 0.004, -0.003, 0.005, 0.002, -0.004, 0.006};
  if (gsens) t.insert(t.end(), {1e-4, 2e-5, 0, 0, -1e-4, 3e-5, 5e-5, 0, 1e-4});
  return t;
}

GyroOptions gyro_options(bool gsens) {
  GyroOptions o;
  o.estimate_g_sensitivity = gsens;
  return o;
}

bool contains(const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); }

// The planted value of each parameter lies in its interval.
std::vector<bool> covered(const CalibrationResult& r, const std::vector<double>& truth) {
  std::vector<bool> in;
  for (std::size_t i = 0; i < truth.size(); ++i) in.push_back(r.parameters[i].lower <= truth[i] && truth[i] <= r.parameters[i].upper);
  return in;
}

}  // namespace

// -----------------------------------------------------------------------------------------------
// Turns

TEST(CeresTurns, RecoversThePlantedErrorsWithGSensitivity) {
  tr::Spec spec;
  spec.gyro_theta = planted(true);
  spec.turn_error_deg = 0.2;
  spec.seed = 7;
  const Recording rec = tr::make(spec, tr::ferraris_steps());
  GyroOptions o = gyro_options(true);
  o.turn_angle_sigma_deg = 0.2;
  const CalibrationResult r = calibrate_gyro_turns(rec, o);
  ASSERT_TRUE(r.ok()) << r.report();
  EXPECT_EQ(r.method, Method::kTurns);
  EXPECT_EQ(r.turns.size(), 3u);
  EXPECT_EQ(r.intervals.size(), 9u);  // eight known stills and one detected
  EXPECT_EQ(r.observations, 3 * (9 + 3));
  EXPECT_EQ(r.dof, 3 * (9 + 3) - 21);
  ASSERT_EQ(r.parameters.size(), 21u);
  for (std::size_t i = 0; i < spec.gyro_theta.size(); ++i) {
    const auto& p = r.parameters[i];
    EXPECT_NEAR(p.value, spec.gyro_theta[i], 5.0 * p.std_error) << p.name;
    EXPECT_TRUE(p.identifiable) << p.name;
  }
  // Scale and cross-axis from three turns known to 0.2°: about 0.2°/360° ≈ 560 ppm along the axis,
  // 0.35 % across it.
  EXPECT_LT(r.parameter("scale_x").std_error, 2e-3);
  EXPECT_LT(r.parameter("cross_yx").std_error, 1e-2);
  EXPECT_LT(r.parameter("bias_x").std_error, 1e-4);
  // The integrated turns: raw off by the planted scale (~1 % of 360°), calibrated within the angles.
  EXPECT_GT(r.turn_error_rad.before, 1.0 * physics::kDegToRad);
  EXPECT_LT(r.turn_error_rad.after, 0.1 * r.turn_error_rad.before);
  EXPECT_NE(r.uncertainty.find("reduced χ²"), std::string::npos) << r.uncertainty;
  EXPECT_NE(r.uncertainty.find(std::to_string(r.dof) + " dof"), std::string::npos) << r.uncertainty;
  const std::string text = r.report();
  EXPECT_NE(text.find("turns: 3"), std::string::npos) << text;
  EXPECT_NE(text.find("uncertainty:"), std::string::npos) << text;
}

// 20 seeds, turns off their stated angle and axis by 1° (1σ) as the option assumes: the 95 %
// intervals hold the planted values, and the standard errors match the scatter of the estimates.
TEST(CeresTurns, IntervalsCoverThePlantedValuesOverTwentySeeds) {
  const int seeds = 20;
  const std::vector<double> truth = planted(false);
  std::vector<int> hits(truth.size(), 0);
  std::vector<std::vector<double>> err(truth.size()), se(truth.size());
  for (int s = 0; s < seeds; ++s) {
    tr::Spec spec;
    spec.gyro_theta = truth;
    spec.turn_error_deg = 1.0;
    spec.seed = 100 + static_cast<std::uint64_t>(s);
    const CalibrationResult r = calibrate_gyro_turns(tr::make(spec, tr::ferraris_steps()), gyro_options(false));
    ASSERT_TRUE(r.ok()) << r.report();
    const std::vector<bool> in = covered(r, truth);
    for (std::size_t i = 0; i < truth.size(); ++i) {
      hits[i] += in[i] ? 1 : 0;
      err[i].push_back(r.parameters[i].value - truth[i]);
      se[i].push_back(r.parameters[i].std_error);
    }
  }
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const std::string name = gyroscope_model(false).params()[i].name;
    EXPECT_GE(hits[i], 16) << name << ": " << hits[i] << " of " << seeds;
    const double rms = std::sqrt(std::inner_product(err[i].begin(), err[i].end(), err[i].begin(), 0.0) / seeds);
    const double mean_se = std::accumulate(se[i].begin(), se[i].end(), 0.0) / seeds;
    std::cout << "[turns coverage] " << name << ": " << hits[i] << "/" << seeds << " intervals hold the planted value; "
              << "scatter / std error = " << rms / mean_se << "\n";
    EXPECT_GT(rms / mean_se, 0.45) << name << ": scatter " << rms << ", std error " << mean_se;
    EXPECT_LT(rms / mean_se, 1.8) << name << ": scatter " << rms << ", std error " << mean_se;
  }
}

TEST(CeresTurns, TurnsAboutTwoAxesFailNamingTheUnseenCombination) {
  tr::Spec spec;
  spec.gyro_theta = planted(false);
  const Recording rec = tr::make(spec, tr::ferraris_steps(/*turn_x=*/false));
  const CalibrationResult r = calibrate_gyro_turns(rec, gyro_options(false));
  std::cout << r.message << "\n";
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message.find("not identifiable"), std::string::npos) << r.message;
  for (const char* name : {"scale_x", "cross_yx", "cross_zx"}) EXPECT_TRUE(contains(r.not_identifiable, name)) << name;
  EXPECT_NE(r.message.find("scale_x"), std::string::npos) << r.message;
  for (const auto& p : r.parameters) EXPECT_TRUE(std::isnan(p.value)) << p.name;
  const std::string json = r.to_json();
  EXPECT_EQ(nlohmann::json::parse(json)["parameters"][3]["value"], nullptr);
}

TEST(CeresTurns, FailsWithoutTurnTruthOrStills) {
  tr::Spec spec;
  spec.gyro_theta = planted(false);
  Recording rec = tr::make(spec, tr::ferraris_steps());
  Recording no_turns = rec;
  no_turns.header.truth_columns[6] = "other";
  const CalibrationResult a = calibrate_gyro_turns(no_turns, gyro_options(false));
  EXPECT_FALSE(a.ok());
  EXPECT_NE(a.message.find("turn_x_deg"), std::string::npos) << a.message;
  Recording no_stills = rec;
  std::erase_if(no_stills.segments, [](const Segment& s) { return s.kind != SegmentKind::kRotation; });
  const CalibrationResult b = calibrate_gyro_turns(no_stills, gyro_options(false));
  EXPECT_FALSE(b.ok());
  EXPECT_NE(b.message.find("no still segments"), std::string::npos) << b.message;
  // A lost sample inside a turn leaves it out (and then only two axes are turned).
  Recording gap = rec;
  const Segment& turn = *std::find_if(gap.segments.begin(), gap.segments.end(),
                                      [](const Segment& s) { return s.kind == SegmentKind::kRotation; });
  for (auto& smp : gap.samples)
    if (smp.t_s > turn.t_start_s + 1.0) {
      smp.flags |= kGapBefore;
      break;
    }
  const CalibrationResult c = calibrate_gyro_turns(gap, gyro_options(false));
  EXPECT_FALSE(c.ok());
  ASSERT_FALSE(c.notes.empty());
  EXPECT_NE(c.notes[0].find("lost sample"), std::string::npos) << c.notes[0];
}

// -----------------------------------------------------------------------------------------------
// Earth rate

namespace {

// An up/down pair of `axis` at 47° N, `seconds` each, with per-sample noise from a noise density
// [rad/s/√Hz] at 10 Hz; planted bias and scale on that axis only (no cross-axis: the method holds it).
Recording earth_rate_record(int axis, double density_radps_rthz, double seconds, std::uint64_t seed,
                            std::vector<double>& theta) {
  tr::Spec spec;
  spec.rate_hz = 10.0;
  spec.latitude_deg = 47.0;
  spec.gyro_noise_radps = density_radps_rthz * std::sqrt(spec.rate_hz);
  spec.seed = seed;
  theta.assign(12, 0.0);
  theta[static_cast<std::size_t>(axis)] = 2e-5;       // bias [rad/s]
  theta[static_cast<std::size_t>(3 + axis)] = 0.005;  // scale: 5000 ppm
  spec.gyro_theta = theta;
  return tr::make(spec, tr::up_down_steps(axis, seconds));
}

}  // namespace

TEST(CeresEarthRate, LowNoiseGyroRecoversAPlantedScaleFromAnUpDownPair) {
  std::vector<double> theta;
  // Navigation grade: 0.002 deg/√h angle random walk, 20 minutes per position.
  const double density = 0.002 * physics::kDegToRad / 60.0;
  const Recording rec = earth_rate_record(2, density, 1200.0, 3, theta);
  const CalibrationResult r = calibrate_gyro_earth_rate(rec);
  ASSERT_TRUE(r.ok()) << r.report();
  EXPECT_EQ(r.method, Method::kEarthRate);
  EXPECT_EQ(r.intervals.size(), 2u);
  EXPECT_EQ(r.dof, 0);
  const auto& s = r.parameter("scale_z");
  EXPECT_LE(s.lower, theta[5]);
  EXPECT_GE(s.upper, theta[5]);
  EXPECT_LT(s.std_error, 5e-4);
  EXPECT_EQ(s.judged(), estimation::Verdict::kDetermined);
  EXPECT_NEAR(r.parameter("bias_z").value, theta[2], 4.0 * r.parameter("bias_z").std_error);
  // x and y are never vertical: held and said so, not invented; the cross-axis terms are held too.
  for (const char* name : {"bias_x", "scale_x", "bias_y", "scale_y"}) {
    EXPECT_TRUE(r.parameter(name).held) << name;
    EXPECT_NE(r.parameter(name).reason.find("never within 45 deg of the vertical"), std::string::npos) << name;
  }
  EXPECT_TRUE(r.parameter("cross_xy").held);
  // 0 dof: the a-priori covariance as it is, and said so.
  EXPECT_NE(r.uncertainty.find("0 dof"), std::string::npos) << r.uncertainty;
  EXPECT_NE(r.uncertainty.find("a-priori"), std::string::npos) << r.uncertainty;
  EXPECT_LT(r.rate_error_radps.after, 0.1 * r.rate_error_radps.before);
}

TEST(CeresEarthRate, Mpu6050GradeGyroGivesAnImpreciseScale) {
  std::vector<double> theta;
  // MPU-6050: 0.005 deg/s/√Hz, 10 minutes per position.
  const Recording rec = earth_rate_record(2, 0.005 * physics::kDegToRad, 600.0, 4, theta);
  const CalibrationResult r = calibrate_gyro_earth_rate(rec);
  std::cout << r.report();
  ASSERT_TRUE(r.ok()) << r.report();
  const auto& s = r.parameter("scale_z");
  EXPECT_EQ(s.judged(), estimation::Verdict::kImprecise) << r.report();
  EXPECT_GT(s.std_error, 0.01);  // more than 1 %: the Earth rate is below the noise of the means
  EXPECT_GT(s.upper - s.lower, 0.04);
  EXPECT_NE(s.reason.find("exceeds 1.96 × the tolerance"), std::string::npos) << s.reason;
}

TEST(CeresEarthRate, OnlyUpPositionsOrNoLatitudeFail) {
  std::vector<double> theta;
  Recording rec = earth_rate_record(2, 1e-6, 100.0, 5, theta);
  // Drop the down position: bias_z and scale_z alias.
  Recording up = rec;
  std::erase_if(up.segments, [](const Segment& s) { return s.label == "still 2"; });
  const CalibrationResult a = calibrate_gyro_earth_rate(up);
  EXPECT_FALSE(a.ok());
  EXPECT_TRUE(a.message.find("too few stills") != std::string::npos ||
              a.message.find("not identifiable") != std::string::npos)
      << a.message;
  for (const auto& p : a.parameters)
    if (!p.held) {
      EXPECT_TRUE(std::isnan(p.value)) << p.name;
    }
  // No latitude: the truth's w is NaN in the stills, nothing to fit.
  Recording no_lat = rec;
  for (auto& row : no_lat.truth) std::fill(row.begin() + 3, row.begin() + 6, kNaN);
  const CalibrationResult b = calibrate_gyro_earth_rate(no_lat);
  EXPECT_FALSE(b.ok());
  // g-sensitivity cannot be separated from the scale.
  GyroOptions o;
  o.estimate_g_sensitivity = true;
  const CalibrationResult c = calibrate_gyro_earth_rate(rec, o);
  EXPECT_FALSE(c.ok());
  EXPECT_NE(c.message.find("g-sensitivity"), std::string::npos) << c.message;
}

// -----------------------------------------------------------------------------------------------
// Rate table with an unknown specific force

namespace {

// Rates of ±1, ±2 rad/s about each axis and two stills, every interval a mean of 400 readings.
struct RateLegs {
  std::vector<processing::StaticPoint> intervals;
  std::vector<Eigen::Vector3d> w, f;
};

RateLegs rate_legs(const std::vector<double>& theta, bool gsens, std::uint64_t seed) {
  RateLegs d;
  const model::ErrorModel m = gyroscope_model(gsens);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 0.004 / 20.0);
  auto add = [&](const Eigen::Vector3d& w, const Eigen::Vector3d& f) {
    model::Stimulus<double> s;
    s.input = w;
    s.specific_force = f;
    processing::StaticPoint iv;
    iv.accel.mean = f;
    iv.gyro.mean = m.measure<double>(theta.data(), s) + Eigen::Vector3d(n(rng), n(rng), n(rng));
    iv.samples_used = 400;
    d.intervals.push_back(iv);
    d.w.push_back(w);
    d.f.push_back(Eigen::Vector3d::Constant(kNaN));  // the orientation is not known
  };
  add(Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 9.8));
  add(Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, -9.8));
  for (int axis = 0; axis < 3; ++axis)
    for (double r : {-2.0, -1.0, 1.0, 2.0}) add(Eigen::Vector3d::Unit(axis) * r, Eigen::Vector3d::Unit(axis) * 9.8);
  return d;
}

}  // namespace

TEST(CeresRateTable, UnknownSpecificForcePassesWithoutGSensitivityAndFailsWithIt) {
  const std::vector<double> truth = planted(false);
  const RateLegs d = rate_legs(truth, false, 1);
  const CalibrationResult r = calibrate_gyro_rate_table(d.intervals, d.w, d.f, gyro_options(false));
  ASSERT_TRUE(r.ok()) << r.message;
  for (std::size_t i = 0; i < truth.size(); ++i)
    EXPECT_NEAR(r.parameters[i].value, truth[i], 5.0 * r.parameters[i].std_error) << r.parameters[i].name;
  const CalibrationResult g = calibrate_gyro_rate_table(d.intervals, d.w, d.f, gyro_options(true));
  EXPECT_FALSE(g.ok());
  EXPECT_NE(g.message.find("specific-force truth"), std::string::npos) << g.message;
  EXPECT_NE(g.message.find("g-sensitivity"), std::string::npos) << g.message;
  // A NaN rate is refused in any case.
  RateLegs bad = d;
  bad.w[3] = Eigen::Vector3d::Constant(kNaN);
  EXPECT_FALSE(calibrate_gyro_rate_table(bad.intervals, bad.w, bad.f, gyro_options(false)).ok());
}

// -----------------------------------------------------------------------------------------------
// Model file, results document and its reader

TEST(CeresTurnsModelFile, MethodsAndTheirKeys) {
  const ModelFileOptions t = options_from_yaml(
      YAML::Load("ceres_nonlinear:\n  accelerometer: none\n  gyroscope: turns\n  turn_angle_sigma_deg: 0.5\n"), "m.yaml");
  EXPECT_EQ(t.gyroscope, "turns");
  EXPECT_EQ(t.gyro.turn_angle_sigma_deg, 0.5);
  EXPECT_NE(describe_options(t).find("known to 0.5 deg"), std::string::npos) << describe_options(t);
  EXPECT_EQ(nlohmann::json::parse(options_json(t))["turn_angle_sigma_deg"], 0.5);
  const ModelFileOptions e =
      options_from_yaml(YAML::Load("ceres_nonlinear:\n  accelerometer: none\n  gyroscope: earth_rate\n"), "m.yaml");
  EXPECT_EQ(e.gyroscope, "earth_rate");
  auto refused = [](const std::string& yaml, const std::string& what) {
    try {
      (void)options_from_yaml(YAML::Load(yaml), "m.yaml");
      ADD_FAILURE() << "expected an error: " << yaml;
    } catch (const ExperimentError& err) {
      EXPECT_NE(std::string(err.what()).find(what), std::string::npos) << err.what();
    }
  };
  refused("ceres_nonlinear:\n  gyroscope: earth_rate\n  gyro_g_sensitivity: true\n", "m.yaml:3:23");
  refused("ceres_nonlinear:\n  gyroscope: rate_table\n  turn_angle_sigma_deg: 1\n", "only with gyroscope: turns");
  refused("ceres_nonlinear:\n  gyroscope: turn\n", "turns");
  refused("ceres_nonlinear:\n  gyroscope: turns\n  turn_angle_sigma_deg: 0\n", "must be > 0");
}

TEST(CeresTurnsModelFile, ShippedExamplesLoad) {
  for (const char* name : {"ferraris", "earth_rate", "rate_legs"}) {
    const auto file = stend::testing::source_path(std::string("estimators/ceres_nonlinear/examples/") + name + ".yaml");
    const ModelFileOptions o = load_model_file(file.string());
    EXPECT_TRUE(o.IsValid()) << name;
  }
  const ModelFileOptions f = load_model_file(stend::testing::source_path("estimators/ceres_nonlinear/examples/ferraris.yaml").string());
  EXPECT_EQ(f.gyroscope, "turns");
  EXPECT_EQ(f.accelerometer, "known_orientations");
  EXPECT_TRUE(f.gyro.estimate_g_sensitivity);
  EXPECT_EQ(f.accel.orientation_sigma_deg, 1.0);
}

// A model-file fit: ceres.json written and read back as the typed result, the gyroscope's model
// with its uncertainty statement and what earth_rate holds.
TEST(CeresTurnsModelFile, ResultsDocumentReadsBackThroughTheRegistryReader) {
  tr::Spec spec;
  spec.gyro_theta = planted(true);
  const Recording rec = tr::make(spec, tr::ferraris_steps());
  const ModelFileOptions o = load_model_file(stend::testing::source_path("estimators/ceres_nonlinear/examples/ferraris.yaml").string());
  const ModelFileFit fit = fit_model_file(rec, o);
  ASSERT_TRUE(fit.ok()) << fit.text;
  EXPECT_NE(fit.text.find("Ceres gyroscope calibration (turns)"), std::string::npos);
  const estimation::FitResult back = read_results(nlohmann::json::parse(fit.document.dump(2)));
  ASSERT_TRUE(back.gyroscope.has_value());
  ASSERT_TRUE(back.gyroscope->ok());
  ASSERT_EQ(back.gyroscope->theta.size(), 21u);
  for (std::size_t i = 0; i < 21; ++i) EXPECT_DOUBLE_EQ(back.gyroscope->theta[i], fit.gyro.theta[i]);
  const auto& notes = back.gyroscope->notes;
  EXPECT_TRUE(std::any_of(notes.begin(), notes.end(), [](const std::string& n) { return n.find("uncertainty (turns)") == 0; }));
  EXPECT_TRUE(std::any_of(back.summary.notes.begin(), back.summary.notes.end(),
                          [](const std::string& n) { return n.find("gyroscope (turns): ") == 0; }));
  const nlohmann::json& doc = fit.document;
  EXPECT_EQ(doc["gyroscope"]["method"], "turns");
  EXPECT_EQ(doc["gyroscope"]["turns"].size(), 3u);
  EXPECT_TRUE(doc["gyroscope"].contains("rms_turn_after_rad"));

  std::vector<double> theta;
  const Recording er = earth_rate_record(2, 1e-6, 200.0, 6, theta);
  ModelFileOptions eo = o;
  eo.accelerometer = "none";
  eo.gyroscope = "earth_rate";
  eo.gyro.estimate_g_sensitivity = false;
  const ModelFileFit ef = fit_model_file(er, eo);
  ASSERT_TRUE(ef.ok()) << ef.text;
  const estimation::FitResult eb = read_results(nlohmann::json::parse(ef.document.dump(2)));
  ASSERT_TRUE(eb.gyroscope && eb.gyroscope->ok());
  EXPECT_EQ(eb.gyroscope->theta[0], 0.0);  // bias_x held
  EXPECT_TRUE(eb.gyroscope->find("scale_x")->held);
  EXPECT_TRUE(std::any_of(eb.gyroscope->notes.begin(), eb.gyroscope->notes.end(), [](const std::string& n) {
    return n.find("gyro_bias_x") != std::string::npos && n.find("never within 45 deg") != std::string::npos;
  })) << eb.FullReport();
}

// -----------------------------------------------------------------------------------------------
// Real data: imucal's Ferraris session (six faces, then 360° turns about x, y, z).

namespace {

// The imported session with the turn truth its annotations imply: each `<axis>_rot` segment a turn
// of 360° about that axis, its sign from the data (imucal's own R_g has a negative diagonal: its
// turns ran the negative way), held over the segment.
Recording imucal_with_turns(const std::filesystem::path& csv) {
  Recording rec = io::import_imucal_session(csv);
  for (auto& row : rec.truth) row.insert(row.end(), 3, kNaN);
  rec.header.truth_columns = truth_column_names({kSpecificForceColumns, kRateColumns, kTurnColumns});
  for (const Segment& s : rec.segments) {
    if (s.kind != SegmentKind::kRotation) continue;
    const int axis = s.label[0] - 'x';
    double sum = 0.0;
    for (const ImuSample& smp : rec.samples)
      if (smp.t_s >= s.t_start_s && smp.t_s <= s.t_end_s) sum += smp.gyro_radps[axis];
    std::vector<double> row = {kNaN, kNaN, kNaN, kNaN, kNaN, kNaN, 0.0, 0.0, 0.0};  // f, w unknown
    row[static_cast<std::size_t>(6 + axis)] = sum > 0.0 ? 360.0 : -360.0;
    for (const double t : {s.t_start_s, 0.5 * (s.t_start_s + s.t_end_s), s.t_end_s}) {
      rec.truth_t.push_back(t);
      rec.truth.push_back(row);
    }
  }
  std::vector<std::size_t> order(rec.truth_t.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return rec.truth_t[a] < rec.truth_t[b]; });
  std::vector<double> t;
  std::vector<std::vector<double>> rows;
  for (std::size_t k : order)
    if (t.empty() || rec.truth_t[k] > t.back()) {
      t.push_back(rec.truth_t[k]);
      rows.push_back(rec.truth[k]);
    }
  rec.truth_t = t;
  rec.truth = rows;
  return rec;
}

Eigen::Matrix3d matrix(const nlohmann::json& j) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) m(i, k) = j[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)].get<double>();
  return m;
}

}  // namespace

TEST(CeresTurnsRealData, ImucalTurnsAgreeWithImucalsFerrarisCalibration) {
  const auto dir = stend::testing::shared_data("imucal");
  STEND_SKIP_IF_ABSENT(dir / "annotated_session.csv");
  STEND_SKIP_IF_ABSENT(dir / "example_cal.json");
  const Recording rec = imucal_with_turns(dir / "annotated_session.csv");
  const ModelFileOptions o = load_model_file(stend::testing::source_path("estimators/ceres_nonlinear/examples/ferraris.yaml").string());
  const ModelFileFit fit = fit_model_file(rec, o);
  std::cout << fit.text;
  ASSERT_TRUE(fit.gyro.ok()) << fit.gyro.report();
  const CalibrationResult& g = fit.gyro;
  ASSERT_EQ(g.turns.size(), 3u);
  ASSERT_EQ(g.intervals.size(), 6u);

  // imucal: raw = R_g·K_g·ω + b_g + K_ga·a (counts, ω in deg/s). The importer's SI reading is
  // counts / 16.4 [deg/s], so our A = I + diag(scale) + M = ±R_g·K_g / 16.4, the sign that of
  // imucal's expected angle against the data's (its R_g diagonal is negative).
  std::ifstream in(dir / "example_cal.json");
  const auto cal = nlohmann::json::parse(in);
  const double lsb_per_dps = io::ImucalOptions{}.gyro_lsb_per_dps;
  const Eigen::Matrix3d RK = matrix(cal["R_g"]) * matrix(cal["K_g"]);
  const Eigen::Matrix3d A_ref = (RK(0, 0) < 0.0 ? -1.0 : 1.0) * RK / lsb_per_dps;
  const Eigen::Matrix3d K_ga = matrix(cal["K_ga"]);  // counts per m/s^2
  const Eigen::Vector3d b_ref(cal["b_g"][0].get<double>(), cal["b_g"][1].get<double>(), cal["b_g"][2].get<double>());
  const char* axes = "xyz";
  for (int i = 0; i < 3; ++i) {
    const auto& s = g.parameter(std::string("scale_") + axes[i]);
    const double ref = A_ref(i, i) - 1.0;
    std::cout << "[imucal turns] scale_" << axes[i] << ": ours " << s.value << " ± " << s.std_error << ", imucal "
              << ref << " (K_g " << RK(i, i) << " counts per deg/s), difference " << s.value - ref << "\n";
    EXPECT_LT(std::abs(s.value - ref), 1e-3) << s.name;  // within a per mille …
    EXPECT_LT(std::abs(s.value - ref), s.std_error) << s.name;  // … and well within our uncertainty
    for (int k = 0; k < 3; ++k) {
      if (k != i) {
        const auto& c = g.parameter(std::string("cross_") + axes[i] + axes[k]);
        std::cout << "[imucal turns] cross_" << axes[i] << axes[k] << ": ours " << c.value << " ± " << c.std_error
                  << ", imucal " << A_ref(i, k) << "\n";
        EXPECT_LT(std::abs(c.value - A_ref(i, k)), 2e-3) << c.name;
      }
      const auto& gs = g.parameter(std::string("gsens_") + axes[i] + axes[k]);
      const double g_ref = K_ga(i, k) / lsb_per_dps * physics::kDegToRad;
      std::cout << "[imucal turns] gsens_" << axes[i] << axes[k] << ": ours " << gs.value << " ± " << gs.std_error
                << " rad/s/(m/s^2), imucal " << g_ref << "\n";
    }
    const auto& b = g.parameter(std::string("bias_") + axes[i]);
    std::cout << "[imucal turns] bias_" << axes[i] << ": ours " << b.value / physics::kDegPerSecond << " deg/s ± "
              << b.std_error / physics::kDegPerSecond << ", imucal " << b_ref[i] / lsb_per_dps << " deg/s\n";
    EXPECT_LT(std::abs(b.value / physics::kDegPerSecond - b_ref[i] / lsb_per_dps), 0.005) << b.name;
  }
  // The calibrated integrated turns come to the stated 360° better than the raw ones.
  for (const TurnCheck& t : g.turns) {
    std::cout << "[imucal turns] " << t.label << ": raw |v − θ| " << (t.before_rad - t.stated_rad).norm() * physics::kRadToDeg
              << " deg, calibrated " << (t.after_rad - t.stated_rad).norm() * physics::kRadToDeg << " deg\n";
    EXPECT_LT((t.after_rad - t.stated_rad).norm(), (t.before_rad - t.stated_rad).norm()) << t.label;
  }
  std::cout << "[imucal turns] " << g.uncertainty << "\n";
}
