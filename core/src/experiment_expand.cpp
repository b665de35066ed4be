// The experiment's procedure: section read and expanded — each step's settings with their
// defaults and units checked, repeats unrolled (every pass numbered in repeat_index), sweeps,
// lists and grids of angles turned into orientations — and Step::Kind's name table.
#include "experiment_parse.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

namespace stend {
namespace detail {

using yaml::MapReader;
using yaml::format_number;

namespace {

// Each step kind: its YAML name and the keys its body may hold. `repeat` is a step kind of the
// file that expands into the others, so it has no Step::Kind.
struct StepKindSpec {
  Step::Kind kind;
  const char* name;
  std::vector<std::string> keys;
};
const std::vector<StepKindSpec> kStepKindSpecs = {
    {Step::Kind::kSetTemperature, "set_temperature",
     {"fixture", "setpoint_c", "tolerance_c", "hold_s", "timeout_s", "record", "label"}},
    {Step::Kind::kOrientations, "orientations",
     {"fixture", "sweep", "list", "grid", "dwell_s", "record_s", "label"}},
    {Step::Kind::kRates, "rates", {"fixture", "axis", "rates_dps", "dwell_s", "record_s", "label"}},
    {Step::Kind::kSetVibration, "set_vibration", {"fixture", "amplitude_g", "frequency_hz", "label"}},
    {Step::Kind::kRecord, "record", {"duration_s", "label"}},
    {Step::Kind::kWait, "wait", {"duration_s", "label"}},
    {Step::Kind::kFaces, "faces", {"list", "record_s", "within_s", "label"}},
    {Step::Kind::kTurns, "turns", {"axis", "angle_deg", "direction", "count", "within_s", "label"}},
    {Step::Kind::kRateLegs, "rate_legs", {"axis", "rates_dps", "up", "record_s", "within_s", "label"}},
    {Step::Kind::kStill, "still", {"count", "record_s", "within_s", "label"}},
};

// Every step kind name of the file, `repeat` last.
std::vector<std::string> step_kind_names() {
  std::vector<std::string> out;
  for (const auto& k : kStepKindSpecs) out.push_back(k.name);
  out.push_back("repeat");
  return out;
}
const std::vector<std::string> kStepKinds = step_kind_names();

const StepKindSpec* find_step_kind(const std::string& name) {
  for (const auto& k : kStepKindSpecs)
    if (name == k.name) return &k;
  return nullptr;
}

// One step in the expansion, with how many times its source step is repeated per pass of the
// repeat that encloses this list (to number the passes of nested repeats through).
struct Expanded {
  Step step;
  std::int64_t multiplicity = 1;
};

// Reads the procedure of an experiment whose bench and limits are read already.
class ProcedureReader {
 public:
  explicit ProcedureReader(const Experiment& exp)
      : file_(exp.file), limits_(exp.limits), fixture_ids_(fixture_ids(exp)) {}

  // procedure: the expanded steps.
  std::vector<Step> read(const MapReader& top) {
    const YAML::Node list = top.get("procedure");
    const std::string hint = "add at least one step, e.g. '- record: {duration_s: 60}'";
    if (list.IsNull()) top.fail_key("procedure", "the procedure is empty", hint);
    if (!list.IsSequence())
      top.fail_value("procedure", "expected a list of steps for 'procedure', got " +
                                      yaml::describe(list),
                     "each step is an item like '- record: {duration_s: 60}'");
    if (list.size() == 0) top.fail_value("procedure", "the procedure is empty", hint);
    std::vector<Expanded> steps = step_list(list, "procedure", false);
    std::vector<Step> out;
    out.reserve(steps.size());
    for (auto& e : steps) out.push_back(std::move(e.step));
    return out;
  }

 private:
  // The steps of a list (the procedure, or a repeat's steps) with every repeat in it expanded.
  std::vector<Expanded> step_list(const YAML::Node& list, const std::string& path,
                                  bool inside_repeat) {
    std::vector<Expanded> out;
    for (std::size_t i = 0; i < list.size(); ++i)
      step(list[i], path + "[" + std::to_string(i) + "]", inside_repeat, out);
    return out;
  }

