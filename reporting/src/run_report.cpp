// The per-run HTML report (see run_report.hpp).
#include "stend/reporting/run_report.hpp"

#include "stend/allan/allan.hpp"
#include "stend/estimation/registry.hpp"
#include "stend/estimation/summary.hpp"
#include "stend/recording/files.hpp"
#include "stend/model/terms.hpp"
#include "stend/physics/units.hpp"
#include "stend/reporting/results.hpp"
#include "stend/recording/recording.hpp"
#include "stend/recording/samples.hpp"
#include "stend/reporting/svg_plot.hpp"
#include "display_unit.hpp"
#include "fitted_model.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace stend::reporting {

namespace fs = std::filesystem;
using nlohmann::json;
using svg::escape;
using svg::Plot;
using svg::Series;
using svg::Style;
using detail::contribution;
using detail::display_unit;
using detail::DisplayUnit;
using detail::fitted_model;
using detail::FittedModel;

namespace {

constexpr double kNaN = NAN;
const char* kAxes = "xyz";

double num(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return kNaN;
  return j[key].get<double>();
}
double at(const json& a, std::size_t i) {
  if (!a.is_array() || i >= a.size() || !a[i].is_number()) return kNaN;
  return a[i].get<double>();
}
std::string str(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_string()) return {};
  return j[key].get<std::string>();
}
int axis_index(const std::string& a) {
  if (a == "x") return 0;
  if (a == "y") return 1;
  if (a == "z") return 2;
  return -1;
}
std::string g(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "—"; }
std::string g3(double v) { return std::isfinite(v) ? fmt::format("{:.3g}", v) : "—"; }

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Loads RUN/<name> when present; a parse failure becomes an error paragraph in `body`.
bool load(const fs::path& dir, const std::string& name, json& out, std::string& body) {
  const fs::path f = dir / name;
  if (!fs::exists(f)) return false;
  try {
    out = json::parse(read_text(f));
    return true;
  } catch (const std::exception& e) {
    body += fmt::format("<p class=\"bad\">{}: not readable ({})</p>\n", escape(name), escape(e.what()));
    return false;
  }
}

std::string figure(const Plot& p, const std::string& caption) {
  return "<figure>" + p.render() + "<figcaption>" + escape(caption) + "</figcaption></figure>\n";
}

// A parameter's verdict (stend/estimation/identifiability.hpp): "determined", "imprecise: why" or
// "NO: why" (documents written before verdicts: an identified parameter is determined).
std::string verdict_text(const json& p) {
  if (!p.value("identifiable", false)) return "NO: " + escape(str(p, "reason"));
  const std::string v = str(p, "verdict");
  if (v == "imprecise") return "imprecise: " + escape(str(p, "reason"));
  return "determined";
}

// Parameter table of a "stend.fit/1"-shaped document.
std::string parameter_table(const json& fit) {
  if (!fit.contains("parameters") || !fit["parameters"].is_array()) return {};
  double conf = num(fit.value("solution", json::object()), "confidence");
  if (!std::isfinite(conf)) conf = num(fit, "confidence");
  std::string o = fmt::format(
      "<table class=\"params\"><tr><th>parameter</th><th>value</th><th>unit</th><th>std error</th><th>{} "
      "interval</th><th>verdict</th></tr>\n",
      std::isfinite(conf) ? fmt::format("{:.0f} %", 100 * conf) : "");
  for (const auto& p : fit["parameters"]) {
    const bool id = p.value("identifiable", false);
    const detail::DisplayUnit du = detail::display_unit(str(p, "unit"));  // the unit family of the plots
    std::string interval = "—";
    if (p.contains("interval") && p["interval"].is_array())
      interval = fmt::format("[{}, {}]", g(at(p["interval"], 0) * du.scale), g(at(p["interval"], 1) * du.scale));
    o += fmt::format("<tr{}><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     id ? "" : " class=\"nid\"", escape(str(p, "name")), id ? g(num(p, "value") * du.scale) : "not estimated",
                     escape(du.unit), g(num(p, "std_error") * du.scale), interval, verdict_text(p));
  }
  o += "</table>\n";
  if (fit.contains("aliases") && fit["aliases"].is_array())
    for (const auto& a : fit["aliases"]) {
      std::string names;
      for (const auto& n : a.value("parameters", json::array())) names += (names.empty() ? "" : ", ") + n.get<std::string>();
      o += fmt::format("<p class=\"warn\">aliased (the data cannot separate them): {}", escape(names));
      for (const auto& c : a.value("identified_combinations", json::array()))
        o += fmt::format("; identified: {} = {} ± {}", escape(str(c, "text")), g(num(c, "value")), g(num(c, "std_error")));
      o += "</p>\n";
    }
  for (const auto& w : fit.value("warnings", json::array()))
    if (w.is_string()) o += "<p class=\"warn\">warning: " + escape(w.get<std::string>()) + "</p>\n";
  return o;
}

// Display scale of residuals: mg for accelerometers, deg/h for gyroscopes.
double display_scale(const json& fit) {
  const json res = fit.value("residuals", json::object());
  const json rms = res.value("rms", json::object()), disp = res.value("rms_display", json::object());
  for (auto it = rms.begin(); it != rms.end(); ++it) {
    const double a = it->is_number() ? it->get<double>() : kNaN;
    const double b = disp.contains(it.key()) && disp[it.key()].is_number() ? disp[it.key()].get<double>() : kNaN;
    if (std::isfinite(a) && std::isfinite(b) && a > 0) return b / a;
  }
  return 1.0;
}

// The physical quantity each static point is plotted against: the tilt of the sensor [deg] when
// every true input lies in one plane through the sensor's z axis (a one-axis tilt, as in the
// paper), else the true input on the one axis that varies [unit], else the point number.
struct PointAxis {
  std::vector<double> x;  // per point
  std::string label;
  bool categories = false;
};

PointAxis point_axis(const json& points, const std::string& unit) {
  PointAxis a;
  std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  double mag = 0.0;
  for (const auto& pt : points)
    for (std::size_t k = 0; k < 3; ++k) {
      const double u = at(pt.value("true_input", json::array()), k);
      lo[k] = std::min(lo[k], u);
      hi[k] = std::max(hi[k], u);
      mag = std::max(mag, std::abs(u));
    }
  std::vector<std::size_t> varying, still_zero;
  for (std::size_t k = 0; k < 3; ++k) {
    if (!(hi[k] >= lo[k])) return {{}, "point number", true};  // a point without truth
    if (hi[k] - lo[k] > 1e-3 * mag) varying.push_back(k);
    else if (std::max(std::abs(lo[k]), std::abs(hi[k])) <= 1e-3 * mag) still_zero.push_back(k);
  }
  const bool tilt = unit == "m/s^2" && varying.size() == 2 && still_zero.size() == 1 && still_zero[0] != 2;
  for (const auto& pt : points) {
    const json u = pt.value("true_input", json::array());
    if (tilt) {
      const std::size_t h = still_zero[0] == 0 ? 1 : 0;  // the horizontal axis in the tilt plane
      a.x.push_back(std::atan2(at(u, h), at(u, 2)) * physics::kRadToDeg);
    } else if (varying.size() == 1) {
      a.x.push_back(at(u, varying[0]));
    }
  }
  if (tilt) {
    const std::size_t h = still_zero[0] == 0 ? 1 : 0;
    a.label = fmt::format("tilt: gravity direction from +z toward +{} [deg]", kAxes[h]);
  } else if (varying.size() == 1) {
    a.label = fmt::format("true input, axis {} [{}]", kAxes[varying[0]], unit);
  } else {
    a.categories = true;
    a.label = "orientation (point number; the truth varies on three axes)";
    a.x.clear();
  }
  return a;
}

