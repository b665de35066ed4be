// sim_imu: configuration through the host's schema reader, ideal output, deterministic errors
// against an independently built ErrorModel, noise statistics, output stage, timing, seeds.
#include <gtest/gtest.h>

#include <stend/core/experiment.hpp>
#include <stend/physics/geometry.hpp>
#include <stend/model/terms.hpp>

#include <cmath>
#include <random>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

#include <stend/sim/imu.hpp>

extern "C" const stend_plugin_info* stend_plugin_entry(void);

namespace {

using stend::BenchTruth;
using stend::ImuSample;
using stend::sim::SimImu;
using stend::sim::SimImuConfig;

constexpr double kG = 9.80665;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

// The host's own validation of a `config:` block (defaults filled from the schema).
stend::Params cfg(const std::string& yaml = "{}") {
  return stend::params_from_yaml(YAML::Load(yaml), *stend_plugin_entry(), "test.yaml", "config");
}

const std::string kQuiet =
    "accel_noise_density: 0, accel_bias_instability_mps2: 0, accel_random_walk: 0, "
    "gyro_noise_density: 0, gyro_bias_instability_radps: 0, gyro_random_walk: 0";

class ConstTruth : public stend::TruthSource {
 public:
  BenchTruth truth;
  bool record = false;
  mutable std::vector<double> calls;
  BenchTruth at(double t) const override {
    if (record) calls.push_back(t);
    BenchTruth b = truth;
    b.t_s = t;
    return b;
  }
};

BenchTruth static_truth(const Eigen::Vector3d& f, const Eigen::Vector3d& w = Eigen::Vector3d::Zero(),
                        double die_c = 25.0) {
  BenchTruth t;
  t.specific_force_mps2 = f;
  t.angular_rate_radps = w;
  t.die_temperature_c = die_c;
  t.air_temperature_c = die_c;
  return t;
}

std::vector<ImuSample> record(SimImu& imu, const stend::TruthSource& truth, double duration_s,
                              double chunk_s = 0.01) {
  std::vector<ImuSample> all, buf;
  imu.start(0.0);
  const auto n = static_cast<long>(std::llround(duration_s / chunk_s));
  for (long k = 1; k <= n; ++k) {
    buf.clear();
    imu.acquire(static_cast<double>(k) * chunk_s, truth, buf);
    all.insert(all.end(), buf.begin(), buf.end());
  }
  return all;
}

struct Stats {
  double mean = 0, var = 0;
};
template <class F>
Stats stats(const std::vector<ImuSample>& s, F f) {
  double m = 0;
  for (const auto& x : s) m += f(x);
  m /= static_cast<double>(s.size());
  double v = 0;
  for (const auto& x : s) v += (f(x) - m) * (f(x) - m);
  return {m, v / static_cast<double>(s.size() - 1)};
}

Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-3.14159, 3.14159);
  return stend::physics::Rz(u(rng)) * stend::physics::Ry(u(rng)) * stend::physics::Rx(u(rng));
}

}  // namespace

TEST(SimImu, DefaultsAreAnMpu6050) {
  // The defaults as the host fills them in (from SimImuConfig{}, through the field table).
  SimImu from_schema(cfg());
  EXPECT_EQ(from_schema.identity().who_am_i, "0x68");
  EXPECT_EQ(from_schema.identity().model, "MPU-6050");
  EXPECT_EQ(from_schema.identity().serial, "");
  EXPECT_EQ(from_schema.info().output_rate_hz, 1000.0);
  // MPU-6050 scale: 16384 LSB/g and 131.072 LSB/(°/s), temperature 340 LSB/°C.
  EXPECT_NEAR(kG / from_schema.info().accel_lsb_mps2, 16384.0, 1e-9);
  EXPECT_NEAR(kDeg / from_schema.info().gyro_lsb_radps, 131.072, 1e-9);
  EXPECT_NEAR(1.0 / from_schema.info().temperature_lsb_c, 340.0, 1e-9);
}

