// A fitted calibration read back from the estimators' results, applied to a held-out recording and
// validated: static |a| - g, integrated turns against their stated angle and uncertainty.
#include <stend/calibration/calibration.hpp>
#include <stend/calibration/validation.hpp>
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/estimators/builtin.hpp>

#include "synthetic_record.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <iostream>
#include <random>

namespace {

using namespace stend;
using namespace stend::calibration;
namespace synthetic = stend::ceres_nonlinear::synthetic;

// A results document read back through the built-in registry, as `stend apply` reads a file.
Calibration calibration_from_json(const nlohmann::json& doc, const std::string& source,
                                  const std::vector<Assumption>& assumed = {}) {
  return calibration_from(estimators::builtin().read(doc, source), source, assumed);
}

// A sensor turn about one of its axes by `deg` degrees.
struct Turn {
  int axis;
  double deg;
};

// A held-out recording of the sensor synthetic::Spec describes (same error parameters, another
// noise seed): `still_start_s` still with z up, then for each turn a smooth turn of `turn_s`
// (rate 2φ/T·sin²(πt/T)) and a pose of `pose_s`.
Recording held_out(const synthetic::Spec& spec, const std::vector<Turn>& turns, std::uint64_t seed,
                   double still_start_s = 20.0, double turn_s = 3.0, double pose_s = 8.0) {
  Recording rec;
  rec.header.gravity_mps2 = spec.gravity_mps2;
  rec.header.info.output_rate_hz = spec.rate_hz;
  rec.header.status = RunStatus::kComplete;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const model::ErrorModel ma = ceres_nonlinear::accelerometer_model();
  const model::ErrorModel mg = ceres_nonlinear::gyroscope_model(false);
  const Eigen::Vector3d up(0.0, 0.0, spec.gravity_mps2);
  const double dt = 1.0 / spec.rate_hz;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // R_sensor_from_local
  auto emit = [&](const Eigen::Matrix3d& Rs, const Eigen::Vector3d& w) {
    ImuSample s;
    s.t_s = static_cast<double>(rec.samples.size()) * dt;
    model::Stimulus<double> sa;
    sa.input = Rs * up;
    sa.specific_force = sa.input;
    model::Stimulus<double> sg;
    sg.input = w;
    sg.specific_force = sa.input;
    s.accel_mps2 = ma.measure<double>(spec.accel_theta.data(), sa) +
                   spec.accel_noise_mps2 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    s.gyro_radps = mg.measure<double>(spec.gyro_theta.data(), sg) +
                   spec.gyro_noise_radps * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    s.temperature_c = 25.0;
    rec.samples.push_back(s);
  };
  auto still = [&](double seconds) {
    for (int j = 0; j < static_cast<int>(seconds * spec.rate_hz); ++j) emit(R, Eigen::Vector3d::Zero());
  };
  still(still_start_s);
  const int n = static_cast<int>(turn_s * spec.rate_hz);
  for (const Turn& t : turns) {
    const Eigen::Vector3d axis = Eigen::Vector3d::Unit(t.axis);
    const double phi = t.deg * std::numbers::pi / 180.0;
    for (int j = 1; j <= n; ++j) {
      const double tt = j * dt, T = turn_s;
      const double ang = phi * (tt / T - std::sin(2.0 * std::numbers::pi * tt / T) / (2.0 * std::numbers::pi));
      const double rate = 2.0 * phi / T * std::pow(std::sin(std::numbers::pi * tt / T), 2);
      emit(Eigen::AngleAxisd(-ang, axis).toRotationMatrix() * R, axis * rate);
    }
    R = Eigen::AngleAxisd(-phi, axis).toRotationMatrix() * R;
    still(pose_s);
  }
  return rec;
}

// The ceres_nonlinear results document of a 38-position training record of the same sensor:
// accelerometer from |g|, gyroscope by integration (or none).
nlohmann::json trained(const synthetic::Spec& spec, const std::string& gyroscope) {
  const synthetic::Record rec = synthetic::make(spec);
  ceres_nonlinear::ModelFileOptions o;
  o.gyroscope = gyroscope;
  o.accel.estimate_gyro_bias = false;  // as the model file sets it unless gyroscope: bias_only
  o.accel.processing.detector.trim_s = 0.5;
  o.accel.processing.detector.max_gyro_radps = 0.05;
  const auto fit = ceres_nonlinear::fit_model_file(rec.recording, o);
  EXPECT_TRUE(fit.ok()) << fit.message;
  return fit.document;
}

// From z up: gravity to +y, +x, +z, +y, +z — every turn moves gravity, so every pose is detected
// apart from its neighbours.
const std::vector<Turn> kTurns = {{0, 90}, {2, 90}, {1, 90}, {0, 90}, {0, -90}};

class HeldOut : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    spec_ = new synthetic::Spec;
    spec_->seed = 21;
    doc_ = new nlohmann::json(trained(*spec_, "integration"));
  }
  static void TearDownTestSuite() {
    delete spec_;
    delete doc_;
  }
  static synthetic::Spec* spec_;
  static nlohmann::json* doc_;
};
synthetic::Spec* HeldOut::spec_ = nullptr;
nlohmann::json* HeldOut::doc_ = nullptr;

