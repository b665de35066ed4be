// The text report of a ceres_nonlinear result, and what the report and the results document
// read of it. See stend/ceres_nonlinear/calibration.hpp.
#include "report.hpp"

#include "stend/estimation/report_section.hpp"

#include <stend/physics/units.hpp>

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace stend::ceres_nonlinear {

using namespace detail;

const char* method_name(Method m) {
  switch (m) {
    case Method::kUnknownOrientations: return "unknown_orientations";
    case Method::kKnownOrientations: return "known_orientations";
    case Method::kRateTable: return "rate_table";
    case Method::kIntegration: return "integration";
    case Method::kTurns: return "turns";
    case Method::kEarthRate: return "earth_rate";
  }
  return "?";
}

namespace detail {

const Rms& reported_rms(const CalibrationResult& r) {
  switch (r.method) {
    case Method::kRateTable:
    case Method::kEarthRate: return r.rate_error_radps;
    case Method::kIntegration: return r.direction_error_rad;
    case Method::kTurns: return r.turn_error_rad;
    case Method::kUnknownOrientations:
    case Method::kKnownOrientations: break;
  }
  return r.norm_error_mps2;
}

const AxisRms& reported_axis_rms(const CalibrationResult& r) {
  switch (r.method) {
    case Method::kUnknownOrientations: return r.norm_error_axis_mps2;
    case Method::kIntegration: return r.direction_error_axis_rad;
    case Method::kTurns: return r.turn_error_axis_rad;
    case Method::kKnownOrientations:
    case Method::kRateTable:
    case Method::kEarthRate: break;
  }
  return r.truth_error_axis;
}

int norm_check_dof(const CalibrationResult& r) {
  const int magnitudes = static_cast<int>(r.intervals.size());
  if (r.method == Method::kKnownOrientations && r.whitened) {
    int bias_scale = 0;
    for (const auto& p : r.parameters)
      bias_scale += !p.held && (p.name.rfind("bias_", 0) == 0 || p.name.rfind("scale_", 0) == 0);
    return magnitudes - bias_scale;
  }
  return r.dof;
}

std::string norm_check_caveat(const CalibrationResult& r) {
  const int dof = norm_check_dof(r);
  const int fitted = static_cast<int>(r.intervals.size()) - dof;
  if (dof <= 0)
    return fmt::format("zero by construction ({} magnitudes for {} parameters fitted to them): no check of the "
                       "calibration",
                       r.intervals.size(), fitted);
  if (dof < estimation::kFewDegreesOfFreedom)
    return fmt::format("fitted to these {} magnitudes by {} parameters, {} degree{} of freedom left: no measure of "
                       "accuracy",
                       r.intervals.size(), fitted, dof, dof == 1 ? "" : "s");
  return {};
}

std::string fmt_num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "—"; }

const char* interval_kind(Method m) {
  switch (m) {
    case Method::kRateTable: return "rate and static";
    case Method::kTurns: return "still";
    case Method::kEarthRate: return "still (known orientation and rate)";
    case Method::kUnknownOrientations:
    case Method::kKnownOrientations:
    case Method::kIntegration: break;
  }
  return "static";
}

const char* check_unit(Method m) {
  switch (m) {
    case Method::kIntegration:
    case Method::kTurns: return "rad";
    case Method::kRateTable:
    case Method::kEarthRate: return "radps";
    case Method::kUnknownOrientations:
    case Method::kKnownOrientations: break;
  }
  return "mps2";
}

// Each turn's integrated reading against the stated turn, raw and calibrated [deg].
std::string turns_report(const CalibrationResult& r) {
  const double deg = physics::kRadToDeg;
  std::string s = fmt::format("integrated turn − stated turn (RMS of |v − θ|): raw {} deg, calibrated {} deg\n",
                              fmt_num(r.turn_error_rad.before * deg), fmt_num(r.turn_error_rad.after * deg));
  for (const TurnCheck& t : r.turns) {
    const Eigen::Vector3d st = t.stated_rad * deg, b = t.before_rad * deg, a = t.after_rad * deg;
    s += fmt::format("  turn {:<12} {:.2f}–{:.2f} s: stated ({} {} {}) deg, integrated raw ({} {} {}), calibrated "
                     "({} {} {})\n",
                     t.label, t.t_start_s, t.t_end_s, fmt_num(st[0]), fmt_num(st[1]), fmt_num(st[2]), fmt_num(b[0]),
                     fmt_num(b[1]), fmt_num(b[2]), fmt_num(a[0]), fmt_num(a[1]), fmt_num(a[2]));
  }
  return s;
}

}  // namespace detail

const char* CalibrationResult::sigma_unit() const {
  if (whitened) return "(whitened residuals; 1 = as expected)";
  if (method == Method::kIntegration) return "rad (gravity direction)";  // never whitened
  return is_gyroscope() ? "rad/s" : "m/s^2";
}

const estimation::ParameterEstimate& CalibrationResult::parameter(const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name) return p;
  for (const auto& p : gyro_bias)
    if (p.name == name) return p;
  throw std::out_of_range("no parameter '" + name + "'");
}

