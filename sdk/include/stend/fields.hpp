// Field tables: each plugin parameter declared once — its key, the Config member it sets, unit,
// bounds, choices and doc — and from that one declaration both
//   * the schema the host checks an experiment's `config:` block against (the stend_param_spec
//     array of the C ABI, each default written as YAML text from the default Config's member), and
//   * the reader that turns the validated stend::Params into the Config
// are generated. A parameter's default is its Config member's initializer and nothing else.
//
//   struct BiasSensorConfig {
//     double rate_hz = 100.0;                                 // Hz
//     Eigen::Vector3d bias_mps2 = Eigen::Vector3d::Zero();   // sensor frame
//     std::string port;                                      // required: the experiment gives it
//   };
//
//   const stend::fields::Table<BiasSensorConfig>& bias_sensor_fields() {
//     using F = stend::fields::Field<BiasSensorConfig>;
//     static const stend::fields::Table<BiasSensorConfig> table("bias_sensor", {
//         F("rate_hz", &BiasSensorConfig::rate_hz, "Hz", "output data rate").range(1.0, 1000.0),
//         F("bias_mps2", &BiasSensorConfig::bias_mps2, "m/s^2", "constant bias").range(-50.0, 50.0),
//         F("port", &BiasSensorConfig::port, "", "serial port, e.g. /dev/ttyUSB0").required(),
//     });
//     return table;
//   }
//
//   BiasSensor::BiasSensor(const stend::Params& p) : c_(bias_sensor_fields().read(p)) {}
//   STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "bias_sensor", "0.1.0", "…", bias_sensor_fields(), BiasSensor)
//
// Member types and the schema type they declare:
//   double                  number     integral types (not bool)          integer
//   bool                    bool       std::string                        string
//   Eigen::Vector3d         vec3       Eigen::Matrix3d                    mat3
//   std::vector<double>     numbers    std::vector<std::vector<double>>   matrix3
// A member is named by a member pointer, by two member pointers for a member of a member
// (&SimImuConfig::accel, &TriadErrors::bias), or by any callable `T& (Config&)`.
// Field::property declares a parameter whose YAML value is converted on the way in and out, and
// fields::nested lifts the fields of a part of the Config (shared by several plugins) into it.
//
// A Table owns the strings its stend_param_spec array points to, so it can be neither copied nor
// moved: keep it in static storage (a function-local static as above). The plugin ABI requires
// everything reachable from the entry point to live as long as the library is loaded.
//
// Header-only; depends on the SDK (sdk.hpp) only.
#pragma once

#include <stend/plugin_abi.h>
#include <stend/sdk.hpp>

#include <Eigen/Core>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace stend::fields {

// What the schema says about one parameter (the C ABI's stend_param_spec, owning its text).
struct Spec {
  std::string key;
  std::string type;     // "number" | "integer" | "bool" | "string" | "vec3" | "mat3" | "numbers" | "matrix3"
  std::string unit;     // SI unit of the value, "1" dimensionless, "" not applicable
  std::string doc;
  std::string choices;  // strings: '|'-separated allowed values; "" = any
  double min = std::numeric_limits<double>::quiet_NaN();  // inclusive, every element; NaN = unbounded
  double max = std::numeric_limits<double>::quiet_NaN();
  bool required = false;  // no default: the experiment must give it
};

