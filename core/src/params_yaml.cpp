// Plugin `config:` mappings validated against the plugin's parameter schema.
#include <stend/core/experiment.hpp>
#include <stend/yaml/reader.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <variant>
#include <string>
#include <vector>

namespace stend {

namespace {

std::string str_or(const char* s, const char* fallback = "") { return s ? std::string(s) : fallback; }

std::vector<std::string> split_choices(const char* choices) {
  std::vector<std::string> out;
  if (!choices) return out;
  std::string cur;
  for (const char* p = choices; *p; ++p) {
    if (*p == '|') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += *p;
    }
  }
  out.push_back(cur);
  return out;
}

std::string unit_words_of(const stend_param_spec& spec) {
  const std::string unit = str_or(spec.unit);
  if (unit.empty() || unit == "1") return {};
  return "in " + unit;
}

std::string unit_suffix_of(const stend_param_spec& spec) {
  const std::string unit = str_or(spec.unit);
  if (unit.empty() || unit == "1") return {};
  return " " + unit;
}

// The types a schema declares (stend_param_spec::type, plugin_abi.h): one name table.
enum class ParamType { kNumber, kInteger, kBool, kString, kVec3, kMat3, kNumbers, kMatrix3 };
struct ParamTypeName {
  ParamType type;
  const char* name;   // as the schema writes it
  const char* words;  // as a message reads it
};
constexpr ParamTypeName kParamTypes[] = {
    {ParamType::kNumber, "number", "a number"},
    {ParamType::kInteger, "integer", "an integer"},
    {ParamType::kBool, "bool", "true or false"},
    {ParamType::kString, "string", "text"},
    {ParamType::kVec3, "vec3", "a list of 3 numbers"},
    {ParamType::kMat3, "mat3", "a 3x3 matrix (3 lists of 3 numbers)"},
    {ParamType::kNumbers, "numbers", "a list of numbers"},
    {ParamType::kMatrix3, "matrix3", "3 rows of numbers of equal length"},
};

const ParamTypeName* param_type(const std::string& name) {
  for (const auto& t : kParamTypes)
    if (name == t.name) return &t;
  return nullptr;
}

std::string type_words(const std::string& type) {
  const ParamTypeName* t = param_type(type);
  return t ? t->words : "a value of type '" + type + "'";
}

// "a number, in Hz, range [1, 1000]"
std::string describe_type(const stend_param_spec& spec) {
  std::string out = type_words(str_or(spec.type));
  const std::string unit = str_or(spec.unit);
  if (!unit.empty() && unit != "1") out += ", in " + unit;
  if (!std::isnan(spec.min) || !std::isnan(spec.max)) {
    out += ", range [" + (std::isnan(spec.min) ? std::string("-inf") : yaml::format_number(spec.min)) +
           ", " + (std::isnan(spec.max) ? std::string("inf") : yaml::format_number(spec.max)) + "]";
  }
  if (spec.choices) out += ", one of " + yaml::join(split_choices(spec.choices), " | ");
  return out;
}

// "odr_hz (a number, in Hz, range [1, 1000]): output data rate"
std::string describe_spec(const stend_param_spec& spec) {
  std::string out = str_or(spec.key) + " (" + describe_type(spec) + ")";
  const std::string doc = str_or(spec.doc);
  if (!doc.empty()) out += ": " + doc;
  return out;
}

// Checks one element against [min, max].
void check_range(double v, const YAML::Node& node, const stend_param_spec& spec,
                 const std::string& file, const std::string& path, const std::string& name) {
  const std::string unit = unit_suffix_of(spec);
  if (!std::isnan(spec.min) && v < spec.min)
    throw ExperimentError(yaml::location_of(node, file), path,
                          "'" + name + "' = " + yaml::format_number(v) + " is below the minimum " +
                              yaml::format_number(spec.min) + unit,
                          describe_spec(spec));
  if (!std::isnan(spec.max) && v > spec.max)
    throw ExperimentError(yaml::location_of(node, file), path,
                          "'" + name + "' = " + yaml::format_number(v) + " is above the maximum " +
                              yaml::format_number(spec.max) + unit,
                          describe_spec(spec));
}

Params::Matrix read_matrix(const YAML::Node& node, const stend_param_spec& spec,
                           const std::string& file, const std::string& path,
                           const std::string& name, bool square3) {
  const std::string expected = "expected " + type_words(str_or(spec.type)) + " for '" + name + "'";
  const std::string hint = square3 ? "write [[1, 0, 0], [0, 1, 0], [0, 0, 1]]"
                                   : "write three rows of equal length, e.g. [[1, 2], [3, 4], [5, 6]]";
  if (!node.IsSequence())
    throw ExperimentError(yaml::location_of(node, file), path,
                          expected + ", got " + yaml::describe(node), hint);
  if (node.size() != 3)
    throw ExperimentError(yaml::location_of(node, file), path,
                          expected + ", got " + std::to_string(node.size()) + " rows", hint);
  Params::Matrix m;
  for (std::size_t r = 0; r < 3; ++r) {
    const std::string rpath = path + "[" + std::to_string(r) + "]";
    const YAML::Node row = node[r];
    if (!row.IsSequence())
      throw ExperimentError(yaml::location_of(row, file), rpath,
                            expected + ": row " + std::to_string(r + 1) + " is " + yaml::describe(row),
                            hint);
    const std::size_t want = square3 ? 3 : (r == 0 ? row.size() : m[0].size());
    if (row.size() == 0 || row.size() != want)
      throw ExperimentError(yaml::location_of(row, file), rpath,
                            expected + ": row " + std::to_string(r + 1) + " has " +
                                std::to_string(row.size()) + " numbers" +
                                (row.size() == 0 ? "" : ", expected " + std::to_string(want)),
                            hint);
    std::vector<double> values;
    for (std::size_t c = 0; c < row.size(); ++c) {
      const std::string epath = rpath + "[" + std::to_string(c) + "]";
      const double v = yaml::as_number(row[c], file, epath, unit_words_of(spec));
      check_range(v, row[c], spec, file, epath, name);
      values.push_back(v);
    }
    m.push_back(std::move(values));
  }
  return m;
}

// A string, one of the schema's choices when it lists some.
std::string read_string(const YAML::Node& node, const stend_param_spec& spec, const std::string& file,
                        const std::string& path, const std::string& name) {
  const std::string v = yaml::as_string(node, file, path);
  if (spec.choices) {
    const auto choices = split_choices(spec.choices);
    bool ok = false;
    for (const auto& c : choices) ok = ok || c == v;
    if (!ok) {
      const std::string hint = yaml::join_sentences(yaml::did_you_mean(v, choices),
                                                    "Choices: " + yaml::join(choices, " | "));
      throw ExperimentError(yaml::location_of(node, file), path,
                            "'" + v + "' is not one of the choices for '" + name + "'", hint);
    }
  }
  return v;
}

// A list of numbers (exactly three for a vec3), each within the schema's range.
std::vector<double> read_numbers(const YAML::Node& node, const stend_param_spec& spec, const std::string& file,
                                 const std::string& path, const std::string& name, bool vec3) {
  if (!node.IsSequence())
    throw ExperimentError(yaml::location_of(node, file), path,
                          "expected " + type_words(str_or(spec.type)) + " for '" + name + "', got " +
                              yaml::describe(node),
                          vec3 ? "write [x, y, z]" : "write a list like [1, 2, 3]");
  if (vec3 && node.size() != 3)
    throw ExperimentError(yaml::location_of(node, file), path,
                          "expected a list of 3 numbers for '" + name + "', got " + std::to_string(node.size()),
                          "write [x, y, z]" + (unit_suffix_of(spec).empty() ? std::string{}
                                                                             : " in" + unit_suffix_of(spec)));
  std::vector<double> out;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string epath = path + "[" + std::to_string(i) + "]";
    const double v = yaml::as_number(node[i], file, epath, unit_words_of(spec));
    check_range(v, node[i], spec, file, epath, name);
    out.push_back(v);
  }
  return out;
}

