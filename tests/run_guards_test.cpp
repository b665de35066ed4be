// What `stend validate` and `stend run` refuse before anything runs, and what a run records about
// itself: the limits derived from what the run would produce, run names that are names, plugin
// folders from an experiment file loaded only when allowed (and recorded), `record: false`.
#include <gtest/gtest.h>

#include "stend/recording/recording.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"
#include "stend/testing/sim_bench.hpp"

#include <sys/statvfs.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using stend::testing::ProgramOutput;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::TempDir;

namespace {

// A simulated one-axis bench with a chamber, the sensor at `rate_hz`; `top` goes before
// `procedure:` (line 7), `steps` is the procedure.
std::string experiment(const std::string& top, const std::string& steps, int rate_hz = 200) {
  return "experiment: {name: guards, seed: 3}\n"
         "bench:\n"
         "  sensor: {plugin: sim_imu, config: {output_rate_hz: " + std::to_string(rate_hz) + ", lowpass_hz: 0}}\n"
         "  fixtures:\n"
         "    - {id: table, plugin: sim_one_axis_table}\n"
         "    - {id: chamber, plugin: sim_thermochamber, on: table, config: {initial_c: 24}}\n" +
         top + "procedure:\n" + steps;
}

fs::path write(const fs::path& file, const std::string& text) {
  std::ofstream(file) << text;
  return file;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::size_t entries(const fs::path& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

}  // namespace

// --- limits ----------------------------------------------------------------------------------

TEST(RunGuards, ValidatePrintsTheExpectedRunTimeSamplesAndBytes) {
  const TempDir dir("guards");
  // 2 orientations × (2 s move + 1 s dwell + 10 s record) + 5 s record = 31 s at 200 Hz.
  const fs::path f = write(dir / "e.yaml", experiment("", "  - orientations: {fixture: table, list: [{angle_deg: 0}, "
                                                          "{angle_deg: 90}], dwell_s: 1, record_s: 10}\n"
                                                          "  - record: {duration_s: 5}\n"));
  const ProgramOutput o = run_stend("validate " + f.string());
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(contains(o.text, "run time 31 s, 6.2e+03 samples, up to ")) << o.text;
  EXPECT_TRUE(contains(o.text, "(hdf5)")) << o.text;
}

TEST(RunGuards, AHugeDurationIsRefusedWhereItIsWritten) {
  const TempDir dir("guards");
  for (const std::string& step : {std::string("  - orientations: {fixture: table, list: [{angle_deg: 0}], dwell_s: 1e300, "
                                              "record_s: 1}\n"),
                                  std::string("  - record: {duration_s: 1e12}\n")}) {
    const fs::path f = write(dir / "huge.yaml", experiment("", step));
    const ProgramOutput o = run_stend("validate " + f.string());
    EXPECT_EQ(o.code, 2) << o.text;
    EXPECT_TRUE(contains(o.text, f.string() + ":8:")) << o.text;
    EXPECT_TRUE(contains(o.text, "more than the run-time limit of 2592000 s (30 days)")) << o.text;
  }
}

// Each step within the limit, the whole run beyond it: refused before anything is written, with
// the numbers; a `limits:` block raises the limit.
TEST(RunGuards, TheWholeRunIsCheckedAgainstTheLimits) {
  const TempDir dir("guards");
  const std::string steps = "  - repeat: {count: 40, steps: [{record: {duration_s: 86400}}]}\n";  // 40 days
  const fs::path f = write(dir / "long.yaml", experiment("", steps));
  const ProgramOutput v = run_stend("validate " + f.string());
  EXPECT_EQ(v.code, 2) << v.text;
  EXPECT_TRUE(contains(v.text, "the run would exceed limits.max_run_time_s: expected run time 40d00h00m00s (3.456e+06 s) "
                               "> 2.592e+06 s"))
      << v.text;
  const ProgramOutput r = run_stend("run " + f.string() + " --quiet -o " + (dir / "runs").string());
  EXPECT_EQ(r.code, 2) << r.text;
  EXPECT_FALSE(fs::exists(dir / "runs")) << "nothing is written for a refused run";

  const fs::path few = write(dir / "few.yaml", experiment("limits: {max_samples: 1000}\n", "  - record: {duration_s: 10}\n"));
  const ProgramOutput s = run_stend("validate " + few.string());
  EXPECT_EQ(s.code, 2) << s.text;
  EXPECT_TRUE(contains(s.text, few.string() + ":7:")) << s.text;  // the limits: block
  EXPECT_TRUE(contains(s.text, "limits.max_samples: 2000 samples > 1000")) << s.text;

  const fs::path small = write(dir / "small.yaml", experiment("limits: {max_bytes: 1e5}\n", "  - record: {duration_s: 10}\n"));
  const ProgramOutput b = run_stend("validate " + small.string());
  EXPECT_EQ(b.code, 2) << b.text;
  EXPECT_TRUE(contains(b.text, "limits.max_bytes: up to ")) << b.text;

  const fs::path raised =
      write(dir / "raised.yaml", experiment("limits: {max_run_time_s: 4e6}\n", steps, 10));
  const ProgramOutput ok = run_stend("validate " + raised.string());
  // The raised limit is honoured; the estimate (several GB) may still exceed this machine's free
  // space, which is then the only refusal.
  EXPECT_FALSE(contains(ok.text, "limits.")) << ok.text;
  EXPECT_TRUE(ok.code == 0 || contains(ok.text, "free [run time 40d00h00m00s")) << ok.text;
  EXPECT_TRUE(contains(ok.text, "run time 40d00h00m00s, 3.46e+07 samples")) << ok.text;
}

// A run that would not fit on the output folder's file system is refused with both numbers.
TEST(RunGuards, ARunLargerThanTheFreeSpaceIsRefused) {
  const TempDir dir("guards");
  struct statvfs st {};
  ASSERT_EQ(statvfs(dir.str().c_str(), &st), 0);
  const double free_bytes = static_cast<double>(st.f_bavail) * static_cast<double>(st.f_frsize);
  // Ten times the free space at ≥ 96 bytes per sample and 200 Hz, with the limits raised out of the way.
  const double seconds = std::ceil(10.0 * free_bytes / (96.0 * 200.0));
  const std::string limits = "limits: {max_run_time_s: 1e15, max_samples: 1e18, max_bytes: 1e20}\n";
  const fs::path f = write(dir / "big.yaml", experiment(limits, "  - record: {duration_s: " + std::to_string(seconds) + "}\n"));
  const ProgramOutput o = run_stend("run " + f.string() + " --quiet -o " + dir.str());
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(contains(o.text, "but the file system of '" + dir.str() + "' has ")) << o.text;
  EXPECT_TRUE(contains(o.text, "free")) << o.text;
  EXPECT_EQ(entries(dir.path()), 1u) << "only the experiment file";
}

// --- run names -------------------------------------------------------------------------------

TEST(RunGuards, RunNamesThatAreNotOneFolderNameAreRefused) {
  const TempDir dir("guards");
  const fs::path f = write(dir / "e.yaml", experiment("", "  - record: {duration_s: 1}\n"));
  const fs::path out = dir / "out";
  fs::create_directories(out);
  for (const std::string& name : {std::string("../escaped"), std::string("a/b/c"), std::string("/tmp/abs"),
                                  std::string("."), std::string(".."), std::string(""), std::string("tab\there")}) {
    const ProgramOutput o = run_stend("run " + f.string() + " --quiet -o " + out.string() + " --name " + shell_quote(name));
    EXPECT_EQ(o.code, 1) << name << "\n" << o.text;
    EXPECT_TRUE(contains(o.text, "a run name names one folder inside the output folder")) << name << "\n" << o.text;
  }
  EXPECT_EQ(entries(out), 0u);
  EXPECT_FALSE(fs::exists(dir / "escaped"));
  EXPECT_FALSE(fs::exists(out / "a"));
  const ProgramOutput ok = run_stend("run " + f.string() + " --quiet -o " + out.string() + " --name good.run-1");
  EXPECT_EQ(ok.code, 0) << ok.text;
  EXPECT_TRUE(fs::exists(out / "good.run-1"));
}

// --- plugins ---------------------------------------------------------------------------------

// A plugin folder named by the experiment: its library runs no code on validate or run unless
// allowed; allowed, it is loaded and the run records it with its path, origin and hash.
TEST(RunGuards, ExperimentPluginFoldersAreLoadedOnlyWhenAllowed) {
  const TempDir dir("guards");
  const fs::path marker_plugin = fs::path(STEND_BINARY_DIR) / "lib/stend/test-plugins-marker/stend_test_marker.so";
  ASSERT_TRUE(fs::exists(marker_plugin)) << "build the target stend_test_plugins";
  fs::create_directories(dir / "plugins");
  fs::copy_file(marker_plugin, dir / "plugins/stend_test_marker.so");
  const fs::path marker = dir / "marker.txt";
  const stend::testing::Environment env = {{"STEND_TEST_MARKER_FILE", marker.string()}};

  // The experiment does not need the plugin: validates, nothing loaded.
  const std::string sim = "experiment: {name: p, plugin_paths: [./plugins]}\n"
                          "bench: {sensor: {plugin: sim_imu}}\nprocedure: [{record: {duration_s: 1}}]\n";
  const fs::path unused = write(dir / "unused.yaml", sim);
  ProgramOutput o = run_stend("validate " + unused.string(), env);
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_FALSE(fs::exists(marker)) << "validate ran the plugin's code";

  // The experiment needs it: an error naming the file and the flag.
  const fs::path needs = write(dir / "needs.yaml", "experiment: {name: p, plugin_paths: [./plugins]}\n"
                                                   "bench: {sensor: {plugin: test_marker}}\n"
                                                   "procedure: [{record: {duration_s: 1}}]\n");
  o = run_stend("validate " + needs.string(), env);
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(contains(o.text, needs.string() + ":2:")) << o.text;
  EXPECT_TRUE(contains(o.text, "unknown plugin 'test_marker': " + (dir / "plugins/stend_test_marker.so").string() +
                                   ": not loaded")) << o.text;
  EXPECT_TRUE(contains(o.text, "--allow-plugins")) << o.text;
  o = run_stend("run " + needs.string() + " --quiet -o " + (dir / "runs").string(), env);
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_FALSE(fs::exists(marker)) << "run ran the plugin's code";

  // Allowed (flag or environment): loaded, and recorded in the run's provenance.
  o = run_stend("validate --allow-plugins " + needs.string(), env);
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(fs::exists(marker));
  stend::testing::Environment allowed = env;
  allowed["STEND_ALLOW_PLUGINS"] = "1";
  o = run_stend("run " + needs.string() + " --quiet -o " + (dir / "runs").string() + " --name r", allowed);
  ASSERT_EQ(o.code, 0) << o.text;
  const stend::Recording rec = stend::Recording::open(dir / "runs/r", stend::SampleLoading::kStream);
  ASSERT_EQ(rec.header.plugins.size(), 1u);
  const stend::PluginUse& p = rec.header.plugins[0];
  EXPECT_EQ(p.name, "test_marker");
  EXPECT_EQ(p.file, (dir / "plugins/stend_test_marker.so").string());
  EXPECT_EQ(p.origin, "experiment");
  EXPECT_EQ(p.hash.size(), std::string("crc32:").size() + 8) << p.hash;
}

TEST(RunGuards, AMissingPluginFolderIsAnErrorAtItsEntry) {
  const TempDir dir("guards");
  const fs::path f = write(dir / "e.yaml", "experiment: {name: p, plugin_paths: [./nowhere]}\n"
                                           "bench: {sensor: {plugin: sim_imu}}\nprocedure: [{record: {duration_s: 1}}]\n");
  const ProgramOutput o = run_stend("validate " + f.string());
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(contains(o.text, f.string() + ":1:")) << o.text;
  EXPECT_TRUE(contains(o.text, "plugin path './nowhere' (" + (dir / "nowhere").string() + ") does not exist")) << o.text;
}

// --- record: false -----------------------------------------------------------------------------

// Settling with `record: false` writes no samples: the stretch is missing, the next sample is
// flagged as a gap and an event names the stretch.
TEST(RunGuards, RecordFalseWritesNoSamplesWhileSettling) {
  const TempDir dir("guards");
  const std::string steps = "  - set_temperature: {fixture: chamber, setpoint_c: 25, tolerance_c: 2, hold_s: 3, record: false}\n"
                            "  - record: {duration_s: 2}\n";
  const stend::Experiment exp = stend::parse_experiment(experiment("", steps), "rf.yaml", stend::testing::build_tree_plugins());
  const stend::RunResult r = stend::testing::run_in_process(exp, dir.path());
  ASSERT_EQ(r.status, stend::RunStatus::kComplete) << r.message;
  const stend::Recording rec = stend::Recording::open(r.dir);
  ASSERT_EQ(rec.segments.size(), 1u);
  const stend::Segment& seg = rec.segments[0];
  ASSERT_FALSE(rec.samples.empty());
  // Only the record step's samples (200 Hz × 2 s, give or take the period at its edges).
  EXPECT_NEAR(static_cast<double>(rec.samples.size()), 400.0, 2.0);
  EXPECT_GE(rec.samples.front().t_s, seg.t_start_s - 0.011);
  EXPECT_TRUE(rec.samples.front().flags & stend::kGapBefore);
  bool event = false;
  for (const auto& e : rec.events) event = event || contains(e.message, "not recorded (record: false)");
  EXPECT_TRUE(event);
}