TEST_F(HeldOut, StaticNormAfterApplyingIsWithinTheNoiseFloor) {
  const Calibration cal = calibration_from_json(*doc_, "ceres.json");
  ASSERT_TRUE(cal.accel.present());
  ASSERT_TRUE(cal.gyro.present());
  const Recording raw = held_out(*spec_, kTurns, 77);
  const Recording calibrated = apply_calibration(raw, cal);
  const ValidationReport r = validate(raw, calibrated, cal, {});
  std::ostringstream text;
  r.print(text);
  ASSERT_TRUE(r.ok) << text.str();
  std::cout << text.str();
  EXPECT_EQ(r.verdict(), CheckVerdict::kPass);
  EXPECT_EQ(r.statics.verdict, CheckVerdict::kPass);
  EXPECT_EQ(r.statics.limit_mps2, kStaticLimitNoiseFloors * r.statics.noise_floor);
  EXPECT_NE(text.str().find("PASS         static |a| - g: calibrated RMS"), std::string::npos) << text.str();
  EXPECT_EQ(r.statics.intervals, 6) << text.str();  // the still start and five poses
  // Calibrated: within the noise of the interval means (the fit's own uncertainty is smaller).
  EXPECT_LT(r.statics.rms_after, 3.0 * r.statics.noise_floor) << text.str();
  // Raw: the biases and scale errors (0.1-0.2 m/s^2, 1 %) are far above it.
  EXPECT_GT(r.statics.rms_before, 50.0 * r.statics.rms_after) << text.str();
  EXPECT_LT(r.statics.direction_max_deg, 0.05) << text.str();
}

TEST_F(HeldOut, PlantedTurnsIntegrateToTheirAngleWithinTheStatedUncertainty) {
  const Calibration cal = calibration_from_json(*doc_, "ceres.json");
  const Recording raw = held_out(*spec_, kTurns, 78);
  const Recording calibrated = apply_calibration(raw, cal);
  ValidationOptions o;
  o.rotations = {parse_expected_rotation("x:90")};
  const ValidationReport r = validate(raw, calibrated, cal, o);
  std::ostringstream text;
  r.print(text);
  ASSERT_TRUE(r.ok) << text.str();
  std::cout << text.str();
  ASSERT_EQ(r.turns.size(), 3u) << text.str();  // the three turns about x, not those about y and z
  for (const auto& t : r.turns) {
    EXPECT_EQ(t.verdict, CheckVerdict::kPass) << text.str();
    EXPECT_NEAR(std::abs(t.measured_deg), 90.0, t.bound_deg) << text.str();
    EXPECT_GT(t.sigma_noise_deg, 0.0);
    EXPECT_GT(t.sigma_scale_deg, 0.0);
    EXPECT_LT(t.bound_deg, 0.5) << text.str();  // a stated uncertainty, not a blanket one
  }
  // The raw rates miss by the scale error (1 % of 90°) and the bias × the turn's duration.
  const ValidationReport before = validate(raw, raw, cal, o);
  for (const auto& t : before.turns) EXPECT_EQ(t.verdict, CheckVerdict::kFail);
  EXPECT_EQ(before.verdict(), CheckVerdict::kFail);
  // Re-biasing from the still start: the bias left is below its noise, and the turns still hold.
  o.rebias_from_start_s = 15.0;
  const ValidationReport rb = validate(raw, calibrated, cal, o);
  ASSERT_TRUE(rb.ok) << rb.message;
  ASSERT_TRUE(rb.rebiased);
  for (int i = 0; i < 3; ++i) EXPECT_LT(std::abs(rb.rebias_radps[i]), 5.0 * rb.rebias_se_radps[i] + 2e-4);
}

