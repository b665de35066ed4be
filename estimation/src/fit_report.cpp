// The report pieces every fit shares (see stend/estimation/fit_report.hpp).
#include "stend/estimation/fit_report.hpp"

#include "stend/estimation/json_fields.hpp"
#include "stend/physics/units.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

namespace stend::estimation {

namespace {

using nlohmann::json;
using figure::Plot;
using figure::Series;
using figure::Style;

constexpr const char* kAxes = "xyz";

double num(const json& j, const char* key) { return number_field(j, key); }
double at(const json& a, std::size_t i) { return number_at(a, i); }
std::string str(const json& j, const char* key) { return text_field(j, key); }
int axis_index(const std::string& a) {
  if (a == "x") return 0;
  if (a == "y") return 1;
  if (a == "z") return 2;
  return -1;
}
std::string g(double v) { return report_number(v); }

// The verdict cell: "determined", "imprecise: why" or "NO: why".
std::string verdict_text(const ParameterEstimate& p) {
  switch (p.judged()) {
    case Verdict::kNotIdentifiable: return "NO: " + p.reason;
    case Verdict::kImprecise: return "imprecise: " + p.reason;
    case Verdict::kDetermined: break;
  }
  return "determined";
}

}  // namespace

Table parameter_table(const FitSummary& summary) {
  Table t;
  t.kind = Table::Kind::kParameters;
  const double conf = summary.confidence;
  t.header = {"parameter", "value", "unit", "std error",
              fmt::format("{} interval{}", std::isfinite(conf) ? fmt::format("{:.0f} %", 100 * conf) : "",
                          summary.dof ? fmt::format(" ({} dof)", *summary.dof) : ""),
              "verdict"};
  for (const auto& p : summary.parameters) {
    const DisplayUnit du = display_unit(p.unit);  // the unit family of the plots
    const bool interval = std::isfinite(p.lower) || std::isfinite(p.upper);
    Row r;
    r.mark = p.identifiable ? Row::Mark::kNone : Row::Mark::kNotIdentified;
    r.cells = {p.name,
               p.identifiable ? g(p.value * du.scale) : "not estimated",
               du.unit,
               g(p.std_error * du.scale),
               interval ? fmt::format("[{}, {}]", g(p.lower * du.scale), g(p.upper * du.scale)) : "—",
               verdict_text(p)};
    t.rows.push_back(std::move(r));
  }
  return t;
}

std::vector<Paragraph> fit_notes(const json& fit) {
  std::vector<Paragraph> out;
  if (fit.contains("aliases") && fit["aliases"].is_array())
    for (const auto& a : fit["aliases"]) {
      std::string names;
      for (const auto& n : a.value("parameters", json::array())) names += (names.empty() ? "" : ", ") + n.get<std::string>();
      std::string text = "aliased (the data cannot separate them): " + names;
      for (const auto& c : a.value("identified_combinations", json::array()))
        text += fmt::format("; identified: {} = {} ± {}", str(c, "text"), g(num(c, "value")), g(num(c, "std_error")));
      out.push_back(Paragraph{{Span{text}}, Emphasis::kWarning});
    }
  for (const auto& w : fit.value("warnings", json::array()))
    if (w.is_string()) out.push_back(Paragraph{{Span{"warning: " + w.get<std::string>()}}, Emphasis::kWarning});
  return out;
}

namespace {

// Display scale of residuals: the fit's own (display_unit: mg for accelerometers, deg/s for gyroscopes).
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
  // The tilt toward the side the sensor was tilted to (the horizontal axis's sign over the points),
  // so the angles run as the experiment states them (0 … 44°, not −44 … 0°).
  const std::size_t h = tilt && still_zero[0] == 0 ? 1 : 0;  // the horizontal axis in the tilt plane
  double side = 0.0;
  for (const auto& pt : points) side += at(pt.value("true_input", json::array()), h);
  const double sign = side < 0.0 ? -1.0 : 1.0;
  for (const auto& pt : points) {
    const json u = pt.value("true_input", json::array());
    if (tilt) {
      a.x.push_back(std::atan2(sign * at(u, h), at(u, 2)) * physics::kRadToDeg);
    } else if (varying.size() == 1) {
      a.x.push_back(at(u, varying[0]));
    }
  }
  if (tilt) {
    a.label = fmt::format("tilt: gravity direction from +z toward {}{} [deg]", sign < 0 ? '-' : '+', kAxes[h]);
  } else if (varying.size() == 1) {
    a.label = fmt::format("true input, axis {} [{}]", kAxes[varying[0]], unit);
  } else {
    a.categories = true;
    a.label = "orientation (point number; the truth varies on three axes)";
    a.x.clear();
  }
  return a;
}

// What the residual plots read of a fit document: its points, residual rows and units.
struct StaticPointPlots {
  const json& fit;
  const json& points;
  const json rows;
  const std::string what, unit, dunit;
  const double ds;  // residual display scale
};

// Residual against the physical quantity of each static point (point_axis): one series per fitted
// axis, with ±σ lines (residuals scaled to the display unit).
Figure residual_figure(const StaticPointPlots& d) {
  const PointAxis pa = point_axis(d.points, d.unit);
  Plot r;
  r.title = d.what + ": residual against orientation";
  r.x_label = pa.label;
  r.y_label = "residual [" + d.dunit + "]";
  r.width = 760;
  if (pa.categories)
    for (std::size_t i = 0; i < d.points.size(); ++i) r.x_categories.push_back(fmt::format("{}", i));
  std::map<std::string, Series> by_axis;
  for (const auto& row : d.rows) {
    const std::string ax = str(row, "axis");
    auto& s = by_axis[ax];
    s.name = "axis " + ax;
    s.style = pa.categories ? Style::kLinePoints : Style::kPoints;
    const double pi = num(row, "point");
    const auto i = static_cast<std::size_t>(std::max(0.0, pi));
    s.x.push_back(pa.categories || !std::isfinite(pi) || i >= pa.x.size() ? pi : pa.x[i]);
    s.y.push_back(num(row, "residual") * d.ds);
  }
  for (auto& [ax, s] : by_axis) {
    const int k = axis_index(ax);
    s.color = figure::palette(k < 0 ? 3 : static_cast<std::size_t>(k));
    r.series.push_back(s);
  }
  r.lines.push_back({true, 0.0, "", "#555"});
  const double sigma = num(d.fit.value("solution", json::object()), "sigma");
  if (std::isfinite(sigma)) {
    r.lines.push_back({true, sigma * d.ds, "+σ", "#999"});
    r.lines.push_back({true, -sigma * d.ds, "−σ", "#999"});
  }
  return {r, "Residual Δ − fitted of each static orientation (σ: residual standard deviation of the fit)."};
}

// Static means against truth on axis ax (index k): (measured − true) ± 2 SE against the true
// input, and the fitted model at the same stimulus (display unit).
Figure static_mean_figure(const StaticPointPlots& d, const std::string& ax, std::size_t k) {
  Plot p;
  p.title = d.what + ": static mean − truth, axis " + ax;
  p.x_label = "true input, axis " + ax + " [" + d.unit + "]";
  p.y_label = "measured − true [" + d.dunit + "]";
  Series meas{"measured mean ± 2 SE", Style::kPoints, {}, {}, {}, {}, figure::palette(k), false, 1.0};
  Series fitted{"fitted model", Style::kPoints, {}, {}, {}, {}, "#000", false, 0.55};
  for (const auto& pt : d.points) {
    const double u = at(pt.value("true_input", json::array()), k);
    const double m = at(pt.value("measured", json::array()), k);
    const double se = at(pt.value("measured_std_error", json::array()), k);
    meas.x.push_back(u);
    meas.y.push_back((m - u) * d.ds);
    meas.y_lo.push_back((m - u - 2 * se) * d.ds);
    meas.y_hi.push_back((m - u + 2 * se) * d.ds);
  }
  for (const auto& row : d.rows) {
    if (str(row, "axis") != ax) continue;
    const auto pi = static_cast<std::size_t>(std::max(0.0, num(row, "point")));
    if (pi >= d.points.size()) continue;
    fitted.x.push_back(at(d.points[pi].value("true_input", json::array()), k));
    fitted.y.push_back(num(row, "fitted") * d.ds);
  }
  p.series = {meas, fitted};
  return {p, "Each static orientation's low-passed mean minus the bench truth, against the truth; black: the fitted "
             "error model at the same stimulus."};
}

}  // namespace