// Residual against the physical quantity of each static point (point_axis): one series per fitted
// axis, with ±σ lines (residuals scaled to the display unit by ds).
std::string residual_plot(const json& fit, const json& points, const json& rows, const std::string& what,
                          const std::string& unit, const std::string& dunit, double ds) {
  const PointAxis pa = point_axis(points, unit);
  Plot r;
  r.title = what + ": residual against orientation";
  r.x_label = pa.label;
  r.y_label = "residual [" + dunit + "]";
  r.width = 760;
  if (pa.categories)
    for (std::size_t i = 0; i < points.size(); ++i) r.x_categories.push_back(fmt::format("{}", i));
  std::map<std::string, Series> by_axis;
  for (const auto& row : rows) {
    const std::string ax = str(row, "axis");
    auto& s = by_axis[ax];
    s.name = "axis " + ax;
    s.style = pa.categories ? Style::kLinePoints : Style::kPoints;
    const double pi = num(row, "point");
    const auto i = static_cast<std::size_t>(std::max(0.0, pi));
    s.x.push_back(pa.categories || !std::isfinite(pi) || i >= pa.x.size() ? pi : pa.x[i]);
    s.y.push_back(num(row, "residual") * ds);
  }
  for (auto& [ax, s] : by_axis) {
    const int k = axis_index(ax);
    s.color = svg::palette(k < 0 ? 3 : static_cast<std::size_t>(k));
    r.series.push_back(s);
  }
  r.lines.push_back({true, 0.0, "", "#555"});
  const double sigma = num(fit.value("solution", json::object()), "sigma");
  if (std::isfinite(sigma)) {
    r.lines.push_back({true, sigma * ds, "+σ", "#999"});
    r.lines.push_back({true, -sigma * ds, "−σ", "#999"});
  }
  return figure(r, "Residual Δ − fitted of each static orientation (σ: residual standard deviation of the fit).");
}

// Static means against truth on axis ax (index k): (measured − true) ± 2 SE against the true
// input, and the fitted model at the same stimulus (display unit via ds).
std::string static_mean_plot(const json& points, const json& rows, const std::string& what, const std::string& ax,
                             std::size_t k, const std::string& unit, const std::string& dunit, double ds) {
  Plot p;
  p.title = what + ": static mean − truth, axis " + ax;
  p.x_label = "true input, axis " + ax + " [" + unit + "]";
  p.y_label = "measured − true [" + dunit + "]";
  Series meas{"measured mean ± 2 SE", Style::kPoints, {}, {}, {}, {}, svg::palette(k), false, 1.0};
  Series fitted{"fitted model", Style::kPoints, {}, {}, {}, {}, "#000", false, 0.55};
  for (const auto& pt : points) {
    const double u = at(pt.value("true_input", json::array()), k);
    const double m = at(pt.value("measured", json::array()), k);
    const double se = at(pt.value("measured_std_error", json::array()), k);
    meas.x.push_back(u);
    meas.y.push_back((m - u) * ds);
    meas.y_lo.push_back((m - u - 2 * se) * ds);
    meas.y_hi.push_back((m - u + 2 * se) * ds);
  }
  for (const auto& row : rows) {
    if (str(row, "axis") != ax) continue;
    const auto pi = static_cast<std::size_t>(std::max(0.0, num(row, "point")));
    if (pi >= points.size()) continue;
    fitted.x.push_back(at(points[pi].value("true_input", json::array()), k));
    fitted.y.push_back(num(row, "fitted") * ds);
  }
  p.series = {meas, fitted};
  return figure(p, "Each static orientation's low-passed mean minus the bench truth, against the truth; black: the "
                   "fitted error model at the same stimulus.");
}

// Residual against orientation and static means against truth for a fit document.
std::string fit_plots(const json& fit, const std::string& what) {
  if (!fit.contains("points") || !fit.contains("residuals")) return {};
  const json& points = fit["points"];
  const json rows = fit["residuals"].value("rows", json::array());
  const std::string unit = fit.value("units", json::object()).value("residual", "m/s^2");
  const std::string dunit = fit.value("units", json::object()).value("residual_display", unit);
  const double ds = display_scale(fit);
  std::string o = residual_plot(fit, points, rows, what, unit, dunit, ds);
  std::set<std::string> axes;
  for (const auto& row : rows) axes.insert(str(row, "axis"));
  for (const std::string& ax : axes) {
    const int k = axis_index(ax);
    if (k < 0) continue;
    o += static_mean_plot(points, rows, what, ax, static_cast<std::size_t>(k), unit, dunit, ds);
  }
  return o;
}

// ---- Ceres (ceres_nonlinear) -----------------------------------------------------------------

// Each estimated parameter with its interval, one plot per display unit (values against names).
std::string parameter_interval_plots(const json& fit) {
  std::map<std::string, Plot> by_unit;
  for (const auto& p : fit.value("parameters", json::array())) {
    if (!p.value("identifiable", false) || p.value("fixed", false)) continue;
    const DisplayUnit du = display_unit(str(p, "unit"));
    Plot& pl = by_unit[du.unit];
    if (pl.series.empty()) {
      pl.title = "estimated parameters [" + du.unit + "] with their intervals";
      pl.x_label = "parameter";
      pl.y_label = "value [" + du.unit + "]";
      pl.width = 760;
      pl.series.push_back(Series{"value with its interval", Style::kPoints, {}, {}, {}, {}, svg::palette(0), false, 1.0});
      pl.lines.push_back({true, 0.0, "", "#555"});
    }
    const json iv = p.value("interval", json::array());
    Series& s = pl.series[0];
    s.x.push_back(static_cast<double>(pl.x_categories.size()));
    s.y.push_back(num(p, "value") * du.scale);
    s.y_lo.push_back(at(iv, 0) * du.scale);
    s.y_hi.push_back(at(iv, 1) * du.scale);
    pl.x_categories.push_back(str(p, "name"));
  }
  std::string o;
  for (const auto& [unit, pl] : by_unit)
    o += figure(pl, "Each estimated parameter's value with its interval (fixed and unidentified parameters left out).");
  return o;
}

// Accelerometer: each static interval's |a| − g before and after calibration [mg], against time.
std::string ceres_norm_plot(const json& acc) {
  Plot p;
  p.title = "accelerometer: |a| − g per static interval, before and after calibration";
  p.x_label = "time of the static interval (middle) [s]";
  p.y_label = "|a| − g [mg]";
  p.width = 760;
  Series before{"raw |ȳ| − g", Style::kPoints, {}, {}, {}, {}, svg::palette(1), false, 0.9};
  Series after{"calibrated |correct(ȳ)| − g", Style::kPoints, {}, {}, {}, {}, svg::palette(0), false, 0.9};
  for (const auto& iv : acc.value("intervals", json::array())) {
    const double t = 0.5 * (num(iv, "t_start_s") + num(iv, "t_end_s"));
    before.x.push_back(t);
    before.y.push_back(num(iv, "norm_error_before_mps2") / physics::kMilliG);
    after.x.push_back(t);
    after.y.push_back(num(iv, "norm_error_after_mps2") / physics::kMilliG);
  }
  if (before.x.empty() || !std::any_of(before.y.begin(), before.y.end(), [](double v) { return std::isfinite(v); }))
    return "";
  p.series = {before, after};
  p.lines.push_back({true, 0.0, "", "#555"});
  return figure(p, fmt::format("The magnitude of each static interval's mean minus local gravity g = {} m/s², raw and "
                               "with the fitted calibration applied (RMS {} → {} mg).",
                               g(num(acc, "gravity_mps2")), g3(num(acc, "rms_norm_before_mps2") / physics::kMilliG),
                               g3(num(acc, "rms_norm_after_mps2") / physics::kMilliG)));
}

