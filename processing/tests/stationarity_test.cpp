// The stationarity rule of a noise analysis (stend/processing/stationarity.hpp) on records whose
// truth the test writes: still records with the slow noises the noise model contains (a strong
// random walk, a Gauss–Markov bias, a steady ramp) pass; a hand turn, a step, a short tilt and a
// temperature sweep are named with their stretch and size; a temperature that was never measured
// (NaN) is not judged.
#include "stend/processing/stationarity.hpp"

#include "stend/physics/units.hpp"
#include "stend/recording/instruments.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

namespace {

using stend::ImuSample;
using stend::MemorySamples;
using stend::processing::check_stationarity;
using stend::processing::Mover;
using stend::processing::Stationarity;
namespace physics = stend::physics;

constexpr double kRateHz = 100.0;
// MPU-6050-like white noise densities: 400 µg/√Hz, 0.005 deg/s/√Hz, per sample ·√rate.
const double kAccelSigma = 400e-6 * physics::kStandardGravity * std::sqrt(kRateHz);
const double kGyroSigma = 0.005 * physics::kDegPerSecond * std::sqrt(kRateHz);

// What the test adds to a still, level sensor at time t [s]: accel [m/s²], gyro [rad/s].
struct Motion {
  std::function<void(double t, Eigen::Vector3d& a, Eigen::Vector3d& w)> add = [](double, Eigen::Vector3d&,
                                                                               Eigen::Vector3d&) {};
  std::function<double(double t)> temperature_c = [](double) { return 25.0; };
  double random_walk = 0.0;  // K of every axis per √s [unit/√s]
};

std::vector<ImuSample> record(double seconds, const Motion& m, unsigned seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<ImuSample> out;
  Eigen::Vector3d walk_a = Eigen::Vector3d::Zero(), walk_g = Eigen::Vector3d::Zero();
  const double step = m.random_walk / std::sqrt(kRateHz);
  const auto n = static_cast<std::size_t>(seconds * kRateHz);
  for (std::size_t i = 0; i < n; ++i) {
    ImuSample s;
    s.t_s = static_cast<double>(i) / kRateHz;
    for (int k = 0; k < 3; ++k) {
      walk_a[k] += step * unit(rng);
      walk_g[k] += step * physics::kDegPerSecond * unit(rng);
      s.accel_mps2[k] = kAccelSigma * unit(rng) + walk_a[k];
      s.gyro_radps[k] = kGyroSigma * unit(rng) + walk_g[k];
    }
    s.accel_mps2.z() += physics::kStandardGravity;
    m.add(s.t_s, s.accel_mps2, s.gyro_radps);
    s.temperature_c = m.temperature_c(s.t_s);
    out.push_back(s);
  }
  return out;
}

Stationarity check(const std::vector<ImuSample>& samples) {
  const MemorySamples src(samples);
  return check_stationarity(src, {0, src.size()}, kRateHz, stend::SensorInfo{});
}

TEST(Stationarity, StillRecordsWithTheModelsSlowNoisesPass) {
  // White noise alone, 10 min.
  Stationarity s = check(record(600, {}));
  EXPECT_TRUE(s.judged);
  EXPECT_TRUE(s.still()) << s.describe();
  // A random walk that wanders ~40 block-mean spreads over 40 min (K = 2e-4 unit/√s against a
  // block mean's 4e-4 m/s²): a slow wandering, not a step.
  Motion walk;
  walk.random_walk = 2e-4;
  s = check(record(2400, walk, 2));
  EXPECT_TRUE(s.still()) << s.describe();
  // A steady ramp over the whole record (the noise model's rate ramp): 20 mg in 20 min.
  Motion ramp;
  ramp.add = [](double t, Eigen::Vector3d& a, Eigen::Vector3d&) { a.x() += 20 * physics::kMilliG * t / 1200.0; };
  s = check(record(1200, ramp, 3));
  EXPECT_TRUE(s.still()) << s.describe();
}

TEST(Stationarity, AHandTurnIsNamedWithItsStretch) {
  // 5 s turn about x at 18 deg/s starting at 200 s (90°): gravity goes from z to y.
  Motion turn;
  turn.add = [](double t, Eigen::Vector3d& a, Eigen::Vector3d& w) {
    const double t0 = 200.0, t1 = 205.0;
    const double angle = std::clamp((t - t0) / (t1 - t0), 0.0, 1.0) * M_PI / 2;
    a.z() += physics::kStandardGravity * (std::cos(angle) - 1.0);
    a.y() += physics::kStandardGravity * std::sin(angle);
    if (t >= t0 && t < t1) w.x() += 18.0 * physics::kDegPerSecond;
  };
  const Stationarity s = check(record(400, turn));
  ASSERT_FALSE(s.still());
  bool accel = false, gyro = false;
  for (const auto& m : s.stretches) {
    EXPECT_LE(m.t_start_s, 200.0) << s.describe();
    EXPECT_GE(m.t_end_s, 204.9) << s.describe();
    EXPECT_LT(m.t_end_s - m.t_start_s, 12.0) << s.describe();
    if (m.mover == Mover::kAccelerometer) {
      accel = true;
      EXPECT_NEAR(m.change / physics::kMilliG, 1000.0 * std::sqrt(2.0), 50.0);  // |(0, 1, -1) g|
    }
    if (m.mover == Mover::kGyroscope) {
      gyro = true;
      EXPECT_NEAR(m.change / physics::kDegPerSecond, 18.0, 0.5);
    }
  }
  EXPECT_TRUE(accel && gyro) << s.describe();
  EXPECT_NE(s.describe().find("the accelerometer moves at"), std::string::npos) << s.describe();
  EXPECT_NE(s.describe().find("the gyroscope turns at"), std::string::npos) << s.describe();
  // The longest still stretch is the part after the turn (195 s) or before it (200 s): before.
  EXPECT_NEAR(s.still_start_s, 0.0, 1e-9);
  EXPECT_GT(s.still_end_s, 190.0);
  EXPECT_LE(s.still_end_s, 200.0);
}

TEST(Stationarity, AStepAndAShortTiltOfTheAccelerometerAreNamed) {
  Motion step;  // 40 mg on x from 300 s on
  step.add = [](double t, Eigen::Vector3d& a, Eigen::Vector3d&) { a.x() += t >= 300.0 ? 40 * physics::kMilliG : 0.0; };
  Stationarity s = check(record(600, step));
  ASSERT_EQ(s.stretches.size(), 1u) << s.describe();
  EXPECT_EQ(s.stretches[0].mover, Mover::kAccelerometer);
  EXPECT_LE(s.stretches[0].t_start_s, 300.0);
  EXPECT_GE(s.stretches[0].t_end_s, 300.0);
  EXPECT_NEAR(s.stretches[0].change / physics::kMilliG, 40.0, 2.0);

  Motion tilt;  // 50 mg on y, tilted over 20 s from 250 s on and held
  tilt.add = [](double t, Eigen::Vector3d& a, Eigen::Vector3d&) {
    a.y() += 50 * physics::kMilliG * std::clamp((t - 250.0) / 20.0, 0.0, 1.0);
  };
  s = check(record(600, tilt, 4));
  ASSERT_FALSE(s.still());
  EXPECT_EQ(s.stretches[0].mover, Mover::kAccelerometer);
  EXPECT_LT(s.stretches[0].t_start_s, 270.0) << s.describe();
  EXPECT_GT(s.stretches[0].t_end_s, 250.0) << s.describe();
}

TEST(Stationarity, ATemperatureSweepIsNamedAndAnUnmeasuredTemperatureIsNot) {
  Motion sweep;  // 20 → 40 °C over the record, the sensor otherwise still
  sweep.temperature_c = [](double t) { return 20.0 + 20.0 * t / 600.0; };
  Stationarity s = check(record(600, sweep));
  ASSERT_EQ(s.stretches.size(), 1u) << s.describe();
  EXPECT_EQ(s.stretches[0].mover, Mover::kTemperature);
  EXPECT_NEAR(s.stretches[0].change, 20.0, 0.2);
  EXPECT_NE(s.describe().find("the temperature drifts"), std::string::npos) << s.describe();

  Motion absent;  // NaN: no temperature was measured
  absent.temperature_c = [](double) { return stend::kNaN; };
  s = check(record(600, absent));
  EXPECT_TRUE(s.still()) << s.describe();
}

TEST(Stationarity, ARecordTooShortToJudgeIsNotRefused) {
  Motion turn;
  turn.add = [](double t, Eigen::Vector3d&, Eigen::Vector3d& w) { w.z() += t > 5.0 ? 1.0 : 0.0; };
  const Stationarity s = check(record(10, turn));  // 10 blocks of 1 s
  EXPECT_FALSE(s.judged);
  EXPECT_TRUE(s.still());
}

}  // namespace

