// The vocabulary's random and output-stage parts: stend/model/noise.hpp, output_stage.hpp.
#include <gtest/gtest.h>

#include <stend/model/noise.hpp>
#include <stend/model/output_stage.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace stend::model;

namespace {
double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }
}  // namespace

TEST(Rng, NormalHasTheRightMomentsAndTails) {
  Rng rng(2024);
  const int n = 4000000;
  double s1 = 0, s2 = 0, s3 = 0, s4 = 0;
  int beyond3 = 0, beyond4 = 0;
  std::vector<int> below(9, 0);
  const double cuts[9] = {-2.5, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.5};
  for (int i = 0; i < n; ++i) {
    const double x = rng.normal();
    s1 += x;
    s2 += x * x;
    s3 += x * x * x;
    s4 += x * x * x * x;
    beyond3 += std::abs(x) > 3.0;
    beyond4 += std::abs(x) > 4.0;
    for (int k = 0; k < 9; ++k) below[static_cast<std::size_t>(k)] += x < cuts[k];
  }
  const double m = s1 / n, v = s2 / n - m * m;
  EXPECT_NEAR(m, 0.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(v, 1.0, 5.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(s3 / n, 0.0, 5.0 * std::sqrt(15.0 / n));
  EXPECT_NEAR(s4 / n, 3.0, 5.0 * std::sqrt(96.0 / n));
  const double p3 = 2.0 * normal_cdf(-3.0), p4 = 2.0 * normal_cdf(-4.0);
  EXPECT_NEAR(beyond3, p3 * n, 5.0 * std::sqrt(p3 * n));
  EXPECT_NEAR(beyond4, p4 * n, 5.0 * std::sqrt(p4 * n) + 2);
  for (int k = 0; k < 9; ++k) {
    const double p = normal_cdf(cuts[k]);
    EXPECT_NEAR(below[static_cast<std::size_t>(k)] / static_cast<double>(n), p, 5.0 * std::sqrt(p * (1 - p) / n))
        << cuts[k];
  }
}

TEST(Rng, DeterministicAndJumpGivesAnotherStream) {
  Rng a(7), b(7), c(8);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(a(), b());
  EXPECT_NE(a(), c());
  Rng d(7);
  d.jump();
  Rng e(7);
  int same = 0;
  for (int i = 0; i < 100; ++i) same += d() == e();
  EXPECT_EQ(same, 0);
  for (int i = 0; i < 1000; ++i) {
    const double u = a.uniform();
    ASSERT_GT(u, 0.0);
    ASSERT_LT(u, 1.0);
  }
}

TEST(Noise, WhiteNoiseSigmaFromDensity) {
  const WhiteNoise w(0.004, 1e-3);
  EXPECT_DOUBLE_EQ(w.sigma(), 0.004 * std::sqrt(500.0));
  EXPECT_DOUBLE_EQ(WhiteNoise::density_from_sigma(w.sigma(), 1e-3), 0.004);
  EXPECT_THROW(WhiteNoise(-1.0, 1e-3), std::invalid_argument);
  EXPECT_THROW(WhiteNoise(1.0, 0.0), std::invalid_argument);
}

TEST(Noise, GaussMarkovExactDiscretizationIsIndependentOfTheStep) {
  // Stationary variance σ² and autocorrelation e^{-lag/τc} at two very different sample periods.
  for (double dt : {0.01, 0.5}) {
    Rng rng(5);
    GaussMarkov g(2.0, 3.0, dt);
    g.reset_stationary(rng);
    const int n = 2000000;
    std::vector<double> x(static_cast<std::size_t>(n));
    for (auto& v : x) v = g.step(rng);
    double m = 0, var = 0;
    for (double v : x) m += v;
    m /= n;
    for (double v : x) var += (v - m) * (v - m);
    var /= n;
    // Effective independent samples ≈ n·dt / (2 τc).
    const double neff = n * dt / 6.0;
    EXPECT_NEAR(var / 4.0, 1.0, 4.0 * std::sqrt(2.0 / neff)) << dt;
    const auto lag = static_cast<std::size_t>(std::lround(3.0 / dt));
    double c = 0;
    for (std::size_t i = 0; i + lag < x.size(); ++i) c += (x[i] - m) * (x[i + lag] - m);
    c /= static_cast<double>(x.size() - lag) * var;
    EXPECT_NEAR(c, std::exp(-1.0), 0.03) << dt;
  }
}

TEST(Noise, AllanVarianceOfSimulatedChannelMatchesTheory) {
  // White + GM + random walk at 100 Hz, overlapping-free Allan variance at three τ.
  NoiseSpec spec;
  spec.white_density = 0.01;
  spec.bias_instability = {{0.002, 5.0}};
  spec.random_walk = 1e-4;
  const double dt = 0.01;
  NoiseChannel ch(spec, dt);
  Rng rng(99);
  ch.reset(rng);
  const std::size_t n = 4000000;  // 40000 s
  std::vector<double> x(n);
  for (auto& v : x) v = ch.step(rng);
  for (double tau : {0.1, 10.0, 100.0}) {
    const auto m = static_cast<std::size_t>(std::lround(tau / dt));
    std::vector<double> avg;
    for (std::size_t i = 0; i + m <= n; i += m) {
      double s = 0;
      for (std::size_t j = 0; j < m; ++j) s += x[i + j];
      avg.push_back(s / static_cast<double>(m));
    }
    double av = 0;
    for (std::size_t i = 0; i + 1 < avg.size(); ++i) av += 0.5 * std::pow(avg[i + 1] - avg[i], 2);
    av /= static_cast<double>(avg.size() - 1);
    // Theory for averages of discrete white noise is exact; the continuous GM/RW formulas hold
    // for τ ≫ dt.
    const double theory = allan::channel(spec, tau);
    const double rel = 3.0 * std::sqrt(2.0 / static_cast<double>(avg.size() / 2));
    EXPECT_NEAR(av / theory, 1.0, std::max(0.05, rel)) << "tau " << tau;
  }
  // Peak of a GM Allan deviation.
  const double peak = std::sqrt(allan::gauss_markov(1.0, 1.0, allan::kGaussMarkovPeakTau));
  EXPECT_NEAR(peak, allan::kGaussMarkovPeakDeviation, 1e-5);
  EXPECT_LT(allan::gauss_markov(1.0, 1.0, 1.5), peak * peak);
  EXPECT_LT(allan::gauss_markov(1.0, 1.0, 2.3), peak * peak);
  // The small-τ series joins the closed form.
  EXPECT_NEAR(allan::gauss_markov(1.0, 1.0, 0.99e-3) / allan::gauss_markov(1.0, 1.0, 1.01e-3), 0.99 / 1.01, 1e-4);
}

TEST(Noise, RandomWalkStepVariance) {
  RandomWalk w(0.5, 0.04);
  EXPECT_DOUBLE_EQ(w.drive(), 0.5 * 0.2);
  Rng rng(1);
  const int reps = 20000;
  double v = 0;
  for (int r = 0; r < reps; ++r) {
    w.reset();
    for (int k = 0; k < 250; ++k) w.step(rng);  // 10 s
    v += w.value() * w.value() / reps;
  }
  EXPECT_NEAR(v / (0.25 * 10.0), 1.0, 4.0 * std::sqrt(2.0 / reps));
}

TEST(OutputStage, QuantizerRoundsAndClamps) {
  const Quantizer q(0.5, 4);  // counts −8..7
  bool c = false;
  EXPECT_EQ(q.counts(0.2, &c), 0);
  EXPECT_EQ(q.counts(0.26, &c), 1);
  EXPECT_EQ(q.counts(-0.26, &c), -1);
  EXPECT_EQ(q.counts(-0.24, &c), 0);
  EXPECT_EQ(q.counts(3.5, &c), 7);
  EXPECT_FALSE(c);
  EXPECT_EQ(q.counts(3.8, &c), 7);
  EXPECT_TRUE(c);
  c = false;
  EXPECT_EQ(q.counts(-100.0, &c), -8);
  EXPECT_TRUE(c);
  c = false;
  EXPECT_EQ(q.counts(NAN, &c), -8);
  EXPECT_TRUE(c);
  EXPECT_DOUBLE_EQ(q.value(-3), -1.5);
  const Quantizer w(1e-3, 32);
  EXPECT_EQ(w.counts(1e9), 2147483647);
  EXPECT_THROW(Quantizer(0.0, 16), std::invalid_argument);
  EXPECT_THROW(Quantizer(1.0, 40), std::invalid_argument);
}

TEST(OutputStage, SaturationFlags) {
  const Saturation s(2.0);
  bool f = false;
  EXPECT_EQ(s.apply(2.0, f), 2.0);
  EXPECT_FALSE(f);
  EXPECT_EQ(s.apply(-1.0, f), -1.0);
  EXPECT_FALSE(f);
  EXPECT_EQ(s.apply(2.5, f), 2.0);
  EXPECT_TRUE(f);
  f = false;
  EXPECT_EQ(s.apply(-7.0, f), -2.0);
  EXPECT_TRUE(f);
  bool g = false;
  EXPECT_EQ(Saturation().apply(1e300, g), 1e300);
  EXPECT_FALSE(g);
}

TEST(OutputStage, ButterworthBiquadResponse) {
  const double fs = 1000.0, fc = 50.0;
  Biquad b = Biquad::butterworth_lowpass(fc, fs);
  EXPECT_NEAR(b.dc_gain(), 1.0, 1e-12);
  EXPECT_NEAR(b.magnitude(fc, fs), 1.0 / std::sqrt(2.0), 1e-12);
  constexpr double kPi = 3.14159265358979323846;
  for (double f : {5.0, 20.0, 80.0, 200.0, 400.0}) {
    const double r = std::tan(kPi * f / fs) / std::tan(kPi * fc / fs);
    EXPECT_NEAR(b.magnitude(f, fs), 1.0 / std::sqrt(1.0 + std::pow(r, 4)), 1e-12) << f;
  }
  // Running a sine through the filter gives the predicted amplitude.
  const double f = 120.0;
  double peak = 0;
  for (int k = 0; k < 20000; ++k) {
    const double y = b(std::sin(2 * kPi * f * k / fs));
    if (k > 10000) peak = std::max(peak, std::abs(y));
  }
  EXPECT_NEAR(peak, b.magnitude(f, fs), 2e-3);
  // reset() puts the filter in steady state: a constant input comes straight out.
  b.reset(3.0);
  for (int k = 0; k < 10; ++k) EXPECT_NEAR(b(3.0), 3.0, 1e-12);
  EXPECT_THROW(Biquad::butterworth_lowpass(500.0, 1000.0), std::invalid_argument);
  EXPECT_THROW(Biquad::butterworth_lowpass(0.0, 1000.0), std::invalid_argument);
}
