// temp_poly's section of the run report (temp_poly.json, temp_poly-gyroscope.json): per axis the
// order selection, the parameter table, the zero offset and scale-factor error against
// temperature with the points they were fitted to, and the cooling-minus-heating hysteresis.
#include "report_section.hpp"

#include "stend/estimation/fit_report.hpp"
#include "stend/estimation/json_fields.hpp"
#include "stend/estimation/result_io.hpp"
#include "stend/physics/units.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <optional>

namespace stend::temp_poly {

namespace {

using estimation::Cell;
using estimation::Emphasis;
using estimation::InstrumentModel;
using estimation::Paragraph;
using estimation::ReportSection;
using estimation::Row;
using estimation::Span;
using estimation::Table;
using estimation::figure::Plot;
using estimation::figure::Series;
using estimation::figure::Style;
using nlohmann::json;

double num(const json& j, const char* key) { return estimation::number_field(j, key); }
double at(const json& a, std::size_t i) { return estimation::number_at(a, i); }
std::string str(const json& j, const char* key) { return estimation::text_field(j, key); }
std::string g(double v) { return estimation::report_number(v); }
int axis_index(const std::string& a) { return a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1; }

// Display scale and unit of a temp_poly result (estimation::display_unit: mg for an accelerometer,
// deg/s for a gyroscope).
struct TempDisplay {
  double scale;
  std::string unit;
  double min_scale_input;  // smallest input that observes the scale factor [m/s² or rad/s]
};

// The chosen order, then the candidate orders with their BIC, CV error and rank.
void add_orders(ReportSection& s, const json& ax) {
  const std::string order = std::to_string(ax.value("chosen_order", -1));
  s.add(Paragraph{{Span{"chosen polynomial order: "}, Span{order, Span::Kind::kStrong}}});
  Table t;
  t.header = {"order", "BIC", "CV MSE", "rank", "note"};
  for (const auto& sc : ax.value("scores", json::array()))
    t.rows.push_back(Row{{std::to_string(sc.value("order", -1)), g(num(sc, "bic")), g(num(sc, "cv_mse")),
                          g(num(sc, "rank")), str(sc, "note")}});
  s.add(std::move(t));
}

// The rows of axis a's residuals whose point is one of the fit's points.
template <class F>
void for_each_residual(const json& fit, const std::string& a, F&& f) {
  const json points = fit.value("points", json::array());
  for (const auto& row : fit.value("residuals", json::object()).value("rows", json::array())) {
    if (str(row, "axis") != a) continue;
    const auto pi = static_cast<std::size_t>(std::max(0.0, num(row, "point")));
    if (pi < points.size()) f(points[pi], num(row, "residual"));
  }
}

// Partial residuals of axis a (index k): each static orientation's residual added to the fitted
// offset at its temperature [display unit], against temperature [°C].
Series partial_residuals(const InstrumentModel& fm, const json& fit, const std::string& a, int k, double ds) {
  const model::Vec3<double> zero = model::Vec3<double>::Zero();
  Series pts{"observations (partial residuals)", Style::kPoints, {}, {}, {}, {}, "#222", false, 0.7};
  for_each_residual(fit, a, [&](const json& point, double residual) {
    const double T = num(point, "temperature_c");
    pts.x.push_back(T);
    pts.y.push_back((fm.contribution(k, zero, T).first + residual) * ds);
  });
  return pts;
}

// Partial residuals of the scale-factor error of axis a (index k) [ppm]: each static orientation
// with a large input on that axis (over half the largest, and at least min_input) contributes its
// residual over that input, added to the fitted scale error at its temperature, against
// temperature [°C].
Series scale_partial_residuals(const InstrumentModel& fm, const json& fit, const std::string& a, int k, double min_input) {
  const auto uk = static_cast<std::size_t>(k);
  const model::Vec3<double> zero = model::Vec3<double>::Zero();
  model::Vec3<double> unit_in = zero;
  unit_in[k] = 1.0;
  double largest = 0.0;
  for (const auto& pt : fit.value("points", json::array()))
    largest = std::max(largest, std::abs(at(pt.value("true_input", json::array()), uk)));
  Series pts{"observations (partial residuals)", Style::kPoints, {}, {}, {}, {}, "#222", false, 0.7};
  for_each_residual(fit, a, [&](const json& point, double residual) {
    const double u = at(point.value("true_input", json::array()), uk);
    if (!(std::abs(u) > 0.5 * largest) || !(std::abs(u) >= min_input)) return;
    const double T = num(point, "temperature_c");
    pts.x.push_back(T);
    pts.y.push_back((fm.contribution(k, unit_in, T, &zero).first + residual / u) * 1e6);
  });
  return pts;
}

// Zero-offset and scale-factor plots of axis a (index k) over the valid range and the points'
// temperatures [°C]; false (nothing added) when that range is empty.
bool add_temperature_plots(ReportSection& s, const json& ax, const InstrumentModel& fm, const std::string& a, int k,
                           double vmin, double vmax, const TempDisplay& d) {
  const json& fit = ax["fit"];
  double tlo = vmin, thi = vmax;
  for (const auto& p : fit.value("points", json::array())) {
    tlo = std::min(tlo, num(p, "temperature_c"));
    thi = std::max(thi, num(p, "temperature_c"));
  }
  if (!std::isfinite(tlo) || !std::isfinite(thi) || !(thi > tlo)) return false;
  const double quantile = num(fit.value("solution", json::object()), "quantile");
  const estimation::TemperatureCurves c =
      estimation::temperature_curves(fm, std::isfinite(quantile) ? quantile : 1.96, k, tlo, thi, d.scale);
  Plot p;
  p.title = "zero offset against temperature, axis " + a;
  p.x_label = "die temperature [°C]";
  p.y_label = "zero offset [" + d.unit + "]";
  p.series = {c.offset_band, c.offset, partial_residuals(fm, fit, a, k, d.scale)};
  const double confidence = num(fit.value("solution", json::object()), "confidence");
  s.add(p, "Fitted bias polynomial (order " + std::to_string(ax.value("chosen_order", -1)) + ") with its " +
               estimation::report_number(std::round(100 * confidence), 3) +
               " % interval band; points: each static orientation's residual added to the fitted offset at its "
               "temperature.");
  const Series observed = scale_partial_residuals(fm, fit, a, k, d.min_scale_input);
  if (observed.x.empty()) {
    s.add_text("No static orientation has an input on axis " + a +
               ": its scale-factor error is not observed by this run (no plot).");
    return true;
  }
  Plot sp;
  sp.title = "scale-factor error against temperature, axis " + a;
  sp.x_label = "die temperature [°C]";
  sp.y_label = "scale-factor error [ppm]";
  sp.series = {c.scale_band, c.scale, observed};
  s.add(sp, "Fitted scale-factor error (scale + scale_temperature terms) with its interval band; points: each "
            "orientation with a large input on this axis, its residual over that input added to the fitted scale "
            "error at its temperature.");
  return true;
}

// Cooling-minus-heating hysteresis per level with its standard error and interval.
Table hysteresis_table(const json& hy) {
  Table t;
  t.header = {"level [°C]", "cooling − heating", "std error", "interval", "significant"};
  for (const auto& h : hy)
    t.rows.push_back(Row{{g(num(h, "temperature_c")), g(num(h, "value")), g(num(h, "std_error")),
                          "[" + g(num(h, "lower")) + ", " + g(num(h, "upper")) + "]",
                          h.value("significant", false) ? "YES" : "no"}});
  return t;
}

// One axis of a temp_poly result: order table, parameters, plots and hysteresis.
void add_axis(ReportSection& s, const json& ax, double vmin, double vmax, const TempDisplay& d) {
  const std::string a = str(ax, "axis");
  const int k = axis_index(a);
  s.add(estimation::Subheading{"axis " + a});
  if (!ax.value("ok", false) || !ax.contains("fit") || ax["fit"].is_null()) {
    s.add_text("axis failed: " + str(ax, "message"), Emphasis::kFailure);
    return;
  }
  const json& fit = ax["fit"];
  add_orders(s, ax);
  s.add(estimation::parameter_table(estimation::summary_from_json(fit)));
  s.append(estimation::fit_notes(fit));
  const std::optional<InstrumentModel> fm = estimation::read_fit_model(fit);
  if (!fm || !fm->ok() || k < 0) return;
  if (!add_temperature_plots(s, ax, *fm, a, k, vmin, vmax, d)) return;
  const json hy = ax.value("hysteresis", json::array());
  if (!hy.empty()) s.add(hysteresis_table(hy));
}

}  // namespace

ReportSection report_section(const estimation::FitResult& result) {
  const json& tp = result.document;
  ReportSection s;
  s.heading = "Temperature model — temp_poly";
  s.file = result.results_file;
  s.topic = ReportSection::Topic::kTemperatureModel;
  if (!result.ok()) {
    s.add(estimation::failure_paragraph("TEMPERATURE FIT REFUSED OR FAILED", result.summary.message));
    return s;
  }
  const json valid_range = tp.value("valid_range_c", json::array());
  const double vmin = at(valid_range, 0), vmax = at(valid_range, 1);
  s.add_text("Reference temperature T0 = " + g(num(tp, "reference_c")) + " °C; coefficients valid over " + g(vmin) +
             " … " + g(vmax) + " °C (die temperature).");
  const bool accel = str(tp, "unit") != "rad/s";
  // The scale factor is observed by inputs of ≥ 0.1 g (accelerometer) or ≥ 1 deg/s (gyroscope): an
  // Earth-rate or noise-sized input would divide the residual by almost nothing.
  const estimation::DisplayUnit du = estimation::display_unit(accel ? "m/s^2" : "rad/s");
  const TempDisplay d{du.scale, du.unit, accel ? 0.1 * physics::kStandardGravity : physics::kDegPerSecond};
  for (const auto& ax : tp.value("axes", json::array())) add_axis(s, ax, vmin, vmax, d);
  return s;
}

}  // namespace stend::temp_poly
