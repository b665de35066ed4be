// The experiment model: parsing, validation (stage 1 and 2), defaults, expansion, resolved YAML.
// Uses an in-memory plugin catalogue and tiny fixtures; no real plugin is loaded.
#include <gtest/gtest.h>

#include <stend/core/experiment.hpp>
#include <stend/core/runner.hpp>
#include <stend/physics/geometry.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>
#include <stend/yaml/reader.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;

namespace {

// ---------------------------------------------------------------------------------------------
// Test plugins: schemas only.

const stend_param_spec kImuParams[] = {
    {"serial", "string", "", nullptr, kNaN, kNaN, nullptr, "unit serial number"},
    {"odr_hz", "number", "Hz", "100", 1.0, 1000.0, nullptr, "output data rate"},
    {"accel_range", "string", "", "4g", kNaN, kNaN, "2g|4g|8g|16g", "accelerometer full scale"},
    {"fifo_depth", "integer", "1", "32", 1.0, 1024.0, nullptr, "samples buffered"},
    {"gyro_enabled", "bool", "", "true", kNaN, kNaN, nullptr, "produce gyro samples"},
    {"accel_bias_mps2", "vec3", "m/s^2", "[0, 0, 0]", -10.0, 10.0, nullptr, "accelerometer bias"},
    {"misalignment", "mat3", "1", "[[1, 0, 0], [0, 1, 0], [0, 0, 1]]", -1.0, 1.0, nullptr,
     "axis misalignment"},
    {"temp_coeffs", "numbers", "1", "[]", kNaN, kNaN, nullptr, "temperature polynomial"},
    {"scale_poly", "matrix3", "1", "[[1], [1], [1]]", kNaN, kNaN, nullptr,
     "scale polynomial per axis"},
};
const stend_param_spec kTableParams[] = {
    {"max_rate_dps", "number", "deg/s", "500", 0.0, 1000.0, nullptr, "rate limit"},
};
const stend_param_spec kChamberParams[] = {
    {"initial_c", "number", "degC", "22", -40.0, 100.0, nullptr, "initial air temperature"},
};

stend_plugin_info make_info(stend_plugin_kind kind, const char* name,
                            const stend_param_spec* params, std::size_t count) {
  return {STEND_PLUGIN_ABI_VERSION, static_cast<uint32_t>(sizeof(stend_plugin_info)), kind, name,
          "0.0.1", "test plugin", params, count, nullptr, nullptr};
}

class TestCatalogue : public PluginCatalogue {
 public:
  TestCatalogue() {
    add(make_info(STEND_KIND_SENSOR, "sim_imu_like", kImuParams, std::size(kImuParams)));
    add(make_info(STEND_KIND_FIXTURE, "sim_table_like", kTableParams, std::size(kTableParams)));
    add(make_info(STEND_KIND_FIXTURE, "sim_two_axis_like", nullptr, 0));
    add(make_info(STEND_KIND_FIXTURE, "sim_chamber_like", kChamberParams,
                  std::size(kChamberParams)));
    add(make_info(STEND_KIND_FIXTURE, "sim_shaker_like", nullptr, 0));
    add(make_info(STEND_KIND_ESTIMATOR, "batch_lsq_like", nullptr, 0));
  }
  const stend_plugin_info* find(const std::string& name) const override {
    auto it = infos_.find(name);
    return it == infos_.end() ? nullptr : &it->second;
  }
  std::vector<std::string> names() const override {
    std::vector<std::string> out;
    for (const auto& [k, v] : infos_) out.push_back(k);
    return out;
  }

 private:
  void add(const stend_plugin_info& info) { infos_[info.name] = info; }
  std::map<std::string, stend_plugin_info> infos_;
};

const TestCatalogue& catalogue() {
  static const TestCatalogue c;
  return c;
}

// ---------------------------------------------------------------------------------------------
// Test fixtures: declared axes only.

class AxesFixture : public Fixture {
 public:
  AxesFixture(FixtureRole role, std::vector<AxisSpec> axes) : role_(role), axes_(std::move(axes)) {}
  FixtureRole role() const override { return role_; }
  std::vector<AxisSpec> axes() const override { return axes_; }
  void command(std::size_t, CommandMode, double) override {}
  void advance(double) override {}
  double measured(std::size_t) const override { return 0.0; }
  double commanded(std::size_t) const override { return 0.0; }
  bool settled() const override { return true; }
  std::string safe_state() noexcept override { return ""; }