// Gyroscope (integration): each move's gravity-direction mismatch before and after [deg].
std::string ceres_move_plot(const json& gy) {
  const json moves = gy.value("moves", json::array());
  if (moves.empty()) return "";
  Plot p;
  p.title = "gyroscope: gravity-direction mismatch per move, before and after calibration";
  p.x_label = "end of the move [s]";
  p.y_label = "mismatch [deg]";
  p.width = 760;
  p.y_include_zero = true;
  Series before{"raw rate", Style::kPoints, {}, {}, {}, {}, svg::palette(1), false, 0.9};
  Series after{"calibrated rate", Style::kPoints, {}, {}, {}, {}, svg::palette(0), false, 0.9};
  for (const auto& m : moves) {
    before.x.push_back(num(m, "t_end_s"));
    before.y.push_back(num(m, "mismatch_before_rad") * physics::kRadToDeg);
    after.x.push_back(num(m, "t_end_s"));
    after.y.push_back(num(m, "mismatch_after_rad") * physics::kRadToDeg);
  }
  p.series = {before, after};
  return figure(p, "Angle between the gravity direction carried over each move by the integrated gyro rate and the one "
                   "measured in the static interval after it, with the raw and the calibrated rate.");
}

// The Ceres calibration's plots: |a| − g, the move mismatch, the parameters with their intervals.
std::string ceres_plots(const json& fit) {
  std::string o;
  if (fit.contains("accelerometer")) o += ceres_norm_plot(fit["accelerometer"]);
  if (fit.contains("gyroscope")) o += ceres_move_plot(fit["gyroscope"]);
  return o + parameter_interval_plots(fit);
}

std::string fit_section(const json& fit, const std::string& file) {
  std::string o;
  // "estimator": {name, version} (stend.fit/1) or a plain name (ceres_nonlinear).
  const json est = fit.contains("estimator") && fit["estimator"].is_string()
                       ? json{{"name", fit["estimator"].get<std::string>()}}
                       : fit.value("estimator", json::object());
  o += fmt::format("<h2>Error-model fit — {} {} <span class=\"file\">({})</span></h2>\n", escape(str(est, "name")),
                   escape(str(est, "version")), escape(file));
  if (estimation::status_of(fit) != estimation::FitStatus::kOk) {
    return o + "<p class=\"bad\">FIT FAILED: " + escape(str(fit, "message")) + " — no numbers are reported.</p>\n";
  }
  const json sol = fit.value("solution", json::object());
  const json model = fit.value("model", json::object());
  std::string terms;
  for (const auto& t : model.value("terms", json::array())) terms += (terms.empty() ? "" : ", ") + str(t, "kind");
  const std::string residual_unit = fit.value("units", json::object()).value("residual", "");
  const detail::DisplayUnit sigma_unit =
      residual_unit.empty() ? detail::DisplayUnit{1.0, ""} : detail::display_unit(residual_unit);
  if (fit.contains("solution")) o += fmt::format(
      "<p>{} model, terms: {}. Observations k = {}, parameters p = {}, rank {}, dof {}, σ = {} {}, "
      "condition number {} (identified subspace {}).</p>\n",
      escape(str(model, "instrument")), escape(terms), g(num(sol, "observations")), g(num(sol, "parameters")),
      g(num(sol, "rank")), g(num(sol, "dof")), g(num(sol, "sigma") * sigma_unit.scale), escape(sigma_unit.unit),
      g(num(sol, "condition_number")),
      g(num(sol, "condition_number_identified")));
  o += parameter_table(fit);
  o += fit_plots(fit, str(est, "name"));
  if (fit.contains("accelerometer") || fit.contains("gyroscope")) o += ceres_plots(fit);
  return o;
}

// ---- temperature -------------------------------------------------------------------------------

// Display scale and unit of a temp_poly result: mg for an accelerometer, deg/h for a gyroscope.
struct TempDisplay {
  double scale;
  std::string unit;
  double min_scale_input;  // smallest input that observes the scale factor [m/s² or rad/s]
};

// The candidate orders with their BIC, CV error and rank, and the chosen one.
std::string order_table(const json& ax) {
  std::string o = fmt::format("<p>chosen polynomial order: <b>{}</b></p><table><tr><th>order</th><th>BIC</th><th>CV MSE</th>"
                              "<th>rank</th><th>note</th></tr>\n",
                              ax.value("chosen_order", -1));
  for (const auto& s : ax.value("scores", json::array()))
    o += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", s.value("order", -1),
                     g(num(s, "bic")), g(num(s, "cv_mse")), g(num(s, "rank")), escape(str(s, "note")));
  return o + "</table>\n";
}

// Zero offset [display unit] and scale-factor error [ppm] of axis k against temperature tlo..thi
// [°C] (81 steps), each as a curve with its interval band: {band, curve, scale band, scale curve}.
std::array<Series, 4> temperature_curves(const FittedModel& fm, int k, double tlo, double thi, double ds) {
  const auto uk = static_cast<std::size_t>(k);
  Series band{"interval", Style::kBand, {}, {}, {}, {}, svg::palette(uk), false, 0.25};
  Series curve{"fitted zero offset", Style::kLine, {}, {}, {}, {}, svg::palette(uk), false, 1.0};
  Series sband{"interval", Style::kBand, {}, {}, {}, {}, svg::palette(uk), false, 0.25};
  Series scurve{"fitted scale error", Style::kLine, {}, {}, {}, {}, svg::palette(uk), false, 1.0};
  const model::Vec3<double> zero = model::Vec3<double>::Zero();
  model::Vec3<double> unit_in = zero;
  unit_in[k] = 1.0;
  for (int i = 0; i <= 80; ++i) {
    const double T = tlo + (thi - tlo) * i / 80.0;
    const auto [b, bse] = contribution(fm, k, zero, T);
    curve.x.push_back(T);
    curve.y.push_back(b * ds);
    band.x.push_back(T);
    band.y_lo.push_back((b - fm.quantile * bse) * ds);
    band.y_hi.push_back((b + fm.quantile * bse) * ds);
    const auto [sc, sse] = contribution(fm, k, unit_in, T, &zero);
    scurve.x.push_back(T);
    scurve.y.push_back(sc * 1e6);
    sband.x.push_back(T);
    sband.y_lo.push_back((sc - fm.quantile * sse) * 1e6);
    sband.y_hi.push_back((sc + fm.quantile * sse) * 1e6);
  }
  return {band, curve, sband, scurve};
}

