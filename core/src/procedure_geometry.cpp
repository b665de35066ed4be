// Table steps as what the sensor saw, through a bench of the declared fixtures. See
// procedure_geometry.hpp.
#include "stend/core/procedure_geometry.hpp"

#include "stend/physics/units.hpp"

#include <cmath>

namespace stend {

namespace {

constexpr double kStepS = 0.05;           // simulated time per advance [s]
constexpr double kMaxSettleS = 3600.0;    // a table that has not settled by then is refused [s]

bool uses_a_table(const Experiment& exp) {
  for (const Step& s : exp.procedure)
    if (s.kind == Step::Kind::kOrientations || s.kind == Step::Kind::kRates) return true;
  return false;
}

void require_simulated_fixtures(const Experiment& exp) {
  for (std::size_t i = 0; i < exp.fixtures.size(); ++i) {
    const FixtureDecl& d = exp.fixtures[i];
    if (d.plugin.rfind("sim_", 0) != 0)
      throw ExperimentError(d.where, "bench.fixtures[" + std::to_string(i) + "]",
                            "fixture '" + d.id + "' (" + d.plugin + ") would talk to its device: a recording made "
                            "elsewhere takes its table's geometry from a simulated twin",
                            "declare the table as sim_three_axis_table or sim_one_axis_table with the same axes and zero "
                            "positions");
  }
}

// Commands and settles a bench of fixtures only, and reads what the sensor sees.
class Geometry {
 public:
  Geometry(const Experiment& exp, const PluginHost& host) : bench_(exp, host, Bench::FixturesOnly{}) {}

  // The sensor direction pointing up at an orientation (unit vector, sensor frame).
  Eigen::Vector3d up_at(const Step& s, const Orientation& o) {
    Fixture& f = fixture(s);
    for (const AxisTarget& t : o.targets) f.command(axis(f, t.axis), CommandMode::kPosition, t.value);
    settle(s);
    return bench_.at(t_).specific_force_mps2.normalized();
  }

  // The sensor direction pointing up where the fixtures stand now.
  Eigen::Vector3d up_now() {
    bench_.advance(t_ += kStepS);
    return bench_.at(t_).specific_force_mps2.normalized();
  }

  // The sensor-frame axis the step's table axis turns about (unit vector: positive rate), and the
  // sensor direction up before it turns.
  std::pair<Eigen::Vector3d, Eigen::Vector3d> rate_axis(const Step& s) {
    Fixture& f = fixture(s);
    const std::size_t a = axis(f, s.axis);
    settle(s);
    const BenchTruth rest = bench_.at(t_);
    const double rate = s.rates.front();
    f.command(a, CommandMode::kRate, rate);
    settle(s);
    const Eigen::Vector3d w = bench_.at(t_).angular_rate_radps - rest.angular_rate_radps;
    f.command(a, CommandMode::kRate, 0.0);
    settle(s);
    return {w.normalized() * (rate > 0 ? 1.0 : -1.0), rest.specific_force_mps2.normalized()};
  }

 private:
  Fixture& fixture(const Step& s) { return bench_.fixture(static_cast<std::size_t>(bench_.fixture_index(s.fixture))); }
  static std::size_t axis(const Fixture& f, const std::string& name) {
    const auto axes = f.axes();
    for (std::size_t i = 0; i < axes.size(); ++i)
      if (axes[i].name == name) return i;
    return 0;  // validate_against_bench checked every step's axes
  }
  void settle(const Step& s) {
    const double until = t_ + kMaxSettleS;
    do {
      t_ += kStepS;
      bench_.advance(t_);
    } while (!fixture(s).settled() && t_ < until);
    if (!fixture(s).settled())
      throw ExperimentError(s.where, "procedure", "the simulated table did not settle within " + std::to_string(static_cast<int>(kMaxSettleS)) + " s");
  }
  Bench bench_;
  double t_ = 0.0;
};

Step as_faces(const Step& s, Geometry& g) {
  Step out = s;
  out.kind = Step::Kind::kFaces;
  out.fixture.clear();
  out.orientations.clear();
  for (const Orientation& o : s.orientations) out.faces_up.push_back(g.up_at(s, o));
  return out;
}

// A record step holds the table where it stands: one face.
Step as_face(const Step& s, Geometry& g) {
  Step out = s;
  out.kind = Step::Kind::kFaces;
  out.faces_up = {g.up_now()};
  return out;
}

Step as_rate_legs(const Step& s, Geometry& g) {
  Step out = s;
  out.kind = Step::Kind::kRateLegs;
  out.fixture.clear();
  const auto [axis, up] = g.rate_axis(s);
  out.sensor_axis = axis;
  if (std::abs(axis.dot(up)) > std::cos(1.0 * physics::kDegToRad)) out.up = up;  // a vertical axis keeps gravity
  return out;
}

}  // namespace

Experiment as_observed_procedure(const Experiment& exp, const PluginHost& host) {
  if (!uses_a_table(exp)) return exp;
  require_simulated_fixtures(exp);
  Geometry geometry(exp, host);
  Experiment out = exp;
  out.procedure.clear();
  for (const Step& s : exp.procedure) {
    if (s.kind == Step::Kind::kOrientations) out.procedure.push_back(as_faces(s, geometry));
    else if (s.kind == Step::Kind::kRates) out.procedure.push_back(as_rate_legs(s, geometry));
    else if (s.kind == Step::Kind::kRecord) out.procedure.push_back(as_face(s, geometry));
    else out.procedure.push_back(s);
  }
  return out;
}

Experiment load_observed_procedure(const std::string& file) {
  PluginHost host;  // the fixtures a procedure may declare; its own plugin_paths are not loaded
  host.scan(PluginHost::default_search_path());
  return as_observed_procedure(load_experiment(file, host), host);
}

}  // namespace stend