TEST(SimImu, RejectsBadConfiguration) {
  stend::Params p;
  p.set("no_such_key", 1.0);
  EXPECT_THROW(SimImu{p}, std::invalid_argument);
  // Params built in code (not by the host) are held to the schema too: shape and bounds.
  stend::Params short_bias;
  short_bias.set("accel_bias_mps2", std::vector<double>{0.1, 0.2});
  EXPECT_THROW(SimImu{short_bias}, std::invalid_argument);
  stend::Params wide;
  wide.set("output_bits", std::int64_t{40});
  EXPECT_THROW(SimImu{wide}, std::invalid_argument);
  EXPECT_THROW(SimImu{cfg("{accel_cross_axis: [[0.01, 0, 0], [0, 0, 0], [0, 0, 0]]}")}, std::invalid_argument);
  EXPECT_THROW(SimImu{cfg("{output_rate_hz: 100, lowpass_hz: 60}")}, std::invalid_argument);
  // Through the plugin factory: a failure comes back as a message, not an exception.
  const stend::Params bad = cfg("{accel_cross_axis: [[0.01, 0, 0], [0, 0, 0], [0, 0, 0]]}");
  char err[256] = {0};
  EXPECT_EQ(stend_plugin_entry()->create(&bad, err, sizeof err), nullptr);
  EXPECT_NE(std::string(err).find("diagonal"), std::string::npos) << err;
}

TEST(SimImu, IdealSensorReadsTheTruthWithinHalfAnLsb) {
  SimImu imu(cfg("{" + kQuiet + "}"));
  const double la = imu.info().accel_lsb_mps2, lg = imu.info().gyro_lsb_radps;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> w(-2.0, 2.0);  // rad/s, inside ±250 °/s
  for (int trial = 0; trial < 50; ++trial) {
    ConstTruth truth;
    const Eigen::Vector3d f = random_rotation(rng) * Eigen::Vector3d(0, 0, kG);
    const Eigen::Vector3d rate(w(rng), w(rng), w(rng));
    truth.truth = static_truth(f, rate);
    const auto s = record(imu, truth, 0.02);
    ASSERT_EQ(s.size(), 20u);
    for (const auto& x : s) {
      for (int i = 0; i < 3; ++i) {
        EXPECT_LE(std::abs(x.accel_mps2[i] - f[i]), 0.5 * la + 1e-12);
        EXPECT_LE(std::abs(x.gyro_radps[i] - rate[i]), 0.5 * lg + 1e-12);
        EXPECT_EQ(x.accel_counts[i], static_cast<int>(std::lround(f[i] / la)));
      }
      EXPECT_EQ(x.flags, 0u);
    }
  }
}

TEST(SimImu, StaticMeanEqualsTheErrorModelPrediction) {
  // Errors planted through the YAML keys; the prediction comes from a model built here, term by
  // term, so a wrong key-to-parameter mapping in the plugin shows up.
  const std::string yaml =
      "{accel_bias_mps2: [0.027, -0.05, 0.08], accel_scale: [0.0007, -0.002, 0.0015],"
      " accel_cross_axis: [[0, 0.0055, 0.0002], [-0.003, 0, 0.004], [0.006, -0.001, 0]],"
      " accel_nonlinear_k2: [0.0002, 0, -0.0003],"
      " accel_bias_tc: [[0.001, 0.0001], [-0.002, 0], [0.0005, -0.00005]],"
      " gyro_bias_radps: [0.01, -0.02, 0.005], gyro_scale: [0.01, 0, -0.01],"
      " gyro_cross_axis: [[0, 0.01, 0], [0, 0, -0.02], [0.015, 0, 0]],"
      " gyro_g_sensitivity: [[0.001, 0, 0], [0, -0.002, 0.0005], [0, 0, 0.0015]],"
      " accel_bias_instability_mps2: 0, accel_random_walk: 0, gyro_bias_instability_radps: 0,"
      " gyro_random_walk: 0, seed: 5}";
  SimImu imu(cfg(yaml));
  using namespace stend::model;
  ErrorModel am{Instrument::kAccelerometer,
                {{TermKind::kBias}, {TermKind::kScale}, {TermKind::kCrossAxis}, {TermKind::kNonlinearK2},
                 {TermKind::kBiasTemperature, 2, 25.0}}};
  const std::vector<double> at = {0.027, -0.05, 0.08, 0.0007, -0.002, 0.0015, 0.0055, 0.0002, -0.003,
                                  0.004, 0.006, -0.001, 0.0002, 0, -0.0003, 0.001, 0.0001, -0.002, 0,
                                  0.0005, -0.00005};
  ErrorModel gm{Instrument::kGyroscope,
                {{TermKind::kBias}, {TermKind::kScale}, {TermKind::kCrossAxis}, {TermKind::kGSensitivity}}};
  const std::vector<double> gt = {0.01, -0.02, 0.005, 0.01, 0, -0.01, 0.01, 0, 0, -0.02, 0.015, 0,
                                  0.001, 0, 0, 0, -0.002, 0.0005, 0, 0, 0.0015};
  const double sa = imu.config().accel_noise_density * std::sqrt(500.0);
  const double sg = imu.config().gyro_noise_density * std::sqrt(500.0);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 4; ++trial) {
    ConstTruth truth;
    const Eigen::Vector3d f = random_rotation(rng) * Eigen::Vector3d(0, 0, kG);
    const Eigen::Vector3d w(0.5, -0.3, 0.8);
    const double die = 25.0 + 6.0 * trial;
    truth.truth = static_truth(f, w, die);
    const auto s = record(imu, truth, 30.0);
    const double n = static_cast<double>(s.size());
    Stimulus<double> st;
    st.input = f;
    st.specific_force = f;
    st.temperature_c = die;
    const Eigen::Vector3d ya = am.measure<double>(at.data(), st);
    st.input = w;
    const Eigen::Vector3d yg = gm.measure<double>(gt.data(), st);
    for (int i = 0; i < 3; ++i) {
      const Stats a = stats(s, [i](const ImuSample& x) { return x.accel_mps2[i]; });
      const Stats g = stats(s, [i](const ImuSample& x) { return x.gyro_radps[i]; });
      EXPECT_NEAR(a.mean, ya[i], 4.0 * sa / std::sqrt(n)) << "accel axis " << i << " trial " << trial;
      EXPECT_NEAR(g.mean, yg[i], 4.0 * sg / std::sqrt(n)) << "gyro axis " << i << " trial " << trial;
      // The planted errors are far bigger than the tolerance: the test can fail.
      EXPECT_GT(std::abs(ya[i] - f[i]), 10.0 * sa / std::sqrt(n));
    }
  }
}