// Partial residuals of axis a (index k): each static orientation's residual added to the fitted
// offset at its temperature [display unit], against temperature [°C].
Series partial_residuals(const FittedModel& fm, const json& fit, const std::string& a, int k, double ds) {
  const json points = fit.value("points", json::array());
  const model::Vec3<double> zero = model::Vec3<double>::Zero();
  Series pts{"observations (partial residuals)", Style::kPoints, {}, {}, {}, {}, "#222", false, 0.7};
  for (const auto& row : fit.value("residuals", json::object()).value("rows", json::array())) {
    if (str(row, "axis") != a) continue;
    const auto pi = static_cast<std::size_t>(std::max(0.0, num(row, "point")));
    if (pi >= points.size()) continue;
    const double T = num(points[pi], "temperature_c");
    pts.x.push_back(T);
    pts.y.push_back((contribution(fm, k, zero, T).first + num(row, "residual")) * ds);
  }
  return pts;
}

// Partial residuals of the scale-factor error of axis a (index k) [ppm]: each static orientation
// with a large input on that axis (over half the largest, and at least min_input) contributes its residual over that input,
// added to the fitted scale error at its temperature, against temperature [°C].
Series scale_partial_residuals(const FittedModel& fm, const json& fit, const std::string& a, int k,
                               double min_input) {
  const json points = fit.value("points", json::array());
  const auto uk = static_cast<std::size_t>(k);
  const model::Vec3<double> zero = model::Vec3<double>::Zero();
  model::Vec3<double> unit_in = zero;
  unit_in[k] = 1.0;
  double largest = 0.0;
  for (const auto& pt : points) largest = std::max(largest, std::abs(at(pt.value("true_input", json::array()), uk)));
  Series pts{"observations (partial residuals)", Style::kPoints, {}, {}, {}, {}, "#222", false, 0.7};
  for (const auto& row : fit.value("residuals", json::object()).value("rows", json::array())) {
    if (str(row, "axis") != a) continue;
    const auto pi = static_cast<std::size_t>(std::max(0.0, num(row, "point")));
    if (pi >= points.size()) continue;
    const double u = at(points[pi].value("true_input", json::array()), uk);
    if (!(std::abs(u) > 0.5 * largest) || !(std::abs(u) >= min_input)) continue;
    const double T = num(points[pi], "temperature_c");
    pts.x.push_back(T);
    pts.y.push_back((contribution(fm, k, unit_in, T, &zero).first + num(row, "residual") / u) * 1e6);
  }
  return pts;
}

// Zero-offset and scale-factor plots of axis a (index k) over the valid range and the points'
// temperatures [°C]; nothing when that range is empty.
std::string temperature_plots(const json& ax, const json& fit, const FittedModel& fm, const std::string& a, int k,
                              double vmin, double vmax, const TempDisplay& d) {
  double tlo = vmin, thi = vmax;
  for (const auto& p : fit.value("points", json::array())) {
    tlo = std::min(tlo, num(p, "temperature_c"));
    thi = std::max(thi, num(p, "temperature_c"));
  }
  if (!std::isfinite(tlo) || !std::isfinite(thi) || !(thi > tlo)) return "";
  const auto [band, curve, sband, scurve] = temperature_curves(fm, k, tlo, thi, d.scale);
  Plot p;
  p.title = "zero offset against temperature, axis " + a;
  p.x_label = "die temperature [°C]";
  p.y_label = "zero offset [" + d.unit + "]";
  p.series = {band, curve, partial_residuals(fm, fit, a, k, d.scale)};
  std::string o = figure(p, fmt::format("Fitted bias polynomial (order {}) with its {:.0f} % interval band; points: each static "
                                        "orientation's residual added to the fitted offset at its temperature.",
                                        ax.value("chosen_order", -1), 100 * num(fit.value("solution", json::object()), "confidence")));
  Plot s;
  s.title = "scale-factor error against temperature, axis " + a;
  s.x_label = "die temperature [°C]";
  s.y_label = "scale-factor error [ppm]";
  const Series observed = scale_partial_residuals(fm, fit, a, k, d.min_scale_input);
  if (observed.x.empty())
    return o + "<p>No static orientation has an input on axis " + escape(a) +
           ": its scale-factor error is not observed by this run (no plot).</p>\n";
  s.series = {sband, scurve, observed};
  return o + figure(s, "Fitted scale-factor error (scale + scale_temperature terms) with its interval band; points: "
                       "each orientation with a large input on this axis, its residual over that input added to the "
                       "fitted scale error at its temperature.");
}

// Cooling-minus-heating hysteresis per level with its standard error and interval.
std::string hysteresis_table(const json& hy) {
  std::string o = "<table><tr><th>level [°C]</th><th>cooling − heating</th><th>std error</th><th>interval</th><th>significant</th></tr>\n";
  for (const auto& h : hy)
    o += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>[{}, {}]</td><td>{}</td></tr>\n",
                     g(num(h, "temperature_c")), g(num(h, "value")), g(num(h, "std_error")), g(num(h, "lower")),
                     g(num(h, "upper")), h.value("significant", false) ? "YES" : "no");
  return o + "</table>\n";
}

// One axis of a temp_poly result: order table, parameters, plots and hysteresis.
std::string temp_axis(const json& ax, double vmin, double vmax, const TempDisplay& d) {
  const std::string a = str(ax, "axis");
  const int k = axis_index(a);
  std::string o = fmt::format("<h3>axis {}</h3>\n", escape(a));
  if (!ax.value("ok", false) || !ax.contains("fit") || ax["fit"].is_null())
    return o + "<p class=\"bad\">axis failed: " + escape(str(ax, "message")) + "</p>\n";
  const json& fit = ax["fit"];
  o += order_table(ax) + parameter_table(fit);
  const FittedModel fm = fitted_model(fit);
  if (!fm.ok || k < 0) return o;
  const std::string plots = temperature_plots(ax, fit, fm, a, k, vmin, vmax, d);
  if (plots.empty()) return o;
  o += plots;
  const json hy = ax.value("hysteresis", json::array());
  if (!hy.empty()) o += hysteresis_table(hy);
  return o;
}

std::string temp_section(const json& tp, const std::string& file) {
  std::string o = "<h2>Temperature model — temp_poly <span class=\"file\">(" + escape(file) + ")</span></h2>\n";
  if (estimation::status_of(tp) != estimation::FitStatus::kOk)
    return o + "<p class=\"bad\">TEMPERATURE FIT REFUSED OR FAILED: " + escape(str(tp, "message")) +
           " — no numbers are reported.</p>\n";
  const double vmin = at(tp.value("valid_range_c", json::array()), 0), vmax = at(tp.value("valid_range_c", json::array()), 1);
  o += fmt::format("<p>Reference temperature T0 = {} °C; coefficients valid over {} … {} °C (die temperature).</p>\n",
                   g(num(tp, "reference_c")), g(vmin), g(vmax));
  const bool accel = str(tp, "unit") != "rad/s";
  // The scale factor is observed by inputs of ≥ 0.1 g (accelerometer) or ≥ 1 deg/s (gyroscope): an
  // Earth-rate or noise-sized input would divide the residual by almost nothing.
  const TempDisplay d{accel ? 1.0 / physics::kMilliG : 1.0 / physics::kDegPerHour, accel ? "mg" : "deg/h",
                      accel ? 0.1 * physics::kStandardGravity : physics::kDegPerSecond};
  for (const auto& ax : tp.value("axes", json::array())) o += temp_axis(ax, vmin, vmax, d);
  return o;
}

// ---- Allan ---------------------------------------------------------------------------------------

