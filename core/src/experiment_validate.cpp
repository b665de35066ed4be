// Stage 2 of reading an experiment: with the plugin objects created, the procedure checked against
// what the fixtures declare (roles, axes, ranges, rates). See validate_against_bench.
#include "experiment_parse.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace stend {

namespace {

using detail::fail;
using yaml::format_number;

const char* role_words(FixtureRole r) {
  switch (r) {
    case FixtureRole::kTable: return "table";
    case FixtureRole::kChamber: return "chamber";
    case FixtureRole::kStimulus: return "vibration stimulus";
  }
  return "?";
}

std::string range_text(const AxisSpec& a) {
  return "[" + format_number(a.min) + ", " + format_number(a.max) + "] " + a.unit;
}

// The fixture objects match the declarations one to one, in order.
void check_fixture_objects(const Experiment& exp, const std::vector<const Fixture*>& fixtures) {
  if (fixtures.size() != exp.fixtures.size())
    throw std::invalid_argument("validate_against_bench: " + std::to_string(fixtures.size()) +
                                " fixture objects for " + std::to_string(exp.fixtures.size()) +
                                " declared fixtures");
  for (std::size_t i = 0; i < fixtures.size(); ++i)
    if (!fixtures[i])
      throw std::invalid_argument("validate_against_bench: no object for fixture '" +
                                  exp.fixtures[i].id + "'");
}

// What the fixtures declare: each one's role and axes, in declaration order.
struct BenchDeclared {
  std::vector<FixtureRole> roles;
  std::vector<std::vector<AxisSpec>> axes;
};

// The fixture one procedure step commands, with the lookups its checks need; every failure
// names the step, the fixture and what it declares.
class StepFixture {
 public:
  StepFixture(const Experiment& exp, const BenchDeclared& bench, const Step& s, std::size_t si)
      : exp_(exp), bench_(bench), step_(s), path_("procedure[" + std::to_string(si) + "]"),
        kind_(step_kind_name(s.kind)) {
    while (fi_ < exp.fixtures.size() && exp.fixtures[fi_].id != s.fixture) ++fi_;
    if (fi_ == exp.fixtures.size())
      fail(s.where, path_ + ".fixture", "unknown fixture '" + s.fixture + "'");
    const FixtureDecl& decl = exp.fixtures[fi_];
    name_ = "fixture '" + decl.id + "' (plugin " + decl.plugin + ")";
  }

  const std::string& path() const { return path_; }
  const std::string& name() const { return name_; }

  // Fails unless the fixture has the role the step needs.
  void need_role(FixtureRole want) const {
    const FixtureRole role = bench_.roles[fi_];
    if (role == want) return;
    std::vector<std::string> fitting;
    for (std::size_t j = 0; j < bench_.roles.size(); ++j)
      if (bench_.roles[j] == want) fitting.push_back(exp_.fixtures[j].id);
    fail(step_.where, path_ + ".fixture",
         std::string("step '") + kind_ + "' needs a " + role_words(want) + ", but " + name_ +
             " is a " + role_words(role),
         fitting.empty() ? std::string("no ") + role_words(want) + " is declared on this bench"
                         : std::string("declared ") + role_words(want) + "s: " + yaml::join(fitting));
  }

  // The axis called `name`, which must be in `unit`.
  const AxisSpec& axis(const std::string& name, const std::string& unit, const SourceLocation& where) const {
    for (const auto& a : axes()) {
      if (a.name != name) continue;
      if (a.unit != unit)
        fail(where, path_,
             "axis '" + name + "' of " + name_ + " is in '" + a.unit + "', but step '" + kind_ +
                 "' gives it in '" + unit + "'",
             "this step can only command axes in " + unit + "; axes of the fixture: " + axis_list());
      return a;
    }
    std::vector<std::string> names;
    for (const auto& a : axes()) names.push_back(a.name);
    fail(where, path_, name_ + " has no axis '" + name + "'",
         yaml::join_sentences(yaml::did_you_mean(name, names),
                              "Its axes: " + (axes().empty() ? std::string("none") : axis_list())));
  }

  // The axis in `unit` (the one called `preferred` when there are several).
  const AxisSpec& unit_axis(const std::string& preferred, const std::string& unit,
                            const std::string& what) const {
    for (const auto& a : axes())
      if (a.name == preferred && a.unit == unit) return a;
    for (const auto& a : axes())
      if (a.unit == unit) return a;
    fail(step_.where, path_, name_ + " declares no " + what + " axis (unit " + unit + ")",
         "its axes: " + (axes().empty() ? std::string("none") : axis_list()));
  }

 private:
  const std::vector<AxisSpec>& axes() const { return bench_.axes[fi_]; }
  std::string axis_list() const {
    std::vector<std::string> out;
    for (const auto& a : axes()) out.push_back(a.name + " (" + a.unit + ")");
    return yaml::join(out);
  }

