// Acceptance: the paper's experiment through the real drivers — mpu6050_modbus, evo10l,
// thermochamber — against the emulated bench world, the twin of configs/paper_mpu6050_z.yaml's
// in-process simulated bench, gives the same fitted parameters as the same procedure on the
// in-process bench, within the reported uncertainty. Runs ≈ 40 s of wall time.
#include <gtest/gtest.h>

#include <stend/experiment.hpp>
#include <stend/plugin_host.hpp>
#include <stend/recording.hpp>
#include <stend/runner.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/program.hpp>
#include <stend/testing/sim_bench.hpp>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "bench_world.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kSrc = STEND_SOURCE_DIR;

using stend::testing::read_text;

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
}

struct Param {
  bool identifiable = false;
  double value = NAN, se = NAN;
};

std::map<std::string, Param> fit(const fs::path& run, const fs::path& json) {
  const std::string args =
      "fit " + run.string() + " -m " + kSrc + "/configs/models/paper_z_channel_short.yaml --out " + json.string();
  EXPECT_EQ(stend::testing::run_stend(args).code, 0) << args;
  std::map<std::string, Param> out;
  std::ifstream f(json);
  if (!f) return out;
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_EQ(j.value("status", ""), "ok");
  for (const auto& p : j["parameters"]) {
    Param q;
    q.identifiable = p.value("identifiable", false);
    if (q.identifiable) {
      q.value = p["value"].get<double>();
      q.se = p["std_error"].get<double>();
    }
    out[p["name"].get<std::string>()] = q;
  }
  return out;
}

TEST(PaperThroughDrivers, FitAgreesWithTheInProcessBenchWithinUncertainty) {
  const stend::testing::TempDir tmp("paper-drivers");
  const stend::PluginHost& host = stend::testing::build_tree_plugins();
  const std::string drivers_file = kSrc + "/configs/paper_mpu6050_z_drivers.yaml";
  const stend::Experiment twin = stend::load_experiment(kSrc + "/configs/paper_mpu6050_z.yaml", host);

  // The world, twin of the in-process bench; the chamber's plant runs 50× faster than the wall.
  stend::emu::BenchWorld world(stend::emu::BenchWorldConfig::from_experiment(twin, 50.0));
  std::string text = read_text(drivers_file);
  replace_all(text, "/dev/ttyUSB0", world.mcu_device());
  replace_all(text, "/dev/ttyUSB1", world.chamber_device());
  replace_all(text, "port: 5025", "port: " + std::to_string(world.table_port()));
  const stend::Experiment drivers = stend::parse_experiment(text, drivers_file, host);

  // The same procedure on the in-process simulated bench: the drivers file with the twin's bench.
  YAML::Node sim = YAML::Load(read_text(drivers_file));
  sim["bench"] = YAML::Load(read_text(kSrc + "/configs/paper_mpu6050_z.yaml"))["bench"];
  sim["experiment"]["clock"] = "simulated";
  sim["experiment"]["name"] = "paper_mpu6050_z_inprocess";
  YAML::Emitter em;
  em << sim;
  const stend::Experiment inproc = stend::parse_experiment(em.c_str(), drivers_file, host);

  stend::RunOptions opt;
  opt.run_name = "drivers";
  const stend::RunResult rd = stend::testing::run_in_process(drivers, tmp.path(), opt);
  ASSERT_EQ(rd.status, stend::RunStatus::kComplete) << rd.message;
  EXPECT_LT(rd.wall_time_s, 60.0);
  opt.run_name = "inprocess";
  const stend::RunResult rs = stend::testing::run_in_process(inproc, tmp.path(), opt);
  ASSERT_EQ(rs.status, stend::RunStatus::kComplete) << rs.message;
  EXPECT_EQ(rd.segments, rs.segments);

  const auto fd = fit(rd.dir, tmp / "drivers.json");
  const auto fsim = fit(rs.dir, tmp / "inprocess.json");
  // The truth the sim sensor carries (configs/paper_mpu6050_z.yaml): Δa_z, δM, μ33.
  const std::map<std::string, double> truth = {{"bias_z", 0.027}, {"scale_z", 0.0007}, {"cross_zx", 0.0055}};
  for (const auto& [name, true_value] : truth) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(fd.count(name) && fsim.count(name));
    const Param& a = fd.at(name);
    const Param& b = fsim.at(name);
    ASSERT_TRUE(a.identifiable && b.identifiable);
    const double combined = std::hypot(a.se, b.se);
    std::printf("%-9s drivers %+.6f ± %.6f   in-process %+.6f ± %.6f   truth %+.6f\n", name.c_str(), a.value, a.se,
                b.value, b.se, true_value);
    EXPECT_LE(std::abs(a.value - b.value), 3.0 * combined) << "drivers and in-process fits disagree";
    EXPECT_LE(std::abs(a.value - true_value), 3.0 * a.se) << "the drivers' fit misses the simulated truth";
  }
  // At h = 0 neither run can see μ34: both must say so rather than print a number.
  EXPECT_FALSE(fd.at("cross_zy").identifiable);
  EXPECT_FALSE(fsim.at("cross_zy").identifiable);
}

}  // namespace
