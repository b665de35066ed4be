// The shared test support: commands run to their end or read while running, the paths and the
// skip rule, temporary folders, and an experiment run in-process with the build tree's plugins.
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"
#include "stend/testing/sim_bench.hpp"

#include <stend/recording/recording.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

namespace fs = std::filesystem;
namespace st = stend::testing;

TEST(TestingProgram, RunCommandReturnsTheExitCodeAndBothStreams) {
  const st::ProgramOutput o = st::run_command("echo out; echo err >&2; exit 3");
  EXPECT_EQ(o.code, 3);
  EXPECT_EQ(o.text, "out\nerr\n");
  EXPECT_EQ(st::run_command("kill -9 $$").code, -1);  // ended by a signal
}

TEST(TestingProgram, EnvironmentIsAddedAndOverridesTheProcesss) {
  const st::ProgramOutput o =
      st::run_command("printf '%s|%s' \"$STEND_TESTING_VALUE\" \"$HOME\"", {{"STEND_TESTING_VALUE", "a b'c"}, {"HOME", "/nowhere"}});
  EXPECT_EQ(o.code, 0);
  EXPECT_EQ(o.text, "a b'c|/nowhere");
}

TEST(TestingProgram, ShellQuoteKeepsOneWord) {
  EXPECT_EQ(st::run_command("printf '%s' " + st::shell_quote("it's $HOME; `x`")).text, "it's $HOME; `x`");
}

TEST(TestingProgram, StartedCommandIsReadLineByLineWhileItRuns) {
  st::StartedCommand c("echo starting; echo 'listening on 127.0.0.1:4711'; echo after; exit 5");
  EXPECT_EQ(c.wait_for("127\\.0\\.0\\.1:([0-9]+)"), "4711");
  const st::ProgramOutput rest = c.finish();
  EXPECT_EQ(rest.code, 5);
  EXPECT_EQ(rest.text, "after\n");
  st::StartedCommand quiet("echo nothing to see");
  EXPECT_EQ(quiet.wait_for("port ([0-9]+)"), "");
}

// Whether process `pid` runs (exists and is not a zombie left for its new parent to reap).
bool running(const std::string& pid) {
  std::ifstream stat("/proc/" + pid + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return false;
  const auto close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && line[close + 2] != 'Z';
}

// A test that fails before it stops its server leaves the command unfinished: the destructor stops
// it and what it started (here a shell running a child that ignores nothing and would sleep 300 s)
// instead of waiting for it to end.
TEST(TestingProgram, AnUnfinishedCommandIsStoppedWithWhatItStarted) {
  const auto start = std::chrono::steady_clock::now();
  std::string child;
  {
    st::StartedCommand c("sleep 300 & echo child $!; wait");
    child = c.wait_for("child ([0-9]+)");
    ASSERT_FALSE(child.empty());
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  for (int k = 0; k < 100 && running(child); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(running(child)) << "sleep " << child << " still runs";
}

TEST(TestingProgram, RunStendRunsThisBuildsProgram) {
  const st::ProgramOutput o = st::run_stend("plugins");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("sim_imu"), std::string::npos) << o.text;
}

TEST(TestingFiles, TempDirIsFreshAndRemovedAtTheEndOfItsScope) {
  fs::path kept;
  {
    const st::TempDir a("testing"), b("testing");
    EXPECT_TRUE(fs::is_directory(a.path()));
    EXPECT_TRUE(fs::is_empty(a.path()));
    EXPECT_NE(a.path(), b.path());
    EXPECT_EQ(a.path().filename().string().rfind("stend-testing-", 0), 0u) << a.path();
    fs::create_directories(a / "sub" / "deeper");
    st::write_text(a / "sub" / "f.bin", std::string("x\0y\n", 4));
    EXPECT_EQ(st::read_text(a / "sub" / "f.bin"), std::string("x\0y\n", 4));
    kept = a.path();
  }
  EXPECT_FALSE(fs::exists(kept));
  EXPECT_EQ(st::read_text(kept / "sub" / "f.bin"), "");
}

TEST(TestingPaths, SourceProgramAndSharedData) {
  EXPECT_TRUE(fs::exists(st::source_path("CMakeLists.txt")));
  EXPECT_TRUE(fs::exists(st::stend_program()));
  EXPECT_EQ(st::shared_data("imucal/annotated_session.csv"), st::shared_data_dir() / "imucal" / "annotated_session.csv");
}

TEST(TestingPaths, WhyAbsentNamesTheMissingPath) {
  EXPECT_EQ(st::why_absent(st::source_path("CMakeLists.txt")), "");
  const fs::path missing = st::source_path("no/such/file.csv");
  EXPECT_EQ(st::why_absent(missing), "skipped: " + missing.string() + " is absent");
  const fs::path data = st::shared_data("no_such_dataset/x.csv");
  const std::string why = st::why_absent(data);
  EXPECT_EQ(why.rfind("skipped: " + data.string() + " is absent", 0), 0u) << why;
  if (!fs::is_directory(st::shared_data_dir())) {
    EXPECT_NE(why.find("no shared data folder " + st::shared_data_dir().string()), std::string::npos) << why;
  }
}

TEST(TestingSimBench, RunsAnExperimentInProcessWithTheBuildTreesPlugins) {
  const st::TempDir tmp("testing-run");
  const fs::path file = tmp / "short.yaml";
  st::write_text(file, R"(experiment: {name: testing_short, seed: 1}
bench:
  sensor: {plugin: sim_imu, config: {output_rate_hz: 100}}
procedure:
  - record: {duration_s: 2}
)");
  const stend::RunResult r = st::run_in_process(file, tmp / "runs");
  ASSERT_EQ(r.status, stend::RunStatus::kComplete) << r.message;
  EXPECT_EQ(r.dir.parent_path(), tmp / "runs");
  EXPECT_NEAR(static_cast<double>(stend::Recording::open(r.dir).samples.size()), 200.0, 2.0);
  EXPECT_NE(st::build_tree_plugins().record_of("sim_imu"), nullptr);
}
