// Raw-sample access shared by the diagnosis' input and noise-stage evidence. Internal to
// stend_diagnosis.
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

#include "stend/recording.hpp"

namespace stend::diagnosis {

using SampleIt = std::vector<ImuSample>::const_iterator;

// The samples with t_start_s ≤ t_s ≤ t_end_s [s] (samples sorted by time).
inline std::pair<SampleIt, SampleIt> sample_window(const std::vector<ImuSample>& S, double t_start_s,
                                                   double t_end_s) {
  const auto lo = std::lower_bound(S.begin(), S.end(), t_start_s,
                                   [](const ImuSample& s, double t) { return s.t_s < t; });
  const auto hi = std::upper_bound(S.begin(), S.end(), t_end_s,
                                   [](double t, const ImuSample& s) { return t < s.t_s; });
  return {lo, hi};
}

// Axis a of the instrument's reading: specific force [m/s²] or angular rate [rad/s].
inline double axis_value(const ImuSample& s, bool accel, int a) { return accel ? s.accel_mps2[a] : s.gyro_radps[a]; }

}  // namespace stend::diagnosis