Eigen::Vector3d CalibrationResult::correct(const Eigen::Vector3d& y) const {
  if (!ok()) throw std::logic_error("CalibrationResult::correct: the calibration failed: " + message);
  return model.correct(theta.data(), y, model::Stimulus<double>{});
}

std::string CalibrationResult::report() const {
  const bool gyro = model.instrument == model::Instrument::kGyroscope;
  if (status == estimation::FitStatus::kNotApplicable)  // nothing was fitted, no method ran
    return fmt::format("Ceres {} calibration\nstatus: {} — {}\n", gyro ? "gyroscope" : "accelerometer",
                       estimation::status_text(status), message);
  std::string s = fmt::format("Ceres {} calibration ({})\n", gyro ? "gyroscope" : "accelerometer", method_name(method));
  s += fmt::format("status: {}\n", ok() ? "ok" : "FAILED — " + message);
  s += fmt::format("{} intervals: {}{}, residuals: {}, estimated parameters: {}, dof: {}, condition number {}{}\n",
                   interval_kind(method), intervals.size(),
                   method == Method::kTurns ? fmt::format(", turns: {}", turns.size()) : std::string(), observations,
                   estimated, dof, fmt_num(condition_number),
                   gyro ? std::string() : fmt::format(", g = {} m/s^2", gravity_mps2));
  s += fmt::format("residual sigma: {} {}, solver: {}\n", fmt_num(sigma), sigma_unit(), solver_report);
  const AxisRms& axis = reported_axis_rms(*this);
  const Eigen::Vector3d& after = axis.after;
  const Eigen::Vector3d& before = axis.before;
  if (detection) s += detection->print() + "\n";
  if (!gyro) {
    const std::string caveat = ok() ? norm_check_caveat(*this) : std::string();
    s += fmt::format("RMS of |a| - g over the intervals: raw {} m/s^2, calibrated {} m/s^2{}\n",
                     fmt_num(norm_error_mps2.before), fmt_num(norm_error_mps2.after),
                     caveat.empty() ? "" : " — " + caveat);
    s += fmt::format("residual RMS per axis (x y z), calibrated: {} {} {} m/s^2 = {} {} {} mg; raw: {} {} {} mg\n",
                     fmt_num(after[0]), fmt_num(after[1]), fmt_num(after[2]),
                     fmt_num(after[0] / physics::kMilliG), fmt_num(after[1] / physics::kMilliG),
                     fmt_num(after[2] / physics::kMilliG), fmt_num(before[0] / physics::kMilliG),
                     fmt_num(before[1] / physics::kMilliG), fmt_num(before[2] / physics::kMilliG));
  } else if (method == Method::kTurns) {
    s += turns_report(*this);
  } else if (method == Method::kEarthRate) {
    const double dps = 1.0 / physics::kDegPerSecond;
    s += fmt::format("u·ȳ − Ω_v over the stills (RMS): raw {} deg/s, calibrated {} deg/s\n",
                     fmt_num(rate_error_radps.before * dps), fmt_num(rate_error_radps.after * dps));
  } else if (method == Method::kIntegration) {
    s += fmt::format("gravity-direction mismatch after each move (RMS): raw {} rad, calibrated {} rad; per axis "
                     "calibrated {} {} {} rad\n",
                     fmt_num(direction_error_rad.before), fmt_num(direction_error_rad.after), fmt_num(after[0]),
                     fmt_num(after[1]), fmt_num(after[2]));
  } else {
    const double dps = 1.0 / physics::kDegPerSecond;
    s += fmt::format("residual RMS per axis (x y z), calibrated: {} {} {} rad/s = {} {} {} deg/s; raw: {} {} {} deg/s\n",
                     fmt_num(after[0]), fmt_num(after[1]), fmt_num(after[2]),
                     fmt_num(after[0] * dps), fmt_num(after[1] * dps),
                     fmt_num(after[2] * dps), fmt_num(before[0] * dps),
                     fmt_num(before[1] * dps), fmt_num(before[2] * dps));
  }
  s += fmt::format("{:<22} {:>14} {:<14} {:>12} {:>14} {:>14}  {:<12} {}\n", "parameter", "value", "unit",
                   "std error", "95% lower", "95% upper", "verdict", "note");
  auto row = [&](const estimation::ParameterEstimate& p) {  // in the row's display unit (mg, deg/s, ppm, …)
    const estimation::DisplayUnit du = estimation::display_unit(p.unit);
    s += fmt::format("{:<22} {:>14} {:<14} {:>12} {:>14} {:>14}  {:<12} {}\n", p.name, fmt_num(p.value * du.scale),
                     du.unit, fmt_num(p.std_error * du.scale), fmt_num(p.lower * du.scale),
                     fmt_num(p.upper * du.scale), p.held ? "fixed" : estimation::to_string(p.judged()), p.reason);
  };
  for (const auto& p : parameters) row(p);
  for (const auto& p : gyro_bias) row(p);
  if (!uncertainty.empty()) s += "uncertainty: " + uncertainty + "\n";
  for (const auto& n : notes) s += "note: " + n + "\n";
  return s;
}

}  // namespace stend::ceres_nonlinear
