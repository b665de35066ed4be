// The assembled bench: the sensor and fixtures an experiment names, created from plugins, and
// the composition of the fixture stack into the truth the sensor experiences.
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/core/plugin_host.hpp>
#include <stend/sdk.hpp>

#include <string>
#include <utility>
#include <vector>

namespace stend {

class Bench final : public TruthSource {
 public:
  // Creates every plugin object (seeding simulated ones whose `seed` is 0 from the experiment
  // seed) and checks the procedure against the fixtures' declared limits (stage-2 validation).
  Bench(const Experiment& exp, const PluginHost& host);
  // The fixtures alone, no sensor (sensor() must not be called): the geometry of the bench's
  // table steps, for a procedure whose recording was made elsewhere (procedure_geometry.hpp).
  struct FixturesOnly {};
  Bench(const Experiment& exp, const PluginHost& host, FixturesOnly);
  ~Bench() override;

  Sensor& sensor() { return *sensor_; }
  std::size_t fixture_count() const { return fixtures_.size(); }
  Fixture& fixture(std::size_t i) { return *fixtures_[i]; }
  const std::string& fixture_id(std::size_t i) const { return exp_.fixtures[i].id; }
  int fixture_index(const std::string& id) const;  // −1 when absent
  int chamber_index() const { return chamber_; }    // −1 when the bench has no chamber

  // Advance every fixture to run time t_s.
  void advance(double t_s);
  // Bring every fixture to its safe state and check it (Fixture::safe_state); one line
  // "fixture '<id>': <what failed>" per fixture whose safe state is not confirmed. Never throws.
  std::vector<std::string> safe_state() noexcept;

  // TruthSource: composes base → fixture chain → mounting → sensor at t_s.
  //   R_sensor_from_local = R_mount · R_n ⋯ R_1
  //   ω = R_mount·(ω_n + R_n·(ω_{n−1} + …)) + R_sensor_from_local·ω_earth
  //   f = R_sensor_from_local·(0,0,g) + R_mount·(a_n + R_n·(a_{n−1} + …))
  // Temperatures come from the chamber (25 °C air and die when the bench has none). Keeps the
  // last composition for the next call: one thread at a time.
  BenchTruth at(double t_s) const override;

  // Names of the truth snapshot columns (see recording.hpp) and one row of values at t_s.
  std::vector<std::string> truth_columns() const;
  void truth_row(double t_s, std::vector<double>& row) const;

  // All objects simulated (plugin names starting with "sim_")?
  bool simulated() const { return simulated_; }

 private:
  const Experiment& exp_;
  PluginPtr<Sensor> sensor_;
  std::vector<PluginPtr<Fixture>> fixtures_;
  std::vector<int> chain_;  // fixture indices from base up to the one carrying the sensor
  int chamber_ = -1;
  Eigen::Vector3d earth_rate_local_ = Eigen::Vector3d::Zero();
  bool simulated_ = true;
  mutable std::vector<std::pair<std::string, double>> telemetry_;

  // The kinematic part of at() for the chain's last poses. A chain that holds still gives the
  // same poses sample after sample; their composition is then reused (bit for bit the same).
  struct Kinematics {
    std::vector<Pose> poses;  // one per chain_ entry
    Eigen::Matrix3d R_sensor_from_local = Eigen::Matrix3d::Identity();
    Eigen::Vector3d specific_force_mps2 = Eigen::Vector3d::Zero();
    Eigen::Vector3d angular_rate_radps = Eigen::Vector3d::Zero();
    bool valid = false;
  };
  void compose(Kinematics& k) const;
  void create_fixtures(const PluginHost& host);
  mutable Kinematics last_;
};

}  // namespace stend
