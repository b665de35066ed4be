// Butterworth SOS design and filtering, static extraction.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <vector>

#include "stend/processing/butterworth.hpp"
#include "stend/processing/static_extraction.hpp"

using namespace stend::processing;
using std::numbers::pi;

namespace {
// Closed-form magnitude of a bilinear-transformed Butterworth low-pass (the reference):
// |H|² = 1 / (1 + (tan(π f/fs) / tan(π fc/fs))^{2N}).
double reference_magnitude(int order, double fc, double fs, double f) {
  const double r = std::tan(pi * f / fs) / std::tan(pi * fc / fs);
  return 1.0 / std::sqrt(1.0 + std::pow(r, 2 * order));
}
}  // namespace

TEST(Butterworth, DcGainIsOne) {
  for (int order = 1; order <= 10; ++order)
    for (double fc : {0.01, 0.5, 5.0, 40.0}) {
      const SosFilter f = butterworth_lowpass(order, fc, 100.0);
      EXPECT_NEAR(f.dc_gain(), 1.0, 1e-12) << order << " " << fc;
      EXPECT_NEAR(std::abs(f.response(0.0)), 1.0, 1e-12);
      EXPECT_EQ(static_cast<int>(f.sections.size()), (order + 1) / 2);
    }
}

TEST(Butterworth, MinusThreeDecibelsAtCutoff) {
  for (int order : {1, 2, 3, 4, 6, 8})
    for (double fc : {0.1, 1.0, 10.0, 30.0}) {
      const SosFilter f = butterworth_lowpass(order, fc, 100.0);
      const double db = 20.0 * std::log10(f.magnitude(fc));
      EXPECT_NEAR(db, -3.0103, 1e-4) << "order " << order << " fc " << fc;
    }
}

TEST(Butterworth, AgreesWithClosedFormMagnitude) {
  const double fs = 200.0;
  for (int order : {1, 2, 5, 6, 7}) {
    const double fc = 7.5;
    const SosFilter f = butterworth_lowpass(order, fc, fs);
    for (double fr = 0.0; fr < 0.5 * fs; fr += 0.37) {
      const double ref = reference_magnitude(order, fc, fs, fr);
      EXPECT_NEAR(f.magnitude(fr), ref, 1e-10 * std::max(1.0, ref)) << order << " at " << fr;
    }
  }
}

// Known published coefficients: butter(2, 0.5) (cutoff at a quarter of the sample rate) is
// b = [0.29289322, 0.58578644, 0.29289322], a = [1, 0, 0.17157288]  (= (2 − √2)/(2 + √2)).
TEST(Butterworth, SecondOrderQuarterRateCoefficients) {
  const SosFilter f = butterworth_lowpass(2, 25.0, 100.0);
  ASSERT_EQ(f.sections.size(), 1u);
  const Biquad& s = f.sections[0];
  EXPECT_NEAR(s.b0, 0.29289322, 1e-8);
  EXPECT_NEAR(s.b1, 0.58578644, 1e-8);
  EXPECT_NEAR(s.b2, 0.29289322, 1e-8);
  EXPECT_NEAR(s.a1, 0.0, 1e-12);
  EXPECT_NEAR(s.a2, 0.17157288, 1e-8);
}

// Independent route for the paper's 6th order: the tabulated normalised Butterworth polynomial
// B6(s) = s⁶ + 3.8637033 s⁵ + 7.4641016 s⁴ + 9.1416202 s³ + 7.4641016 s² + 3.8637033 s + 1,
// bilinear-transformed as one direct-form polynomial, must give the SOS cascade's response.
TEST(Butterworth, SixthOrderMatchesTabulatedPolynomial) {
  const double fs = 100.0, fc = 2.0;
  const SosFilter f = butterworth_lowpass(6, fc, fs);
  const double c[7] = {1.0, 3.8637033, 7.4641016, 9.1416202, 7.4641016, 3.8637033, 1.0};
  const double K = std::tan(pi * fc / fs);
  for (double fr : {0.0, 0.5, 1.0, 1.9, 2.0, 2.1, 3.0, 5.0, 10.0, 30.0, 49.0}) {
    const std::complex<double> zi = std::polar(1.0, -2.0 * pi * fr / fs);
    const std::complex<double> p = 1.0 + zi, m = 1.0 - zi;  // s = m / (K p)
    std::complex<double> den = 0.0;
    for (int i = 0; i <= 6; ++i) den += c[i] * std::pow(m, i) * std::pow(K * p, 6 - i);
    const std::complex<double> h = std::pow(K * p, 6) / den;
    EXPECT_NEAR(std::abs(f.response(fr) - h), 0.0, 2e-7 * std::max(1e-3, std::abs(h))) << fr;
  }
}

TEST(Butterworth, StableEvenForVeryLowCutoffs) {
  for (int order = 1; order <= 12; ++order)
    for (double ratio : {1e-5, 1e-3, 0.01, 0.1, 0.3, 0.49}) {
      const SosFilter f = butterworth_lowpass(order, ratio * 1000.0, 1000.0);
      EXPECT_TRUE(f.stable()) << order << " " << ratio;
      EXPECT_LT(f.max_pole_radius(), 1.0);
    }
  // The impulse response of the paper's filter decays.
  const SosFilter f = butterworth_lowpass(6, 1.0, 100.0);
  std::vector<double> x(5000, 0.0);
  x[0] = 1.0;
  const auto y = filter(f, x, InitialState::kZero);
  double tail = 0.0;
  for (std::size_t i = 4000; i < y.size(); ++i) tail = std::max(tail, std::abs(y[i]));
  EXPECT_LT(tail, 1e-12);
}