// The fitted noise model of a channel's "model" document (missing coefficients as 0), for the
// Allan library's own formula.
allan::NoiseModel noise_model_from_json(const json& m, double rate_hz) {
  allan::NoiseModel nm;
  nm.rate_hz = rate_hz;
  nm.lowpass_hz = num(m, "lowpass_hz");
  for (int j = 0; j < allan::NoiseModel::kCoefficients; ++j) {
    allan::Coefficient& c = nm.coefficients()[j];
    c.fitted = num(m.value(c.symbol, json::object()), "fitted");
    if (!std::isfinite(c.fitted)) c.fitted = 0.0;
  }
  return nm;
}

// The fitted model's ADEV over its τ range [s] (61 log-spaced τ, dashed in color c), and the slope
// lines of the identified coefficients: −½ (N/√τ), +½ (K·√(τ/3)); empty lines are left out.
std::vector<Series> model_series(const json& m, double rate_hz, const std::string& c) {
  const allan::NoiseModel nm = noise_model_from_json(m, rate_hz);
  const json tr = m.value("tau_range_s", json::array());
  const double t0 = at(tr, 0), t1 = at(tr, 1);
  Series model{"", Style::kLine, {}, {}, {}, {}, c, true, 1.0};
  Series nline{"", Style::kLine, {}, {}, {}, {}, "#555", true, 0.6};
  Series kline{"", Style::kLine, {}, {}, {}, {}, "#999", true, 0.6};
  const json N = m.value("N", json::object()), K = m.value("K", json::object());
  if (std::isfinite(t0) && std::isfinite(t1) && t1 > t0) {
    for (int i = 0; i <= 60; ++i) {
      const double tau = t0 * std::pow(t1 / t0, i / 60.0);
      model.x.push_back(tau);
      model.y.push_back(std::sqrt(nm.avar(tau)));
      if (N.value("identified", false)) {
        nline.x.push_back(tau);
        nline.y.push_back(num(N, "value") / std::sqrt(tau));
      }
      if (K.value("identified", false)) {
        kline.x.push_back(tau);
        kline.y.push_back(num(K, "value") * std::sqrt(tau / 3.0));
      }
    }
  }
  std::vector<Series> out = {model};
  if (!nline.x.empty()) out.push_back(nline);
  if (!kline.x.empty()) out.push_back(kline);
  return out;
}

// Table row of a channel's N, K, B and Gauss–Markov bias (σ, τc): each coefficient's verdict —
// value ± σ when identified, else the upper bound, or failed.
std::string coefficient_row(const json& ch, const json& m) {
  auto cell = [](const json& coef) {
    const std::string v = coef.value("verdict", coef.value("identified", false) ? "identified" : "upper_bound");
    if (v == "identified") return fmt::format("{} ± {}", g3(num(coef, "value")), g3(num(coef, "sigma")));
    if (v == "failed") return std::string("failed");
    const double ub = num(coef, "upper_bound");
    return std::isfinite(ub) ? fmt::format("≤ {} (not identified)", g3(ub)) : std::string("not identified");
  };
  const json N = m.value("N", json::object()), K = m.value("K", json::object()), B = m.value("B", json::object());
  const json G = m.value("G", json::object()), Tc = m.value("Tc", json::object());
  const std::string gm = G.value("identified", false) ? cell(G) + ", τc " + cell(Tc) + " s" : cell(G);
  return fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     escape(str(ch, "channel")), cell(N), cell(K), cell(B), gm,
                     escape(str(N, "unit") + ", " + str(K, "unit") + ", " + str(B, "unit")));
}

// One channel into the instrument's plot (confidence band, points, model curves in color c) and
// its table row (or the model's failure).
void add_allan_channel(const json& ch, const std::string& c, Plot& p, std::string& table) {
  p.y_label = "Allan deviation [" + str(ch, "unit") + "]";
  Series band{"", Style::kBand, {}, {}, {}, {}, c, false, 0.2};
  Series pts{str(ch, "channel"), Style::kPoints, {}, {}, {}, {}, c, false, 1.0};
  for (const auto& pt : ch.value("points", json::array())) {
    band.x.push_back(num(pt, "tau_s"));
    band.y_lo.push_back(num(pt, "adev_lo"));
    band.y_hi.push_back(num(pt, "adev_hi"));
    pts.x.push_back(num(pt, "tau_s"));
    pts.y.push_back(num(pt, "adev"));
  }
  p.series.push_back(band);
  p.series.push_back(pts);
  const json m = ch.value("model", json::object());
  if (!m.value("ok", false)) {
    table += fmt::format("<tr><td>{}</td><td colspan=\"6\" class=\"bad\">model fit failed: {}</td></tr>\n",
                         escape(str(ch, "channel")), escape(str(m, "message")));
    return;
  }
  for (auto& s : model_series(m, num(ch, "rate_hz"), c)) p.series.push_back(std::move(s));
  table += coefficient_row(ch, m);
}

// The Allan plot and coefficient table of one instrument; nothing when it has no channel.
std::string allan_instrument(const json& al, const std::string& inst) {
  Plot p;
  p.x_log = p.y_log = true;
  p.width = 760;
  p.height = 440;
  p.title = inst + " Allan deviation";
  p.x_label = "averaging time τ [s]";
  std::string table;
  std::size_t color = 0;
  for (const auto& ch : al.value("channels", json::array()))
    if (str(ch, "instrument") == inst) add_allan_channel(ch, svg::palette(color++), p, table);
  if (color == 0) return "";
  return figure(p, "Overlapping Allan deviation with its confidence band (shaded), the fitted noise model (dashed, "
                   "same color) and the slope lines of identified coefficients (grey dashed: −½ white noise N/√τ, "
                   "light grey: +½ random walk K·√(τ/3)).") +
         "<table><tr><th>channel</th><th>N (white)</th><th>K (random walk)</th><th>B (bias instability)</th>"
         "<th>Gauss–Markov bias σ (unit of B)</th><th>units N, K, B</th></tr>\n" + table + "</table>\n";
}

// The Kalibr noise parameters (with identification and upper-bound flags).
std::string kalibr_paragraph(const json& kb) {
  return fmt::format(
      "<p>Kalibr: accelerometer_noise_density {}{}, accelerometer_random_walk {}{}, gyroscope_noise_density {}{}, "
      "gyroscope_random_walk {}{}, update_rate {} Hz (<code>stend export RUN --to kalibr</code>).</p>\n",
      g3(num(kb, "accelerometer_noise_density")), kb.value("accelerometer_noise_identified", false) ? "" : " (not identified)",
      g3(num(kb, "accelerometer_random_walk")), kb.value("accelerometer_random_walk_is_upper_bound", false) ? " (UPPER BOUND)" : "",
      g3(num(kb, "gyroscope_noise_density")), kb.value("gyroscope_noise_identified", false) ? "" : " (not identified)",
      g3(num(kb, "gyroscope_random_walk")), kb.value("gyroscope_random_walk_is_upper_bound", false) ? " (UPPER BOUND)" : "",
      g(num(kb, "update_rate")));
}

std::string allan_section(const json& al) {
  std::string o = "<h2>Noise — Allan deviation <span class=\"file\">(allan.json)</span></h2>\n";
  o += fmt::format("<p>{} samples at {} Hz ({}).</p>\n", g(num(al, "samples")), g(num(al, "rate_hz")),
                   escape(str(al, "source")));
  for (const auto& w : al.value("warnings", json::array()))
    if (w.is_string()) o += "<p class=\"warn\">warning: " + escape(w.get<std::string>()) + "</p>\n";
  for (const char* inst : {"accelerometer", "gyroscope"}) o += allan_instrument(al, inst);
  if (al.contains("kalibr")) o += kalibr_paragraph(al["kalibr"]);
  return o;
}