namespace detail {

// Shortest text that reads back as the same double: fixed notation from 1e-4 up to 1e16
// ("0.0005", "4000000"), scientific outside ("1e-06", "8.726646259971648e-05").
inline std::string number_text(double v) {
  const double a = std::abs(v);
  const auto format = a == 0.0 || (a >= 1e-4 && a < 1e16) ? std::chars_format::fixed : std::chars_format::scientific;
  char buf[48];  // the longest: 17 digits, sign, point and 4 leading zeros, or an exponent
  const auto end = std::to_chars(buf, buf + sizeof buf, v, format).ptr;
  return std::string(buf, end);
}

inline std::string list_text(const std::vector<double>& v) {
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + number_text(v[i]);
  return out + "]";
}

// A YAML double-quoted scalar: always text, whatever it looks like ("0x68", "", "true").
inline std::string quoted_text(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto u = static_cast<unsigned char>(ch);
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (ch == '\n') {
      out += "\\n";
    } else if (ch == '\r') {
      out += "\\r";
    } else if (ch == '\t') {
      out += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      char esc[8];
      std::snprintf(esc, sizeof esc, "\\x%02X", static_cast<unsigned>(u));
      out += esc;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

// YAML text of a value: `2`, `0.5`, `true`, `"text"`, `[a, b, c]`, `[[a, b], [c, d], [e, f]]`.
inline std::string yaml_text(const Params::Value& value) {
  if (const auto* d = std::get_if<double>(&value)) return number_text(*d);
  if (const auto* i = std::get_if<std::int64_t>(&value)) return std::to_string(*i);
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  if (const auto* s = std::get_if<std::string>(&value)) return quoted_text(*s);
  if (const auto* l = std::get_if<std::vector<double>>(&value)) return list_text(*l);
  const auto& m = std::get<Params::Matrix>(value);
  std::string out = "[";
  for (std::size_t r = 0; r < m.size(); ++r) out += (r ? ", " : "") + list_text(m[r]);
  return out + "]";
}

// "a number", "text", "a list of 2 numbers", … for messages about a value of the wrong shape.
inline std::string describe(const Params::Value& value) {
  if (std::holds_alternative<double>(value)) return "a number";
  if (std::holds_alternative<std::int64_t>(value)) return "an integer";
  if (std::holds_alternative<bool>(value)) return "true/false";
  if (std::holds_alternative<std::string>(value)) return "text";
  if (const auto* l = std::get_if<std::vector<double>>(&value))
    return "a list of " + std::to_string(l->size()) + " numbers";
  const auto& m = std::get<Params::Matrix>(value);
  std::string out = "a matrix of " + std::to_string(m.size()) + " rows (";
  for (std::size_t r = 0; r < m.size(); ++r) out += (r ? ", " : "") + std::to_string(m[r].size());
  return out + " numbers)";
}

[[noreturn]] inline void wrong_shape(const std::string& who, const char* expected, const Params::Value& v) {
  throw std::invalid_argument(who + " must be " + expected + ", got " + describe(v));
}

// Every number a value holds (none for bool and string), for the bounds check.
inline std::vector<double> elements(const Params::Value& value) {
  if (const auto* d = std::get_if<double>(&value)) return {*d};
  if (const auto* i = std::get_if<std::int64_t>(&value)) return {static_cast<double>(*i)};
  if (const auto* l = std::get_if<std::vector<double>>(&value)) return *l;
  std::vector<double> out;
  if (const auto* m = std::get_if<Params::Matrix>(&value))
    for (const auto& row : *m) out.insert(out.end(), row.begin(), row.end());
  return out;
}

inline std::vector<std::string> split_choices(const std::string& choices) {
  std::vector<std::string> out;
  std::string cur;
  for (const char ch : choices + "|") {
    if (ch == '|') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += ch;
    }
  }
  return out;
}

// Shape<T>: the schema type of a member type, and its conversion to and from a Params value.
// `who` ("sim_imu: parameter 'seed'") starts the message of a value of the wrong shape.
template <class T, class = void>
struct Shape;  // a member type without a schema type stops here

template <>
struct Shape<double> {
  static constexpr const char* type = "number";
  static Params::Value to_value(double v) { return v; }
  static double from_value(const Params::Value& v, const std::string& who) {
    if (const auto* d = std::get_if<double>(&v)) return *d;
    if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
    wrong_shape(who, "a number", v);
  }
};

template <class T>
struct Shape<T, std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>>> {
  static constexpr const char* type = "integer";
  static Params::Value to_value(T v) { return static_cast<std::int64_t>(v); }
  static T from_value(const Params::Value& v, const std::string& who) {
    std::int64_t i = 0;
    if (const auto* p = std::get_if<std::int64_t>(&v)) {
      i = *p;
    } else if (const auto* d = std::get_if<double>(&v); d && std::trunc(*d) == *d && std::abs(*d) < 9.2e18) {
      i = static_cast<std::int64_t>(*d);  // a whole number given as a double (direct construction)
    } else {
      wrong_shape(who, "an integer", v);
    }
    if (!std::in_range<T>(i))
      throw std::invalid_argument(who + " = " + std::to_string(i) + " does not fit its " +
                                  std::to_string(sizeof(T) * 8) + "-bit integer");
    return static_cast<T>(i);
  }
};

template <>
struct Shape<bool> {
  static constexpr const char* type = "bool";
  static Params::Value to_value(bool v) { return v; }
  static bool from_value(const Params::Value& v, const std::string& who) {
    if (const auto* b = std::get_if<bool>(&v)) return *b;
    wrong_shape(who, "true or false", v);
  }
};

template <>
struct Shape<std::string> {
  static constexpr const char* type = "string";
  static Params::Value to_value(const std::string& v) { return v; }
  static std::string from_value(const Params::Value& v, const std::string& who) {
    if (const auto* s = std::get_if<std::string>(&v)) return *s;
    wrong_shape(who, "text", v);
  }
};

template <>
struct Shape<std::vector<double>> {
  static constexpr const char* type = "numbers";
  static Params::Value to_value(const std::vector<double>& v) { return v; }
  static std::vector<double> from_value(const Params::Value& v, const std::string& who) {
    if (const auto* l = std::get_if<std::vector<double>>(&v)) return *l;
    wrong_shape(who, "a list of numbers", v);
  }
};

template <>
struct Shape<Eigen::Vector3d> {
  static constexpr const char* type = "vec3";
  static Params::Value to_value(const Eigen::Vector3d& v) { return std::vector<double>{v[0], v[1], v[2]}; }
  static Eigen::Vector3d from_value(const Params::Value& v, const std::string& who) {
    const auto* l = std::get_if<std::vector<double>>(&v);
    if (!l || l->size() != 3) wrong_shape(who, "a list of 3 numbers", v);
    return {(*l)[0], (*l)[1], (*l)[2]};
  }
};

template <>
struct Shape<Eigen::Matrix3d> {
  static constexpr const char* type = "mat3";
  static Params::Value to_value(const Eigen::Matrix3d& m) {
    Params::Matrix rows(3, std::vector<double>(3));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) rows[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)] = m(r, c);
    return rows;
  }
  static Eigen::Matrix3d from_value(const Params::Value& v, const std::string& who) {
    const auto* m = std::get_if<Params::Matrix>(&v);
    bool ok = m && m->size() == 3;
    for (std::size_t r = 0; ok && r < 3; ++r) ok = (*m)[r].size() == 3;
    if (!ok) wrong_shape(who, "a 3x3 matrix", v);
    Eigen::Matrix3d out;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out(r, c) = (*m)[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)];
    return out;
  }
};