TEST(SimImu, WhiteNoiseMatchesItsDensity) {
  // Low-pass off: σ = density·√(rate/2).
  SimImu imu(cfg("{accel_noise_density: 0.002, gyro_noise_density: 0.0002, accel_bias_instability_mps2: 0,"
                 " accel_random_walk: 0, gyro_bias_instability_radps: 0, gyro_random_walk: 0,"
                 " output_rate_hz: 800, seed: 9}"));
  ConstTruth truth;
  truth.truth = static_truth({0, 0, kG}, {0, 0, 0.1});
  const auto s = record(imu, truth, 250.0);
  ASSERT_EQ(s.size(), 200000u);
  for (int i = 0; i < 3; ++i) {
    const double ea = 0.002 * std::sqrt(400.0), eg = 0.0002 * std::sqrt(400.0);
    const double la = imu.info().accel_lsb_mps2, lg = imu.info().gyro_lsb_radps;
    // Quantization adds LSB²/12 of variance.
    const double sa = std::sqrt(stats(s, [i](const ImuSample& x) { return x.accel_mps2[i]; }).var - la * la / 12);
    const double sg = std::sqrt(stats(s, [i](const ImuSample& x) { return x.gyro_radps[i]; }).var - lg * lg / 12);
    EXPECT_NEAR(sa / ea, 1.0, 0.02) << i;
    EXPECT_NEAR(sg / eg, 1.0, 0.02) << i;
  }
  // Periodogram check on accel x: the one-sided PSD averaged over the band is density².
  const std::size_t nfft = 256;
  std::vector<double> psd(nfft / 2 + 1, 0.0);
  int segments = 0;
  for (std::size_t start = 0; start + nfft <= s.size() && segments < 200; start += nfft) {
    double mean = 0;
    for (std::size_t j = 0; j < nfft; ++j) mean += s[start + j].accel_mps2[0];
    mean /= static_cast<double>(nfft);
    for (std::size_t k = 1; k < nfft / 2; ++k) {
      double re = 0, im = 0;
      for (std::size_t j = 0; j < nfft; ++j) {
        const double ph = 2.0 * 3.14159265358979323846 * static_cast<double>(k * j) / static_cast<double>(nfft);
        const double x = s[start + j].accel_mps2[0] - mean;
        re += x * std::cos(ph);
        im -= x * std::sin(ph);
      }
      psd[k] += 2.0 * (re * re + im * im) / (800.0 * static_cast<double>(nfft));
    }
    ++segments;
  }
  double band = 0;
  for (std::size_t k = 1; k < nfft / 2; ++k) band += psd[k];
  band /= static_cast<double>((nfft / 2 - 1) * static_cast<std::size_t>(segments));
  EXPECT_NEAR(std::sqrt(band) / 0.002, 1.0, 0.05);
}

