// ceres_nonlinear's section of the run report (ceres.json): the parameter table, each static
// interval's |a| − g and each move's gravity-direction mismatch before and after calibration,
// and the estimated parameters with their intervals.
#include "report_section.hpp"

#include "stend/estimation/fit_report.hpp"
#include "stend/estimation/json_fields.hpp"
#include "stend/physics/units.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <map>

namespace stend::ceres_nonlinear {

namespace {

using estimation::Figure;
using estimation::report_number;
using estimation::figure::Plot;
using estimation::figure::Series;
using estimation::figure::Style;
using estimation::figure::palette;
using nlohmann::json;

double num(const json& j, const char* key) { return estimation::number_field(j, key); }
std::string g3(double v) { return report_number(v, 3); }

// Accelerometer: each static interval's |a| − g before and after calibration [mg], against time;
// none when no interval has a value.
std::vector<Figure> norm_figure(const json& acc) {
  Plot p;
  p.title = "accelerometer: |a| − g per static interval, before and after calibration";
  p.x_label = "time of the static interval (middle) [s]";
  p.y_label = "|a| − g [mg]";
  p.width = 760;
  Series before{"raw |ȳ| − g", Style::kPoints, {}, {}, {}, {}, palette(1), false, 0.9};
  Series after{"calibrated |correct(ȳ)| − g", Style::kPoints, {}, {}, {}, {}, palette(0), false, 0.9};
  for (const auto& iv : acc.value("intervals", json::array())) {
    const double t = 0.5 * (num(iv, "t_start_s") + num(iv, "t_end_s"));
    before.x.push_back(t);
    before.y.push_back(num(iv, "norm_error_before_mps2") / physics::kMilliG);
    after.x.push_back(t);
    after.y.push_back(num(iv, "norm_error_after_mps2") / physics::kMilliG);
  }
  if (before.x.empty() || !std::any_of(before.y.begin(), before.y.end(), [](double v) { return std::isfinite(v); }))
    return {};
  p.series = {before, after};
  p.lines.push_back({true, 0.0, "", "#555"});
  return {{p, fmt::format("The magnitude of each static interval's mean minus local gravity g = {} m/s², raw and with "
                          "the fitted calibration applied (RMS {} → {} mg).",
                          report_number(num(acc, "gravity_mps2")), g3(num(acc, "rms_norm_before_mps2") / physics::kMilliG),
                          g3(num(acc, "rms_norm_after_mps2") / physics::kMilliG))}};
}

// Gyroscope (integration): each move's gravity-direction mismatch before and after [deg]; none
// without moves.
std::vector<Figure> move_figure(const json& gy) {
  const json moves = gy.value("moves", json::array());
  if (moves.empty()) return {};
  Plot p;
  p.title = "gyroscope: gravity-direction mismatch per move, before and after calibration";
  p.x_label = "end of the move [s]";
  p.y_label = "mismatch [deg]";
  p.width = 760;
  p.y_include_zero = true;
  Series before{"raw rate", Style::kPoints, {}, {}, {}, {}, palette(1), false, 0.9};
  Series after{"calibrated rate", Style::kPoints, {}, {}, {}, {}, palette(0), false, 0.9};
  for (const auto& m : moves) {
    before.x.push_back(num(m, "t_end_s"));
    before.y.push_back(num(m, "mismatch_before_rad") * physics::kRadToDeg);
    after.x.push_back(num(m, "t_end_s"));
    after.y.push_back(num(m, "mismatch_after_rad") * physics::kRadToDeg);
  }
  p.series = {before, after};
  return {{p, "Angle between the gravity direction carried over each move by the integrated gyro rate and the one "
              "measured in the static interval after it, with the raw and the calibrated rate."}};
}

// Gyroscope (turns): each turn's integrated reading minus the stated turn, |v − θ| [deg], raw and
// calibrated; none without turns.
std::vector<Figure> turn_figure(const json& gy) {
  const json turns = gy.value("turns", json::array());
  if (turns.empty()) return {};
  Plot p;
  p.title = "gyroscope: integrated turn minus the stated turn, before and after calibration";
  p.x_label = "turn";
  p.y_label = "|v − θ| [deg]";
  p.width = 760;
  p.y_include_zero = true;
  Series before{"raw rate", Style::kPoints, {}, {}, {}, {}, palette(1), false, 0.9};
  Series after{"calibrated rate", Style::kPoints, {}, {}, {}, {}, palette(0), false, 0.9};
  auto miss_deg = [](const json& t, const char* key) {
    const json stated = t.value("stated_deg", json::array()), v = t.value(key, json::array());
    double sq = 0.0;
    for (std::size_t a = 0; a < 3; ++a) sq += std::pow(estimation::number_at(v, a) - estimation::number_at(stated, a), 2);
    return std::sqrt(sq);
  };
  for (const auto& t : turns) {
    const auto x = static_cast<double>(p.x_categories.size());
    before.x.push_back(x);
    before.y.push_back(miss_deg(t, "integrated_before_deg"));
    after.x.push_back(x);
    after.y.push_back(miss_deg(t, "integrated_after_deg"));
    p.x_categories.push_back(estimation::text_field(t, "label"));
  }
  p.series = {before, after};
  return {{p, "How far the gyro reading integrated over each known turn lies from the turn the recording states, with "
              "the raw and the calibrated rate."}};
}

// Each estimated parameter with its interval, one plot per display unit (values against names);
// fixed and unidentified parameters left out.
std::vector<Figure> parameter_interval_figures(const json& fit) {
  std::map<std::string, Plot> by_unit;
  for (const auto& p : fit.value("parameters", json::array())) {
    if (!p.value("identifiable", false) || p.value("fixed", false)) continue;
    const estimation::DisplayUnit du = estimation::display_unit(estimation::text_field(p, "unit"));
    Plot& pl = by_unit[du.unit];
    if (pl.series.empty()) {
      pl.title = "estimated parameters [" + du.unit + "] with their intervals";
      pl.x_label = "parameter";
      pl.y_label = "value [" + du.unit + "]";
      pl.width = 760;
      pl.series.push_back(Series{"value with its interval", Style::kPoints, {}, {}, {}, {}, palette(0), false, 1.0});
      pl.lines.push_back({true, 0.0, "", "#555"});
    }
    const json iv = p.value("interval", json::array());
    Series& s = pl.series[0];
    s.x.push_back(static_cast<double>(pl.x_categories.size()));
    s.y.push_back(num(p, "value") * du.scale);
    s.y_lo.push_back(estimation::number_at(iv, 0) * du.scale);
    s.y_hi.push_back(estimation::number_at(iv, 1) * du.scale);
    pl.x_categories.push_back(estimation::text_field(p, "name"));
  }
  std::vector<Figure> out;
  for (const auto& [unit, pl] : by_unit)
    out.push_back({pl, "Each estimated parameter's value with its interval (fixed and unidentified parameters left out)."});
  return out;
}

}  // namespace

estimation::ReportSection report_section(const estimation::FitResult& result) {
  const estimation::FitSummary& s = result.summary;
  const json& fit = result.document;
  estimation::ReportSection section;
  section.heading = "Error-model fit — " + s.estimator + " " + s.version;
  section.file = result.results_file;
  section.topic = estimation::ReportSection::Topic::kErrorModel;
  if (!s.ok()) {
    section.add(estimation::failure_paragraph("FIT FAILED", s.message));
    return section;
  }
  section.add(estimation::parameter_table(s));
  for (const auto& n : s.notes) section.add_text("note: " + n);
  if (fit.contains("accelerometer")) section.append(norm_figure(fit["accelerometer"]));
  if (fit.contains("gyroscope")) {
    section.append(move_figure(fit["gyroscope"]));
    section.append(turn_figure(fit["gyroscope"]));
  }
  section.append(parameter_interval_figures(fit));
  return section;
}

}  // namespace stend::ceres_nonlinear