template <>
struct Shape<Params::Matrix> {
  static constexpr const char* type = "matrix3";
  static Params::Value to_value(const Params::Matrix& m) { return m; }
  static Params::Matrix from_value(const Params::Value& v, const std::string& who) {
    const auto* m = std::get_if<Params::Matrix>(&v);
    bool ok = m && m->size() == 3 && !(*m)[0].empty();
    for (std::size_t r = 1; ok && r < 3; ++r) ok = (*m)[r].size() == (*m)[0].size();
    if (!ok) wrong_shape(who, "3 rows of numbers of equal length", v);
    return *m;
  }
};

}  // namespace detail

// One parameter of a Config: its schema entry and how to get and set it.
template <class Config>
class Field {
 public:
  // The parameter's value as a Params value.
  using Getter = std::function<Params::Value(const Config&)>;
  // Sets the parameter from a value; throws std::invalid_argument starting with `who` when the
  // value has the wrong shape.
  using Setter = std::function<void(Config&, const Params::Value&, const std::string& who)>;

  // A member, named by a member pointer or a callable `T& (Config&)`.
  template <class Access>
    requires std::is_lvalue_reference_v<std::invoke_result_t<const Access&, Config&>>
  Field(std::string key, Access access, std::string unit, std::string doc)
      : Field(make<Member<Access>>(std::move(key), std::move(unit), std::move(doc), access,
                                   [access](Config& c, Member<Access> v) { std::invoke(access, c) = std::move(v); })) {}