Params::Value read_value(const YAML::Node& node, const stend_param_spec& spec,
                         const std::string& file, const std::string& path, const std::string& plugin) {
  const std::string type = str_or(spec.type);
  const std::string name = str_or(spec.key);
  const ParamTypeName* t = param_type(type);
  if (!t) {
    std::string names;
    for (std::size_t i = 0; i < std::size(kParamTypes); ++i)
      names += (i == 0 ? "" : i + 1 == std::size(kParamTypes) ? " or " : ", ") + std::string(kParamTypes[i].name);
    throw ExperimentError(yaml::location_of(node, file), path,
                          "plugin '" + plugin + "' declares key '" + name + "' with unknown type '" + type + "'",
                          "this is a bug in the plugin; its schema types must be " + names);
  }
  switch (t->type) {
    case ParamType::kNumber: {
      const double v = yaml::as_number(node, file, path, unit_words_of(spec));
      check_range(v, node, spec, file, path, name);
      return v;
    }
    case ParamType::kInteger: {
      const std::int64_t v = yaml::as_integer(node, file, path);
      check_range(static_cast<double>(v), node, spec, file, path, name);
      return v;
    }
    case ParamType::kBool: return yaml::as_bool(node, file, path);
    case ParamType::kString: return read_string(node, spec, file, path, name);
    case ParamType::kVec3:
    case ParamType::kNumbers: return read_numbers(node, spec, file, path, name, t->type == ParamType::kVec3);
    case ParamType::kMat3: return read_matrix(node, spec, file, path, name, true);
    case ParamType::kMatrix3: return read_matrix(node, spec, file, path, name, false);
  }
  return {};
}

}  // namespace