 private:
  FixtureRole role_;
  std::vector<AxisSpec> axes_;
};

AxisSpec axis(const char* name, const char* unit, double min, double max, double max_rate,
              bool supports_rate) {
  AxisSpec a;
  a.name = name;
  a.unit = unit;
  a.min = min;
  a.max = max;
  a.max_rate = max_rate;
  a.supports_rate = supports_rate;
  return a;
}

std::unique_ptr<Fixture> make_fixture(const std::string& plugin) {
  if (plugin == "sim_table_like")
    return std::make_unique<AxesFixture>(FixtureRole::kTable,
                                         std::vector{axis("angle", "deg", -360, 360, 500, true)});
  if (plugin == "sim_two_axis_like")
    return std::make_unique<AxesFixture>(
        FixtureRole::kTable, std::vector{axis("angle", "deg", -360, 360, 500, true),
                                         axis("tilt", "deg", -90, 90, 30, false)});
  if (plugin == "sim_chamber_like")
    return std::make_unique<AxesFixture>(
        FixtureRole::kChamber, std::vector{axis("temperature", "degC", -30, 75, 2, false)});
  if (plugin == "sim_shaker_like")
    return std::make_unique<AxesFixture>(
        FixtureRole::kStimulus, std::vector{axis("amplitude", "g", 0, 0.5, INFINITY, false),
                                            axis("frequency", "Hz", 20, 800, INFINITY, false)});
  throw std::runtime_error("no test fixture for plugin " + plugin);
}

struct TestBench {
  std::vector<std::unique_ptr<Fixture>> owned;
  std::vector<const Fixture*> ptrs;
  explicit TestBench(const Experiment& exp) {
    for (const auto& f : exp.fixtures) {
      owned.push_back(make_fixture(f.plugin));
      ptrs.push_back(owned.back().get());
    }
  }
};

using stend::testing::read_text;
using stend::testing::source_path;

// A valid experiment with a table, a two-axis table, a chamber and a shaker; `procedure` is
// appended under "procedure:".
std::string minimal(const std::string& procedure, const std::string& bench_extra = {}) {
  return "experiment:\n  name: mini\nbench:\n  sensor:\n    plugin: sim_imu_like\n"
         "    config: {serial: A}\n  fixtures:\n"
         "    - {id: table, plugin: sim_table_like}\n"
         "    - {id: tilt_table, plugin: sim_two_axis_like}\n"
         "    - {id: chamber, plugin: sim_chamber_like, on: table}\n"
         "    - {id: shaker, plugin: sim_shaker_like}\n" +
         bench_extra + "procedure:\n" + procedure;
}

Experiment parse(const std::string& text) { return parse_experiment(text, "mem.yaml", catalogue()); }

// Expects parsing (and stage 2) to fail; returns the error.
ExperimentError parse_error(const std::string& text) {
  try {
    const Experiment e = parse(text);
    TestBench bench(e);
    validate_against_bench(e, bench.ptrs);
  } catch (const ExperimentError& err) {
    return err;
  }
  ADD_FAILURE() << "expected an ExperimentError for:\n" << text;
  return ExperimentError({}, "", "");
}

// ---------------------------------------------------------------------------------------------

TEST(ExperimentError, FormatsLocationMessageAndHint) {
  const ExperimentError e({"a.yaml", 12, 7}, "procedure[2].dwel_s", "unknown key 'dwel_s'",
                          "did you mean 'dwell_s'?");
  EXPECT_STREQ(e.what(), "a.yaml:12:7: error: unknown key 'dwel_s'\n  hint: did you mean 'dwell_s'?");
  EXPECT_EQ(e.key(), "procedure[2].dwel_s");
  EXPECT_EQ(e.where().line, 12);
  const ExperimentError no_hint({"b.yaml", 0, 0}, "", "cannot open");
  EXPECT_STREQ(no_hint.what(), "b.yaml: error: cannot open");
  EXPECT_EQ((SourceLocation{"c.yaml", 3, 0}).str(), "c.yaml:3");
  EXPECT_EQ((SourceLocation{"c.yaml", 3, 4}).str(), "c.yaml:3:4");
}

TEST(YamlUtil, EditDistanceAndSuggestions) {
  EXPECT_EQ(yaml::edit_distance("dwel_s", "dwell_s"), 1u);
  EXPECT_EQ(yaml::edit_distance("dewll_s", "dwell_s"), 1u);  // transposition
  EXPECT_EQ(yaml::edit_distance("ABC", "abc"), 0u);
  const std::vector<std::string> keys = {"fixture", "dwell_s", "record_s", "frequency_hz"};
  EXPECT_EQ(yaml::closest_match("dwel_s", keys), "dwell_s");
  EXPECT_EQ(yaml::closest_match("fix", keys), "fixture");  // prefix
  EXPECT_EQ(yaml::closest_match("zzz", keys), "");
  EXPECT_EQ(yaml::did_you_mean("dwell", keys), "did you mean 'dwell_s'? durations are in seconds");
  EXPECT_EQ(yaml::did_you_mean("dwell_ms", keys),
            "did you mean 'dwell_s'? durations are in seconds");
  EXPECT_EQ(yaml::did_you_mean("frequency", keys),
            "did you mean 'frequency_hz'? frequencies are in hertz");
  EXPECT_EQ(yaml::did_you_mean("fixtrue", keys), "did you mean 'fixture'?");
  EXPECT_EQ(yaml::format_number(0.1), "0.1");
  EXPECT_EQ(yaml::format_number(44.0), "44");
}

// ---------------------------------------------------------------------------------------------
// Positive: the full example.

class FullExperiment : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    exp_ = new Experiment(load_experiment(source_path("core/tests/data/experiments/full.yaml").string(), catalogue()));
  }
  static void TearDownTestSuite() {
    delete exp_;
    exp_ = nullptr;
  }
  static Experiment* exp_;
};
Experiment* FullExperiment::exp_ = nullptr;

TEST_F(FullExperiment, Header) {
  const Experiment& e = *exp_;
  EXPECT_EQ(e.name, "paper_mpu6050_z");
  EXPECT_EQ(e.description, "Full example: every step kind, nested repeats");
  EXPECT_EQ(e.seed, 42u);
  EXPECT_EQ(e.clock, ClockKind::kSimulated);
  ASSERT_EQ(e.plugin_paths.size(), 2u);
  const fs::path expected = (source_path("core/tests/data/experiments") / "my_plugins").lexically_normal();
  EXPECT_EQ(e.plugin_paths[0], expected.string());
  EXPECT_EQ(e.plugin_paths[1], "/usr/lib");  // folders that exist
  EXPECT_EQ(e.outputs.directory, "my_runs");
  EXPECT_FALSE(e.outputs.report);
  ASSERT_TRUE(e.processing.IsMap());
  EXPECT_EQ(e.processing["static"]["window_s"].as<double>(), 5.0);
  EXPECT_EQ(e.estimation["method"].as<std::string>(), "batch_lsq");
}

