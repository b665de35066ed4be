// Text report, JSON and YAML options of temp_poly. See stend/temp_poly/temp_poly.hpp.
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stend/errors.hpp>
#include <stend/yaml/reader.hpp>
#include <yaml-cpp/yaml.h>

#include "stend/temp_poly/temp_poly.hpp"

namespace stend::temp_poly {

namespace {

// Formats are literals at every call site (printf-style helper).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}
#pragma GCC diagnostic pop

nlohmann::json num_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

void print_report(std::ostream& os, const TempPolyResult& r) {
  const TempPolyOptions& o = r.options;
  os << "temp_poly " << kEstimatorVersion << " — bias and scale versus temperature ("
     << estimation::instrument_name(o.instrument) << ")\n";
  if (!r.recording_dir.empty()) os << "recording: " << r.recording_dir << " (" << r.experiment_name << ")\n";
  os << "selection: " << o.selection;
  if (o.selection == "fixed") os << ", order " << o.order;
  else os << ", orders 0.." << o.max_order;
  os << "; terms: bias, scale" << (o.cross_axis ? ", cross_axis" : "")
     << (o.bias_temperature ? ", bias_temperature" : "") << (o.scale_temperature ? ", scale_temperature" : "")
     << "; reference T0 = " << o.reference_c << " degC; min_span_c = " << o.min_span_c << " degC\n";
  if (!r.ok && r.axes.empty()) {
    os << "TEMPERATURE FIT REFUSED: " << r.message << "\n";
    for (const auto& nt : r.notes) os << "note: " << nt << "\n";
    return;
  }
  os << "valid temperature range: " << fmt("%.2f", r.valid_min_c) << " … " << fmt("%.2f", r.valid_max_c)
     << " degC; " << r.points.size() << " static points\n";
  os << "levels (degC: points heating/cooling/unknown):\n";
  for (const auto& L : r.levels)
    os << "  " << fmt("%8.2f", L.temperature_c) << "  [" << fmt("%.2f", L.min_c) << ", " << fmt("%.2f", L.max_c)
       << "]  " << L.points << " (" << L.heating_points << "/" << L.cooling_points << "/" << L.unknown_points << ")\n";
  for (const auto& ax : r.axes) {
    const char name = estimation::axis_name(ax.axis);
    os << "\n== axis " << name << " ==\n";
    os << "  order  n    rank  RSS            BIC          CV-MSE        note\n";
    for (const auto& s : ax.scores)
      os << (s.order == ax.chosen_order ? "* " : "  ") << fmt("%5.0f", s.order) << fmt("%5.0f", s.observations)
         << fmt("%6.0f", s.parameters) << "  " << fmt("%-13.6g", s.rss) << "  " << fmt("%-11.6g", s.bic) << "  "
         << (s.cv_ok ? fmt("%-12.6g", s.cv_mse) : std::string("-           ")) << "  " << s.note << "\n";
    if (!ax.ok) {
      os << "  AXIS FAILED: " << ax.message << "\n";
      continue;
    }
    os << "  chosen order " << ax.chosen_order << " (" << o.selection << ")\n";
    for (const auto& p : ax.fit.lsq.parameters) os << "  " << p << "\n";
    os << "  residual RMS " << fmt("%.4g", ax.fit.residual_rms[ax.axis]) << " " << r.unit << " ("
       << fmt("%.4g", ax.fit.residual_rms_display[ax.axis]) << " " << ax.fit.display_unit << ")\n";
    for (const auto& w : ax.fit.lsq.warnings) os << "  warning: " << w << "\n";
    if (ax.hysteresis.empty()) {
      os << "  hysteresis: no level was visited on both the heating and the cooling leg\n";
    } else {
      os << "  hysteresis (cooling − heating mean residual, " << r.unit << "):\n";
      for (const auto& h : ax.hysteresis)
        os << "    " << fmt("%8.2f", h.temperature_c) << " degC  " << fmt("%+.4g", h.value) << " ± "
           << fmt("%.2g", h.std_error) << "  [" << fmt("%.4g", h.lower) << ", " << fmt("%.4g", h.upper) << "]  ("
           << h.heating_points << " heating, " << h.cooling_points << " cooling)"
           << (h.significant ? "  SIGNIFICANT" : "") << "\n";
    }
  }
  if (!r.ok) os << "\nTEMPERATURE FIT FAILED: " << r.message << "\n";
  for (const auto& nt : r.notes) os << "note: " << nt << "\n";
}

std::ostream& operator<<(std::ostream& os, const TempPolyResult& r) {
  print_report(os, r);
  return os;
}

namespace {

using nlohmann::json;

// "options": the settings the fit ran with.
json options_json(const TempPolyOptions& o) {
  json axes = json::array();
  for (int a : o.axes) axes.push_back(std::string(1, estimation::axis_name(a)));
  return {{"instrument", estimation::instrument_name(o.instrument)},
          {"axes", axes},
          {"selection", o.selection},
          {"max_order", o.max_order},
          {"order", o.order},
          {"reference_c", o.reference_c},
          {"min_span_c", o.min_span_c},
          {"level_tolerance_c", o.level_tolerance_c},
          {"bias_temperature", o.bias_temperature},
          {"scale_temperature", o.scale_temperature},
          {"cross_axis", o.cross_axis},
          {"confidence", o.confidence}};
}

// "levels": each temperature level [°C] with its point counts per leg.
json levels_json(const std::vector<TemperatureLevel>& levels) {
  json out = json::array();
  for (const auto& L : levels)
    out.push_back({{"temperature_c", L.temperature_c},
                   {"min_c", L.min_c},
                   {"max_c", L.max_c},
                   {"points", L.points},
                   {"heating_points", L.heating_points},
                   {"cooling_points", L.cooling_points},
                   {"unknown_points", L.unknown_points}});
  return out;
}

// "points": each static point's label, temperature [°C], level and leg.
json points_json(const TempPolyResult& r) {
  json pts = json::array();
  for (std::size_t i = 0; i < r.points.size(); ++i)
    pts.push_back({{"label", processing::label(r.points[i].segment)},
                   {"temperature_c", r.points[i].stimulus.temperature_c},
                   {"level", i < r.level_of.size() ? r.level_of[i] : -1},
                   {"leg", i < r.legs.size() ? leg_name(r.legs[i]) : "unknown"}});
  return pts;
}

// The candidate orders' scores (RSS, BIC, CV error) of an axis.
json scores_json(const std::vector<OrderScore>& scores) {
  json out = json::array();
  for (const auto& s : scores)
    out.push_back({{"order", s.order},
                   {"ok", s.ok},
                   {"observations", s.observations},
                   {"rank", s.parameters},
                   {"rss", num_or_null(s.rss)},
                   {"bic", num_or_null(s.bic)},
                   {"cv_ok", s.cv_ok},
                   {"cv_mse", num_or_null(s.cv_mse)},
                   {"note", s.note}});
  return out;
}

// The cooling-minus-heating hysteresis per level of an axis.
json hysteresis_json(const std::vector<Hysteresis>& hysteresis) {
  json out = json::array();
  for (const auto& h : hysteresis)
    out.push_back({{"temperature_c", h.temperature_c},
                   {"heating_points", h.heating_points},
                   {"cooling_points", h.cooling_points},
                   {"value", num_or_null(h.value)},
                   {"std_error", num_or_null(h.std_error)},
                   {"lower", num_or_null(h.lower)},
                   {"upper", num_or_null(h.upper)},
                   {"significant", h.significant}});
  return out;
}

// One axis: status, chosen order, scores, hysteresis and the chosen fit's own document.
json axis_json(const AxisResult& ax) {
  json a;
  a["axis"] = std::string(1, estimation::axis_name(ax.axis));
  a["ok"] = ax.ok;
  a["message"] = ax.message;
  a["chosen_order"] = ax.chosen_order;
  a["scores"] = scores_json(ax.scores);
  a["hysteresis"] = hysteresis_json(ax.hysteresis);
  a["max_abs_hysteresis"] = num_or_null(ax.max_abs_hysteresis);
  a["fit"] = ax.ok ? json::parse(batch_lsq::to_json(ax.fit, -1)) : json();
  return a;
}

}  // namespace

std::string to_json(const TempPolyResult& r, int indent) {
  json j;
  j["schema"] = kSchema;
  j["estimator"] = {{"name", kEstimatorName}, {"version", kEstimatorVersion}};
  j["status"] = r.ok ? "ok" : "failed";
  j["message"] = r.message;
  j["recording"] = {{"dir", r.recording_dir}, {"experiment", r.experiment_name}};
  j["options"] = options_json(r.options);
  j["unit"] = r.unit;
  j["reference_c"] = r.reference_c;
  j["valid_range_c"] = {num_or_null(r.valid_min_c), num_or_null(r.valid_max_c)};
  j["levels"] = levels_json(r.levels);
  j["points"] = points_json(r);
  json axes = json::array();
  for (const auto& ax : r.axes) axes.push_back(axis_json(ax));
  j["axes"] = axes;
  j["notes"] = r.notes;
  return j.dump(indent);
}

TempPolyOptions parse_options(const std::string& yaml_text, const std::string& f) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw ExperimentError({f, e.mark.line + 1, e.mark.column + 1}, "", "YAML syntax error: " + e.msg);
  }
  TempPolyOptions o;
  std::vector<std::string> keys = {"instrument", "axes", "selection", "max_order", "order", "reference_c",
                                   "min_span_c", "level_tolerance_c", "bias_temperature", "scale_temperature",
                                   "cross_axis", "confidence", estimation::kTolerancesKey};
  keys.insert(keys.end(), processing::kOptionKeys.begin(), processing::kOptionKeys.end());
  yaml::MapReader top(root, f, "", "temp_poly options", keys);
  const std::string inst = top.string("instrument", "accelerometer");
  if (inst == "accelerometer") o.instrument = model::Instrument::kAccelerometer;
  else if (inst == "gyroscope") o.instrument = model::Instrument::kGyroscope;
  else top.fail_value("instrument", "unknown instrument '" + inst + "'", "use accelerometer or gyroscope");
  if (top.has("axes")) {
    const YAML::Node axes = top.get("axes");
    if (!axes.IsSequence() || axes.size() == 0) top.fail_value("axes", "expected a list such as [x, y, z]");
    o.axes.clear();
    for (std::size_t i = 0; i < axes.size(); ++i) {
      const std::string path = "axes[" + std::to_string(i) + "]";
      const std::string a = yaml::as_string(axes[i], f, path);
      const int idx = a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1;
      if (idx < 0) throw ExperimentError(yaml::location_of(axes[i], f), path, "unknown axis '" + a + "'", "axes are x, y and z");
      o.axes.push_back(idx);
    }
  }
  o.selection = top.string("selection", o.selection);
  if (o.selection != "bic" && o.selection != "cv" && o.selection != "fixed")
    top.fail_value("selection", "unknown selection '" + o.selection + "'", "use bic, cv or fixed");
  o.max_order = static_cast<int>(top.integer("max_order", o.max_order));
  if (o.max_order < 1 || o.max_order > 6) top.fail_value("max_order", "max_order must be 1..6");
  o.order = static_cast<int>(top.integer("order", o.order));
  if (o.order < 0 || o.order > 6) top.fail_value("order", "order must be 0..6");
  o.reference_c = top.number("reference_c", o.reference_c, "in degrees Celsius");
  o.min_span_c = top.number("min_span_c", o.min_span_c, "in degrees Celsius");
  if (o.min_span_c < 0) top.fail_value("min_span_c", "min_span_c must be ≥ 0");
  o.level_tolerance_c = top.number("level_tolerance_c", o.level_tolerance_c, "in degrees Celsius");
  if (!(o.level_tolerance_c > 0)) top.fail_value("level_tolerance_c", "level_tolerance_c must be > 0");
  o.bias_temperature = top.boolean("bias_temperature", o.bias_temperature);
  o.scale_temperature = top.boolean("scale_temperature", o.scale_temperature);
  if (!o.bias_temperature && !o.scale_temperature)
    top.fail_key("scale_temperature", "bias_temperature and scale_temperature are both false: nothing depends on temperature");
  o.cross_axis = top.boolean("cross_axis", o.cross_axis);
  o.confidence = top.number("confidence", o.confidence, "");
  if (!(o.confidence > 0 && o.confidence < 1)) top.fail_value("confidence", "confidence must be in (0, 1)");
  processing::read_options(top, o.processing);
  estimation::read_tolerances(top, o.tolerances);
  return o;
}

TempPolyOptions load_options(const std::filesystem::path& file) {
  return parse_options(yaml::read_file(file.string(), "model file"), file.string());
}

}  // namespace stend::temp_poly
