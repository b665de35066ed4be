// Simulator grid for the noise-model fit: records from the simulated IMU (sim/, its own noise
// processes and output stage), analysed by stend::allan, scored against the simulator's
// configuration. Used by allan_grid_test (few seeds) and noise_grid_bench (the full table).
#pragma once

#include <stend/allan/allan.hpp>
#include <stend/sim/imu.hpp>

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace stend::allan::grid {

enum class Mix { kWhite, kWhiteGm, kWhiteRw, kAll };
inline const char* to_string(Mix m) {
  switch (m) {
    case Mix::kWhite: return "white";
    case Mix::kWhiteGm: return "white+GM";
    case Mix::kWhiteRw: return "white+RW";
    case Mix::kAll: return "all";
  }
  return "?";
}

struct Cell {
  double rate_hz = 100.0;
  bool lowpass = false;  // the sensor's low-pass at 0.184·rate (as 184 Hz at 1 kHz)
  Mix mix = Mix::kWhite;
  double duration_s = 600.0;
};

// The simulator's configuration of a cell: noise only (no deterministic errors), 24-bit words so
// the quantization step is far below the noise, the default white densities, a Gauss–Markov bias
// and random walk scaled to show within duration_s (τc = duration/120).
inline sim::SimImuConfig config_of(const Cell& c, std::int64_t seed) {
  sim::SimImuConfig s;
  s.output_rate_hz = c.rate_hz;
  s.lowpass_hz = c.lowpass ? 0.184 * c.rate_hz : 0.0;
  s.output_bits = 24;
  s.seed = seed;
  const bool gm = c.mix == Mix::kWhiteGm || c.mix == Mix::kAll;
  const bool rw = c.mix == Mix::kWhiteRw || c.mix == Mix::kAll;
  const double tc = c.duration_s / 120.0;
  s.accel_bias_instability_mps2 = gm ? 3e-3 : 0.0;
  s.accel_bias_correlation_s = tc;
  s.accel_random_walk = rw ? 2e-4 * std::sqrt(600.0 / c.duration_s) : 0.0;
  s.gyro_bias_instability_radps = gm ? 7e-5 : 0.0;
  s.gyro_bias_correlation_s = tc;
  s.gyro_random_walk = rw ? 4.5e-6 * std::sqrt(600.0 / c.duration_s) : 0.0;
  return s;
}

// Still sensor, Z up.
class StillTruth final : public TruthSource {
 public:
  BenchTruth at(double t_s) const override {
    BenchTruth b;
    b.t_s = t_s;
    b.specific_force_mps2 = {0.0, 0.0, 9.80665};
    return b;
  }
};

// The six channels of one simulated record, each analysed with the stated output filter.
inline std::vector<ChannelResult> analyze_record(const Cell& cell, std::int64_t seed) {
  const sim::SimImuConfig cfg = config_of(cell, seed);
  sim::SimImu imu(cfg);
  StillTruth truth;
  std::vector<ImuSample> samples;
  imu.acquire(cell.duration_s, truth, samples);
  const std::size_t n = samples.size();
  std::vector<double> y(n);
  AllanOptions opt;
  opt.lowpass_hz = cfg.lowpass_hz;
  std::vector<ChannelResult> out;
  static const char* names[6] = {"ax", "ay", "az", "gx", "gy", "gz"};
  for (int ch = 0; ch < 6; ++ch) {
    for (std::size_t i = 0; i < n; ++i) y[i] = ch < 3 ? samples[i].accel_mps2[ch] : samples[i].gyro_radps[ch - 3];
    out.push_back(analyze(y.data(), n, 1, cfg.output_rate_hz,
                          {names[ch], ch < 3 ? Instrument::kAccelerometer : Instrument::kGyroscope, {}}, opt));
  }
  return out;
}

// Truth of a channel's coefficients in the estimator's convention (NaN = absent): N = one-sided
// density/√2 (AVAR N²/τ), K, G = σ and Tc = τc of the Gauss–Markov bias; Q, B, R are absent.
struct Truth {
  double N = NAN, K = NAN, G = NAN, Tc = NAN;
};
inline Truth truth_of(const sim::SimImuConfig& c, bool gyro) {
  Truth t;
  t.N = (gyro ? c.gyro_noise_density : c.accel_noise_density) / std::sqrt(2.0);
  const double k = gyro ? c.gyro_random_walk : c.accel_random_walk;
  const double g = gyro ? c.gyro_bias_instability_radps : c.accel_bias_instability_mps2;
  if (k > 0.0) t.K = k;
  if (g > 0.0) {
    t.G = g;
    t.Tc = gyro ? c.gyro_bias_correlation_s : c.accel_bias_correlation_s;
  }
  return t;
}

// Counts over the channels of a cell, per coefficient Q N B K R G Tc.
struct Score {
  std::array<int, 7> present{}, covered{}, off{}, absent{}, false_identified{};
  std::array<int, 7> identified{};
  int failed = 0;
};

// A present coefficient's reported interval covers the truth: identified with truth in [lo, hi],
// or not identified with truth ≤ its upper bound (Tc not identified: nothing claimed, counted as
// covered only when its σ_G is not identified either). Off: identified and outside [lo, hi].
inline void score_channel(const NoiseModel& m, const Truth& t, Score& s) {
  if (!m.ok) {
    ++s.failed;
    return;
  }
  const std::array<double, 7> truth = {NAN, t.N, NAN, t.K, NAN, t.G, t.Tc};
  for (int j = 0; j < 7; ++j) {
    const Coefficient& c = m.coefficients()[j];
    if (std::isnan(truth[static_cast<std::size_t>(j)])) {
      ++s.absent[static_cast<std::size_t>(j)];
      s.false_identified[static_cast<std::size_t>(j)] += c.identified ? 1 : 0;
      continue;
    }
    const double v = truth[static_cast<std::size_t>(j)];
    ++s.present[static_cast<std::size_t>(j)];
    s.identified[static_cast<std::size_t>(j)] += c.identified ? 1 : 0;
    bool cover;
    if (c.identified) cover = c.lo <= v && v <= c.hi;
    else if (j == 6) cover = !m.gauss_markov.identified;
    else cover = v <= c.upper_bound;
    s.covered[static_cast<std::size_t>(j)] += cover ? 1 : 0;
    s.off[static_cast<std::size_t>(j)] += (c.identified && !cover) ? 1 : 0;
  }
}

inline const char* symbol_of(int j) {
  static const char* s[7] = {"Q", "N", "B", "K", "R", "G", "Tc"};
  return s[j];
}

}  // namespace stend::allan::grid