// The same report whether the raw samples are in memory or behind a store's SampleSource.
TEST_F(HeldOut, SameReportFromSamplesInMemoryOrStreamed) {
  const Calibration cal = calibration_from_json(*doc_, "ceres.json");
  const Recording raw = held_out(*spec_, kTurns, 78);
  Recording streamed = raw;
  streamed.source = std::make_shared<MemorySamples>(std::vector<ImuSample>(raw.samples));
  streamed.samples.clear();
  ValidationOptions o;
  o.rotations = {parse_expected_rotation("x:90")};
  o.rebias_from_start_s = 15.0;
  const ValidationReport a = validate(raw, apply_calibration(raw, cal), cal, o);
  const ValidationReport b = validate(streamed, apply_calibration(streamed, cal), cal, o);
  ASSERT_TRUE(a.ok) << a.message;
  EXPECT_EQ(a.turns.size(), 3u);
  EXPECT_EQ(a.to_json(), b.to_json());  // every number to the last digit
}

TEST(Calibration, AccelerometerOnlyCalibrationRefusesARotationCheck) {
  synthetic::Spec spec;
  spec.seed = 22;
  spec.samples = 20000;
  spec.positions = 20;
  const Calibration cal = calibration_from_json(trained(spec, "none"), "accel_only.json");
  ASSERT_TRUE(cal.accel.present());
  EXPECT_FALSE(cal.gyro.present());
  const Recording raw = held_out(spec, kTurns, 79);
  const Recording calibrated = apply_calibration(raw, cal);
  ValidationOptions o;
  o.rotations = {parse_expected_rotation("x:90")};
  try {
    validate(raw, calibrated, cal, o);
    FAIL() << "a rotation check without a gyroscope calibration must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no gyroscope calibration (accelerometer only)"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("accel_only.json"), std::string::npos) << e.what();
  }
  // The static check alone is fine.
  const ValidationReport r = validate(raw, calibrated, cal, {});
  std::ostringstream text;
  r.print(text);
  EXPECT_TRUE(r.ok) << text.str();
}

// The fit with unknown orientations holds cross_xy, cross_xz, cross_yz at 0 as its frame
// convention: 0 is exact there, so the calibration applies without an assumption.
TEST_F(HeldOut, FrameConventionHeldTermsApplyWithoutAnAssumption) {
  const Calibration cal = calibration_from_json(*doc_, "ceres.json");
  int held = 0;
  for (const auto& p : cal.accel.parameters) {
    if (!p.held) continue;
    ++held;
    EXPECT_TRUE(p.zero_is_exact) << p.name << ": " << p.reason;
  }
  EXPECT_EQ(held, 3);
  EXPECT_TRUE(cal.assumed.empty());
}

// A wrong calibration (another sensor's: other biases and scale factors) FAILs the static check
// and the turns; the same sensor's PASSes them.
TEST_F(HeldOut, AnotherSensorsCalibrationFails) {
  const Calibration cal = calibration_from_json(*doc_, "ceres.json");
  synthetic::Spec other = *spec_;
  other.accel_theta[0] += 0.05;  // 5 mg more bias on x [m/s^2]
  other.accel_theta[4] -= 0.004;  // scale_y
  other.gyro_theta[3] += 0.01;    // gyro scale_x: 0.9 deg in 90
  const Recording raw = held_out(other, kTurns, 80);
  const Recording calibrated = apply_calibration(raw, cal);
  ValidationOptions o;
  o.rotations = {parse_expected_rotation("x:90")};
  const ValidationReport r = validate(raw, calibrated, cal, o);
  std::ostringstream text;
  r.print(text);
  EXPECT_FALSE(r.ok) << text.str();
  EXPECT_EQ(r.verdict(), CheckVerdict::kFail) << text.str();
  EXPECT_EQ(r.statics.verdict, CheckVerdict::kFail) << text.str();
  EXPECT_GT(r.statics.rms_after, r.statics.limit_mps2);
  for (const auto& t : r.turns) EXPECT_EQ(t.verdict, CheckVerdict::kFail) << text.str();
  EXPECT_NE(text.str().find("validation of ceres.json: FAIL — outside the limit: static |a| - g; turn x:90"),
            std::string::npos)
      << text.str();
  EXPECT_NE(nlohmann::json::parse(r.to_json())["static"]["verdict"], "PASS");
}