// ---- gap -------------------------------------------------------------------------------------------

// Residual layout of a gap result: per axis (x y z), or the magnitude form (orientations unknown)
// with one |f| row per segment in slot 0 of every vector.
struct GapAxes {
  bool magnitude = false;
  int count = 3;
  std::string label(int k) const { return magnitude ? std::string("|f|") : std::string(1, kAxes[k]); }
};

// Heading, the magnitude-form note, and the static residual RMS [m/s²] per axis and over the noise floor.
std::string gap_summary(const json& gp, const GapAxes& axes) {
  std::string o = fmt::format("<h2>Sim-to-real gap — {} <span class=\"file\">(gap.json)</span></h2>\n",
                              escape(str(gp, "model")));
  const json gap = gp.value("gap", json::object());
  const json floor = gp.value("noise_floor", json::object());
  if (axes.magnitude)
    o += "<p>Magnitude form: the orientations were not recorded, only |g| is known; each segment is its mean "
         "along the estimated gravity direction, and rotations of the sensor frame cannot be seen.</p>\n";
  std::string rms, ratio;
  for (int k = 0; k < axes.count; ++k) {
    rms += fmt::format("{}{} {}", k ? ", " : "", axes.label(k),
                       g3(at(gap.value("static_rms_mps2", json::array()), static_cast<std::size_t>(k)) / physics::kMilliG));
    ratio += fmt::format("{}{} {}", k ? ", " : "", axes.label(k),
                         g3(at(gap.value("static_rms_over_floor", json::array()), static_cast<std::size_t>(k))));
  }
  o += fmt::format("<p>Static residual RMS [mg]: {}; over the noise floor: {} (floor source: {}).</p>\n", rms, ratio,
                   escape(str(floor, "source")));
  return o;
}

// Where: bar chart of the share of the residual energy each (dimension, place) holds; without a
// recorded temperature, the temperature places (all at the importer's placeholder) are left out.
std::string gap_where_figure(const json& where_all, bool temperature_recorded) {
  json where = json::array();
  for (const auto& w : where_all)
    if (temperature_recorded || str(w, "dimension") != "temperature") where.push_back(w);
  Plot p;
  p.title = "where the gap lies";
  p.y_label = "share of the residual energy";
  p.x_label = "dimension : place";
  p.width = 760;
  p.height = 520;  // room for the slanted (dimension : place) labels
  Series bars{"share", Style::kBars, {}, {}, {}, {}, svg::palette(3), false, 0.85};
  for (std::size_t i = 0; i < where.size(); ++i) {
    p.x_categories.push_back(str(where[i], "dimension") + ":" + str(where[i], "place"));
    bars.x.push_back(static_cast<double>(i));
    bars.y.push_back(num(where[i], "share"));
  }
  bars.name.clear();
  p.series = {bars};
  return figure(p, "Localization: the share of the residual each (dimension, place) holds.");
}

// The span of the segments' values of `key` (temperature [°C], time since the last change [s]);
// NaN when none has one.
double segment_span(const json& segs, const char* key) {
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& sg : segs) {
    const double t = num(sg, key);
    if (!std::isfinite(t)) continue;
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  return hi >= lo ? hi - lo : kNaN;
}

// A residual against a range narrower than this is a vertical stripe: not plotted [°C, s].
constexpr double kMinPlottedSpanC = 2.0, kMinPlottedSpanS = 1.0;

// Segment residual per axis [mg] against temperature [°C] (when the segments span a range of
// temperatures) and against time since the last change [s].
std::string gap_segment_figures(const json& segs, const GapAxes& axes, bool temperature_recorded) {
  std::string o;
  const double span = temperature_recorded ? segment_span(segs, "temperature_c") : kNaN;
  const double span_s = segment_span(segs, "time_since_change_s");
  if (!std::isfinite(span))
    o += "<p>No temperature was recorded: no residual-against-temperature plot.</p>\n";
  else if (span < kMinPlottedSpanC)
    o += fmt::format("<p>The segments' temperatures span {} °C (under {} °C): no residual-against-temperature plot "
                     "(it would be a vertical stripe).</p>\n", g3(span), g3(kMinPlottedSpanC));
  if (!(span_s >= kMinPlottedSpanS))
    o += fmt::format("<p>All segments began {} after the last change: no residual-against-time plot.</p>\n",
                     std::isfinite(span_s) ? "within " + g3(span_s) + " s of each other" : "at an unknown time");
  for (const char* dim : {"temperature_c", "time_since_change_s"}) {
    if (dim[1] == 'e' ? !(span >= kMinPlottedSpanC) : !(span_s >= kMinPlottedSpanS)) continue;
    Plot p;
    p.title = std::string("segment residual against ") + (dim[0] == 't' && dim[1] == 'e' ? "temperature" : "time since change");
    p.x_label = dim[1] == 'e' ? "temperature [°C]" : "time since the last change [s]";
    p.y_label = "residual [mg]";
    for (int k = 0; k < axes.count; ++k) {
      Series s{fmt::format("axis {}", axes.label(k)), Style::kPoints, {}, {}, {}, {}, svg::palette(static_cast<std::size_t>(k)), false, 0.8};
      for (const auto& sg : segs) {
        s.x.push_back(num(sg, dim));
        s.y.push_back(at(sg.value("axis_residual_mps2", json::array()), static_cast<std::size_t>(k)) / physics::kMilliG);
      }
      p.series.push_back(s);
    }
    p.lines.push_back({true, 0.0, "", "#555"});
    o += figure(p, "Twin-minus-recording residual of each static segment, per axis.");
  }
  return o;
}

// Shrink: held-out and in-sample RMS [mg] after each forward-selection step, against the noise floor.
std::string gap_shrink_figure(const json& steps) {
  Plot p;
  p.title = "how far the gap shrinks";
  p.y_label = "RMS [mg]";
  p.x_label = "model after step";
  p.width = 760;
  Series held{"held-out RMS", Style::kLinePoints, {}, {}, {}, {}, svg::palette(0), false, 1.0};
  Series ins{"in-sample RMS", Style::kLinePoints, {}, {}, {}, {}, svg::palette(1), true, 1.0};
  Series fl{"noise floor", Style::kLine, {}, {}, {}, {}, "#777", true, 1.0};
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const std::string added = str(steps[i], "added");
    p.x_categories.push_back(added.empty() ? fmt::format("step {}", i) : "+" + added);
    held.x.push_back(static_cast<double>(i));
    held.y.push_back(num(steps[i], "heldout_rms_mps2") / physics::kMilliG);
    ins.x.push_back(static_cast<double>(i));
    ins.y.push_back(num(steps[i], "in_sample_rms_mps2") / physics::kMilliG);
    fl.x.push_back(static_cast<double>(i));
    fl.y.push_back(num(steps[i], "noise_floor_mps2") / physics::kMilliG);
  }
  p.series = {held, ins, fl};
  p.y_include_zero = true;
  return figure(p, "Residual RMS on data not used to fit (held-out) as each candidate term is added, against the "
                   "noise floor.");
}

