// The procedure player and the twin's logs: what a person does is played where the procedure says
// (faces held within the placement of the stated up, hand turns by their angle about their axis,
// rate legs at their rate, stills at distinct unstated orientations), the sensor reads the planted
// errors through the vocabulary, the planted truth re-expressed in a fit's frame convention is the
// same sensor, and each quirk of the written log is what it says and reads back through the csv
// importer with the keys it names.
#include <stend/sim/procedure_player.hpp>
#include <stend/sim/twin_check.hpp>
#include <stend/sim/twin_log.hpp>

#include <stend/core/procedure_geometry.hpp>
#include <stend/io/formats.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

namespace stend::sim {
namespace {

using stend::testing::source_path;

Experiment procedure(const std::string& name) {
  return load_observed_procedure(source_path("configs/procedures/" + name + ".yaml").string());
}

// A sensor without errors or noise (its output stage only), to see the motion itself.
SimImuConfig ideal_sensor() {
  SimImuConfig c;
  c.accel_noise_density = c.gyro_noise_density = 0.0;
  c.accel_bias_instability_mps2 = c.accel_random_walk = 0.0;
  c.gyro_bias_instability_radps = c.gyro_random_walk = 0.0;
  c.gyro_range_dps = 500.0;
  return c;
}

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / physics::kDegToRad;
}

// Mean of the samples in [t0, t1].
struct Mean {
  Eigen::Vector3d accel = Eigen::Vector3d::Zero(), gyro = Eigen::Vector3d::Zero();
  int n = 0;
};
Mean mean_between(const Played& p, double t0, double t1) {
  Mean m;
  for (const auto& s : p.samples)
    if (s.t_s >= t0 && s.t_s <= t1) {
      m.accel += s.accel_mps2;
      m.gyro += s.gyro_radps;
      ++m.n;
    }
  if (m.n > 0) {
    m.accel /= m.n;
    m.gyro /= m.n;
  }
  return m;
}

// The triad's planted reading of input u: b + (I + diag(s) + M)·u.
Eigen::Vector3d planted_reading(const TriadErrors& e, const Eigen::Vector3d& u) {
  return e.bias + u + e.scale.cwiseProduct(u) + e.cross_axis * u;
}

TEST(ProcedurePlayer, FacesAreHeldWhereStatedWithinThePlacement) {
  const Experiment exp = procedure("six_faces");
  const SimImuConfig sensor = twin_sensor(7);
  PlayerOptions o;
  o.seed = 7;
  const Played p = play_procedure(exp, sensor, o);
  ASSERT_EQ(p.steps.size(), 6u);
  const double white = sensor.accel_noise_density * std::sqrt(0.5 * o.rate_hz);  // per sample
  for (std::size_t k = 0; k < 6; ++k) {
    const PlayedStep& s = p.steps[k];
    EXPECT_LT(angle_deg(s.up, exp.procedure[0].faces_up[k]), 3.0) << s.label;  // 0.5 deg per component
    EXPECT_GT(angle_deg(s.up, exp.procedure[0].faces_up[k]), 1e-3) << s.label;  // placed by hand, never exactly
    EXPECT_GE(s.t_end_s - s.t_start_s, 0.9 * 1.2 * 4.0) << s.label;            // record_s 4, held a bit longer
    // The reading over the hold is the planted accelerometer's at g·up, to the noise of the mean.
    const Mean m = mean_between(p, s.t_start_s + 0.2, s.t_end_s - 0.2);
    const Eigen::Vector3d expect = planted_reading(sensor.accel, p.gravity_mps2 * s.up);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(m.accel[i], expect[i], 5.0 * white / std::sqrt(m.n)) << s.label << " axis " << i;
  }
  EXPECT_NEAR(p.gravity_mps2, exp.gravity.resolved_mps2, 1e-12);
  EXPECT_NEAR(p.samples.back().t_s, static_cast<double>(p.samples.size()) / o.rate_hz, 1e-9);
}

TEST(ProcedurePlayer, AHandTurnTurnsByItsAngleAboutItsAxis) {
  const Experiment exp = procedure("ferraris");
  PlayerOptions o;
  o.seed = 3;
  const Played p = play_procedure(exp, ideal_sensor(), o);
  std::vector<const PlayedStep*> turns;
  for (const auto& s : p.steps)
    if (s.rotation_deg.norm() > 0.0) turns.push_back(&s);
  ASSERT_EQ(turns.size(), 3u);
  const double earth = physics::kEarthRateRadps / physics::kDegToRad;  // at most, deg/s
  for (std::size_t k = 0; k < 3; ++k) {
    const PlayedStep& t = *turns[k];
    const Eigen::Vector3d axis = Eigen::Vector3d::Unit(static_cast<Eigen::Index>(k));
    EXPECT_NEAR(t.rotation_deg.norm(), 360.0, 2.5) << t.label;                          // 0.5 deg (1 sigma) off
    EXPECT_LT(angle_deg(t.rotation_deg.cwiseAbs(), axis), 2.5) << t.label;              // about its axis, either way
    // The gyro integrated over the turn: along the turned axis the angle turned; across it what the
    // wobble tilts the axis by while the sensor turns (a 1-degree wobble: about 0.85·360°·1° in
    // rad ≈ 5.3°, as a hand's turn does — the ferraris model's turn_angle_sigma_deg covers |θ|·1°).
    Eigen::Vector3d integral = Eigen::Vector3d::Zero();
    for (std::size_t i = 1; i < p.samples.size(); ++i)
      if (p.samples[i].t_s > t.t_start_s && p.samples[i].t_s <= t.t_end_s)
        integral += p.samples[i].gyro_radps * (p.samples[i].t_s - p.samples[i - 1].t_s);
    const double duration = t.t_end_s - t.t_start_s;
    const Eigen::Vector3d turned = integral / physics::kDegToRad, about = t.rotation_deg.normalized();
    EXPECT_NEAR(turned.dot(about), t.rotation_deg.norm(), 0.2 + earth * duration) << t.label;
    const double across = (turned - turned.dot(about) * about).norm();
    EXPECT_GT(across, 1.0) << t.label;  // the wobble is there
    EXPECT_LT(across, 0.85 * 360.0 * o.hand.wobble_deg * physics::kDegToRad + 0.2) << t.label;
    // Still before and after: the player holds between turns.
    EXPECT_LT(mean_between(p, t.t_start_s - 1.0, t.t_start_s - 0.2).gyro.norm(), 1e-3) << t.label;
  }
}

TEST(ProcedurePlayer, RateLegsHoldTheirRateAboutTheAxisUp) {
  const Experiment exp = procedure("rate_legs");
  PlayerOptions o;
  o.seed = 5;
  const Played p = play_procedure(exp, ideal_sensor(), o);
  ASSERT_EQ(p.steps.size(), 6u);
  const double omega_v = physics::kEarthRateRadps * std::sin(exp.gravity.latitude_deg * physics::kDegToRad);
  for (std::size_t k = 0; k < 6; ++k) {
    const PlayedStep& s = p.steps[k];
    const Step& step = exp.procedure[k / 2];
    const double ramp = std::max(0.5, 25.0 / o.hand.table_accel_dps2);
    const Mean m = mean_between(p, s.t_start_s + ramp + 0.2, s.t_end_s - ramp - 0.2);
    const double rate = s.rate_dps * physics::kDegToRad;
    // About the stated axis: the rate (the mount off by 0.5 deg per component: cos ≈ 1) and the
    // vertical Earth rate; across it the mount's tilt times the rate.
    EXPECT_NEAR(m.gyro.dot(step.sensor_axis), rate + omega_v, 1e-3 * std::abs(rate)) << s.label;
    EXPECT_LT((m.gyro - m.gyro.dot(step.sensor_axis) * step.sensor_axis).norm(), std::abs(rate) * 3.0 * physics::kDegToRad)
        << s.label;
    EXPECT_NEAR(m.accel.dot(step.sensor_axis), p.gravity_mps2, 0.01) << s.label;  // the axis up
  }
}

TEST(ProcedurePlayer, StillsAtUnstatedOrientationsAreManyAndDistinct) {
  const Experiment exp = procedure("unknown_orientations");
  PlayerOptions o;
  o.seed = 11;
  const Played p = play_procedure(exp, ideal_sensor(), o);
  ASSERT_EQ(p.steps.size(), 1u + static_cast<std::size_t>(o.hand.stills_for_all));
  EXPECT_GE(p.steps[0].t_end_s - p.steps[0].t_start_s, 0.9 * 1.2 * 20.0);  // the initial still's record_s 20
  for (std::size_t k = 1; k < p.steps.size(); ++k) EXPECT_GT(angle_deg(p.steps[k].up, p.steps[k - 1].up), 20.0) << k;
}

TEST(ProcedurePlayer, SamplesCarryTheSensorsCountsAndLsb) {
  const Played p = play_procedure(procedure("six_faces"), twin_sensor(2), PlayerOptions{});
  ASSERT_GT(p.info.accel_lsb_mps2, 0.0);
  EXPECT_NEAR(physics::kStandardGravity / p.info.accel_lsb_mps2, 16384.0, 1e-6);  // ±2 g, 16 bits
  EXPECT_NEAR(physics::kDegPerSecond / p.info.gyro_lsb_radps, 65.536, 1e-9);       // ±500 deg/s
  for (std::size_t i = 0; i < p.samples.size(); i += 97)
    for (int a = 0; a < 3; ++a) {
      EXPECT_DOUBLE_EQ(p.samples[i].accel_mps2[a], p.samples[i].accel_counts[a] * p.info.accel_lsb_mps2);
      EXPECT_DOUBLE_EQ(p.samples[i].gyro_radps[a], p.samples[i].gyro_counts[a] * p.info.gyro_lsb_radps);
    }
}

TEST(ProcedurePlayer, StepsItCannotPlayAreRefused) {
  Experiment exp = procedure("rate_legs");
  exp.procedure[0].up = Eigen::Vector3d::UnitX();  // the axis is +z: a vertical table cannot hold x up
  EXPECT_THROW(play_procedure(exp, ideal_sensor(), PlayerOptions{}), InputError);
  exp = procedure("six_faces");
  exp.procedure[0].kind = Step::Kind::kOrientations;  // a table step not turned into faces
  EXPECT_THROW(play_procedure(exp, ideal_sensor(), PlayerOptions{}), InputError);
  PlayerOptions bad;
  bad.rate_hz = 0.0;
  EXPECT_THROW(play_procedure(procedure("six_faces"), ideal_sensor(), bad), std::exception);
}

TEST(PlantedTruth, InTheAccelerometersFrameConventionItIsTheSameSensor) {
  const SimImuConfig c = twin_sensor(4);
  const PlantedTruth t = planted_truth(c);
  ASSERT_EQ(t.parameters.size(), 12u + 21u);
  EXPECT_DOUBLE_EQ(t.parameters.at("accel_cross_yz"), c.accel.cross_axis(1, 2));
  EXPECT_DOUBLE_EQ(t.parameters.at("gyro_gsens_zx"), c.gyro.g_sensitivity(2, 0));
  const PlantedTruth u = t.in_accel_frame_convention();
  for (const char* held : {"accel_cross_xy", "accel_cross_xz", "accel_cross_yz"}) EXPECT_NEAR(u.parameters.at(held), 0.0, 1e-15);
  const auto matrix = [](const PlantedTruth& p, const std::string& triad) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
    const char* ax = "xyz";
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        a(i, j) += p.parameters.at(triad + (i == j ? std::string("scale_") + ax[i] : std::string("cross_") + ax[i] + ax[j]));
    return a;
  };
  // A = L·R with R a rotation: the accelerometer reads |u| alike in both frames, and the gyro
  // reads the same rate expressed in the rotated frame the same.
  const Eigen::Matrix3d R = matrix(u, "accel_").inverse() * matrix(t, "accel_");
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  const Eigen::Vector3d w(0.3, -0.2, 0.9);
  EXPECT_LT((matrix(u, "gyro_") * (R * w) - matrix(t, "gyro_") * w).norm(), 1e-12);
}