std::vector<Figure> static_point_figures(const json& fit, const std::string& what) {
  if (!fit.contains("points") || !fit.contains("residuals")) return {};
  const std::string unit = fit.value("units", json::object()).value("residual", "m/s^2");
  const StaticPointPlots d{fit,
                           fit["points"],
                           fit["residuals"].value("rows", json::array()),
                           what,
                           unit,
                           fit.value("units", json::object()).value("residual_display", unit),
                           display_scale(fit)};
  std::vector<Figure> out = {residual_figure(d)};
  std::set<std::string> axes;
  for (const auto& row : d.rows) axes.insert(str(row, "axis"));
  for (const std::string& ax : axes) {
    const int k = axis_index(ax);
    if (k >= 0) out.push_back(static_mean_figure(d, ax, static_cast<std::size_t>(k)));
  }
  return out;
}

TemperatureCurves temperature_curves(const InstrumentModel& m, double quantile, int k, double t_lo_c, double t_hi_c,
                                     double ds) {
  const auto uk = static_cast<std::size_t>(k);
  TemperatureCurves c{{"interval", Style::kBand, {}, {}, {}, {}, figure::palette(uk), false, 0.25},
                      {"fitted zero offset", Style::kLine, {}, {}, {}, {}, figure::palette(uk), false, 1.0},
                      {"interval", Style::kBand, {}, {}, {}, {}, figure::palette(uk), false, 0.25},
                      {"fitted scale error", Style::kLine, {}, {}, {}, {}, figure::palette(uk), false, 1.0}};
  const model::Vec3<double> zero = model::Vec3<double>::Zero();
  model::Vec3<double> unit_in = zero;
  unit_in[k] = 1.0;
  for (int i = 0; i <= 80; ++i) {
    const double T = t_lo_c + (t_hi_c - t_lo_c) * i / 80.0;
    const auto [b, bse] = m.contribution(k, zero, T);
    c.offset.x.push_back(T);
    c.offset.y.push_back(b * ds);
    c.offset_band.x.push_back(T);
    c.offset_band.y_lo.push_back((b - quantile * bse) * ds);
    c.offset_band.y_hi.push_back((b + quantile * bse) * ds);
    const auto [sc, sse] = m.contribution(k, unit_in, T, &zero);
    c.scale.x.push_back(T);
    c.scale.y.push_back(sc * 1e6);
    c.scale_band.x.push_back(T);
    c.scale_band.y_lo.push_back((sc - quantile * sse) * 1e6);
    c.scale_band.y_hi.push_back((sc + quantile * sse) * 1e6);
  }
  return c;
}

Paragraph failure_paragraph(const std::string& what, const std::string& message) {
  return {{Span{what + ": " + message + " — no numbers are reported."}}, Emphasis::kFailure};
}

ReportSection generic_report_section(const FitResult& result) {
  const FitSummary& s = result.summary;
  ReportSection r;
  r.heading = "Fit — " + s.estimator + (s.version.empty() ? "" : " " + s.version);
  r.file = result.results_file;
  if (!s.ok()) {
    r.add(failure_paragraph("FIT FAILED", s.message));
    return r;
  }
  r.add(parameter_table(s));
  for (const auto& n : s.notes) r.add_text("note: " + n);
  return r;
}

}  // namespace stend::estimation
