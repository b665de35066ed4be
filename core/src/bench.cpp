#include "stend/core/bench.hpp"

#include "stend/physics/geometry.hpp"
#include "stend/recording/truth_columns.hpp"

#include <cstring>
#include <stdexcept>

namespace stend {

namespace {
// The same pose bit for bit (−0 ≠ +0, a NaN equals itself): what at() may reuse exactly.
bool same_bits(const Pose& a, const Pose& b) {
  static_assert(sizeof(Pose) == 15 * sizeof(double), "Pose is 15 doubles");
  std::uint64_t x[15], y[15], diff = 0;
  std::memcpy(x, &a, sizeof x);
  std::memcpy(y, &b, sizeof y);
  for (int i = 0; i < 15; ++i) diff |= x[i] ^ y[i];
  return diff == 0;
}

// Plugins configured with `seed: 0` get a seed derived from the experiment's, distinct per role.
Params seeded(const Params& p, std::uint64_t experiment_seed, std::uint64_t salt) {
  Params out = p;
  if (out.has("seed") && out.integer("seed") == 0)
    out.set("seed", static_cast<std::int64_t>((experiment_seed * 1000003u + salt) & 0x7fffffffffffffffULL));
  return out;
}
}  // namespace

Bench::Bench(const Experiment& exp, const PluginHost& host) : exp_(exp) {
  require_runnable(exp);
  sensor_ = host.create_sensor(exp.sensor.plugin, seeded(exp.sensor.params, exp.seed, 1));
  simulated_ = exp.sensor.plugin.rfind("sim_", 0) == 0;
  create_fixtures(host);
}

Bench::Bench(const Experiment& exp, const PluginHost& host, FixturesOnly) : exp_(exp) { create_fixtures(host); }

// The fixtures in declaration order, checked against the procedure (stage 2), the chain from the
// base to the sensor's mount, and the Earth rate at the site.
void Bench::create_fixtures(const PluginHost& host) {
  const Experiment& exp = exp_;
  std::vector<const Fixture*> raw;
  for (std::size_t i = 0; i < exp.fixtures.size(); ++i) {
    const FixtureDecl& d = exp.fixtures[i];
    fixtures_.push_back(host.create_fixture(d.plugin, seeded(d.params, exp.seed, 2 + i)));
    raw.push_back(fixtures_.back().get());
    simulated_ = simulated_ && d.plugin.rfind("sim_", 0) == 0;
    if (fixtures_.back()->role() == FixtureRole::kChamber) {
      if (chamber_ >= 0)
        throw ExperimentError(d.where, "bench.fixtures[" + std::to_string(i) + "]",
                              "a second chamber ('" + d.id + "'); a bench holds at most one");
      chamber_ = static_cast<int>(i);
    }
  }
  validate_against_bench(exp, raw);

  // The chain from the fixture carrying the sensor down to the base, then reversed.
  if (!fixtures_.empty()) {
    std::string id = exp.mounted_on.empty() ? exp.fixtures.back().id : exp.mounted_on;
    while (!id.empty() && id != "base") {
      const int i = fixture_index(id);
      if (i < 0) throw std::invalid_argument("mounting refers to unknown fixture '" + id + "'");
      chain_.insert(chain_.begin(), i);
      id = exp.fixtures[static_cast<std::size_t>(i)].on;
    }
  }
  const double heading = exp.base_heading_deg * physics::kDegToRad;
  earth_rate_local_ = physics::Rz(heading) * physics::earth_rate_local(exp.gravity.latitude_deg);
}

Bench::~Bench() = default;

int Bench::fixture_index(const std::string& id) const {
  for (std::size_t i = 0; i < exp_.fixtures.size(); ++i)
    if (exp_.fixtures[i].id == id) return static_cast<int>(i);
  return -1;
}

void Bench::advance(double t_s) {
  for (auto& f : fixtures_) f->advance(t_s);
}

std::vector<std::string> Bench::safe_state() noexcept {
  std::vector<std::string> failed;
  for (std::size_t i = 0; i < fixtures_.size(); ++i) {
    const std::string why = fixtures_[i]->safe_state();
    if (!why.empty()) failed.push_back("fixture '" + fixture_id(i) + "': " + why);
  }
  return failed;
}

// The composition of the chain's poses k.poses (see at()) into k's kinematic fields.
void Bench::compose(Kinematics& k) const {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // top-of-chain from local
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();  // relative to base, in top-of-chain frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // of the mounting point, top-of-chain frame
  for (const Pose& p : k.poses) {
    R = p.R_top_from_base * R;
    omega = p.R_top_from_base * omega + p.omega_top_radps;
    accel = p.R_top_from_base * accel + p.accel_top_mps2;
  }
  const Eigen::Matrix3d& M = exp_.R_sensor_from_mount;
  k.R_sensor_from_local = M * R;
  k.specific_force_mps2 =
      physics::gravity_specific_force(k.R_sensor_from_local, exp_.gravity.resolved_mps2) + M * accel;
  k.angular_rate_radps = M * omega + k.R_sensor_from_local * earth_rate_local_;
  k.valid = true;
}

BenchTruth Bench::at(double t_s) const {
  last_.poses.resize(chain_.size());
  bool same = last_.valid;
  for (std::size_t j = 0; j < chain_.size(); ++j) {
    const Pose p = fixtures_[static_cast<std::size_t>(chain_[j])]->pose(t_s);
    if (same && same_bits(p, last_.poses[j])) continue;
    same = false;
    last_.poses[j] = p;
  }
  if (!same) compose(last_);
  BenchTruth truth;
  truth.t_s = t_s;
  truth.R_sensor_from_local = last_.R_sensor_from_local;
  truth.specific_force_mps2 = last_.specific_force_mps2;
  truth.angular_rate_radps = last_.angular_rate_radps;
  if (chamber_ >= 0) {
    double air = 25.0, die = 25.0;
    if (fixtures_[static_cast<std::size_t>(chamber_)]->thermal(t_s, air, die)) {
      truth.air_temperature_c = air;
      truth.die_temperature_c = die;
    }
  }
  return truth;
}

std::vector<std::string> Bench::truth_columns() const {
  std::vector<std::string> cols = truth_column_names({kSpecificForceColumns, kRateColumns});
  cols.insert(cols.end(), {"air_c", "die_c"});
  for (std::size_t i = 0; i < fixtures_.size(); ++i) {
    const std::string& id = exp_.fixtures[i].id;
    for (const AxisSpec& a : fixtures_[i]->axes()) {
      cols.push_back(id + "." + a.name + ".cmd_" + a.unit);
      cols.push_back(id + "." + a.name + ".meas_" + a.unit);
    }
    telemetry_.clear();
    fixtures_[i]->telemetry(telemetry_);
    for (const auto& [name, value] : telemetry_) cols.push_back(id + "." + name);
  }
  return cols;
}

void Bench::truth_row(double t_s, std::vector<double>& row) const {
  row.clear();
  const BenchTruth t = at(t_s);
  for (int i = 0; i < 3; ++i) row.push_back(t.specific_force_mps2[i]);
  for (int i = 0; i < 3; ++i) row.push_back(t.angular_rate_radps[i]);
  row.push_back(t.air_temperature_c);
  row.push_back(t.die_temperature_c);
  for (const auto& f : fixtures_) {
    const std::size_t n = f->axes().size();
    for (std::size_t a = 0; a < n; ++a) {
      row.push_back(f->commanded(a));
      row.push_back(f->measured(a));
    }
    telemetry_.clear();
    f->telemetry(telemetry_);
    for (const auto& kv : telemetry_) row.push_back(kv.second);
  }
}

}  // namespace stend