  // A member of a member: `outer` names a part of the Config, `inner` the member of that part.
  template <class Outer, class Inner>
    requires std::is_lvalue_reference_v<std::invoke_result_t<const Outer&, Config&>>
  Field(std::string key, Outer outer, Inner inner, std::string unit, std::string doc)
      : Field(std::move(key),
              [outer, inner](Config& c) -> auto& { return std::invoke(inner, std::invoke(outer, c)); },
              std::move(unit), std::move(doc)) {}

  // A parameter of type T whose value is converted: get(const Config&) -> T gives the value the
  // schema shows (and the default), set(Config&, T) stores a value read from the experiment.
  template <class T, class Get, class Set>
  static Field property(std::string key, Get get, Set set, std::string unit, std::string doc) {
    return make<T>(std::move(key), std::move(unit), std::move(doc), std::move(get), std::move(set));
  }

  // The low-level form every other one ends in.
  Field(Spec spec, Getter get, Setter set) : spec_(std::move(spec)), get_(std::move(get)), set_(std::move(set)) {}

  // Inclusive bounds on the value (every element of a list or matrix).
  Field& range(double min, double max) {
    spec_.min = min;
    spec_.max = max;
    return *this;
  }
  Field& at_least(double min) {
    spec_.min = min;
    return *this;
  }
  // The allowed strings, '|'-separated: "fifo|poll".
  Field& choices(std::string bar_separated) {
    spec_.choices = std::move(bar_separated);
    return *this;
  }
  // No default: the experiment must give the key (the Config member's initializer is unused).
  Field& required() {
    spec_.required = true;
    return *this;
  }

  const Spec& spec() const { return spec_; }
  const Getter& getter() const { return get_; }
  const Setter& setter() const { return set_; }

  Params::Value value(const Config& c) const { return get_(c); }

  // Checks `v` against the bounds and choices, then sets it; throws std::invalid_argument
  // naming the plugin, the key and what is wrong.
  void assign(Config& c, const Params::Value& v, const std::string& plugin) const {
    const std::string who = plugin + ": parameter '" + spec_.key + "'";
    check(v, who);
    set_(c, v, who);
  }

  // Throws std::invalid_argument when `v` lies outside the bounds or choices.
  void check(const Params::Value& v, const std::string& who) const {
    for (const double x : detail::elements(v)) {
      if (!std::isnan(spec_.min) && x < spec_.min)
        throw std::invalid_argument(who + " = " + detail::number_text(x) + " is below the minimum " +
                                    detail::number_text(spec_.min));
      if (!std::isnan(spec_.max) && x > spec_.max)
        throw std::invalid_argument(who + " = " + detail::number_text(x) + " is above the maximum " +
                                    detail::number_text(spec_.max));
    }
    const auto* s = std::get_if<std::string>(&v);
    if (s && !spec_.choices.empty()) {
      bool ok = false;
      for (const auto& choice : detail::split_choices(spec_.choices)) ok = ok || choice == *s;
      if (!ok) throw std::invalid_argument(who + " = '" + *s + "' is not one of " + spec_.choices);
    }
  }

 private:
  template <class Access>
  using Member = std::remove_cvref_t<std::invoke_result_t<const Access&, Config&>>;

  template <class T, class Get, class Set>
  static Field make(std::string key, std::string unit, std::string doc, Get get, Set set) {
    using S = detail::Shape<T>;
    Spec spec;
    spec.key = std::move(key);
    spec.type = S::type;
    spec.unit = std::move(unit);
    spec.doc = std::move(doc);
    // A getter that takes the Config by non-const reference (an accessor) only reads here.
    Getter getter = [get](const Config& c) { return S::to_value(std::invoke(get, const_cast<Config&>(c))); };
    Setter setter = [set](Config& c, const Params::Value& v, const std::string& who) {
      std::invoke(set, c, S::from_value(v, who));
    };
    return Field(std::move(spec), std::move(getter), std::move(setter));
  }

  Spec spec_;
  Getter get_;
  Setter set_;
};

// The fields of a part of the Config (e.g. the keys several plugins share, declared once on their
// own struct) as fields of the whole: `part` names the part, a member pointer or `Part& (Config&)`.
template <class Config, class Part, class Access>
std::vector<Field<Config>> nested(Access part, const std::vector<Field<Part>>& fields) {
  std::vector<Field<Config>> out;
  for (const Field<Part>& f : fields) {
    auto get = f.getter();
    auto set = f.setter();
    out.emplace_back(
        f.spec(), [part, get](const Config& c) { return get(std::invoke(part, const_cast<Config&>(c))); },
        [part, set](Config& c, const Params::Value& v, const std::string& who) { set(std::invoke(part, c), v, who); });
  }
  return out;
}