// The twin's log of a short procedure read back through the csv importer with the keys it names.
Recording read_back(const std::filesystem::path& file, const ImportKeys& keys) {
  io::ImportOptions o;
  for (const auto& [key, value] : keys) o.set(key, value);
  return io::open_dataset({file}, "csv", o);
}

TEST(TwinLog, EachQuirkIsWrittenAsSaidAndReadsBack) {
  const stend::testing::TempDir dir("twin_log");
  const Played p = play_procedure(procedure("six_faces"), twin_sensor(1), PlayerOptions{});
  const auto file = dir.path() / "log.csv";

  CsvQuirks plain;
  Recording r = read_back(file, write_twin_csv(file, p, plain));
  ASSERT_EQ(r.samples.size(), p.samples.size());
  for (std::size_t i = 0; i < p.samples.size(); i += 101) {
    EXPECT_NEAR(r.samples[i].t_s, p.samples[i].t_s, 1e-6) << i;
    EXPECT_LT((r.samples[i].accel_mps2 - p.samples[i].accel_mps2).norm(), 1e-7) << i;
    EXPECT_LT((r.samples[i].gyro_radps - p.samples[i].gyro_radps).norm(), 1e-8) << i;  // 9 significant digits
  }

  CsvQuirks counts_no_time;
  counts_no_time.counts = counts_no_time.no_time = true;
  const ImportKeys keys = write_twin_csv(file, p, counts_no_time);
  EXPECT_EQ(import_flags(keys).find("--time"), std::string::npos);
  EXPECT_NE(import_flags(keys).find("--rate-hz 100"), std::string::npos) << import_flags(keys);
  EXPECT_NE(import_flags(keys).find("--accel-lsb 1/16384g"), std::string::npos) << import_flags(keys);
  EXPECT_NE(import_flags(keys).find("--gyro-lsb 1/65.536deg/s"), std::string::npos) << import_flags(keys);
  EXPECT_EQ(stend::testing::read_text(file).substr(0, 3), "ax,");
  r = read_back(file, keys);
  ASSERT_EQ(r.samples.size(), p.samples.size());
  for (std::size_t i = 0; i < p.samples.size(); i += 101) {
    EXPECT_NEAR(r.samples[i].t_s, static_cast<double>(i) / 100.0, 1e-9) << i;
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(r.samples[i].accel_counts[a], p.samples[i].accel_counts[a]) << i;
      EXPECT_NEAR(r.samples[i].gyro_radps[a], p.samples[i].gyro_radps[a], 1e-12) << i;
    }
  }

  CsvQuirks bursty;
  bursty.bursty = true;
  write_twin_csv(file, p, bursty);
  std::vector<double> logged;
  const std::string text = stend::testing::read_text(file);
  for (std::size_t at = text.find('\n') + 1; at < text.size(); at = text.find('\n', at) + 1) logged.push_back(std::stod(text.substr(at)));
  ASSERT_EQ(logged.size(), p.samples.size());
  for (std::size_t k = 0; k + 5 < 200; k += 5) {
    for (std::size_t j = 1; j < 5; ++j) EXPECT_NEAR(logged[k + j] - logged[k + j - 1], 0.001, 1e-9) << k;  // a burst
    EXPECT_NEAR(logged[k + 5] - logged[k], 0.05, 1e-9) << k;  // bursts 5 samples of 100 Hz apart: the true mean rate
  }
}