TEST_F(FullExperiment, BenchGravityAndMounting) {
  const Experiment& e = *exp_;
  EXPECT_FALSE(e.gravity.value_mps2.has_value());
  EXPECT_DOUBLE_EQ(e.gravity.latitude_deg, 47.23);
  EXPECT_DOUBLE_EQ(e.gravity.height_m, 70.0);
  EXPECT_DOUBLE_EQ(e.gravity.resolved_mps2, physics::normal_gravity(47.23, 70.0));
  EXPECT_NEAR(e.gravity.resolved_mps2, 9.8077, 1e-3);
  EXPECT_DOUBLE_EQ(e.base_heading_deg, 10.0);
  ASSERT_EQ(e.fixtures.size(), 3u);
  EXPECT_EQ(e.fixtures[0].id, "table");
  EXPECT_EQ(e.fixtures[0].on, "");
  EXPECT_EQ(e.fixtures[1].on, "table");
  EXPECT_EQ(e.fixtures[2].plugin, "sim_shaker_like");
  EXPECT_DOUBLE_EQ(e.fixtures[0].params.number("max_rate_dps"), 400.0);
  EXPECT_DOUBLE_EQ(e.fixtures[1].params.number("initial_c"), 22.0);  // default
  EXPECT_EQ(e.fixtures[1].where.line, 22);
  EXPECT_EQ(e.mounted_on, "chamber");
  EXPECT_TRUE(e.R_sensor_from_mount.isApprox(physics::from_rpy_deg(0, 0, 90)));
}

TEST_F(FullExperiment, SensorParamsHaveDefaultsAndTypes) {
  const Params& p = exp_->sensor.params;
  EXPECT_EQ(exp_->sensor.plugin, "sim_imu_like");
  EXPECT_EQ(p.string("serial"), "SN-001");
  EXPECT_DOUBLE_EQ(p.number("odr_hz"), 200.0);
  EXPECT_EQ(p.string("accel_range"), "4g");
  EXPECT_EQ(p.integer("fifo_depth"), 32);
  EXPECT_TRUE(p.boolean("gyro_enabled"));
  EXPECT_TRUE(p.vec3("accel_bias_mps2").isApprox(Eigen::Vector3d(0.01, -0.02, 0.03)));
  EXPECT_TRUE(p.mat3("misalignment").isIdentity());
  EXPECT_TRUE(p.numbers("temp_coeffs").empty());
  ASSERT_EQ(p.matrix("scale_poly").size(), 3u);
  EXPECT_EQ(p.matrix("scale_poly")[2], (std::vector<double>{1, 0.3}));
  EXPECT_EQ(p.values().size(), std::size(kImuParams));
}