  // One item of a step list: a one-key mapping naming its kind. A repeat appends its expansion.
  void step(const YAML::Node& item, const std::string& path, bool inside_repeat,
            std::vector<Expanded>& out) {
    const YAML::Node key = step_kind_key(item, path);
    const YAML::Node body = item.begin()->second;
    const std::string kind = key.Scalar();
    const SourceLocation where = yaml::location_of(key, file_);
    const std::string spath = path + "." + kind;
    if (kind == "repeat") {
      repeat(body, spath, where, out);
      return;
    }
    const StepKindSpec& spec = *find_step_kind(kind);
    const MapReader m(body, file_, spath, "the " + kind + " step", spec.keys, {"repeat_index"}, where);
    Step s;
    s.kind = spec.kind;
    s.where = where;
    label_and_repeat_index(m, kind, inside_repeat, s);
    step_settings(m, s);
    if (out.size() >= kMaxSteps)
      fail(where, spath, "the procedure expands into more than " + std::to_string(kMaxSteps) +
                             " steps");
    out.push_back({std::move(s), 1});
  }

  // The key naming a step's kind; fails unless the item is a one-key mapping of a known kind.
  YAML::Node step_kind_key(const YAML::Node& item, const std::string& path) const {
    const std::string kinds_hint = "Step kinds: " + yaml::join(kStepKinds);
    if (!item.IsDefined() || item.IsNull())
      fail(yaml::location_of(item, file_), path,
           "expected a step (a one-key mapping naming its kind), got nothing: " + path +
               " is a '-' with nothing after it (reported where the next item starts)",
           "write e.g. '- record: {duration_s: 60}', or remove the empty '-'. " + kinds_hint);
    if (!item.IsMap())
      fail(yaml::location_of(item, file_), path,
           "expected a step (a one-key mapping naming its kind), got " + yaml::describe(item),
           "write e.g. '- record: {duration_s: 60}'. " + kinds_hint);
    if (item.size() != 1) {
      auto it = item.begin();
      const std::string first = it->first.IsScalar() ? it->first.Scalar() : "?";
      ++it;
      const std::string second = it->first.IsScalar() ? it->first.Scalar() : "?";
      fail(yaml::location_of(it->first, file_), path,
           "a step names exactly one kind, but this one has keys '" + first + "' and '" + second +
               "'",
           "indent the step's settings under its kind (deeper than '" + first +
               ":'), or start a new step with '-'");
    }
    const YAML::Node key = item.begin()->first;
    const std::string kind = key.IsScalar() ? key.Scalar() : std::string{};
    if (std::find(kStepKinds.begin(), kStepKinds.end(), kind) == kStepKinds.end())
      fail(yaml::location_of(key, file_), path, "unknown step kind '" + kind + "'",
           yaml::join_sentences(yaml::did_you_mean(kind, kStepKinds), kinds_hint));
    return key;
  }

  // `label` (default the kind's name) and `repeat_index` (only outside a repeat, which numbers
  // its passes itself).
  static void label_and_repeat_index(const MapReader& m, const std::string& kind, bool inside_repeat,
                                     Step& s) {
    s.label = m.string("label", kind);
    if (s.label.empty()) m.fail_value("label", "'label' must not be empty");
    if (!m.has("repeat_index")) return;
    if (inside_repeat)
      m.fail_key("repeat_index", "'repeat_index' is numbered by the enclosing repeat; remove it here");
    const std::int64_t r = m.integer("repeat_index", 0);
    if (r < 0 || r > static_cast<std::int64_t>(kMaxSteps))
      m.fail_value("repeat_index", "'repeat_index' must be between 0 and " +
                                       std::to_string(kMaxSteps) + ", got " + std::to_string(r));
    s.repeat_index = static_cast<int>(r);
  }