// `first` then `second`: shared fields followed by a plugin's own.
template <class Config>
std::vector<Field<Config>> join(std::vector<Field<Config>> first, std::vector<Field<Config>> second) {
  first.insert(first.end(), std::make_move_iterator(second.begin()), std::make_move_iterator(second.end()));
  return first;
}

// A plugin's parameters: the schema handed to the host and the reader of its Params.
template <class Config>
class Table {
 public:
  // `plugin` names the plugin in messages; `defaults` gives every default (normally Config{},
  // or a Config with plugin-specific values when several plugins share one Config type).
  // Throws std::logic_error for a table that is a bug: an empty or repeated key, or a default
  // outside its own bounds or choices.
  Table(std::string plugin, std::vector<Field<Config>> fields, Config defaults = Config{})
      : plugin_(std::move(plugin)), fields_(std::move(fields)), defaults_(std::move(defaults)) {
    std::set<std::string> seen;
    default_yaml_.reserve(fields_.size());
    for (const Field<Config>& f : fields_) {
      const Spec& s = f.spec();
      if (s.key.empty() || !seen.insert(s.key).second)
        throw std::logic_error(plugin_ + ": field table has an empty or repeated key '" + s.key + "'");
      const Params::Value def = f.value(defaults_);
      if (!s.required) {
        try {
          f.check(def, plugin_ + ": default of '" + s.key + "'");
        } catch (const std::invalid_argument& e) {
          throw std::logic_error(e.what());
        }
      }
      default_yaml_.push_back(s.required ? std::string{} : detail::yaml_text(def));
    }
    // Built last: the pointers go into strings that no longer move.
    specs_.reserve(fields_.size());
    for (std::size_t i = 0; i < fields_.size(); ++i) {
      const Spec& s = fields_[i].spec();
      specs_.push_back({s.key.c_str(), s.type.c_str(), s.unit.c_str(),
                        s.required ? nullptr : default_yaml_[i].c_str(), s.min, s.max,
                        s.choices.empty() ? nullptr : s.choices.c_str(), s.doc.c_str()});
    }
  }
  Table(const Table&) = delete;
  Table& operator=(const Table&) = delete;

  const std::string& plugin() const { return plugin_; }
  const std::vector<Field<Config>>& fields() const { return fields_; }
  const Config& defaults() const { return defaults_; }

  // The schema, for STEND_DEFINE_PLUGIN (and the host): one stend_param_spec per field.
  const stend_param_spec* specs() const { return specs_.data(); }
  std::size_t size() const { return specs_.size(); }

  // The Config of `p`: the defaults, with every key present in `p` assigned. The host hands over
  // every key; code that builds a Params itself (tests, emulators) may give only some. Throws
  // std::invalid_argument naming the plugin and the key for an unknown key, a missing required
  // key, or a value of the wrong shape or outside the bounds or choices.
  Config read(const Params& p) const {
    Config c = defaults_;
    for (const auto& [key, value] : p.values()) find(key).assign(c, value, plugin_);
    for (const Field<Config>& f : fields_)
      if (f.spec().required && !p.has(f.spec().key))
        throw std::invalid_argument(plugin_ + ": missing required parameter '" + f.spec().key + "' (" +
                                    f.spec().doc + ")");
    return c;
  }

  // Every key with its value in `c` (the inverse of read()).
  Params params(const Config& c) const {
    Params p;
    for (const Field<Config>& f : fields_) p.set(f.spec().key, f.value(c));
    return p;
  }

 private:
  const Field<Config>& find(const std::string& key) const {
    for (const Field<Config>& f : fields_)
      if (f.spec().key == key) return f;
    throw std::invalid_argument(plugin_ + ": unknown parameter '" + key + "'");
  }

  std::string plugin_;
  std::vector<Field<Config>> fields_;
  Config defaults_;
  std::vector<std::string> default_yaml_;
  std::vector<stend_param_spec> specs_;
};

}  // namespace stend::fields