  const Experiment& exp_;
  const BenchDeclared& bench_;
  const Step& step_;
  std::string path_;
  const char* kind_;
  std::size_t fi_ = 0;
  std::string name_;
};

// orientations: a table, every target angle [deg] within its axis' limits.
void check_orientations(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kTable);
  for (const auto& o : s.orientations) {
    for (const auto& t : o.targets) {
      const AxisSpec& a = fx.axis(t.axis, "deg", o.where);
      if (t.value < a.min || t.value > a.max)
        fail(o.where, fx.path(),
             t.axis + "_deg = " + format_number(t.value) + " is beyond the limits of axis '" +
                 a.name + "' of " + fx.name() + ": " + range_text(a),
             "keep orientations within the range the fixture declares");
    }
  }
}

// rates: a table axis in rate mode, every |rate| [deg/s] within its maximum.
void check_rates(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kTable);
  const AxisSpec& a = fx.axis(s.axis, "deg", s.where);
  if (!a.supports_rate)
    fail(s.where, fx.path(), "axis '" + a.name + "' of " + fx.name() + " cannot turn at a commanded rate",
         "rates need an axis that supports rate mode; use orientations for this axis");
  for (double r : s.rates)
    if (std::abs(r) > a.max_rate)
      fail(s.where, fx.path(),
           "rate " + format_number(r) + " deg/s exceeds the maximum rate " +
               format_number(a.max_rate) + " deg/s of axis '" + a.name + "' of " + fx.name(),
           "keep |rate| <= " + format_number(a.max_rate) + " deg/s");
}

// set_temperature: a chamber whose temperature axis [degC] holds the setpoint.
void check_temperature(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kChamber);
  const AxisSpec& a = fx.unit_axis("temperature", "degC", "temperature");
  if (s.setpoint_c < a.min || s.setpoint_c > a.max)
    fail(s.where, fx.path(),
         "setpoint " + format_number(s.setpoint_c) + " degC is outside the range of " + fx.name() +
             ": " + range_text(a),
         "choose a setpoint the chamber can reach");
}

// set_vibration: a stimulus whose amplitude [g] and (when vibrating) frequency [Hz] axes hold
// the step's values.
void check_vibration(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kStimulus);
  const AxisSpec& amp = fx.unit_axis("amplitude", "g", "amplitude");
  if (s.amplitude_g < amp.min || s.amplitude_g > amp.max)
    fail(s.where, fx.path(),
         "vibration amplitude " + format_number(s.amplitude_g) + " g is outside the range of " +
             fx.name() + ": " + range_text(amp));
  if (s.amplitude_g > 0 || s.frequency_hz > 0) {
    const AxisSpec& fr = fx.unit_axis("frequency", "Hz", "frequency");
    if (s.frequency_hz < fr.min || s.frequency_hz > fr.max)
      fail(s.where, fx.path(),
           "vibration frequency " + format_number(s.frequency_hz) + " Hz is outside the range of " +
               fx.name() + ": " + range_text(fr));
  }
}

}  // namespace

void require_runnable(const Experiment& exp) {
  const std::string how = "it describes what was done to a sensor elsewhere: record that and give the log with "
                          "`stend import LOG --experiment " + exp.file + " -o RUN`";
  if (exp.sensor.plugin.empty())
    fail(SourceLocation{exp.file, 0, 0}, "bench.sensor", "the experiment names no sensor, so it cannot run on a bench",
         "add bench.sensor (plugin and config) to run it; as it is, " + how);
  for (std::size_t i = 0; i < exp.procedure.size(); ++i) {
    const Step& s = exp.procedure[i];
    if (!step_is_commanded(s.kind))
      fail(s.where, "procedure[" + std::to_string(i) + "]",
           std::string("a '") + step_kind_name(s.kind) + "' step is observed, not commanded: no fixture of a bench runs it",
           "use orientations or rates on a table (or the manual fixture) to run it; as it is, " + how);
  }
}

void validate_against_bench(const Experiment& exp, const std::vector<const Fixture*>& fixtures) {
  check_fixture_objects(exp, fixtures);
  BenchDeclared bench;
  for (const Fixture* f : fixtures) {
    bench.roles.push_back(f->role());
    bench.axes.push_back(f->axes());
  }
  for (std::size_t si = 0; si < exp.procedure.size(); ++si) {
    const Step& s = exp.procedure[si];
    if (s.fixture.empty()) continue;
    const StepFixture fx(exp, bench, s, si);
    switch (s.kind) {
      case Step::Kind::kOrientations: check_orientations(s, fx); break;
      case Step::Kind::kRates: check_rates(s, fx); break;
      case Step::Kind::kSetTemperature: check_temperature(s, fx); break;
      case Step::Kind::kSetVibration: check_vibration(s, fx); break;
      case Step::Kind::kRecord:
      case Step::Kind::kWait:
      case Step::Kind::kFaces:
      case Step::Kind::kTurns:
      case Step::Kind::kRateLegs:
      case Step::Kind::kStill: break;
    }
  }
}

}  // namespace stend