// Groups of candidates that stand in for each other (each names another among its aliases, either
// by term or by term_axis): the group number of each candidate, 0 for one without a stand-in.
std::vector<int> alias_groups(const json& cands) {
  const std::size_t n = cands.size();
  std::vector<std::size_t> parent(n);
  for (std::size_t i = 0; i < n; ++i) parent[i] = i;
  auto root = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& a : cands[i].value("aliases", json::array())) {
      if (!a.is_string()) continue;
      for (std::size_t j = 0; j < n; ++j) {
        const std::string t = str(cands[j], "term");
        if (j != i && (a == t || a == t + "_" + str(cands[j], "axis"))) parent[root(i)] = root(j);
      }
    }
  std::map<std::size_t, int> size, number;
  for (std::size_t i = 0; i < n; ++i) ++size[root(i)];
  std::vector<int> group(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (size[root(i)] > 1) group[i] = number.emplace(root(i), static_cast<int>(number.size()) + 1).first->second;
  return group;
}

// Table of the candidate terms: held-out improvement, ΔBIC, p, size with its 95 % interval, aliases;
// candidates that stand in for each other are listed together under one group label, and only the
// group's best (largest held-out improvement) is called significant — the others can replace it.
std::string gap_candidates_table(const json& cands) {
  const std::vector<int> group = alias_groups(cands);
  std::vector<std::size_t> order(cands.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const int ga = group[a] ? group[a] : 1 << 20, gb = group[b] ? group[b] : 1 << 20;
    return ga != gb ? ga < gb : num(cands[a], "heldout_improvement") > num(cands[b], "heldout_improvement");
  });
  std::string o = "<table><tr><th>group</th><th>term</th><th>axis</th><th>held-out improvement</th><th>ΔBIC</th><th>p</th>"
                  "<th>size</th><th>95 % interval</th><th>aliases</th><th>significant</th></tr>\n";
  std::set<int> led;
  for (std::size_t i : order) {
    const json& c = cands[i];
    std::string al;
    for (const auto& a : c.value("aliases", json::array())) al += (al.empty() ? "" : ", ") + (a.is_string() ? a.get<std::string>() : a.dump());
    const bool sig = c.value("significant", false);
    std::string verdict = sig ? "YES" : "no";
    if (group[i] && sig)
      verdict = led.insert(group[i]).second ? "YES (for its group: the data cannot tell its members apart)"
                                            : "stands in for the group's first — not a separate finding";
    o += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} {}</td><td>[{}, {}]</td>"
                     "<td>{}</td><td>{}</td></tr>\n",
                     group[i] ? fmt::format("aliased group {}", group[i]) : "—", escape(str(c, "term")),
                     escape(str(c, "axis")), g3(num(c, "heldout_improvement")), g3(num(c, "delta_bic")),
                     g3(num(c, "p_value")), g3(num(c, "size")), escape(str(c, "size_unit")),
                     g3(at(c.value("ci95", json::array()), 0)), g3(at(c.value("ci95", json::array()), 1)), escape(al),
                     verdict);
  }
  return o + "</table>\n";
}

std::string gap_section(const json& gp, bool temperature_recorded) {
  GapAxes axes;
  axes.magnitude = str(gp, "form") == "magnitude";
  axes.count = axes.magnitude ? 1 : 3;
  std::string o = gap_summary(gp, axes);
  const json where = gp.value("where", json::array());
  if (!where.empty()) o += gap_where_figure(where, temperature_recorded);
  const json segs = gp.value("segments", json::array());
  if (!segs.empty()) o += gap_segment_figures(segs, axes, temperature_recorded);
  const json steps = gp.value("steps", json::array());
  if (!steps.empty()) o += gap_shrink_figure(steps);
  const json cands = gp.value("candidates", json::array());
  if (!cands.empty()) o += gap_candidates_table(cands);
  const json un = gp.value("unexplained", json::object());
  if (!un.empty())
    o += fmt::format("<p><b>Unexplained:</b> held-out RMS {} mg = {} × floor. {}</p>\n",
                     g3(num(un, "heldout_rms_mps2") / physics::kMilliG),
                     g3(num(un, "over_floor")), escape(str(un, "statement")));
  return o;
}

// ---- recording overview --------------------------------------------------------------------

// The recording's channels reduced to kOverviewBins time bins: per bin the minimum, maximum and
// mean of each channel (ax ay az [m/s²], gx gy gz [rad/s], temperature [°C]), so that a run of any
// length is drawn with a fixed number of points, read a chunk at a time.
constexpr std::size_t kOverviewBins = 400;
constexpr std::array<Channel, 7> kOverviewChannels = {Channel::kAx, Channel::kAy, Channel::kAz, Channel::kGx,
                                                      Channel::kGy, Channel::kGz, Channel::kTemperature};
struct Overview {
  double t0 = 0.0, t1 = 0.0;  // [s]
  std::array<std::vector<double>, 7> lo, hi, sum;
  std::vector<double> count;
};

Overview overview_of(const Recording& rec) {
  Overview ov;
  const SampleSource& src = rec.sample_source();
  if (src.size() == 0) return ov;
  ov.t0 = sample_at(src, 0).t_s;
  ov.t1 = sample_at(src, src.size() - 1).t_s;
  for (std::size_t c = 0; c < kOverviewChannels.size(); ++c) {
    ov.lo[c].assign(kOverviewBins, INFINITY);
    ov.hi[c].assign(kOverviewBins, -INFINITY);
    ov.sum[c].assign(kOverviewBins, 0.0);
  }
  ov.count.assign(kOverviewBins, 0.0);
  const double span = std::max(ov.t1 - ov.t0, 1e-9);
  for_each_chunk(src, [&](const ImuSample* chunk, std::size_t n, std::uint64_t) {
    for (std::size_t i = 0; i < n; ++i) {
      const double f = (chunk[i].t_s - ov.t0) / span * static_cast<double>(kOverviewBins);
      const auto b = static_cast<std::size_t>(std::clamp(f, 0.0, static_cast<double>(kOverviewBins - 1)));
      ov.count[b] += 1.0;
      for (std::size_t c = 0; c < kOverviewChannels.size(); ++c) {
        const double v = value_of(chunk[i], kOverviewChannels[c]);
        ov.lo[c][b] = std::min(ov.lo[c][b], v);
        ov.hi[c][b] = std::max(ov.hi[c][b], v);
        ov.sum[c][b] += v;
      }
    }
  });
  return ov;
}