  // The settings of a step of kind s.kind, read from its body.
  void step_settings(const MapReader& m, Step& s) {
    switch (s.kind) {
      case Step::Kind::kSetTemperature: set_temperature_settings(m, s); break;
      case Step::Kind::kOrientations: orientations_settings(m, s); break;
      case Step::Kind::kRates: rates_settings(m, s); break;
      case Step::Kind::kSetVibration: set_vibration_settings(m, s); break;
      case Step::Kind::kRecord:
        m.require("duration_s", "seconds to record");
        s.record_s = positive(m, "duration_s", s.record_s, "in seconds", "s");
        break;
      case Step::Kind::kWait:
        m.require("duration_s", "seconds to wait without recording");
        s.dwell_s = positive(m, "duration_s", s.dwell_s, "in seconds", "s");
        break;
      case Step::Kind::kFaces: faces_settings(m, s); break;
      case Step::Kind::kTurns: turns_settings(m, s); break;
      case Step::Kind::kRateLegs: rate_legs_settings(m, s); break;
      case Step::Kind::kStill: still_settings(m, s); break;
    }
  }

  // set_temperature: chamber setpoint and tolerance [degC], hold and timeout [s].
  void set_temperature_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.require("setpoint_c", "chamber air temperature to reach, in degrees Celsius");
    s.setpoint_c = m.number("setpoint_c", s.setpoint_c, "in degrees Celsius");
    if (s.setpoint_c < -273.15)
      m.fail_value("setpoint_c", "setpoint " + format_number(s.setpoint_c) +
                                     " degC is below absolute zero");
    s.tolerance_c = positive(m, "tolerance_c", s.tolerance_c, "in degrees Celsius", "degC");
    s.hold_s = non_negative(m, "hold_s", s.hold_s);
    s.timeout_s = positive(m, "timeout_s", s.timeout_s, "in seconds", "s");
    s.record_settling = m.boolean("record", s.record_settling);
  }

  // orientations: one of sweep, list or grid [deg], then dwell and record times [s].
  void orientations_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.exactly_one_of({"sweep", "list", "grid"});
    if (m.has("sweep")) sweep(m, s);
    if (m.has("list")) orientation_list(m, s);
    if (m.has("grid")) grid(m, s);
    s.dwell_s = non_negative(m, "dwell_s", s.dwell_s);
    m.require("record_s", "seconds of data recorded at each orientation");
    s.record_s = positive(m, "record_s", s.record_s, "in seconds", "s");
  }

  // rates: the turning axis, its rates [deg/s], then dwell and record times [s].
  void rates_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.require("axis", "name of the table axis that turns, e.g. angle");
    s.axis = m.string("axis", "");
    if (s.axis.empty()) m.fail_value("axis", "'axis' must not be empty");
    m.require("rates_dps", "list of rates in degrees per second");
    s.rates = m.numbers("rates_dps", "in degrees per second");
    if (s.rates.empty())
      m.fail_value("rates_dps", "'rates_dps' is empty", "give at least one rate, e.g. [-100, 100]");
    s.dwell_s = non_negative(m, "dwell_s", s.dwell_s);
    m.require("record_s", "seconds of data recorded at each rate");
    s.record_s = positive(m, "record_s", s.record_s, "in seconds", "s");
  }