// The turn's window is the detected turn and a second of still on each side, not the long stills
// around it: its bias share of the bound stays small, and re-biasing from a long still start passes.
TEST_F(HeldOut, TurnWindowIsTheDetectedTurn) {
  const Calibration cal = calibration_from_json(*doc_, "ceres.json");
  const double still_s = 40.0, turn_s = 3.0, pose_s = 30.0;
  const Recording raw = held_out(*spec_, kTurns, 81, still_s, turn_s, pose_s);
  const Recording calibrated = apply_calibration(raw, cal);
  ValidationOptions o;
  o.rotations = {parse_expected_rotation("x:90")};
  o.rebias_from_start_s = 30.0;
  const ValidationReport r = validate(raw, calibrated, cal, o);
  std::ostringstream text;
  r.print(text);
  ASSERT_TRUE(r.ok) << text.str();
  ASSERT_EQ(r.turns.size(), 3u) << text.str();
  // The first turn runs from 40 to 43 s: its window holds it, with at most the margin and the
  // detector's trim beyond.
  EXPECT_LE(r.turns[0].t_start_s, still_s) << text.str();
  EXPECT_GE(r.turns[0].t_start_s, still_s - kTurnMarginS - 1.0) << text.str();
  EXPECT_GE(r.turns[0].t_end_s, still_s + turn_s) << text.str();
  EXPECT_LE(r.turns[0].t_end_s, still_s + turn_s + kTurnMarginS + 1.0) << text.str();
  for (const auto& t : r.turns) {
    EXPECT_EQ(t.verdict, CheckVerdict::kPass) << text.str();
    EXPECT_LT(t.t_end_s - t.t_start_s, turn_s + 2 * kTurnMarginS + 2.0) << text.str();
    EXPECT_LT(t.sigma_bias_deg, t.sigma_noise_deg + t.sigma_scale_deg) << text.str();
  }
}

// A stated turn that no motion makes is NOT CHECKED, and the validation does not pass.
TEST_F(HeldOut, AStatedTurnNotFoundIsNotChecked) {
  const Calibration cal = calibration_from_json(*doc_, "ceres.json");
  const Recording raw = held_out(*spec_, kTurns, 82);
  ValidationOptions o;
  o.rotations = {parse_expected_rotation("z:360")};  // the record turns about z by 90 only
  const ValidationReport r = validate(raw, apply_calibration(raw, cal), cal, o);
  std::ostringstream text;
  r.print(text);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.verdict(), CheckVerdict::kNotChecked) << text.str();
  ASSERT_EQ(r.turns.size(), 1u);
  EXPECT_EQ(r.turns[0].verdict, CheckVerdict::kNotChecked);
  EXPECT_NE(text.str().find("NOT CHECKED  turn z:360 deg: no motion"), std::string::npos) << text.str();
}

// A result whose parameters the fit did not determine (aliased, not identifiable, held where 0 is a
// guess) is refused, each named with why; stated values apply and are recorded.
TEST(Calibration, RefusesUndeterminedParametersUnlessAssumed) {
  using nlohmann::json;
  auto prm = [](const std::string& name, const std::string& unit, double v) {
    return json{{"name", name}, {"unit", unit}, {"identifiable", true}, {"value", v}, {"std_error", 1e-5},
                {"interval", {v - 2e-5, v + 2e-5}}};
  };
  auto aliased = [](const std::string& name, const std::string& unit) {
    return json{{"name", name}, {"unit", unit}, {"identifiable", false}, {"reason", "aliased with bias_tc1_z"}};
  };
  // One temperature: bias_z and bias_tc1_z alias.
  const json doc = {{"schema", "stend.fit/1"},
                    {"estimator", {{"name", "batch_lsq"}}},
                    {"status", "ok"},
                    {"model",
                     {{"instrument", "accelerometer"},
                      {"axes", json::array({"z"})},
                      {"terms", json::array({{{"kind", "bias"}}, {{"kind", "scale"}},
                                             {{"kind", "bias_temperature"}, {"order", 1}, {"reference_c", 25.0}}})}}},
                    {"parameters", {aliased("bias_z", "m/s^2"), prm("scale_z", "1", 0.002),
                                    aliased("bias_tc1_z", "m/s^2/degC")}}};
  try {
    calibration_from_json(doc, "fit.json");
    FAIL() << "an aliased bias must not be applied as 0";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("fit.json: cannot apply"), std::string::npos) << m;
    EXPECT_NE(m.find("accelerometer bias_z [m/s^2]: aliased with bias_tc1_z"), std::string::npos) << m;
    EXPECT_NE(m.find("--assume bias_z=0,bias_tc1_z=0"), std::string::npos) << m;
    EXPECT_EQ(m.find("scale_z"), std::string::npos) << m;  // determined: not named
    // x and y are outside this fit (not in the document): left uncalibrated, not refused.
    EXPECT_EQ(m.find("bias_x"), std::string::npos) << m;
  }
  // One value stated, one missing: still refused, naming the missing one only.
  try {
    calibration_from_json(doc, "fit.json", {{"bias_z", 0.027}});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("bias_z [m/s^2]"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bias_tc1_z [m/s^2/degC]"), std::string::npos) << e.what();
  }
  // A name the fit determined, or no such parameter: refused, naming it.
  EXPECT_THROW(calibration_from_json(doc, "fit.json", {{"scale_z", 0.0}, {"bias_z", 0}, {"bias_tc1_z", 0}}), InputError);
  const Calibration cal = calibration_from_json(doc, "fit.json", parse_assumptions("bias_z=0.027,accel_bias_tc1_z=0"));
  ASSERT_EQ(cal.assumed.size(), 2u);
  EXPECT_EQ(cal.assumed[0], "accelerometer bias_z = 0.027 m/s^2 (aliased with bias_tc1_z)");
  const auto info = cal.accel.model.params();
  for (std::size_t i = 0; i < info.size(); ++i) {
    if (info[i].name == "bias_z") {
      EXPECT_EQ(cal.accel.theta[i], 0.027);
    }
  }
  std::ostringstream text;
  cal.print(text);
  EXPECT_NE(text.str().find("assumed: accelerometer bias_z = 0.027 m/s^2"), std::string::npos) << text.str();
}