TEST(SimImu, LowPassReducesWhiteNoiseByItsEquivalentBandwidth) {
  SimImu imu(cfg("{accel_noise_density: 0.004, accel_bias_instability_mps2: 0, accel_random_walk: 0,"
                 " gyro_noise_density: 0, gyro_bias_instability_radps: 0, gyro_random_walk: 0,"
                 " lowpass_hz: 44, seed: 4}"));
  // Noise-equivalent bandwidth of the biquad: ∫|H(f)|² df over 0..fs/2.
  const auto lp = stend::model::Biquad::butterworth_lowpass(44.0, 1000.0);
  double enbw = 0;
  const int m = 20000;
  for (int k = 0; k < m; ++k) {
    const double f = (k + 0.5) * 500.0 / m;
    enbw += std::pow(lp.magnitude(f, 1000.0), 2) * 500.0 / m;
  }
  ConstTruth truth;
  truth.truth = static_truth({0, 0, kG});
  const auto s = record(imu, truth, 200.0);
  const double la = imu.info().accel_lsb_mps2;
  const double sd = std::sqrt(stats(s, [](const ImuSample& x) { return x.accel_mps2[0]; }).var - la * la / 12);
  EXPECT_NEAR(sd / (0.004 * std::sqrt(enbw)), 1.0, 0.05);
  EXPECT_LT(sd, 0.5 * 0.004 * std::sqrt(500.0));  // clearly below the unfiltered σ
  // No start-up transient: the first sample already sits at the input (filter starts in steady state).
  EXPECT_NEAR(s.front().accel_mps2[2], kG, 0.05);
}

TEST(SimImu, OutputsAreWholeLsbsAndSubLsbInputGivesAConstant) {
  SimImu imu(cfg("{" + kQuiet + "}"));
  const double la = imu.info().accel_lsb_mps2, lg = imu.info().gyro_lsb_radps;
  ConstTruth truth;
  truth.truth = static_truth({0.3 * la, 0.7 * la, -0.3 * la}, {0.3 * lg, -0.7 * lg, 1000.2 * lg});
  const auto s = record(imu, truth, 1.0);
  for (const auto& x : s) {
    EXPECT_EQ(x.accel_counts[0], 0);
    EXPECT_EQ(x.accel_counts[1], 1);
    EXPECT_EQ(x.accel_counts[2], 0);
    EXPECT_EQ(x.gyro_counts[0], 0);
    EXPECT_EQ(x.gyro_counts[1], -1);
    EXPECT_EQ(x.gyro_counts[2], 1000);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(x.accel_mps2[i], x.accel_counts[i] * la);
      EXPECT_EQ(x.gyro_radps[i], x.gyro_counts[i] * lg);
    }
  }
  // With noise, values are still whole multiples of the LSB.
  SimImu noisy(cfg());
  const auto n = record(noisy, truth, 0.5);
  int distinct = 0;
  for (const auto& x : n)
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(x.accel_mps2[i], x.accel_counts[i] * la);
      EXPECT_EQ(x.gyro_radps[i], x.gyro_counts[i] * lg);
      distinct += x.accel_counts[i] != n.front().accel_counts[i];
    }
  EXPECT_GT(distinct, 100);  // the noise does move the counts
}

TEST(SimImu, SaturationClampsAndFlags) {
  SimImu imu(cfg("{" + kQuiet + "}"));
  ConstTruth truth;
  truth.truth = static_truth({3.0 * kG, -2.5 * kG, 1.9 * kG}, {0, 0, 0});
  auto s = record(imu, truth, 0.05);
  for (const auto& x : s) {
    EXPECT_EQ(x.accel_counts[0], 32767);
    EXPECT_EQ(x.accel_counts[1], -32768);
    EXPECT_EQ(x.accel_counts[2], static_cast<int>(std::lround(1.9 * 16384)));
    EXPECT_TRUE(x.flags & stend::kAccelSaturated);
    EXPECT_FALSE(x.flags & stend::kGyroSaturated);
  }
  truth.truth = static_truth({0, 0, kG}, {0, 300 * kDeg, 0});
  s = record(imu, truth, 0.05);
  for (const auto& x : s) {
    EXPECT_EQ(x.gyro_counts[1], 32767);
    EXPECT_TRUE(x.flags & stend::kGyroSaturated);
    EXPECT_FALSE(x.flags & stend::kAccelSaturated);
  }
  // A wider range does not saturate.
  SimImu wide(cfg("{" + kQuiet + ", accel_range_g: 16, gyro_range_dps: 2000}"));
  s = record(wide, truth, 0.05);
  for (const auto& x : s) {
    EXPECT_EQ(x.flags, 0u);
    EXPECT_NEAR(x.gyro_radps[1], 300 * kDeg, wide.info().gyro_lsb_radps);
  }
}

