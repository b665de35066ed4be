// Internal to ceres_nonlinear: what the text report and the results document read of a result
// (report.cpp).
#pragma once

#include <stend/ceres_nonlinear/calibration.hpp>

#include <string>

namespace stend::ceres_nonlinear::detail {

// The overall check a procedure reports: |ȳ| − g (accelerometer), the rate error (rate table), the
// gravity-direction mismatch (integration).
const Rms& reported_rms(const CalibrationResult& r);
// The per-axis check a procedure reports: (|c| − g)·ĉ (unknown orientations), against the truth
// (known orientations, rate table), the gravity-direction mismatch (integration).
const AxisRms& reported_axis_rms(const CalibrationResult& r);

// The degrees of freedom of an accelerometer fit's |a| − g check: the intervals' magnitudes less the
// parameters fitted to them — all of an unknown-orientations fit's; with a placement sigma a
// known-orientation fit fits the magnitudes apart from the directions, by its biases and scales (6);
// without one it fits whole vectors, and the check has the fit's own dof.
int norm_check_dof(const CalibrationResult& r);
// Why an accelerometer fit's calibrated |a| − g is no measure of its accuracy: zero by construction
// (norm_check_dof ≤ 0) or resting on fewer than estimation::kFewDegreesOfFreedom; "" otherwise.
std::string norm_check_caveat(const CalibrationResult& r);

// A number in the report: %.6g, "—" for NaN.
std::string fmt_num(double v);

// What a procedure's intervals are, in the report ("static", "rate and static", "still", …).
const char* interval_kind(Method m);
// The unit suffix of a procedure's checks in the results document: "mps2", "radps" or "rad".
const char* check_unit(Method m);
// The turns method's per-turn lines: integrated reading against the stated turn [deg].
std::string turns_report(const CalibrationResult& r);

}  // namespace stend::ceres_nonlinear::detail