TEST_F(FullExperiment, ProcedureExpanded) {
  const auto& proc = exp_->procedure;
  ASSERT_EQ(proc.size(), 16u);
  EXPECT_EQ(proc[0].kind, Step::Kind::kSetTemperature);
  EXPECT_EQ(proc[0].label, "warm up");
  EXPECT_EQ(proc[0].fixture, "chamber");
  EXPECT_DOUBLE_EQ(proc[0].hold_s, 120.0);
  EXPECT_TRUE(proc[0].record_settling);
  EXPECT_EQ(proc[0].where.line, 31);
  EXPECT_EQ(proc[0].where.column, 5);

  const Step& sweep = proc[1];
  EXPECT_EQ(sweep.kind, Step::Kind::kOrientations);
  EXPECT_EQ(sweep.label, "orientations");
  ASSERT_EQ(sweep.orientations.size(), 23u);
  for (std::size_t i = 0; i < 23; ++i) {
    ASSERT_EQ(sweep.orientations[i].targets.size(), 1u);
    EXPECT_EQ(sweep.orientations[i].targets[0].axis, "angle");
    EXPECT_DOUBLE_EQ(sweep.orientations[i].targets[0].value, 2.0 * static_cast<double>(i));
  }
  EXPECT_EQ(sweep.orientations.back().targets[0].value, 44.0);
  EXPECT_DOUBLE_EQ(sweep.dwell_s, 5.0);
  EXPECT_DOUBLE_EQ(sweep.record_s, 10.0);

  EXPECT_EQ(proc[2].kind, Step::Kind::kRates);
  EXPECT_EQ(proc[2].axis, "angle");
  EXPECT_EQ(proc[2].rates, (std::vector<double>{-100, -50, 50, 100}));
  EXPECT_EQ(proc[3].kind, Step::Kind::kSetVibration);
  EXPECT_DOUBLE_EQ(proc[3].amplitude_g, 0.5);
  EXPECT_DOUBLE_EQ(proc[3].frequency_hz, 100.0);
  EXPECT_EQ(proc[4].kind, Step::Kind::kRecord);
  EXPECT_DOUBLE_EQ(proc[4].record_s, 3600.0);
  EXPECT_EQ(proc[4].fixture, "");
  EXPECT_EQ(proc[5].label, "vibration off");
  EXPECT_DOUBLE_EQ(proc[5].frequency_hz, 0.0);
  EXPECT_EQ(proc[6].kind, Step::Kind::kWait);
  EXPECT_DOUBLE_EQ(proc[6].dwell_s, 10.0);

  // repeat 3 { orientations; repeat 2 { record } }: passes numbered through.
  std::vector<int> orient_passes, record_passes;
  for (std::size_t i = 7; i < proc.size(); ++i) {
    if (proc[i].kind == Step::Kind::kOrientations) orient_passes.push_back(proc[i].repeat_index);
    if (proc[i].kind == Step::Kind::kRecord) record_passes.push_back(proc[i].repeat_index);
  }
  EXPECT_EQ(orient_passes, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(record_passes, (std::vector<int>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(proc[7].orientations.size(), 2u);
  EXPECT_EQ(proc[0].repeat_index, 0);
}

TEST_F(FullExperiment, StepKindNamesAreTheFileKeys) {
  const auto& proc = exp_->procedure;
  ASSERT_GE(proc.size(), 7u);
  const std::vector<std::string> names = {"set_temperature", "orientations", "rates", "set_vibration",
                                          "record", "set_vibration", "wait"};
  for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(step_kind_name(proc[i].kind), names[i]) << i;
}

TEST_F(FullExperiment, PassesStageTwo) {
  TestBench bench(*exp_);
  EXPECT_NO_THROW(validate_against_bench(*exp_, bench.ptrs));
}

TEST_F(FullExperiment, ResolvedYamlRoundTrips) {
  const Experiment& a = *exp_;
  ASSERT_FALSE(a.resolved_yaml.empty());
  const YAML::Node doc = YAML::Load(a.resolved_yaml);
  EXPECT_DOUBLE_EQ(doc["bench"]["gravity"]["resolved_mps2"].as<double>(), a.gravity.resolved_mps2);
  EXPECT_EQ(doc["bench"]["sensor"]["config"]["fifo_depth"].as<int>(), 32);  // default written out
  EXPECT_EQ(doc["procedure"].size(), 16u);

  const Experiment b = parse_experiment(a.resolved_yaml, "resolved.yaml", catalogue());
  EXPECT_EQ(b.resolved_yaml, a.resolved_yaml);  // a fixed point
  EXPECT_EQ(b.name, a.name);
  EXPECT_EQ(b.seed, a.seed);
  EXPECT_EQ(b.plugin_paths, a.plugin_paths);
  EXPECT_EQ(b.gravity.resolved_mps2, a.gravity.resolved_mps2);
  EXPECT_EQ(b.mounted_on, a.mounted_on);
  EXPECT_EQ(b.R_sensor_from_mount, a.R_sensor_from_mount);
  EXPECT_EQ(b.sensor.params.values(), a.sensor.params.values());
  ASSERT_EQ(b.fixtures.size(), a.fixtures.size());
  for (std::size_t i = 0; i < a.fixtures.size(); ++i) {
    EXPECT_EQ(b.fixtures[i].id, a.fixtures[i].id);
    EXPECT_EQ(b.fixtures[i].on, a.fixtures[i].on);
    EXPECT_EQ(b.fixtures[i].params.values(), a.fixtures[i].params.values());
  }
  ASSERT_EQ(b.procedure.size(), a.procedure.size());
  for (std::size_t i = 0; i < a.procedure.size(); ++i) {
    const Step &x = a.procedure[i], &y = b.procedure[i];
    EXPECT_EQ(y.kind, x.kind);
    EXPECT_EQ(y.label, x.label);
    EXPECT_EQ(y.repeat_index, x.repeat_index);
    EXPECT_EQ(y.fixture, x.fixture);
    EXPECT_EQ(y.dwell_s, x.dwell_s);
    EXPECT_EQ(y.record_s, x.record_s);
    EXPECT_EQ(y.rates, x.rates);
    EXPECT_EQ(y.setpoint_c, x.setpoint_c);
    EXPECT_EQ(y.amplitude_g, x.amplitude_g);
    ASSERT_EQ(y.orientations.size(), x.orientations.size());
    for (std::size_t j = 0; j < x.orientations.size(); ++j) {
      ASSERT_EQ(y.orientations[j].targets.size(), x.orientations[j].targets.size());
      EXPECT_EQ(y.orientations[j].targets[0].axis, x.orientations[j].targets[0].axis);
      EXPECT_EQ(y.orientations[j].targets[0].value, x.orientations[j].targets[0].value);
    }
  }
  EXPECT_EQ(YAML::Dump(b.processing), YAML::Dump(a.processing));
  EXPECT_EQ(b.outputs.report, a.outputs.report);
}

// ---------------------------------------------------------------------------------------------
// Positive: defaults and expansion rules.

TEST(Experiment, DefaultsFilledIn) {
  const Experiment e = parse(minimal(
      "  - set_temperature: {fixture: chamber, setpoint_c: 40}\n"
      "  - orientations: {fixture: table, list: [{angle_deg: 10}], record_s: 2}\n"));
  EXPECT_EQ(e.file, "mem.yaml");
  EXPECT_EQ(e.seed, 1u);
  EXPECT_EQ(e.clock, ClockKind::kAuto);
  EXPECT_TRUE(e.plugin_paths.empty());
  EXPECT_EQ(e.description, "");
  EXPECT_DOUBLE_EQ(e.gravity.latitude_deg, 0.0);
  EXPECT_DOUBLE_EQ(e.gravity.height_m, 0.0);
  EXPECT_DOUBLE_EQ(e.gravity.resolved_mps2, physics::normal_gravity(0, 0));
  EXPECT_NEAR(e.gravity.resolved_mps2, 9.7803253359, 1e-9);
  EXPECT_DOUBLE_EQ(e.base_heading_deg, 0.0);
  EXPECT_EQ(e.mounted_on, "shaker");  // the last fixture declared
  EXPECT_TRUE(e.R_sensor_from_mount.isIdentity());
  EXPECT_EQ(e.outputs.directory, "runs");
  EXPECT_TRUE(e.outputs.report);
  EXPECT_TRUE(e.processing.IsMap());
  EXPECT_EQ(e.processing.size(), 0u);
  const Step& t = e.procedure[0];
  EXPECT_EQ(t.label, "set_temperature");
  EXPECT_DOUBLE_EQ(t.tolerance_c, 0.5);
  EXPECT_DOUBLE_EQ(t.hold_s, 60.0);
  EXPECT_DOUBLE_EQ(t.timeout_s, 3600.0);
  EXPECT_TRUE(t.record_settling);
  EXPECT_DOUBLE_EQ(e.procedure[1].dwell_s, 0.0);
  EXPECT_EQ(e.sensor.params.string("serial"), "A");
  EXPECT_DOUBLE_EQ(e.sensor.params.number("odr_hz"), 100.0);
}

TEST(Experiment, GravityValueAndMatrixMounting) {
  const Experiment e = parse(minimal(
      "  - record: {duration_s: 1}\n",
      "  gravity: {value_mps2: 9.8154}\n"
      "  mounting: {on: base, matrix: [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]}\n"));
  ASSERT_TRUE(e.gravity.value_mps2.has_value());
  EXPECT_DOUBLE_EQ(*e.gravity.value_mps2, 9.8154);
  EXPECT_DOUBLE_EQ(e.gravity.resolved_mps2, 9.8154);
  EXPECT_EQ(e.mounted_on, "base");
  Eigen::Matrix3d R;
  R << 0, 1, 0, -1, 0, 0, 0, 0, 1;
  EXPECT_EQ(e.R_sensor_from_mount, R);
  const Experiment b = parse(e.resolved_yaml);
  EXPECT_EQ(b.resolved_yaml, e.resolved_yaml);
  EXPECT_EQ(b.gravity.value_mps2, e.gravity.value_mps2);
}

TEST(Experiment, NoFixturesMountsOnBase) {
  const Experiment e = parse(
      "experiment: {name: bare}\nbench:\n  sensor: {plugin: sim_imu_like, config: {serial: X}}\n"
      "procedure:\n  - record: {duration_s: 5}\n");
  EXPECT_TRUE(e.fixtures.empty());
  EXPECT_EQ(e.mounted_on, "base");
  const Experiment b = parse(e.resolved_yaml);
  EXPECT_EQ(b.resolved_yaml, e.resolved_yaml);
  EXPECT_NO_THROW(validate_against_bench(e, {}));
}

TEST(Experiment, SweepGridRules) {
  const Experiment e = parse(minimal(
      "  - orientations: {fixture: table, sweep: {axis: angle, from_deg: 0, to_deg: 5, step_deg: 2}, record_s: 1}\n"
      "  - orientations: {fixture: table, sweep: {axis: angle, from_deg: 10, to_deg: 0, step_deg: -5}, record_s: 1}\n"
      "  - orientations: {fixture: table, sweep: {axis: angle, from_deg: 0, to_deg: 0.3, step_deg: 0.1}, record_s: 1}\n"
      "  - orientations: {fixture: table, sweep: {axis: angle, from_deg: 7, to_deg: 7, step_deg: 1}, record_s: 1}\n"
      "  - orientations:\n"
      "      fixture: tilt_table\n"
      "      grid: {angle_deg: [0, 90, 180], tilt_deg: [0, 45]}\n"
      "      record_s: 1\n"));
  const auto values = [&](std::size_t step) {
    std::vector<double> v;
    for (const auto& o : e.procedure[step].orientations) v.push_back(o.targets.at(0).value);
    return v;
  };
  EXPECT_EQ(values(0), (std::vector<double>{0, 2, 4}));  // 5 is not on the grid
  EXPECT_EQ(values(1), (std::vector<double>{10, 5, 0}));
  ASSERT_EQ(values(2).size(), 4u);
  EXPECT_EQ(values(2).back(), 0.3);  // snapped onto to_deg
  EXPECT_EQ(values(3), (std::vector<double>{7}));
  const auto& grid = e.procedure[4].orientations;
  ASSERT_EQ(grid.size(), 6u);
  const double expect[6][2] = {{0, 0}, {0, 45}, {90, 0}, {90, 45}, {180, 0}, {180, 45}};
  for (std::size_t i = 0; i < 6; ++i) {
    ASSERT_EQ(grid[i].targets.size(), 2u);
    EXPECT_EQ(grid[i].targets[0].axis, "angle");
    EXPECT_EQ(grid[i].targets[1].axis, "tilt");
    EXPECT_EQ(grid[i].targets[0].value, expect[i][0]);
    EXPECT_EQ(grid[i].targets[1].value, expect[i][1]);
  }
  TestBench bench(e);
  EXPECT_NO_THROW(validate_against_bench(e, bench.ptrs));
  EXPECT_EQ(parse(e.resolved_yaml).resolved_yaml, e.resolved_yaml);
}

TEST(Experiment, AnchorsAndAliasesWork) {
  const Experiment e = parse(minimal(
      "  - orientations: &six {fixture: table, list: [{angle_deg: 0}, {angle_deg: 180}], record_s: 2}\n"
      "  - set_temperature: {fixture: chamber, setpoint_c: 40}\n"
      "  - orientations: *six\n"));
  ASSERT_EQ(e.procedure.size(), 3u);
  EXPECT_EQ(e.procedure[2].orientations.size(), 2u);
}

TEST(Experiment, RepeatIndexKeptOutsideRepeats) {
  const Experiment e = parse(minimal("  - record: {duration_s: 1, repeat_index: 4}\n"));
  EXPECT_EQ(e.procedure[0].repeat_index, 4);
}

TEST(Experiment, ErrorKeyPathAndLocation) {
  const ExperimentError err = parse_error(minimal(
      "  - record: {duration_s: 1}\n"
      "  - repeat:\n"
      "      count: 2\n"
      "      steps:\n"
      "        - orientations: {fixture: table, list: [{angle_deg: 0}], dwell_s: -1, record_s: 1}\n"));
  EXPECT_EQ(err.key(), "procedure[1].repeat.steps[0].orientations.dwell_s");
  EXPECT_EQ(err.where().file, "mem.yaml");
  EXPECT_EQ(err.where().line, 17);
  EXPECT_EQ(err.where().column, 75);
  EXPECT_EQ(err.hint(), "durations are in seconds");
}

TEST(Experiment, UnknownPluginListsLoadedOnes) {
  const ExperimentError err = parse_error(
      "experiment: {name: x}\nbench:\n  sensor: {plugin: sim_imu_lik}\nprocedure: [{record: {duration_s: 1}}]\n");
  EXPECT_NE(err.hint().find("did you mean 'sim_imu_like'?"), std::string::npos) << err.what();
  EXPECT_NE(err.hint().find("Loaded sensor plugins: sim_imu_like"), std::string::npos) << err.what();
}

TEST(Experiment, UnknownKeyHintListsAllowedKeys) {
  const ExperimentError err = parse_error(minimal("  - record: {duration_s: 1, lable: x}\n"));
  EXPECT_EQ(err.message(), "unknown key 'lable' in the record step");
  EXPECT_EQ(err.hint(), "did you mean 'label'? Allowed keys: duration_s, label");
}

// Smaller malformed inputs: message substring and 1-based line:column.
TEST(Experiment, InlineErrors) {
  struct Case {
    std::string text, expected;
    int line, column;
  };
  const std::string head = "experiment: {name: x}\nbench:\n  sensor: {plugin: sim_imu_like, config: {serial: A}}\n";
  const std::vector<Case> cases = {
      {"experiment: x\n", "expected a mapping (key: value) for the 'experiment' section, got 'x'", 1, 13},
      {"- a\n- b\n", "expected the experiment as a mapping", 1, 1},
      {head + "procedure:\n", "the procedure is empty", 4, 1},
      {head + "procedure:\n  -\n", "expected a step (a one-key mapping naming its kind), got nothing", 0, 0},
      {head + "procedure: {record: {duration_s: 1}}\n", "expected a list of steps for 'procedure'", 4, 12},
      {"experiment: {name: x}\nbench:\n  sensor: {plugin: sim_imu_like, config: 5}\nprocedure: [{record: {duration_s: 1}}]\n",
       "expected a mapping (key: value) for the config of plugin 'sim_imu_like', got '5'", 3, 42},
      {"experiment: {name: x}\nbench:\n  sensor: {plugin: sim_imu_like, config: {serial: A, odr_hz: }}\nprocedure: [{record: {duration_s: 1}}]\n",
       "expected a number for 'odr_hz', got nothing", 3, 54},
      {head + "procedure:\n  - record: {duration_s: .inf}\n", "(numbers must be finite)", 5, 26},
      // Durations longer than a whole run may be, where they are written.
      {head + "procedure:\n  - record: {duration_s: 1e12}\n",
       "'duration_s' is 1e+12 s, more than the run-time limit of 2592000 s (30 days)", 5, 26},
      {head + "procedure:\n  - wait: {duration_s: 1e300}\n", "more than the run-time limit", 5, 24},
      {head + "limits: {max_run_time_s: 10}\nprocedure:\n  - record: {duration_s: 11}\n",
       "'duration_s' is 11 s, more than the run-time limit of 10 s", 6, 26},
      {head + "limits: {max_samples: -1}\nprocedure:\n  - record: {duration_s: 1}\n",
       "'max_samples' must be greater than 0, got -1", 4, 23},
      {head + "limits: {max_byte: 1}\nprocedure:\n  - record: {duration_s: 1}\n", "unknown key 'max_byte'", 4, 10},
      {head + "procedure:\n  - record: {duration_s: 1}\n  - record: {duration_s: 1, label: \"\"}\n", "'label' must not be empty", 6, 36},
      {head + "procedure:\n  - wait: {duration_s: 1, <<: {label: x}}\n", "merge keys", 5, 27},
      {head + "procedure:\n\t- wait: {duration_s: 1}\n", "YAML syntax error", 5, 2},
      // yaml-cpp 0.7's LoadAll looped for ever here, allocating (the fuzz target found it).
      {", {angle_deg: 60}], dwell_s: 2\n", "YAML syntax error: unexpected ',': no YAML node starts with it", 1, 1},
      {head + "procedure: [{record: {duration_s: 1}}]\n---\nexperiment: {name: y}\n",
       "a second YAML document starts here; an experiment is a single document", 6, 1},
      {head + "procedure:\n  - set_vibration: {fixture: shaker, amplitude_g: 0}\n", "unknown fixture 'shaker'", 5, 30},
      {head + "procedure:\n  - record: {duration_s: 1}\noutputs: {directory: \"\"}\n", "'directory' must not be empty", 6, 22},
      {head + "procedure:\n  - record: {duration_s: 1}\nprocessing: [1]\n", "expected a mapping for 'processing'", 6, 13},
      {"experiment: {name: x, seed: 99999999999999999999}\nbench: {sensor: {plugin: sim_imu_like, config: {serial: A}}}\nprocedure: [{record: {duration_s: 1}}]\n",
       "expected an integer for 'seed'", 1, 29},
      {"experiment: {name: x, plugin_paths: ./p}\nbench: {sensor: {plugin: sim_imu_like, config: {serial: A}}}\nprocedure: [{record: {duration_s: 1}}]\n",
       "expected a list of folders for 'plugin_paths'", 1, 37},
      {head + "  gravity: {latitude_deg: 1, resolved_mps2: 9.8}\nprocedure: [{record: {duration_s: 1}}]\n",
       "'resolved_mps2' is 9.8 but the gravity given resolves to", 4, 45},
      {head + "  mounting: {rpy_deg: [0, 90]}\nprocedure: [{record: {duration_s: 1}}]\n",
       "expected [roll, pitch, yaw] in degrees for 'rpy_deg', got 2 numbers", 4, 23},
      // A later fixture without an `id` key while an earlier one stands on an unknown fixture
      // (the fuzz target found yaml-cpp's InvalidNode escaping here).
      {head + "  fixtures:\n    - {id: shaker, plugin: sim_shaker_like, on: table}\n    - {id config: {a: 1}}\n"
              "procedure: [{record: {duration_s: 1}}]\n",
       "unknown fixture 'table' in 'on'", 5, 49},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    const ExperimentError e = parse_error(c.text);
    EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << e.what();
    if (c.line > 0) {
      EXPECT_EQ(e.where().line, c.line) << e.what();
      EXPECT_EQ(e.where().column, c.column) << e.what();
    }
  }
}

// Each default is written once (RunLimits); a `limits:` block overrides any of them and is kept in
// the resolved YAML.
TEST(Experiment, LimitsDefaultAndOverride) {
  const Experiment d = parse(minimal("  - record: {duration_s: 1}\n"));
  EXPECT_EQ(d.limits.max_run_time_s, RunLimits{}.max_run_time_s);
  EXPECT_EQ(d.limits.max_samples, RunLimits{}.max_samples);
  EXPECT_EQ(d.limits.max_bytes, RunLimits{}.max_bytes);
  const Experiment e = parse("experiment: {name: x}\nbench:\n  sensor: {plugin: sim_imu_like, config: {serial: A}}\n"
                             "limits: {max_run_time_s: 4e6, max_bytes: 5e9}\nprocedure: [{record: {duration_s: 3e6}}]\n");
  EXPECT_EQ(e.limits.max_run_time_s, 4e6);
  EXPECT_EQ(e.limits.max_samples, RunLimits{}.max_samples);
  EXPECT_EQ(e.limits.max_bytes, 5e9);
  EXPECT_EQ(e.limits.where.line, 4);
  const Experiment b = parse(e.resolved_yaml);
  EXPECT_EQ(b.limits.max_run_time_s, 4e6);
  EXPECT_EQ(b.limits.max_bytes, 5e9);
}

TEST(Experiment, StageTwoNeedsOneObjectPerFixture) {
  const Experiment e = parse(minimal("  - record: {duration_s: 1}\n"));
  EXPECT_THROW(validate_against_bench(e, {}), std::invalid_argument);
}

TEST(Experiment, MissingFileIsAnExperimentError) {
  try {
    (void)load_experiment("/nonexistent/exp.yaml", catalogue());
    FAIL() << "no error";
  } catch (const ExperimentError& e) {
    EXPECT_EQ(e.where().line, 0);
    EXPECT_EQ(e.where().file, "/nonexistent/exp.yaml");
    EXPECT_NE(std::string(e.what()).find("/nonexistent/exp.yaml: error: experiment file"),
              std::string::npos)
        << e.what();
    EXPECT_NE(e.message().find("does not exist"), std::string::npos);
  }
}

TEST(Experiment, EmptyFile) {
  const ExperimentError err = parse_error("# nothing here\n");
  EXPECT_EQ(err.message(), "the experiment file is empty");
  EXPECT_EQ(err.where().line, 1);
}

TEST(Experiment, PluginPathsReadAlone) {
  const std::string path = source_path("core/tests/data/experiments/full.yaml").string();
  const std::vector<std::string> paths = experiment_plugin_paths(path);
  const Experiment e = load_experiment(path, catalogue());
  EXPECT_EQ(paths, e.plugin_paths);
}

// ---------------------------------------------------------------------------------------------
// params_from_yaml on its own.

TEST(Params, DefaultsAndRequiredKeys) {
  const stend_plugin_info* info = catalogue().find("sim_imu_like");
  ASSERT_NE(info, nullptr);
  try {
    (void)params_from_yaml(YAML::Node(), *info, "cfg.yaml", "config");
    FAIL() << "serial is required";
  } catch (const ExperimentError& e) {
    EXPECT_EQ(e.key(), "config.serial");
    EXPECT_EQ(e.message(),
              "missing required key 'serial' in the config of plugin 'sim_imu_like' (text: unit "
              "serial number)");
  }
  const Params p = params_from_yaml(YAML::Load("{serial: 7, temp_coeffs: [1, 2.5]}"), *info,
                                    "cfg.yaml", "config");
  EXPECT_EQ(p.string("serial"), "7");  // any scalar is text
  EXPECT_EQ(p.numbers("temp_coeffs"), (std::vector<double>{1, 2.5}));
  EXPECT_TRUE(std::holds_alternative<std::int64_t>(p.values().at("fifo_depth")));
  EXPECT_TRUE(std::holds_alternative<double>(p.values().at("odr_hz")));
  EXPECT_TRUE(std::holds_alternative<Params::Matrix>(p.values().at("misalignment")));
  EXPECT_TRUE(std::holds_alternative<std::vector<double>>(p.values().at("accel_bias_mps2")));
}

TEST(Params, RangeMessageStatesBoundAndUnit) {
  const stend_plugin_info* info = catalogue().find("sim_imu_like");
  try {
    (void)params_from_yaml(YAML::Load("{serial: A, odr_hz: 0.5}"), *info, "cfg.yaml", "c");
    FAIL();
  } catch (const ExperimentError& e) {
    EXPECT_EQ(e.message(), "'odr_hz' = 0.5 is below the minimum 1 Hz");
    EXPECT_EQ(e.hint(), "odr_hz (a number, in Hz, range [1, 1000]): output data rate");
    EXPECT_EQ(e.where().line, 1);
    EXPECT_EQ(e.where().column, 21);
  }
}

TEST(Params, PluginWithoutSchemaRejectsAnyKey) {
  const stend_plugin_info* info = catalogue().find("sim_shaker_like");
  EXPECT_TRUE(params_from_yaml(YAML::Node(), *info, "f", "c").values().empty());
  EXPECT_THROW(params_from_yaml(YAML::Load("{gain: 1}"), *info, "f", "c"), ExperimentError);
}

// ---------------------------------------------------------------------------------------------
// Malformed experiments: one file each, first line "# expect: LINE:COL: TEXT"; an optional
// "# stage: 2" line says the file passes stage 1 and fails against the test fixtures.

std::vector<std::string> bad_files() {
  std::vector<std::string> out;
  const fs::path dir = source_path("core/tests/data/bad_experiments");
  if (!fs::is_directory(dir)) return out;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") out.push_back(entry.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(BadExperiments, AtLeastTwentyFiles) { EXPECT_GE(bad_files().size(), 20u); }

class BadExperiment : public ::testing::TestWithParam<std::string> {};

TEST_P(BadExperiment, FailsWhereAndHowItSays) {
  const std::string path = GetParam();
  std::istringstream text(read_text(path));
  std::string first, second;
  std::getline(text, first);
  std::getline(text, second);
  const std::string prefix = "# expect: ";
  ASSERT_EQ(first.rfind(prefix, 0), 0u) << path << " must start with '" << prefix << "'";
  const std::string spec = first.substr(prefix.size());
  const auto c1 = spec.find(':');
  const auto c2 = spec.find(':', c1 + 1);
  ASSERT_NE(c2, std::string::npos) << "expected '# expect: LINE:COL: TEXT' in " << path;
  const std::string line_col = spec.substr(0, c2);
  std::string expected = spec.substr(c2 + 1);
  expected.erase(0, expected.find_first_not_of(' '));
  const bool stage2 = second == "# stage: 2";

  Experiment exp;
  try {
    exp = load_experiment(path, catalogue());
  } catch (const ExperimentError& e) {
    EXPECT_FALSE(stage2) << "stage-2 case failed in stage 1: " << e.what();
    const std::string what = e.what();
    EXPECT_NE(what.find(path + ":" + line_col + ": error:"), std::string::npos)
        << "expected location " << line_col << ", got:\n" << what;
    EXPECT_NE(what.find(expected), std::string::npos)
        << "expected '" << expected << "' in:\n" << what;
    return;
  }
  ASSERT_TRUE(stage2) << path << " parsed without error";
  TestBench bench(exp);
  try {
    validate_against_bench(exp, bench.ptrs);
    FAIL() << path << " passed stage 2";
  } catch (const ExperimentError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path + ":" + line_col + ": error:"), std::string::npos)
        << "expected location " << line_col << ", got:\n" << what;
    EXPECT_NE(what.find(expected), std::string::npos)
        << "expected '" << expected << "' in:\n" << what;
  }
}

INSTANTIATE_TEST_SUITE_P(Files, BadExperiment, ::testing::ValuesIn(bad_files()),
                         [](const ::testing::TestParamInfo<std::string>& param) {
                           std::string name = fs::path(param.param).stem().string();
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

// Every good example passes both stages and round-trips.
TEST(GoodExperiments, ParseValidateRoundTrip) {
  const fs::path dir = source_path("core/tests/data/experiments");
  int n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    try {
      const Experiment e = load_experiment(entry.path().string(), catalogue());
      TestBench bench(e);
      validate_against_bench(e, bench.ptrs);
      EXPECT_EQ(parse_experiment(e.resolved_yaml, "r.yaml", catalogue()).resolved_yaml,
                e.resolved_yaml);
      ++n;
    } catch (const std::exception& ex) {
      ADD_FAILURE() << ex.what();
    }
  }
  EXPECT_GE(n, 1);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The closed sets of the runtime: one name table each, read back as written.

TEST(Names, ClockKindsAndRunPhasesReadBackAsWritten) {
  for (ClockKind k : {ClockKind::kAuto, ClockKind::kSimulated, ClockKind::kWall})
    EXPECT_EQ(clock_kind_from_string(to_string(k)), k);
  EXPECT_EQ(clock_kind_names(), (std::vector<std::string>{"auto", "simulated", "wall"}));
  EXPECT_FALSE(clock_kind_from_string("sundial"));
  for (RunPhase p : {RunPhase::kNone, RunPhase::kMoving, RunPhase::kDwell, RunPhase::kRecording, RunPhase::kSettling,
                     RunPhase::kWaiting, RunPhase::kDone, RunPhase::kRunning, RunPhase::kInterrupted, RunPhase::kFailed})
    EXPECT_EQ(run_phase_from_string(to_string(p)), p);
  EXPECT_STREQ(to_string(RunPhase::kNone), "");  // nothing reported yet
  EXPECT_EQ(run_phase_of(RunStatus::kComplete), RunPhase::kDone);
  EXPECT_EQ(run_phase_of(RunStatus::kFailed), RunPhase::kFailed);
  RunProgress p;
  EXPECT_STREQ(p.step_kind_name(), "");
  p.step_kind = Step::Kind::kSetTemperature;
  EXPECT_STREQ(p.step_kind_name(), "set_temperature");
}

TEST(RunOptions, IsValidNamesWhatDoesNotHold) {
  RunOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.control_period_s = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("control_period_s"), std::string::npos) << why;
  o = RunOptions{};
  o.sensor_retries = 0;
  EXPECT_THROW(require_valid(o, "run options"), std::invalid_argument);
}
