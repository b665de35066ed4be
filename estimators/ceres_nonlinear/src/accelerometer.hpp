// Internal to ceres_nonlinear: what the two accelerometer procedures share (accelerometer.cpp).
#pragma once

#include "solver.hpp"

#include <functional>

namespace stend::ceres_nonlinear::detail {

// r.gyro_bias from the static intervals' gyro means (options.estimate_gyro_bias: gyroscope:
// bias_only): the mean over the intervals [rad/s] with its standard error; it includes the Earth
// rotation projected on each axis.
void estimate_gyro_bias(CalibrationResult& r, const CalibrationOptions& o);

// Leave one out: for each interval k, fit_without(k) (the fit on the others) predicts it, and
// |correct(ȳ_k)| − g_k is its error (NaN where that fit failed). See HeldOutNormError.
HeldOutNormError held_out(const std::vector<processing::StaticPoint>& intervals, const std::vector<double>& g_mps2,
                          const std::function<CalibrationResult(std::size_t k)>& fit_without);

// r.norm_error_mps2 (|ȳ| − g over the intervals) and r.norm_error_axis_mps2 ((|c| − g)·ĉ per axis),
// raw and, when the fit succeeded, calibrated.
void norm_rms(CalibrationResult& r);

}  // namespace stend::ceres_nonlinear::detail