TEST(SimImu, RandomWalkVarianceGrowsAsKSquaredT) {
  // An ensemble of sensors (one seed each): Var[b(t) − b(0)] = K²·t.
  const double ka = 1e-3, kg = 2e-4;
  const int n = 600;
  const std::vector<double> times = {10.0, 40.0, 80.0};
  std::vector<double> va(times.size(), 0.0), vg(times.size(), 0.0);
  ConstTruth truth;
  truth.truth = static_truth({0, 0, 0});
  for (int r = 0; r < n; ++r) {
    SimImu imu(cfg("{accel_noise_density: 0, accel_bias_instability_mps2: 0, accel_random_walk: 0.001,"
                   " gyro_noise_density: 0, gyro_bias_instability_radps: 0, gyro_random_walk: 0.0002,"
                   " output_rate_hz: 50, output_bits: 32, accel_lsb_mps2: 1e-7, gyro_lsb_radps: 1e-8, seed: " +
                   std::to_string(1000 + r) + "}"));
    const auto s = record(imu, truth, 80.0, 1.0);
    for (std::size_t k = 0; k < times.size(); ++k) {
      const auto idx = static_cast<std::size_t>(std::lround(times[k] * 50.0)) - 1;
      const double da = s[idx].accel_mps2[0] - 0.0, dg = s[idx].gyro_radps[2] - 0.0;
      va[k] += da * da / n;
      vg[k] += dg * dg / n;
    }
  }
  for (std::size_t k = 0; k < times.size(); ++k) {
    // Relative standard error of a variance from 600 draws: √(2/600) = 5.8 %.
    EXPECT_NEAR(va[k] / (ka * ka * times[k]), 1.0, 0.18) << times[k];
    EXPECT_NEAR(vg[k] / (kg * kg * times[k]), 1.0, 0.18) << times[k];
  }
}

TEST(SimImu, BiasInstabilityIsAGaussMarkovProcess) {
  SimImu imu(cfg("{accel_noise_density: 0, accel_bias_instability_mps2: 0.01, accel_bias_correlation_s: 2,"
                 " accel_random_walk: 0, gyro_noise_density: 0, gyro_random_walk: 0, output_rate_hz: 20,"
                 " output_bits: 32, accel_lsb_mps2: 1e-7, seed: 77}"));
  ConstTruth truth;
  truth.truth = static_truth({0, 0, 0});
  const auto s = record(imu, truth, 8000.0, 1.0);
  const Stats st = stats(s, [](const ImuSample& x) { return x.accel_mps2[1]; });
  EXPECT_NEAR(std::sqrt(st.var) / 0.01, 1.0, 0.08);
  // Autocorrelation at one correlation time (40 samples) is e^-1.
  double c = 0;
  for (std::size_t i = 0; i + 40 < s.size(); ++i)
    c += (s[i].accel_mps2[1] - st.mean) * (s[i + 40].accel_mps2[1] - st.mean);
  c /= static_cast<double>(s.size() - 40) * st.var;
  EXPECT_NEAR(c, std::exp(-1.0), 0.05);
}

TEST(SimImu, SamplesAtTheOutputRateWithTruthAtEachSampleTime) {
  SimImu imu(cfg("{output_rate_hz: 1000}"));
  ConstTruth truth;
  truth.record = true;
  std::vector<ImuSample> out;
  imu.start(5.0);
  imu.acquire(5.0105, truth, out);
  ASSERT_EQ(out.size(), 10u);
  imu.acquire(5.02, truth, out);  // a sample exactly at the end of the interval belongs to it
  ASSERT_EQ(out.size(), 20u);
  imu.acquire(5.02, truth, out);  // nothing new
  ASSERT_EQ(out.size(), 20u);
  imu.acquire(5.0304, truth, out);
  ASSERT_EQ(out.size(), 30u);
  for (std::size_t k = 0; k < out.size(); ++k) {
    EXPECT_DOUBLE_EQ(out[k].t_s, 5.0 + static_cast<double>(k + 1) / 1000.0);
    EXPECT_EQ(truth.calls[k], out[k].t_s);
  }
  // One hour in 10-ms steps: exactly 3.6 million samples, none lost or repeated at the boundaries.
  SimImu fast(cfg("{" + kQuiet + "}"));
  ConstTruth t2;
  std::vector<ImuSample> buf;
  fast.start(0.0);
  std::size_t count = 0;
  double last = 0.0;
  for (int k = 1; k <= 360000; ++k) {
    buf.clear();
    fast.acquire(k * 0.01, t2, buf);
    count += buf.size();
    for (const auto& x : buf) {
      ASSERT_GT(x.t_s, last);
      last = x.t_s;
    }
  }
  EXPECT_EQ(count, 3600000u);
}

