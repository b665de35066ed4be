// End to end: the paper's experiment on the simulated bench, through the real runner, plugins
// and recording store; then a clean stop and a SIGKILL of the stend program mid-run.
#include <gtest/gtest.h>

#include "stend/core/experiment.hpp"
#include "stend/physics/geometry.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/recording/recording.hpp"
#include "stend/core/runner.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/sim_bench.hpp"

#include <csignal>
#include <cmath>
#include <filesystem>
#include <limits>
#include <fstream>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using stend::testing::TempDir;

namespace {

double mean_over(const stend::Recording& rec, double t0, double t1, int axis) {
  double sum = 0.0;
  int n = 0;
  for (const auto& s : rec.samples)
    if (s.t_s > t0 && s.t_s <= t1) {
      sum += s.accel_mps2[axis];
      ++n;
    }
  return n ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

TEST(PaperExperiment, RunsOnSimulatedBenchAndRecordsTruth) {
  const TempDir tmp("e2e");
  const stend::RunResult r =
      stend::testing::run_in_process(stend::testing::source_path("configs/paper_mpu6050_z.yaml"), tmp.path());
  ASSERT_EQ(r.status, stend::RunStatus::kComplete) << r.message;
  EXPECT_GT(r.run_time_s / r.wall_time_s, 20.0) << "the simulated clock should run far faster than real time";

  const stend::Recording rec = stend::Recording::open(r.dir);
  EXPECT_TRUE(rec.complete());
  EXPECT_EQ(rec.header.identity.model, "MPU-6050");
  EXPECT_NEAR(rec.header.gravity_mps2, stend::physics::normal_gravity(47.21, 40), 1e-9);

  std::vector<stend::Segment> orient;
  for (const auto& s : rec.segments)
    if (s.kind == stend::SegmentKind::kOrientation) orient.push_back(s);
  ASSERT_EQ(orient.size(), 23u);

  const int fx = rec.truth_column("f_x_mps2"), fy = rec.truth_column("f_y_mps2"), fz = rec.truth_column("f_z_mps2");
  const int die = rec.truth_column("die_c");
  ASSERT_GE(fx, 0);
  ASSERT_GE(die, 0);
  const double g = rec.header.gravity_mps2;
  // The sensor's configured Z-row truth (configs/paper_mpu6050_z.yaml).
  const double bz = 0.027, sz = 0.0007, mzx = 0.0055, mzy = 0.0002;
  for (std::size_t k = 0; k < orient.size(); ++k) {
    const auto& seg = orient[k];
    EXPECT_EQ(seg.orientation, static_cast<int>(k));
    EXPECT_TRUE(seg.settled) << "segment " << k;
    EXPECT_GE(seg.t_end_s - seg.t_start_s, 10.0 - 1e-6);
    const double delta = 2.0 * static_cast<double>(k) * stend::physics::kDegToRad;
    // Bench truth inside the segment: gravity through the paper's direction cosines (h = 0).
    for (std::size_t i = 0; i < rec.truth_t.size(); ++i) {
      if (rec.truth_t[i] <= seg.t_start_s || rec.truth_t[i] > seg.t_end_s) continue;
      EXPECT_NEAR(rec.truth[i][static_cast<std::size_t>(fx)], -g * std::sin(delta), 1e-3);
      EXPECT_NEAR(rec.truth[i][static_cast<std::size_t>(fy)], 0.0, 1e-3);
      EXPECT_NEAR(rec.truth[i][static_cast<std::size_t>(fz)], g * std::cos(delta), 1e-3);
      EXPECT_NEAR(rec.truth[i][static_cast<std::size_t>(die)], 25.0, 1.5);
    }
    // The recorded Z channel matches the error model the simulated sensor carries.
    const double f_x = -g * std::sin(delta), f_z = g * std::cos(delta);
    const double expected = f_z + bz + sz * f_z + mzx * f_x + mzy * 0.0;
    EXPECT_NEAR(mean_over(rec, seg.t_start_s, seg.t_end_s, 2), expected, 0.01) << "orientation " << k;
  }
}

TEST(PaperExperiment, StopRequestKeepsDataAndMarksRunInterrupted) {
  const TempDir tmp("e2e");
  std::atomic<bool> stop{false};
  stend::RunOptions opt;
  opt.stop = &stop;
  opt.progress_period_s = 0.0;
  opt.on_progress = [&](const stend::RunProgress& p) {
    if (p.step_kind == stend::Step::Kind::kOrientations && p.item >= 5 && p.phase == stend::RunPhase::kRecording) stop = true;
  };
  const stend::RunResult r =
      stend::testing::run_in_process(stend::testing::source_path("configs/paper_mpu6050_z.yaml"), tmp.path(), opt);
  EXPECT_EQ(r.status, stend::RunStatus::kInterrupted);
  const stend::Recording rec = stend::Recording::open(r.dir);
  EXPECT_EQ(rec.header.status, stend::RunStatus::kInterrupted);
  EXPECT_FALSE(rec.complete());
  EXPECT_EQ(rec.samples.size(), r.samples);
  ASSERT_FALSE(rec.segments.empty());
  EXPECT_FALSE(rec.segments.back().complete);
  int orientations = 0;
  for (const auto& s : rec.segments) orientations += s.kind == stend::SegmentKind::kOrientation && s.complete;
  EXPECT_EQ(orientations, 4);
}

TEST(PaperExperiment, KilledStendProgramLeavesReadableRecording) {
  const fs::path stend_bin = stend::testing::stend_program();
  if (!fs::exists(stend_bin)) GTEST_SKIP() << "stend program not built at " << stend_bin;
  const TempDir tmp("e2e");
  // Ten simulated hours at 1 kHz: far longer than the test waits.
  const fs::path file = tmp / "long.yaml";
  std::ofstream(file) << R"(experiment: {name: long_kill}
bench:
  sensor: {plugin: sim_imu, config: {output_rate_hz: 1000}}
  fixtures: [{id: table, plugin: sim_one_axis_table}]
procedure:
  - record: {duration_s: 36000}
)";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string out = (tmp / "runs").string();
    execl(stend_bin.c_str(), "stend", "run", file.c_str(), "--output", out.c_str(), "--name", "killed", "--quiet",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  const fs::path store = tmp / "runs" / "killed" / "run.h5";  // flushed each second of wall time
  for (int i = 0; i < 200 && (!fs::exists(store) || fs::file_size(store) < 100000); ++i) usleep(20000);
  usleep(1300000);  // past the first flush (each second of wall time)
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));

  const stend::Recording rec = stend::Recording::open(tmp / "runs" / "killed");
  EXPECT_EQ(rec.header.status, stend::RunStatus::kRunning);  // the writer never finished: readers call it incomplete
  EXPECT_FALSE(rec.complete());
  ASSERT_GT(rec.samples.size(), 1000u);
  for (std::size_t i = 1; i < rec.samples.size(); ++i) ASSERT_GT(rec.samples[i].t_s, rec.samples[i - 1].t_s);
}
