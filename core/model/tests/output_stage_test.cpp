// The output stage's white-noise σ: the low-pass's exact noise gain against its impulse response,
// against filtered noise, and against the continuous-time equivalent noise bandwidth.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "stend/model/noise.hpp"
#include "stend/model/output_stage.hpp"

namespace {

using stend::model::Biquad;
using stend::model::white_noise_output_sigma;

TEST(OutputStageNoise, NoiseGainIsTheSumOfTheSquaredImpulseResponse) {
  for (const auto& [fc, fs] : {std::pair{44.0, 200.0}, {44.0, 1000.0}, {5.0, 1000.0}, {40.0, 100.0}, {0.5, 100.0}}) {
    Biquad f = Biquad::butterworth_lowpass(fc, fs);
    double sum = 0.0;
    for (int n = 0; n < 200000; ++n) {
      const double h = f(n == 0 ? 1.0 : 0.0);
      sum += h * h;
    }
    EXPECT_NEAR(Biquad::butterworth_lowpass(fc, fs).noise_gain(), sum, 1e-12 * sum) << fc << " Hz at " << fs << " Hz";
  }
}

TEST(OutputStageNoise, SigmaOfFilteredWhiteNoise) {
  const double density = 4e-3, fs = 200.0, fc = 44.0;
  EXPECT_DOUBLE_EQ(white_noise_output_sigma(density, fs, 0.0),
                   stend::model::WhiteNoise::sigma_from_density(density, 1.0 / fs));
  // The sensor's path: white samples of σ_white through its low-pass.
  stend::model::Rng rng(7);
  const stend::model::WhiteNoise w(density, 1.0 / fs);
  Biquad f = Biquad::butterworth_lowpass(fc, fs);
  const int n = 1000000;
  double s2 = 0.0;
  for (int k = 0; k < n; ++k) {
    const double y = f(w.sample(rng));
    s2 += y * y;
  }
  EXPECT_NEAR(std::sqrt(s2 / n) / white_noise_output_sigma(density, fs, fc), 1.0, 0.003);
}

TEST(OutputStageNoise, LowCutoffApproachesTheContinuousNoiseBandwidth) {
  // 2nd-order Butterworth: ENBW = π·fc / (2·2·sin(π/4)) ≈ 1.1107·fc when fc ≪ fs.
  const double density = 1.0, fs = 1000.0, fc = 5.0;
  const double enbw = std::numbers::pi * fc / (4.0 * std::sin(std::numbers::pi / 4.0));
  EXPECT_NEAR(white_noise_output_sigma(density, fs, fc), density * std::sqrt(enbw), 1e-3 * std::sqrt(enbw));
}

}  // namespace