// A gyro-only record (SensorInfo::has_accel false, its accelerometer values NaN): still stretches
// from the gyroscope alone, and the rule says so; a turn is still named. An accelerometer-only one
// is judged on its accelerometer without reading the gyroscope.
TEST(Stationarity, OneInstrumentIsJudgedOnItsOwn) {
  Motion turn;  // 5 s at 18 deg/s about x from 200 s
  turn.add = [](double t, Eigen::Vector3d&, Eigen::Vector3d& w) {
    if (t >= 200.0 && t < 205.0) w.x() += 18.0 * physics::kDegPerSecond;
  };
  stend::SensorInfo gyro_only;
  gyro_only.has_accel = false;
  gyro_only.has_temperature = false;
  std::vector<ImuSample> samples = record(400, turn);
  for (auto& x : samples) stend::blank_absent(gyro_only, x);
  const MemorySamples src(samples);
  Stationarity s = check_stationarity(src, {0, src.size()}, kRateHz, gyro_only);
  ASSERT_EQ(s.stretches.size(), 1u) << s.describe();
  EXPECT_EQ(s.stretches[0].mover, Mover::kGyroscope);
  EXPECT_NE(s.basis.find("from the gyroscope alone (the recording has no accelerometer)"), std::string::npos) << s.basis;
  std::vector<ImuSample> still = record(400, {});
  for (auto& x : still) stend::blank_absent(gyro_only, x);
  const MemorySamples still_src(still);
  EXPECT_TRUE(check_stationarity(still_src, {0, still_src.size()}, kRateHz, gyro_only).still());

  stend::SensorInfo accel_only;  // the turn's gyroscope is not read: NaN there would say nothing
  accel_only.has_gyro = false;
  std::vector<ImuSample> turned = record(400, turn);
  for (auto& x : turned) stend::blank_absent(accel_only, x);
  const MemorySamples accel_src(turned);
  s = check_stationarity(accel_src, {0, accel_src.size()}, kRateHz, accel_only);
  EXPECT_TRUE(s.still()) << s.describe();
  EXPECT_NE(s.basis.find("from the accelerometer alone"), std::string::npos) << s.basis;
}
