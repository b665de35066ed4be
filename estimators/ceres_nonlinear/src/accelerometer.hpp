// Internal to ceres_nonlinear: what the two accelerometer procedures share (accelerometer.cpp).
#pragma once

#include "solver.hpp"

namespace stend::ceres_nonlinear::detail {

// r.gyro_bias from the static intervals' gyro means (options.estimate_gyro_bias: gyroscope:
// bias_only): the mean over the intervals [rad/s] with its standard error; it includes the Earth
// rotation projected on each axis.
void estimate_gyro_bias(CalibrationResult& r, const CalibrationOptions& o);

// r.norm_error_mps2 (|ȳ| − g over the intervals) and r.norm_error_axis_mps2 ((|c| − g)·ĉ per axis),
// raw and, when the fit succeeded, calibrated.
void norm_rms(CalibrationResult& r);

}  // namespace stend::ceres_nonlinear::detail
