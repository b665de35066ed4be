// YAML model specification of a linear error-model fit. See stend/estimation/model_spec.hpp.
#include "stend/estimation/model_spec.hpp"
#include "stend/recording/instruments.hpp"

#include <algorithm>
#include <stend/errors.hpp>
#include <stend/yaml/reader.hpp>
#include <yaml-cpp/yaml.h>

namespace stend::estimation {

namespace {

std::vector<std::string> term_names(model::Instrument inst) {
  std::vector<std::string> out;
  for (model::TermKind k : model::kAllTermKinds) {
    if (k == model::TermKind::kGSensitivity && inst != model::Instrument::kGyroscope) continue;
    out.push_back(model::term_name(k));
  }
  return out;
}

model::TermSpec parse_term(const YAML::Node& node, const std::string& file, const std::string& path,
                           model::Instrument inst) {
  std::string name;
  YAML::Node options;
  YAML::Node name_node = node;
  if (node.IsScalar()) {
    name = node.Scalar();
  } else if (node.IsMap() && node.size() == 1) {
    // reset() rebinds; operator= on a yaml-cpp Node would overwrite the node it refers to.
    name_node.reset(node.begin()->first);
    name = name_node.Scalar();
    options.reset(node.begin()->second);
  } else {
    throw ExperimentError(yaml::location_of(node, file), path,
                          "a term is a name ('bias') or a one-key mapping "
                          "('bias_temperature: {order: 2, reference_c: 25}'), got " +
                              yaml::describe(node));
  }
  const auto kind = model::term_from_name(name);
  const std::vector<std::string> known = term_names(inst);
  if (!kind || std::find(known.begin(), known.end(), name) == known.end()) {
    std::string msg = "unknown error-model term '" + name + "'";
    if (kind) msg = "term '" + name + "' applies to gyroscopes only";
    throw ExperimentError(yaml::location_of(name_node, file), path, msg,
                          yaml::did_you_mean(name, known) + "known terms: " + yaml::join(known));
  }
  model::TermSpec t;
  t.kind = *kind;
  const bool temperature =
      t.kind == model::TermKind::kBiasTemperature || t.kind == model::TermKind::kScaleTemperature;
  const std::vector<std::string> allowed =
      temperature ? std::vector<std::string>{"order", "reference_c"} : std::vector<std::string>{};
  yaml::MapReader opts(options, file, path + "." + name, "options of term '" + name + "'", allowed,
                       {}, yaml::location_of(name_node, file));
  if (temperature) {
    const std::int64_t order = opts.integer("order", 1);
    if (order < 1 || order > 6)
      opts.fail_value("order", "polynomial order " + std::to_string(order) + " is outside 1..6");
    t.order = static_cast<int>(order);
    t.reference_c = opts.number("reference_c", 25.0, "in degrees Celsius");
  }
  return t;
}

}  // namespace

const char* instrument_name(model::Instrument inst) { return stend::instrument_name(inst); }

std::optional<model::Instrument> instrument_from_name(const std::string& name) {
  for (const auto inst : {model::Instrument::kAccelerometer, model::Instrument::kGyroscope})
    if (name == instrument_name(inst)) return inst;
  return std::nullopt;
}

const char* weighting_name(Weighting w) {
  return w == Weighting::kNone ? "none" : "segment_noise";
}

char axis_name(int axis) { return "xyz"[axis]; }

bool ModelSpec::IsValid(std::string* error) const {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (model.terms.empty()) return fail("no error-model terms");
  for (std::size_t i = 0; i < model.terms.size(); ++i) {
    const model::TermSpec& t = model.terms[i];
    if (model.find(t.kind) != static_cast<int>(i)) return fail(std::string("term '") + model::term_name(t.kind) + "' given twice");
    if (t.kind == model::TermKind::kGSensitivity && model.instrument != model::Instrument::kGyroscope)
      return fail("g_sensitivity is a gyroscope term");
    if (model::is_temperature_polynomial(t.kind) && (t.order < 1 || t.order > 6))
      return fail(std::string("term '") + model::term_name(t.kind) + "': order must be 1..6");
  }
  if (axes.empty()) return fail("no axes to fit");
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (axes[i] < 0 || axes[i] > 2) return fail("axis index " + std::to_string(axes[i]) + " is not 0 (x), 1 (y) or 2 (z)");
    if (std::find(axes.begin(), axes.begin() + static_cast<std::ptrdiff_t>(i), axes[i]) != axes.begin() + static_cast<std::ptrdiff_t>(i))
      return fail(std::string("axis '") + axis_name(axes[i]) + "' given twice");
  }
  if (!(confidence > 0.0 && confidence < 1.0)) return fail("confidence must lie strictly between 0 and 1");
  return tolerances.IsValid(error) && processing.IsValid(error);
}

