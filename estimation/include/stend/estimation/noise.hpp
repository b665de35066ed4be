// The noise of each sensor channel, typed: what a noise analysis (e.g. the Allan estimator) gives
// the exports and the reports, whichever estimator wrote it.
//
// Per channel (accelerometer or gyroscope, one output axis) the three coefficients every IMU
// noise model names, each a ParameterEstimate (value ± σ and interval when identified; the reason,
// e.g. an upper bound, when not):
//   N  white noise density      [unit/√Hz]       (angle / velocity random walk)
//   K  random walk density      [unit/s/√Hz]     (rate / acceleration random walk)
//   B  bias instability         [unit]
// and, per sensor, what stands for N and K when no axis identified them (a tool such as Kalibr
// takes one number per sensor): the estimator's slope read-off, else its upper bound.
#pragma once

#include <stend/estimation/summary.hpp>
#include <stend/model/terms.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace stend::estimation {

struct ChannelNoise {
  std::string channel;  // "ax" … "gz"
  model::Instrument instrument = model::Instrument::kAccelerometer;
  int axis = 0;  // 0 x, 1 y, 2 z
  ParameterEstimate white_noise;       // N
  ParameterEstimate random_walk;       // K
  ParameterEstimate bias_instability;  // B

  bool equals(const ChannelNoise& other, double rel_tol = 1e-9, double abs_tol = 0.0) const;
};

// A density of one sensor that none of its axes identified: the estimator's stand-in.
struct UnidentifiedDensity {
  double value = NAN;        // in the density's unit; NaN when the estimator has none
  bool upper_bound = false;  // value is an upper bound (else a slope read-off)
};

struct SensorNoise {
  UnidentifiedDensity white_noise, random_walk;  // N, K
};

struct NoiseResult {
  std::vector<ChannelNoise> channels;
  double rate_hz = NAN;       // sample rate of the analysed record [Hz]
  std::uint64_t samples = 0;  // samples analysed
  std::array<SensorNoise, 2> sensors;  // [accelerometer, gyroscope]

  const ChannelNoise* find(model::Instrument instrument, int axis) const;  // nullptr when absent
  const SensorNoise& sensor(model::Instrument instrument) const {
    return sensors[instrument == model::Instrument::kAccelerometer ? 0 : 1];
  }
  SensorNoise& sensor(model::Instrument instrument) {
    return sensors[instrument == model::Instrument::kAccelerometer ? 0 : 1];
  }
  // Whether any coefficient of any channel was identified.
  bool any_identified() const;

  // "noise: 6 channels, 1000 Hz, 360000 samples", then a row per channel (N, K, B).
  void print(std::ostream& os) const;
  bool equals(const NoiseResult& other, double rel_tol = 1e-9, double abs_tol = 0.0) const;
};
std::ostream& operator<<(std::ostream& os, const NoiseResult& n);  // = print

}  // namespace stend::estimation
