// The options of the ceres_nonlinear procedures: their checks and the loss names. See
// stend/ceres_nonlinear/calibration.hpp and model_file.hpp.
#include <stend/ceres_nonlinear/model_file.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace stend::ceres_nonlinear {

namespace {

bool fail(std::string* error, const std::string& why) {
  if (error) *error = why;
  return false;
}

bool one_of(const std::string& s, std::initializer_list<const char*> allowed) {
  return std::any_of(allowed.begin(), allowed.end(), [&](const char* a) { return s == a; });
}

// What the two procedures' solver settings share.
bool solver_settings_valid(double confidence, int max_iterations, double rank_tolerance,
                           const estimation::PrecisionTolerances& tolerances, std::string* error) {
  if (!(confidence > 0.0 && confidence < 1.0)) return fail(error, "confidence must be in (0, 1), e.g. 0.95");
  if (max_iterations < 1 || max_iterations > 100000) return fail(error, "max_iterations must be an integer in 1..100000");
  if (!(rank_tolerance > 0.0)) return fail(error, "rank_tolerance must be > 0 (a ratio of singular values)");
  return tolerances.IsValid(error);
}

}  // namespace

const char* loss_name(Loss l) {
  switch (l) {
    case Loss::kHuber: return "huber";
    case Loss::kCauchy: return "cauchy";
    case Loss::kNone: break;
  }
  return "none";
}

Loss loss_from_name(const std::string& name) {
  if (name == "none") return Loss::kNone;
  if (name == "huber") return Loss::kHuber;
  if (name == "cauchy") return Loss::kCauchy;
  throw std::invalid_argument("unknown loss '" + name + "' (expected none, huber or cauchy)");
}

bool CalibrationOptions::IsValid(std::string* error) const {
  if (!(gravity_mps2 >= 0.0) || !std::isfinite(gravity_mps2))
    return fail(error, "gravity_mps2 must be >= 0 m/s^2 (0: the recording's)");
  if (!(loss_scale_mps2 > 0.0)) return fail(error, "loss_scale_mps2 must be > 0 m/s^2");
  if (!solver_settings_valid(confidence, max_iterations, rank_tolerance, tolerances, error)) return false;
  for (const auto& c : fixed_cross_axis)
    if (!one_of(c, {"cross_xy", "cross_xz", "cross_yx", "cross_yz", "cross_zx", "cross_zy"}))
      return fail(error, "fixed_cross_axis: unknown cross-axis term '" + c + "'");
  if (!(orientation_sigma_deg >= 0.0)) return fail(error, "orientation_sigma_deg must be >= 0 deg");
  for (const auto& t : table_offsets)
    if (!one_of(t, {"tilt", "rotation"}))
      return fail(error, "table_offsets: '" + t + "' cannot be estimated (only tilt and rotation; gravity does not "
                         "depend on the azimuth)");
  return processing.IsValid(error);
}

bool GyroOptions::IsValid(std::string* error) const {
  if (!(loss_scale_radps > 0.0)) return fail(error, "gyro_loss_scale_radps must be > 0 rad/s");
  if (!(loss_scale_rad > 0.0)) return fail(error, "gyro_loss_scale_rad must be > 0 rad");
  if (!(turn_angle_sigma_deg > 0.0 && std::isfinite(turn_angle_sigma_deg)))
    return fail(error, "turn_angle_sigma_deg must be > 0 deg");
  if (!(rate_axis_sigma_deg >= 0.0 && std::isfinite(rate_axis_sigma_deg)))
    return fail(error, "rate_axis_sigma_deg must be >= 0 deg");
  if (!(orientation_sigma_deg >= 0.0 && std::isfinite(orientation_sigma_deg)))
    return fail(error, "orientation_sigma_deg must be >= 0 deg");
  if (!(g_sensitivity_sigma_dps_per_g >= 0.0 && std::isfinite(g_sensitivity_sigma_dps_per_g)))
    return fail(error, "g_sensitivity_sigma_dps_per_g must be >= 0 (deg/s)/g");
  if (!solver_settings_valid(confidence, max_iterations, rank_tolerance, tolerances, error)) return false;
  return processing.IsValid(error);
}

bool ModelFileOptions::IsValid(std::string* error) const {
  if (!one_of(accelerometer, {"unknown_orientations", "known_orientations", "none"}))
    return fail(error, "accelerometer: expected unknown_orientations, known_orientations or none, got '" + accelerometer + "'");
  if (std::find(kGyroscopeMethods.begin(), kGyroscopeMethods.end(), gyroscope) == kGyroscopeMethods.end())
    return fail(error, "gyroscope: expected integration, rate_table, turns, earth_rate, bias_only or none, got '" +
                           gyroscope + "'");
  if (gyroscope == "earth_rate" && gyro.estimate_g_sensitivity)
    return fail(error, "gyroscope: earth_rate cannot estimate g-sensitivity (G_ii and scale_i flip together)");
  if (accelerometer == "none" && (gyroscope == "integration" || gyroscope == "bias_only"))
    return fail(error, "gyroscope: '" + gyroscope + "' needs the accelerometer calibration first (accelerometer: none)");
  if (accelerometer == "none" && gyroscope == "none") return fail(error, "nothing to fit: accelerometer and gyroscope are none");
  if (!accel.table_offsets.empty() && accelerometer != "known_orientations")
    return fail(error, "table_offsets are estimated only with accelerometer: known_orientations");
  return accel.IsValid(error) && gyro.IsValid(error);
}

}  // namespace stend::ceres_nonlinear
