// Acceptance: the paper's experiment through the real drivers — mpu6050_modbus, evo10l,
// thermochamber — against the emulated bench world, the twin of configs/paper_mpu6050_z.yaml's
// in-process simulated bench, gives the same fitted parameters as the same procedure on the
// in-process bench, within the reported uncertainty. Runs ≈ 40 s of wall time.
#include <gtest/gtest.h>

#include <stend/core/experiment.hpp>
#include <stend/core/plugin_host.hpp>
#include <stend/recording/recording.hpp>
#include <stend/core/runner.hpp>
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
#include <thread>
#include <memory>
#include <chrono>

#include "bench_world.hpp"
#ifdef STEND_BENCH_MCU_ELF
#include "firmware_in_loop.hpp"
#endif

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

#ifdef STEND_BENCH_MCU_ELF
// ---- The same drivers against the bench microcontroller's real firmware under simavr ----------
// The firmware is the sensor's MCU (slave 1) and the chamber's controller (slave 2, the published
// PID driving the plant by its PWM, in wall time); the world serves both on two ports in front of
// its one UART.

// The twin with the chamber starting at the drivers' 25 °C setpoint: the firmware's plant runs in
// wall time, and the paper's 3 °C warm-up from 22 °C would take minutes.
stend::Experiment twin_at_setpoint(const stend::PluginHost& host) {
  const std::string file = kSrc + "/configs/paper_mpu6050_z.yaml";
  YAML::Node y = YAML::Load(read_text(file));
  for (YAML::Node f : y["bench"]["fixtures"]) {
    if (f["plugin"].as<std::string>() == "sim_thermochamber") f["config"]["initial_c"] = 25.0;
  }
  YAML::Emitter em;
  em << y;
  return stend::parse_experiment(em.c_str(), file, host);
}

// The drivers file pointed at the world, with the chamber as the firmware's slave and the sweep in
// `step_deg` steps (a shorter procedure: the test stays well under a minute); without the chamber
// (its fixture and its set_temperature step) when `with_chamber` is false.
stend::Experiment drivers_for(stend::emu::BenchWorld& world, const stend::PluginHost& host, double step_deg,
                              bool with_chamber = true) {
  const std::string file = kSrc + "/configs/paper_mpu6050_z_drivers.yaml";
  YAML::Node y = YAML::Load(read_text(file));
  if (!with_chamber) {
    YAML::Node fixtures, procedure;
    for (const YAML::Node& f : y["bench"]["fixtures"])
      if (f["plugin"].as<std::string>() != "thermochamber") fixtures.push_back(f);
    for (const YAML::Node& step : y["procedure"])
      if (!step["set_temperature"]) procedure.push_back(step);
    y["bench"]["fixtures"] = fixtures;
    y["bench"]["mounting"]["on"] = "table";
    y["procedure"] = procedure;
  }
  y["bench"]["sensor"]["config"]["device"] = world.mcu_device();
  for (YAML::Node f : y["bench"]["fixtures"]) {
    if (f["plugin"].as<std::string>() == "thermochamber") {
      f["config"]["device"] = world.chamber_device();
      f["config"]["slave_id"] = world.chamber_slave_id();
    }
    if (f["plugin"].as<std::string>() == "evo10l") f["config"]["port"] = world.table_port();
  }
  for (YAML::Node step : y["procedure"]) {
    if (step["orientations"]) step["orientations"]["sweep"]["step_deg"] = step_deg;
  }
  YAML::Emitter em;
  em << y;
  return stend::parse_experiment(em.c_str(), file, host);
}

std::unique_ptr<stend::emu::BenchWorld> make_firmware_world(const stend::PluginHost& host) {
  stend::emu::BenchWorldConfig wc = stend::emu::BenchWorldConfig::from_experiment(twin_at_setpoint(host), 1.0);
  wc.firmware_elf = STEND_BENCH_MCU_ELF;
  wc.table_port = 0;
  return std::make_unique<stend::emu::BenchWorld>(wc);  // in place: its models hold `this`
}

// The paper's experiment end to end through the firmware: the real drivers, the real firmware, a
// run folder the estimator fits with bias_z, scale_z, cross_zx within 2 standard errors of the
// twin's truth (12 tilts, 0…44° in 4° steps, instead of 23: ≈ 30 s of wall time, 40 s at load 18).
TEST(PaperThroughFirmware, FitFindsTheTwinsTruthWithinTwoStandardErrors) {
  const stend::testing::TempDir tmp("paper-firmware");
  const stend::PluginHost& host = stend::testing::build_tree_plugins();
  auto world = make_firmware_world(host);
  const stend::Experiment drivers = drivers_for(*world, host, 4.0);
  stend::RunOptions opt;
  opt.run_name = "firmware";
  const stend::RunResult r = stend::testing::run_in_process(drivers, tmp.path(), opt);
  ASSERT_EQ(r.status, stend::RunStatus::kComplete) << r.message;
  EXPECT_EQ(r.segments, 13);  // the temperature hold and 12 tilts
  EXPECT_LT(r.wall_time_s, 60.0);
  std::printf("[figures] firmware run: %llu samples, %d segments, %.1f s run time in %.1f s wall\n",
              static_cast<unsigned long long>(r.samples), r.segments, r.run_time_s, r.wall_time_s);
  const auto fd = fit(r.dir, tmp / "firmware.json");
  const std::map<std::string, double> truth = {{"bias_z", 0.027}, {"scale_z", 0.0007}, {"cross_zx", 0.0055}};
  for (const auto& [name, true_value] : truth) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(fd.count(name));
    const Param& a = fd.at(name);
    ASSERT_TRUE(a.identifiable);
    std::printf("%-9s firmware %+.6f ± %.6f   truth %+.6f\n", name.c_str(), a.value, a.se, true_value);
    EXPECT_LE(std::abs(a.value - true_value), 2.0 * a.se) << "the fit through the firmware misses the twin's truth";
  }
  EXPECT_FALSE(fd.at("cross_zy").identifiable);
}

// The firmware hangs in the middle of the run; the AVR's watchdog resets it: the sensor's driver
// sees the restart (BOOT_COUNT moved) and the run stops saying so, instead of recording on. (No
// chamber driver here: it would see its reading drop to 0 at the restart, and whichever driver
// polls first stops the run.)
TEST(PaperThroughFirmware, DriverSeesTheWatchdogRestart) {
  const stend::testing::TempDir tmp("paper-firmware-hang");
  const stend::PluginHost& host = stend::testing::build_tree_plugins();
  auto world = make_firmware_world(host);
  const stend::Experiment drivers = drivers_for(*world, host, 4.0, false);
  stend::emu::FirmwareInTheLoop* fw = world->firmware();
  ASSERT_NE(fw, nullptr);
  std::thread hang([fw] {
    std::this_thread::sleep_for(std::chrono::seconds(4));  // in the sweep
    fw->hang_mcu();
  });
  stend::RunOptions opt;
  opt.run_name = "hang";
  const stend::RunResult r = stend::testing::run_in_process(drivers, tmp.path(), opt);
  hang.join();
  EXPECT_NE(r.status, stend::RunStatus::kComplete);
  EXPECT_NE(r.message.find("bench MCU restarted"), std::string::npos) << r.message;
  EXPECT_GE(fw->stats().resets, 1u) << "the AVR's watchdog reset the part";
}
#endif

}  // namespace