// A held parameter whose 0 is a guess (earth_rate's cross-axis terms) is refused like an aliased one.
TEST(Calibration, HeldWhereZeroIsAGuessIsRefused) {
  using nlohmann::json;
  json gyro_params = json::array();
  for (const char* n : {"bias_x", "bias_y", "bias_z"})
    gyro_params.push_back({{"name", n}, {"unit", "rad/s"}, {"identifiable", true}, {"value", 0.01}, {"std_error", 1e-5}});
  for (const char* n : {"scale_x", "scale_y", "scale_z"})
    gyro_params.push_back({{"name", n}, {"unit", "1"}, {"identifiable", true}, {"value", 0.001}, {"std_error", 1e-5}});
  for (const char* n : {"cross_xy", "cross_xz", "cross_yx", "cross_yz", "cross_zx", "cross_zy"})
    gyro_params.push_back({{"name", n}, {"unit", "1"}, {"identifiable", false}, {"fixed", true}, {"zero_is_exact", false},
                           {"reason", "held at 0: not estimated by earth_rate"}});
  const json doc = {{"estimator", {{"name", "ceres_nonlinear"}, {"version", "1"}}},
                    {"status", "ok"},
                    {"gyroscope", {{"status", "ok"}, {"method", "earth_rate"}, {"parameters", gyro_params}}}};
  try {
    calibration_from_json(doc, "ceres.json");
    FAIL() << "earth_rate's held cross-axis terms are not a convention";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("gyroscope cross_xy [1]: held at 0: not estimated by earth_rate"),
              std::string::npos)
        << e.what();
  }
  const Calibration cal = calibration_from_json(
      doc, "ceres.json", parse_assumptions("cross_xy=0,cross_xz=0,cross_yx=0,cross_yz=0,cross_zx=0,cross_zy=0"));
  EXPECT_EQ(cal.assumed.size(), 6u);
}

TEST(Calibration, AssumptionText) {
  const auto a = parse_assumptions("bias_x=0,gyro_bias_z=-1.5e-3");
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[1].name, "gyro_bias_z");
  EXPECT_EQ(a[1].value, -1.5e-3);
  for (const char* bad : {"bias_x", "=1", "bias_x=", "bias_x=abc", "bias_x=1,", "bias_x=nan", "bias_x=1mg"})
    EXPECT_THROW(parse_assumptions(bad), std::invalid_argument) << bad;
}

TEST(Calibration, ExpectedRotationText) {
  const auto e = parse_expected_rotation("z:-180");
  EXPECT_EQ(e.axis, 2);
  EXPECT_EQ(e.angle_deg, -180.0);
  for (const char* bad : {"x", "w:90", "x:", "x:abc", "x:90deg", "x:0"})
    EXPECT_THROW(parse_expected_rotation(bad), std::invalid_argument) << bad;
}