  // set_vibration: amplitude [g] (0 turns vibration off) and frequency [Hz].
  void set_vibration_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.require("amplitude_g", "vibration amplitude in g; 0 turns vibration off");
    s.amplitude_g = m.number("amplitude_g", s.amplitude_g, "in g");
    if (s.amplitude_g < 0)
      m.fail_value("amplitude_g",
                   "'amplitude_g' must not be negative, got " + format_number(s.amplitude_g) + " g",
                   "amplitudes are in g; 0 turns vibration off");
    if (s.amplitude_g > 0) m.require("frequency_hz", "vibration frequency in hertz");
    if (m.has("frequency_hz")) s.frequency_hz = positive(m, "frequency_hz", s.frequency_hz, "in hertz", "Hz");
  }

  // repeat: `count` passes of its `steps`, appended to `out` (repeats nest).
  void repeat(const YAML::Node& body, const std::string& path, const SourceLocation& where,
              std::vector<Expanded>& out) {
    const MapReader m(body, file_, path, "the repeat step", {"count", "steps", "label"}, {}, where);
    m.require("count", "how many times to run the steps, at least 1");
    m.require("steps", "the list of steps to repeat");
    const std::int64_t count = m.integer("count", 1);
    if (count < 1)
      m.fail_value("count", "repeat count must be at least 1, got " + std::to_string(count));
    if (m.has("label") && m.string("label", "").empty())
      m.fail_value("label", "'label' must not be empty");
    const YAML::Node list = m.get("steps");
    if (list.IsNull() || (list.IsSequence() && list.size() == 0))
      m.fail_value("steps", "the repeat has no steps", "list the steps to repeat under 'steps:'");
    if (!list.IsSequence())
      m.fail_value("steps", "expected a list of steps for 'steps', got " + yaml::describe(list));
    const std::vector<Expanded> inner = step_list(list, m.child_path("steps"), true);
    if (static_cast<double>(inner.size()) * static_cast<double>(count) +
            static_cast<double>(out.size()) >
        static_cast<double>(kMaxSteps))
      m.fail_value("count", "the repeat expands into more than " + std::to_string(kMaxSteps) +
                                " steps");
    for (std::int64_t pass = 0; pass < count; ++pass) {
      for (const Expanded& e : inner) {
        Expanded x = e;
        x.step.repeat_index =
            static_cast<int>(pass * e.multiplicity + static_cast<std::int64_t>(e.step.repeat_index));
        x.multiplicity = e.multiplicity * count;
        out.push_back(std::move(x));
      }
    }
  }

  // `fixture`: the id of a declared fixture.
  std::string step_fixture(const MapReader& m) {
    m.require("fixture", "id of a fixture declared under bench.fixtures");
    const std::string id = m.string("fixture", "");
    if (std::find(fixture_ids_.begin(), fixture_ids_.end(), id) == fixture_ids_.end()) {
      m.fail_value("fixture", "unknown fixture '" + id + "'",
                   yaml::join_sentences(yaml::did_you_mean(id, fixture_ids_),
                                        fixture_ids_.empty()
                                            ? "No fixtures are declared under bench.fixtures."
                                            : "Declared fixtures: " + yaml::join(fixture_ids_)));
    }
    return id;
  }

  // A duration [s] ≥ 0, at most the run-time limit.
  double non_negative(const MapReader& m, const std::string& key, double fallback) const {
    const double v = m.number(key, fallback, "in seconds");
    if (v < 0)
      m.fail_value(key, "'" + key + "' must not be negative, got " + format_number(v) + " s",
                   "durations are in seconds");
    within_run_time(m, key, v);
    return v;
  }

  // A value > 0; a duration (unit "s") also at most the run-time limit.
  double positive(const MapReader& m, const std::string& key, double fallback, const std::string& unit_words,
                  const std::string& unit) const {
    const double v = m.number(key, fallback, unit_words);
    if (m.has(key) && !(v > 0))
      m.fail_value(key,
                   "'" + key + "' must be greater than 0, got " + format_number(v) + " " + unit);
    if (unit == "s") within_run_time(m, key, v);
    return v;
  }

  // One duration longer than the whole run may be is refused where it is written.
  void within_run_time(const MapReader& m, const std::string& key, double v) const {
    const double limit = limits_.max_run_time_s;
    if (m.has(key) && v > limit)
      m.fail_value(key,
                   "'" + key + "' is " + format_number(v) + " s, more than the run-time limit of " +
                       format_number(limit) + " s (" + format_number(limit / 86400.0) + " days)",
                   "durations are in seconds; raise limits.max_run_time_s if a run this long is meant");
  }

  // "<axis>_deg" -> "<axis>"
  std::string axis_of_key(const YAML::Node& key, const std::string& path) const {
    if (!key.IsScalar())
      fail(yaml::location_of(key, file_), path,
           "orientation keys are '<axis>_deg' names, got " + yaml::describe(key));
    const std::string k = key.Scalar();
    const std::string suffix = "_deg";
    if (k.size() > suffix.size() && k.compare(k.size() - suffix.size(), suffix.size(), suffix) == 0)
      return k.substr(0, k.size() - suffix.size());
    std::string axis = k;
    const auto us = axis.rfind('_');
    if (us != std::string::npos && us > 0 && axis.size() - us <= 5) axis = axis.substr(0, us);
    fail(yaml::location_of(key, file_), path + "." + k,
         "orientation key '" + k + "' has no '_deg' unit",
         "did you mean '" + axis + "_deg'? angles are in degrees; keys are <axis>_deg, e.g. angle_deg");
  }

  // sweep: one axis from from_deg to to_deg in steps of step_deg (to_deg included when on the grid).
  void sweep(const MapReader& step_map, Step& s) {
    const MapReader m(step_map.get("sweep"), file_, step_map.child_path("sweep"), "'sweep'",
                      {"axis", "from_deg", "to_deg", "step_deg"}, {},
                      step_map.key_location("sweep"));
    m.require("axis", "name of the table axis to sweep, e.g. angle");
    m.require("from_deg", "first angle, in degrees");
    m.require("to_deg", "last angle, in degrees (included when it lies on the grid)");
    m.require("step_deg", "angle increment, in degrees");
    const std::string axis = m.string("axis", "");
    if (axis.empty()) m.fail_value("axis", "'axis' must not be empty");
    const double from = m.number("from_deg", 0.0, "in degrees");
    const double to = m.number("to_deg", 0.0, "in degrees");
    const double step = m.number("step_deg", 0.0, "in degrees");
    if (step == 0.0)
      m.fail_value("step_deg", "'step_deg' must not be 0",
                   "give the angle increment in degrees, e.g. step_deg: 2");
    if ((to - from) * step < 0)
      m.fail_value("step_deg",
                   "step_deg " + format_number(step) + " moves away from to_deg (the sweep goes from " +
                       format_number(from) + " to " + format_number(to) + " deg)",
                   "use step_deg: " + format_number(-step));
    const double span = (to - from) / step;  // >= 0
    if (span + 1 > static_cast<double>(kMaxOrientationsPerStep))
      m.fail_value("step_deg", "the sweep gives more than " +
                                   std::to_string(kMaxOrientationsPerStep) + " orientations");
    const auto n = static_cast<std::size_t>(std::floor(span + 1e-9 * std::max(1.0, span))) + 1;
    for (std::size_t i = 0; i < n; ++i) {
      double v = from + static_cast<double>(i) * step;
      if (i + 1 == n && std::abs(v - to) <= 1e-6 * std::abs(step)) v = to;
      Orientation o;
      o.where = m.location();
      o.targets.push_back({axis, v});
      s.orientations.push_back(std::move(o));
    }
  }

  // list: orientations given one by one, each a mapping of <axis>_deg to an angle.
  void orientation_list(const MapReader& step_map, Step& s) {
    const YAML::Node list = step_map.get("list");
    const std::string path = step_map.child_path("list");
    const std::string hint = "write list: [{angle_deg: 0}, {angle_deg: 90, tilt_deg: 10}]";
    if (!list.IsSequence())
      step_map.fail_value("list", "expected a list of orientations for 'list', got " +
                                      yaml::describe(list),
                          hint);
    if (list.size() == 0) step_map.fail_value("list", "the orientation list is empty", hint);
    if (list.size() > kMaxOrientationsPerStep)
      step_map.fail_value("list", "more than " + std::to_string(kMaxOrientationsPerStep) +
                                      " orientations in one step");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const YAML::Node entry = list[i];
      const std::string epath = path + "[" + std::to_string(i) + "]";
      if (!entry.IsMap() || entry.size() == 0)
        fail(yaml::location_of(entry, file_), epath,
             "expected an orientation (a mapping of <axis>_deg to angles), got " +
                 yaml::describe(entry),
             hint);
      Orientation o;
      o.where = yaml::location_of(entry, file_);
      for (auto it = entry.begin(); it != entry.end(); ++it) {
        const std::string axis = axis_of_key(it->first, epath);
        for (const auto& t : o.targets)
          if (t.axis == axis)
            fail(yaml::location_of(it->first, file_), epath + "." + it->first.Scalar(),
                 "axis '" + axis + "' is given twice in this orientation");
        const std::string kpath = epath + "." + it->first.Scalar();
        if (it->second.IsNull())
          fail(yaml::location_of(it->first, file_), kpath,
               "expected a number in degrees for '" + it->first.Scalar() + "', got nothing");
        o.targets.push_back({axis, yaml::as_number(it->second, file_, kpath, "in degrees")});
      }
      s.orientations.push_back(std::move(o));
    }
  }

  // grid: every combination of the angles listed per axis, the first axis varying slowest.
  void grid(const MapReader& step_map, Step& s) {
    const YAML::Node g = step_map.get("grid");
    const std::string path = step_map.child_path("grid");
    const std::string hint = "write grid: {angle_deg: [0, 90, 180], tilt_deg: [0, 45]}";
    if (!g.IsMap() || g.size() == 0)
      step_map.fail_value("grid", "expected a mapping of <axis>_deg to lists of angles for 'grid', got " +
                                      yaml::describe(g),
                          hint);
    std::vector<std::pair<std::string, std::vector<double>>> axes;
    double total = 1;
    for (auto it = g.begin(); it != g.end(); ++it) {
      const std::string axis = axis_of_key(it->first, path);
      const std::string kpath = path + "." + it->first.Scalar();
      for (const auto& a : axes)
        if (a.first == axis)
          fail(yaml::location_of(it->first, file_), kpath,
               "axis '" + axis + "' is given twice in the grid");
      if (it->second.IsNull())
        fail(yaml::location_of(it->first, file_), kpath,
             "expected a list of angles in degrees for '" + it->first.Scalar() + "', got nothing",
             hint);
      std::vector<double> values = yaml::as_numbers(it->second, file_, kpath, "in degrees");
      if (values.empty())
        fail(yaml::location_of(it->second, file_), kpath,
             "the grid gives no angles for '" + it->first.Scalar() + "'", hint);
      total *= static_cast<double>(values.size());
      axes.emplace_back(axis, std::move(values));
    }
    if (total > static_cast<double>(kMaxOrientationsPerStep))
      step_map.fail_value("grid", "the grid gives more than " +
                                      std::to_string(kMaxOrientationsPerStep) + " orientations");
    const SourceLocation where = step_map.value_location("grid");
    std::vector<std::vector<AxisTarget>> combos(1);
    for (const auto& [axis, values] : axes) {
      std::vector<std::vector<AxisTarget>> next;
      next.reserve(combos.size() * values.size());
      for (const auto& c : combos) {
        for (double v : values) {
          auto x = c;
          x.push_back({axis, v});
          next.push_back(std::move(x));
        }
      }
      combos = std::move(next);
    }
    for (auto& c : combos) {
      Orientation o;
      o.where = where;
      o.targets = std::move(c);
      s.orientations.push_back(std::move(o));
    }
  }

  const std::string& file_;
  const RunLimits& limits_;
  std::vector<std::string> fixture_ids_;
};

}  // namespace

std::vector<Step> read_procedure(const MapReader& top, const Experiment& exp) {
  return ProcedureReader(exp).read(top);
}

}  // namespace detail

bool step_is_commanded(Step::Kind kind) {
  switch (kind) {
    case Step::Kind::kFaces:
    case Step::Kind::kTurns:
    case Step::Kind::kRateLegs:
    case Step::Kind::kStill: return false;
    case Step::Kind::kSetTemperature:
    case Step::Kind::kOrientations:
    case Step::Kind::kRates:
    case Step::Kind::kRecord:
    case Step::Kind::kWait:
    case Step::Kind::kSetVibration: return true;
  }
  return true;
}

const char* step_kind_name(Step::Kind kind) {
  for (const auto& k : detail::kStepKindSpecs)
    if (k.kind == kind) return k.name;
  return "?";
}

}  // namespace stend
