// temp_poly's options: read from the model file's YAML and checked. See stend/temp_poly/temp_poly.hpp.
#include "stend/temp_poly/temp_poly.hpp"

#include <stend/errors.hpp>

#include <cmath>
#include <stend/yaml/reader.hpp>
#include <yaml-cpp/yaml.h>

namespace stend::temp_poly {

bool TempPolyOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (selection != "bic" && selection != "cv" && selection != "fixed")
    return fail("unknown selection '" + selection + "': use bic, cv or fixed");
  if (selection == "fixed" && (order < 0 || order > 6)) return fail("order " + std::to_string(order) + " is outside 0..6");
  if (selection != "fixed" && (max_order < 1 || max_order > 6))
    return fail("max_order " + std::to_string(max_order) + " is outside 1..6");
  if (axes.empty()) return fail("no axes to fit");
  for (int a : axes)
    if (a < 0 || a > 2) return fail("axis index " + std::to_string(a) + " is not 0 (x), 1 (y) or 2 (z)");
  if (!bias_temperature && !scale_temperature)
    return fail("neither bias_temperature nor scale_temperature is enabled: nothing depends on temperature");
  if (!(level_tolerance_c > 0.0) || !(min_span_c >= 0.0) || !std::isfinite(reference_c))
    return fail("level_tolerance_c must be > 0, min_span_c ≥ 0 and reference_c finite");
  if (!(confidence > 0.0 && confidence < 1.0)) return fail("confidence must be in (0, 1)");
  return tolerances.IsValid(error) && processing.IsValid(error);
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
                                   "min_span_c", "level_tolerance_c", "scale", "bias_temperature", "scale_temperature",
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
  o.scale = top.boolean("scale", o.scale);
  o.bias_temperature = top.boolean("bias_temperature", o.bias_temperature);
  o.scale_temperature = top.boolean("scale_temperature", o.scale_temperature);
  if (!o.bias_temperature && !o.scale_temperature)
    top.fail_key("scale_temperature", "bias_temperature and scale_temperature are both false: nothing depends on temperature");
  o.cross_axis = top.boolean("cross_axis", o.cross_axis);
  o.confidence = top.number("confidence", o.confidence, "");
  if (!(o.confidence > 0 && o.confidence < 1)) top.fail_value("confidence", "confidence must be in (0, 1)");
  processing::read_options(top, o.processing);
  estimation::read_tolerances(top, o.tolerances);
  if (std::string why; !o.IsValid(&why)) throw ExperimentError(top.location(), "", why);
  return o;
}

TempPolyOptions load_options(const std::filesystem::path& file) {
  return parse_options(yaml::read_file(file.string(), "model file"), file.string());
}

}  // namespace stend::temp_poly