TEST(Butterworth, RejectsBadDesigns) {
  EXPECT_THROW(butterworth_lowpass(0, 1.0, 100.0), std::invalid_argument);
  EXPECT_THROW(butterworth_lowpass(6, 50.0, 100.0), std::invalid_argument);
  EXPECT_THROW(butterworth_lowpass(6, 0.0, 100.0), std::invalid_argument);
  EXPECT_THROW(butterworth_lowpass(6, 1.0, -1.0), std::invalid_argument);
}

TEST(Butterworth, CausalFilterMatchesResponseOnSinusoid) {
  const double fs = 100.0, fc = 2.0, f0 = 3.0;
  const SosFilter f = butterworth_lowpass(6, fc, fs);
  std::vector<double> x(20000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::sin(2 * pi * f0 * static_cast<double>(i) / fs);
  const auto y = filter(f, x, InitialState::kZero);
  const std::complex<double> h = f.response(f0);
  for (std::size_t i = 15000; i < x.size(); i += 97) {
    const double t = static_cast<double>(i) / fs;
    const double expect = std::abs(h) * std::sin(2 * pi * f0 * t + std::arg(h));
    EXPECT_NEAR(y[i], expect, 1e-9);
  }
}

TEST(Butterworth, ZeroPhaseHasNoDelayAndSquaredGain) {
  const double fs = 100.0, fc = 2.0, f0 = 1.5;
  const SosFilter f = butterworth_lowpass(6, fc, fs);
  std::vector<double> x(20000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 3.0 + std::sin(2 * pi * f0 * static_cast<double>(i) / fs);
  const auto y = filtfilt(f, x);
  ASSERT_EQ(y.size(), x.size());
  const double g2 = std::pow(f.magnitude(f0), 2);
  for (std::size_t i = 5000; i < 15000; i += 101) {
    const double t = static_cast<double>(i) / fs;
    EXPECT_NEAR(y[i], 3.0 + g2 * std::sin(2 * pi * f0 * t), 1e-8);
  }
  // A constant passes unchanged, edges included (steady-state initial conditions).
  std::vector<double> c(50, 9.81);
  for (double v : filtfilt(f, c)) EXPECT_NEAR(v, 9.81, 1e-12);
  for (double v : filter(f, c)) EXPECT_NEAR(v, 9.81, 1e-12);
}

TEST(StaticExtraction, RecoversConstantUnderNoiseAndVibration) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 0.02);
  const double fs = 200.0;
  std::vector<double> t, x;
  for (int i = 0; i < 6000; ++i) {  // 30 s
    const double ti = 100.0 + i / fs;
    t.push_back(ti);
    x.push_back(9.7 + 0.5 * std::sin(2 * pi * 25.0 * ti) + n(rng));
  }
  StaticExtractionSettings s;
  s.cutoff_hz = 1.0;
  s.settle_s = 3.0;
  const StaticValue v = extract_static(t, x, 102.0, 128.0, s);
  EXPECT_NEAR(v.sample_rate_hz, fs, 1e-6);
  EXPECT_EQ(v.n_segment, 26u * 200u + 1u);
  EXPECT_GE(v.t_first_s, 105.0);
  EXPECT_LE(v.t_last_s, 125.0);
  EXPECT_NEAR(v.t_last_s - v.t_first_s, 20.0, 0.01);
  EXPECT_NEAR(v.mean, 9.7, 0.003);
  EXPECT_LT(v.filtered_std, 0.01);   // vibration and noise removed
  EXPECT_GT(v.raw_std, 0.3);         // … which the raw samples still carry
  EXPECT_NEAR(v.white_std_error, v.raw_std / std::sqrt(static_cast<double>(v.n_used)), 1e-15);
}

TEST(StaticExtraction, CausalFilterTransientNeedsSettleTime) {
  // The segment opens 5 s before the signal steps from 0 to 1 (e.g. the table still moving): the
  // causal filter's step response must fall inside the discarded settle time.
  const double fs = 100.0;
  std::vector<double> t, x;
  for (int i = 0; i < 3000; ++i) {
    t.push_back(i / fs);
    x.push_back(i / fs < 10.0 ? 0.0 : 1.0);
  }
  StaticExtractionSettings s;
  s.cutoff_hz = 2.0;
  s.zero_phase = false;
  s.settle_s = 8.0;  // keeps [13, 21] s: 3 s after the step, the filter has settled
  EXPECT_NEAR(extract_static(t, x, 5.0, 29.0, s).mean, 1.0, 1e-6);
  s.settle_s = 4.5;  // keeps [9.5, 24.5] s: the step and its transient pull the average away
  EXPECT_GT(std::abs(extract_static(t, x, 5.0, 29.0, s).mean - 1.0), 1e-2);
  // A constant segment needs no settle time at all (steady-state initial conditions).
  std::vector<double> c(3000, 1.0);
  s.settle_s = 0.0;
  EXPECT_NEAR(extract_static(t, c, 12.0, 29.0, s).mean, 1.0, 1e-12);
}

TEST(StaticExtraction, ExplainsWhatToChange) {
  std::vector<double> t, x;
  for (int i = 0; i < 100; ++i) {
    t.push_back(i * 0.01);
    x.push_back(1.0);
  }
  StaticExtractionSettings s;
  s.settle_s = 0.6;
  try {
    extract_static(t, x, 0.0, 0.99, s);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("shorten settle_s"), std::string::npos) << e.what();
  }
  s.settle_s = 0.1;
  s.cutoff_hz = 60.0;  // above Nyquist of 100 Hz sampling
  try {
    extract_static(t, x, 0.0, 0.99, s);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("lower cutoff_hz"), std::string::npos) << e.what();
  }
  EXPECT_THROW(extract_static(t, x, 5.0, 6.0, s), std::invalid_argument);  // no samples
}