// A temp_poly document (one stend.fit/1 per axis, orders chosen per axis): the model is built from
// the parameter names, and applying it inverts measure at each sample's temperature.
TEST(Calibration, TemperatureModelFromATempPolyDocumentInvertsTheForwardModel) {
  using nlohmann::json;
  auto prm = [](const std::string& name, const std::string& unit, double v) {
    return json{{"name", name}, {"unit", unit}, {"identifiable", true}, {"value", v}, {"std_error", 1e-5},
                {"interval", {v - 2e-5, v + 2e-5}}};
  };
  auto axis_fit = [&](char ax, int order, double b, double s, std::vector<double> tc) {
    json params = {prm(std::string("bias_") + ax, "m/s^2", b), prm(std::string("scale_") + ax, "1", s)};
    for (int k = 1; k <= order; ++k)
      params.push_back(prm("bias_tc" + std::to_string(k) + "_" + ax, "m/s^2/degC^" + std::to_string(k),
                           tc[static_cast<std::size_t>(k - 1)]));
    return json{{"axis", std::string(1, ax)},
                {"ok", true},
                {"fit",
                 {{"schema", "stend.fit/1"},
                  {"status", "ok"},
                  {"model",
                   {{"instrument", "accelerometer"},
                    {"terms", json::array({{{"kind", "bias"}}, {{"kind", "scale"}},
                                           {{"kind", "bias_temperature"}, {"order", order}, {"reference_c", 30.0}}})}}},
                  {"parameters", params}}}};
  };
  const json doc = {{"estimator", {{"name", "temp_poly"}}},
                    {"status", "ok"},
                    {"reference_c", 30.0},
                    {"valid_range_c", {-10.0, 70.0}},
                    {"axes", json::array({axis_fit('x', 1, 0.1, 0.01, {0.002}), axis_fit('y', 2, -0.05, -0.004, {0.001, 3e-5}),
                                          axis_fit('z', 1, 0.2, 0.002, {-0.003})})}};
  const Calibration cal = calibration_from_json(doc, "temp_poly.json");
  ASSERT_TRUE(cal.accel.present());
  EXPECT_TRUE(cal.needs_temperature());
  const model::ErrorModel& m = cal.accel.model;
  ASSERT_EQ(m.terms.size(), 3u);
  EXPECT_EQ(m.terms[2].kind, model::TermKind::kBiasTemperature);
  EXPECT_EQ(m.terms[2].order, 2);  // the highest order any axis chose
  EXPECT_EQ(m.terms[2].reference_c, 30.0);
  EXPECT_EQ(cal.valid_max_c, 70.0);
  // bias_tc2_x and bias_tc2_z are not in the document (those axes chose order 1): 0, as fitted.
  const auto info = m.params();
  auto theta_of = [&](const std::string& name) {
    for (std::size_t i = 0; i < info.size(); ++i)
      if (info[i].name == name) return cal.accel.theta[i];
    return std::nan("");
  };
  EXPECT_EQ(theta_of("bias_tc2_x"), 0.0);
  EXPECT_EQ(theta_of("bias_tc2_y"), 3e-5);
  EXPECT_TRUE(cal.notes.empty());

  Recording raw;
  const Eigen::Vector3d u(1.0, -2.0, 9.7);
  for (double T : {-5.0, 25.0, 60.0}) {
    model::Stimulus<double> st;
    st.input = st.specific_force = u;
    st.temperature_c = T;
    ImuSample s;
    s.t_s = static_cast<double>(raw.samples.size());
    s.temperature_c = T;
    s.accel_mps2 = m.measure<double>(cal.accel.theta.data(), st);
    raw.samples.push_back(s);
  }
  const Recording out = apply_calibration(raw, cal);
  ASSERT_EQ(out.sample_count(), raw.samples.size());
  for_each_chunk(out.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t) {
    for (std::size_t k = 0; k < n; ++k) EXPECT_LT((c[k].accel_mps2 - u).norm(), 1e-9) << c[k].temperature_c;
  });
  raw.samples[1].temperature_c = NAN;
  EXPECT_THROW(apply_calibration(raw, cal), std::runtime_error);
}

TEST(Calibration, RefusesAFailedFitAndAForeignDocument) {
  using nlohmann::json;
  const json failed = {{"status", "failed"}, {"message", "too few"}, {"model", json::object()}, {"parameters", json::array()}};
  EXPECT_THROW(calibration_from_json(failed, "fit.json"), std::runtime_error);
  EXPECT_THROW(calibration_from_json(json{{"hello", 1}}, "x.json"), std::runtime_error);
}

}  // namespace
