// Internal to ceres_nonlinear: what the two gyroscope procedures share (gyro_rate_table.cpp).
#pragma once

#include "solver.hpp"

namespace stend::ceres_nonlinear::detail {

// r.parameters for every parameter of the gyro model, all estimated.
void init_gyro_parameters(CalibrationResult& r);

}  // namespace stend::ceres_nonlinear::detail
