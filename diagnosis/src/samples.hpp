// Raw-sample access shared by the diagnosis' input and noise-stage evidence. Internal to
// stend_diagnosis.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "stend/recording.hpp"

namespace stend::diagnosis {

using SampleIt = std::vector<ImuSample>::const_iterator;

// The samples with t_start_s ≤ t_s ≤ t_end_s [s], read from the recording's store (one segment).
inline std::vector<ImuSample> read_window(const Recording& rec, double t_start_s, double t_end_s) {
  return read_interval(rec.sample_source(), t_start_s,
                       std::nextafter(t_end_s, std::numeric_limits<double>::infinity()));
}

// Axis a of the instrument's reading: specific force [m/s²] or angular rate [rad/s].
inline double axis_value(const ImuSample& s, bool accel, int a) { return accel ? s.accel_mps2[a] : s.gyro_radps[a]; }

}  // namespace stend::diagnosis