Params params_from_yaml(const YAML::Node& node, const stend_plugin_info& plugin,
                        const std::string& file, const std::string& key_path) {
  const std::string pname = str_or(plugin.name, "?");
  std::vector<std::string> keys;
  for (std::size_t i = 0; i < plugin.param_count && plugin.params; ++i) {
    if (!plugin.params[i].key || !plugin.params[i].type)
      throw ExperimentError(yaml::location_of(node, file), key_path,
                            "plugin '" + pname + "' has a schema entry without key or type",
                            "this is a bug in the plugin");
    keys.push_back(plugin.params[i].key);
  }
  const yaml::MapReader map(node, file, key_path, "the config of plugin '" + pname + "'", keys);

  Params out;
  for (std::size_t i = 0; i < plugin.param_count && plugin.params; ++i) {
    const stend_param_spec& spec = plugin.params[i];
    const std::string key = spec.key;
    const std::string path = map.child_path(key);
    if (map.has(key)) {
      const YAML::Node value = map.get(key);
      if (value.IsNull())
        map.fail_key(key, "expected " + type_words(spec.type) + " for '" + key + "', got nothing",
                     describe_spec(spec));
      out.set(key, read_value(value, spec, file, path, pname));
    } else if (spec.default_yaml) {
      std::string problem;
      try {
        out.set(key, read_value(YAML::Load(spec.default_yaml), spec, file, path, pname));
      } catch (const ExperimentError& e) {
        problem = e.message();
      } catch (const YAML::Exception& e) {
        problem = e.msg;
      }
      if (!problem.empty())
        throw ExperimentError(map.location(), path,
                              "plugin '" + pname + "' declares an invalid default '" +
                                  spec.default_yaml + "' for '" + key + "' (" + problem + ")",
                              "this is a bug in the plugin; give '" + key + "' explicitly meanwhile");
    } else {
      throw ExperimentError(map.location(), path,
                            "missing required key '" + key + "' in the config of plugin '" +
                                pname + "' (" + describe_type(spec) +
                                (spec.doc && *spec.doc ? std::string(": ") + spec.doc : "") + ")",
                            "add '" + key + ": ...' under the plugin's config:");
    }
  }
  return out;
}

namespace yaml {

void emit_string(YAML::Emitter& out, const std::string& text) {
  if (text.empty() || text == "~" || text == "null" || text == "Null" || text == "NULL")
    out << YAML::DoubleQuoted << text;
  else
    out << text;
}

void emit_params(YAML::Emitter& out, const Params& params, const stend_plugin_info* plugin) {
  std::vector<std::string> order;
  if (plugin && plugin->params)
    for (std::size_t i = 0; i < plugin->param_count; ++i)
      if (plugin->params[i].key && params.has(plugin->params[i].key))
        order.push_back(plugin->params[i].key);
  for (const auto& [k, v] : params.values())
    if (std::find(order.begin(), order.end(), k) == order.end()) order.push_back(k);

  if (order.empty()) out << YAML::Flow;
  out << YAML::BeginMap;
  for (const auto& key : order) {
    const Params::Value& v = params.values().at(key);
    out << YAML::Key << key << YAML::Value;
    if (const auto* d = std::get_if<double>(&v)) {
      out << format_number(*d);
    } else if (const auto* i = std::get_if<std::int64_t>(&v)) {
      out << *i;
    } else if (const auto* b = std::get_if<bool>(&v)) {
      out << *b;
    } else if (const auto* s = std::get_if<std::string>(&v)) {
      emit_string(out, *s);
    } else if (const auto* l = std::get_if<std::vector<double>>(&v)) {
      out << YAML::Flow << YAML::BeginSeq;
      for (double x : *l) out << format_number(x);
      out << YAML::EndSeq;
    } else if (const auto* m = std::get_if<Params::Matrix>(&v)) {
      out << YAML::Flow << YAML::BeginSeq;
      for (const auto& row : *m) {
        out << YAML::Flow << YAML::BeginSeq;
        for (double x : row) out << format_number(x);
        out << YAML::EndSeq;
      }
      out << YAML::EndSeq;
    }
  }
  out << YAML::EndMap;
}

}  // namespace yaml

}  // namespace stend