ModelSpec parse_model_spec(const std::string& yaml_text, const std::string& source_name) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw ExperimentError({source_name, e.mark.line + 1, e.mark.column + 1}, "",
                          "YAML syntax error: " + e.msg);
  }
  ModelSpec spec;
  spec.source = source_name;
  const std::string& f = source_name;
  std::vector<std::string> keys = {"instrument", "axes", "terms", "weighting", "confidence", kTolerancesKey};
  keys.insert(keys.end(), processing::kOptionKeys.begin(), processing::kOptionKeys.end());
  yaml::MapReader top(root, f, "", "model specification", keys);
  top.require("instrument", "accelerometer or gyroscope");
  top.require("terms", "a list of error-model terms");
  const std::string inst = top.string("instrument", "");
  if (inst == "accelerometer") {
    spec.model.instrument = model::Instrument::kAccelerometer;
  } else if (inst == "gyroscope") {
    spec.model.instrument = model::Instrument::kGyroscope;
  } else {
    top.fail_value("instrument", "unknown instrument '" + inst + "'",
                   yaml::did_you_mean(inst, {"accelerometer", "gyroscope"}) +
                       "use accelerometer or gyroscope");
  }

  if (top.has("axes")) {
    const YAML::Node axes = top.get("axes");
    if (!axes.IsSequence() || axes.size() == 0)
      top.fail_value("axes", "expected a non-empty list of axes such as [z] or [x, y, z]");
    spec.axes.clear();
    for (std::size_t i = 0; i < axes.size(); ++i) {
      const std::string path = "axes[" + std::to_string(i) + "]";
      const std::string a = yaml::as_string(axes[i], f, path);
      int idx = a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1;
      if (idx < 0)
        throw ExperimentError(yaml::location_of(axes[i], f), path,
                              "unknown axis '" + a + "'", "axes are x, y and z (sensor frame)");
      if (std::find(spec.axes.begin(), spec.axes.end(), idx) != spec.axes.end())
        throw ExperimentError(yaml::location_of(axes[i], f), path, "axis '" + a + "' given twice");
      spec.axes.push_back(idx);
    }
  }

  const YAML::Node terms = top.get("terms");
  if (!terms.IsSequence() || terms.size() == 0)
    top.fail_value("terms", "expected a non-empty list of error-model terms",
                   "e.g. terms: [bias, scale, {cross_axis: {}}]");
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const std::string path = "terms[" + std::to_string(i) + "]";
    model::TermSpec t = parse_term(terms[i], f, path, spec.model.instrument);
    if (spec.model.find(t.kind) >= 0)
      throw ExperimentError(yaml::location_of(terms[i], f), path,
                            "term '" + std::string(model::term_name(t.kind)) + "' given twice",
                            "give each term once (a temperature term's order covers all powers)");
    spec.model.terms.push_back(t);
  }

  if (spec.model.instrument == model::Instrument::kGyroscope) spec.processing.segment_kinds = {"rate", "orientation"};
  processing::read_options(top, spec.processing);

  if (top.has("weighting")) {
    const std::string w = top.string("weighting", "none");
    if (w == "none") {
      spec.weighting = Weighting::kNone;
    } else if (w == "segment_noise") {
      spec.weighting = Weighting::kSegmentNoise;
    } else {
      top.fail_value("weighting", "unknown weighting '" + w + "'",
                     yaml::did_you_mean(w, {"none", "segment_noise"}) +
                         "use none or segment_noise");
    }
  }
  spec.confidence = top.number("confidence", spec.confidence, "");
  if (!(spec.confidence > 0.0 && spec.confidence < 1.0))
    top.fail_value("confidence", "the interval level must lie strictly between 0 and 1",
                   "e.g. 0.95");
  read_tolerances(top, spec.tolerances);
  if (std::string why; !spec.IsValid(&why)) throw ExperimentError(top.location(), "", why);
  return spec;
}

ModelSpec load_model_spec(const std::filesystem::path& file) {
  return parse_model_spec(yaml::read_file(file.string(), "model file"), file.string());
}

std::string to_yaml(const ModelSpec& spec) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "instrument" << YAML::Value << instrument_name(spec.model.instrument);
  out << YAML::Key << "axes" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int a : spec.axes) out << std::string(1, axis_name(a));
  out << YAML::EndSeq;
  out << YAML::Key << "terms" << YAML::Value << YAML::BeginSeq;
  for (const auto& t : spec.model.terms) {
    if (t.kind == model::TermKind::kBiasTemperature || t.kind == model::TermKind::kScaleTemperature) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << model::term_name(t.kind) << YAML::Value
          << YAML::Flow << YAML::BeginMap << YAML::Key << "order" << YAML::Value << t.order
          << YAML::Key << "reference_c" << YAML::Value << YAML::Precision(17) << t.reference_c
          << YAML::EndMap << YAML::EndMap;
    } else {
      out << model::term_name(t.kind);
    }
  }
  out << YAML::EndSeq;
  processing::emit_options(out, spec.processing);
  out << YAML::Key << "weighting" << YAML::Value << weighting_name(spec.weighting);
  out << YAML::Key << "confidence" << YAML::Value << YAML::Precision(17) << spec.confidence;
  if (!spec.tolerances.equals(PrecisionTolerances{})) {
    const PrecisionTolerances& t = spec.tolerances;
    out << YAML::Key << kTolerancesKey << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Precision(17);
    out << YAML::Key << "accel_bias_mg" << YAML::Value << t.accel_bias_mg;
    out << YAML::Key << "gyro_bias_dps" << YAML::Value << t.gyro_bias_dps;
    out << YAML::Key << "scale_cross_ppm" << YAML::Value << t.scale_cross_ppm;
    out << YAML::Key << "g_sensitivity_dps_per_g" << YAML::Value << t.g_sensitivity_dps_per_g;
    out << YAML::Key << "temperature_span_c" << YAML::Value << t.temperature_span_c;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace stend::estimation