TEST(SimImu, TemperatureOutputAndThermalTerms) {
  SimImu imu(cfg("{" + kQuiet + ", accel_thermal_lag: [0, 0, 0.5], accel_time_drift: [0.001, 0, 0]}"));
  // Die temperature ramping at 0.2 °C/s: thermal lag adds 0.5·0.2 = 0.1 m/s² on z.
  class Ramp : public stend::TruthSource {
   public:
    BenchTruth at(double t) const override {
      BenchTruth b;
      b.t_s = t;
      b.specific_force_mps2 = {0, 0, kG};
      b.die_temperature_c = 20.0 + 0.2 * t;
      return b;
    }
  } ramp;
  const auto s = record(imu, ramp, 10.0);
  const double la = imu.info().accel_lsb_mps2;
  for (std::size_t k = 1; k < s.size(); ++k) {
    const double t = s[k].t_s, die = 20.0 + 0.2 * t;
    EXPECT_EQ(s[k].temperature_counts, static_cast<int>(std::floor((die - 36.53) * 340.0 + 0.5)));
    EXPECT_NEAR(s[k].temperature_c, die, 0.5 / 340.0 + 1e-12);
    EXPECT_NEAR(s[k].accel_mps2[2], kG + 0.1, 0.5 * la + 1e-9);
    EXPECT_NEAR(s[k].accel_mps2[0], 0.001 * t, 0.5 * la + 1e-9);
  }
}

TEST(SimImu, DeterministicFromTheSeed) {
  ConstTruth truth;
  truth.truth = static_truth({0, 0, kG}, {0.1, 0, 0});
  SimImu a(cfg("{seed: 42}")), b(cfg("{seed: 42}")), c(cfg("{seed: 43}"));
  const auto sa = record(a, truth, 1.0), sb = record(b, truth, 1.0), sc = record(c, truth, 1.0);
  const auto sa2 = record(a, truth, 1.0);  // start() restarts the same sequence
  int differ = 0;
  for (std::size_t i = 0; i < sa.size(); ++i) {
    EXPECT_EQ(sa[i].accel_counts[2], sb[i].accel_counts[2]);
    EXPECT_EQ(sa[i].gyro_counts[0], sa2[i].gyro_counts[0]);
    differ += sa[i].accel_counts[2] != sc[i].accel_counts[2];
  }
  EXPECT_GT(differ, static_cast<int>(sa.size()) / 2);
}

TEST(SimImu, ModelExposesOnlyPlantedTerms) {
  SimImu imu(cfg("{accel_bias_mps2: [0.1, 0, 0], accel_scale_tc: [[0, 1e-4], [0, 0], [0, 0]]}"));
  ASSERT_EQ(imu.accel_model().terms.size(), 2u);
  EXPECT_EQ(imu.accel_model().terms[0].kind, stend::model::TermKind::kBias);
  EXPECT_EQ(imu.accel_model().terms[1].kind, stend::model::TermKind::kScaleTemperature);
  EXPECT_EQ(imu.accel_model().terms[1].order, 2);
  EXPECT_EQ(imu.accel_model().size(), static_cast<int>(imu.accel_theta().size()));
  EXPECT_TRUE(imu.gyro_model().terms.empty());
}

TEST(SimImu, ExampleConfigIsValid) {
  const YAML::Node doc = YAML::LoadFile(std::string(STEND_SOURCE_DIR) + "/sensors/sim_imu/example.yaml");
  EXPECT_EQ(doc["plugin"].as<std::string>(), "sim_imu");
  const stend::Params p = stend::params_from_yaml(doc["config"], *stend_plugin_entry(), "example.yaml", "config");
  SimImu imu(p);
  EXPECT_EQ(imu.identity().serial, "SIM-0001");
  EXPECT_EQ(imu.info().output_rate_hz, 200.0);
  EXPECT_EQ(imu.accel_model().find(stend::model::TermKind::kBiasTemperature), 3);
}