TEST(TwinLog, LowRateAndShortHoldsChangeThePlay) {
  const TwinSetup low = twin_setup({Quirk::kLowRate}, 1);
  EXPECT_EQ(low.player.rate_hz, 16.0);
  EXPECT_GT(low.sensor.lowpass_hz, 0.0);
  EXPECT_LT(low.sensor.lowpass_hz, 8.0);
  const TwinSetup brief = twin_setup({Quirk::kShort}, 1);
  const Played p = play_procedure(procedure("six_faces"), brief.sensor, brief.player);
  for (const auto& s : p.steps) EXPECT_LT(s.t_end_s - s.t_start_s, 0.8 * 4.0) << s.label;  // record_s 4, the alignment takes 2
  for (const auto& s : p.steps) EXPECT_GT(s.t_end_s - s.t_start_s, 0.5 * 4.0) << s.label;
  EXPECT_EQ(quirk_from_name("no_time"), Quirk::kNoTime);
  EXPECT_THROW(quirk_from_name("jittery"), std::invalid_argument);
  EXPECT_EQ(quirk_list({Quirk::kCounts, Quirk::kBursty}), "counts, bursty");
}

TEST(TwinCheck, ParametersAreJudgedAgainstTheirPlantedValues) {
  PlantedTruth t;
  t.parameters = {{"gyro_bias_z", 0.01}, {"gyro_scale_z", 0.02}, {"gyro_bias_x", -0.3}};
  const std::string doc = R"({"options": {"accelerometer": "none"}, "parameters": [
      {"name": "gyro_bias_x", "value": 0, "std_error": 0, "interval": [0, 0], "fixed": true, "reason": "held at 0"},
      {"name": "gyro_bias_z", "value": 0.0101, "std_error": 0.0001, "interval": [0.0099, 0.0103], "fixed": false},
      {"name": "gyro_scale_z", "value": 0.5, "std_error": 0.1, "interval": [0.3, 0.7], "fixed": false},
      {"name": "table_offset_tilt", "value": 1, "std_error": 1, "interval": [0, 2], "fixed": false}]})";
  const auto c = check_against_truth(doc, t);
  ASSERT_EQ(c.size(), 3u);  // the table offset is no planted parameter
  EXPECT_TRUE(c[0].held);
  EXPECT_FALSE(c[0].estimated);
  EXPECT_TRUE(c[1].covered);
  EXPECT_NEAR(c[1].z(), 1.0, 1e-9);
  EXPECT_FALSE(c[2].covered);
  EXPECT_FALSE(c[2].covered_within(2.0));
  EXPECT_TRUE(c[2].covered_within(2.5));
}

}  // namespace
}  // namespace stend::sim