// One overview plot: channels c0 … c0+n−1 scaled by `scale`, each a min–max band and a mean line
// over time, with the recording's segments shaded behind them.
Plot overview_plot(const Overview& ov, const Recording& rec, std::size_t c0, std::size_t n, double scale,
                   const std::string& title, const std::string& y_label, const std::vector<std::string>& names) {
  Plot p;
  p.title = title;
  p.x_label = "time since the start of the recording [s]";
  p.y_label = y_label;
  p.width = 760;
  p.height = 300;
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t c = c0; c < c0 + n; ++c)
    for (std::size_t b = 0; b < kOverviewBins; ++b)
      if (ov.count[b] > 0 && std::isfinite(ov.lo[c][b]) && std::isfinite(ov.hi[c][b])) {
        lo = std::min(lo, ov.lo[c][b] * scale);
        hi = std::max(hi, ov.hi[c][b] * scale);
      }
  if (!(hi >= lo)) return p;
  // Segments: shaded over the channels' range, alternating two greys so neighbours stay apart.
  for (std::size_t k = 0; k < rec.segments.size(); ++k) {
    const Segment& sg = rec.segments[k];
    Series sh{k == 0 ? "segment (shaded)" : "", Style::kBand, {}, {}, {}, {}, k % 2 ? "#999" : "#666", false, 0.12};
    sh.x = {sg.t_start_s - ov.t0, sg.t_end_s - ov.t0};
    sh.y_lo = {lo, lo};
    sh.y_hi = {hi, hi};
    p.series.push_back(sh);
  }
  const double bin_s = (ov.t1 - ov.t0) / static_cast<double>(kOverviewBins);
  for (std::size_t c = c0; c < c0 + n; ++c) {
    const std::string color = svg::palette(c - c0);
    Series band{"", Style::kBand, {}, {}, {}, {}, color, false, 0.25};
    Series mean{names[c - c0], Style::kLine, {}, {}, {}, {}, color, false, 1.0};
    for (std::size_t b = 0; b < kOverviewBins; ++b) {
      const double t = (static_cast<double>(b) + 0.5) * bin_s;
      const bool any = ov.count[b] > 0 && std::isfinite(ov.lo[c][b]);
      band.x.push_back(t);
      band.y_lo.push_back(any ? ov.lo[c][b] * scale : kNaN);
      band.y_hi.push_back(any ? ov.hi[c][b] * scale : kNaN);
      mean.x.push_back(t);
      mean.y.push_back(any ? ov.sum[c][b] / ov.count[b] * scale : kNaN);
    }
    p.series.push_back(band);
    p.series.push_back(mean);
  }
  return p;
}

// Whether the recording has a temperature: some finite temperature sample.
bool has_temperature(const Overview& ov) {
  constexpr std::size_t t = 6;
  for (std::size_t b = 0; b < kOverviewBins; ++b)
    if (ov.count[b] > 0 && std::isfinite(ov.lo[t][b]) && std::isfinite(ov.hi[t][b])) return true;
  return false;
}

// The raw time series of the recording (accelerometer, gyroscope, temperature when recorded),
// reduced to bins, with its segments shaded; a paragraph instead when the samples cannot be read.
std::string overview_section(const fs::path& dir, bool& temperature_recorded) {
  std::string o = "<h2>Recording overview <span class=\"file\">(run samples)</span></h2>\n";
  try {
    const Recording rec = Recording::open(dir, SampleLoading::kStream, TruthLoading::kSkip);
    const Overview ov = overview_of(rec);
    temperature_recorded = rec.header.info.has_temperature && has_temperature(ov);
    if (ov.count.empty()) return o + "<p class=\"warn\">The recording has no samples.</p>\n";
    const std::string cap = fmt::format("Raw samples over the whole recording ({} samples, {} s): each channel's "
                                        "minimum–maximum per time bin (band) and mean (line); grey: the segments.",
                                        rec.sample_count(), g3(ov.t1 - ov.t0));
    o += figure(overview_plot(ov, rec, 0, 3, 1.0, "accelerometer, raw", "specific force [m/s²]", {"ax", "ay", "az"}), cap);
    if (rec.header.info.has_gyro)
      o += figure(overview_plot(ov, rec, 3, 3, physics::kRadToDeg, "gyroscope, raw", "rate [deg/s]", {"gx", "gy", "gz"}),
                  cap);
    if (rec.header.info.has_temperature && has_temperature(ov))
      o += figure(overview_plot(ov, rec, 6, 1, 1.0, "sensor temperature", "temperature [°C]", {"temperature"}), cap);
    else
      o += "<p>No temperature was recorded.</p>\n";
  } catch (const std::exception& e) {
    o += "<p class=\"warn\">The samples could not be read for the overview: " + escape(e.what()) + "</p>\n";
  }
  return o;
}

}  // namespace

std::string html_page(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" + escape(title) +
         "</title>\n<style>\n"
         "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}\n"
         "h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:2em}h3{font-size:1.05em}\n"
         "table{border-collapse:collapse;margin:.5em 0;font-size:.9em}td,th{border:1px solid #ccc;padding:2px 6px;"
         "text-align:left}th{background:#f2f2f2}\n"
         "tr.nid td{color:#a00}.bad{color:#b00;font-weight:bold}.warn{color:#a60}.file{color:#888;font-weight:normal;"
         "font-size:.8em}\n"
         "figure{display:inline-block;margin:.5em 1em .5em 0;vertical-align:top}figcaption{font-size:.8em;color:#555;"
         "max-width:760px}\n"
         "code{background:#f4f4f4;padding:0 3px}\n"
         "</style></head><body>\n" +
         body + "</body></html>\n";
}

std::string run_report_html(const fs::path& run_dir) {
  const RunResults rr = load_run_results(run_dir);
  std::string body;
  body += fmt::format("<h1>Stend report — {}</h1>\n", escape(rr.run_name));
  body += "<table class=\"meta\">\n";
  auto row = [&](const std::string& k, const std::string& v) {
    body += "<tr><th>" + escape(k) + "</th><td>" + escape(v) + "</td></tr>\n";
  };
  row("experiment", rr.experiment);
  row("run folder", rr.dir.string());
  row("status", rr.run_status);
  row("started (UTC)", rr.start_time_utc);
  row("sensor", rr.vendor + " " + rr.model + (rr.serial.empty() ? "" : " serial " + rr.serial));
  row("procedure fingerprint", rr.procedure_fingerprint.empty() ? "—" : rr.procedure_fingerprint);
  std::string ests;
  for (const auto& e : rr.estimators)
    ests += (ests.empty() ? "" : "; ") + e.name + " " + e.version + " (" + e.file + ", " + e.status + ")";
  row("estimators", ests.empty() ? "none: no results file in this folder (run `stend fit RUN -m MODEL`)" : ests);
  row("stend", rr.stend_version);
  body += "</table>\n";
  if (rr.run_status != to_string(RunStatus::kComplete))
    body += "<p class=\"bad\">This recording is not complete (status " + escape(rr.run_status) +
            "): results describe the data present only.</p>\n";
  for (const auto& n : rr.notes) body += "<p class=\"warn\">" + escape(n) + "</p>\n";
  bool temperature_recorded = true;  // the gap section's temperature plots need one
  body += overview_section(rr.dir, temperature_recorded);
  json doc;
  // One results file per instrument and estimator (estimation::results_files_of).
  for (const auto& f : estimation::results_files_of("fit.json"))
    if (load(rr.dir, f, doc, body)) body += fit_section(doc, f);
  for (const auto& f : estimation::results_files_of("ceres.json"))
    if (load(rr.dir, f, doc, body)) body += fit_section(doc, f);
  for (const auto& f : estimation::results_files_of("temp_poly.json"))
    if (load(rr.dir, f, doc, body)) body += temp_section(doc, f);
  if (load(rr.dir, "allan.json", doc, body)) body += allan_section(doc);
  if (load(rr.dir, kGapResultsFile, doc, body)) body += gap_section(doc, temperature_recorded);
  body += "<p class=\"file\">Written by stend report. Plots are inline SVG; this file needs nothing else.</p>\n";
  return html_page("Stend report — " + rr.run_name, body);
}

fs::path write_run_report(const fs::path& run_dir) {
  const std::string html = run_report_html(run_dir);
  const fs::path out = run_dir / "report.html";
  write_file_atomic(out, html);
  return out;
}

}  // namespace stend::reporting
