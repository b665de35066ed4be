// The time left that `stend run` shows (ProcedureEta through the runner) on the shipped temperature
// sweep, on the simulated clock's schedule: at 25 %, 50 % and 75 % of the run its error is at most
// 10 % of the time actually left, and the run ends with nothing left.
#include "stend/core/runner.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/sim_bench.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace {

// Drops the records: the test needs the schedule, not the data.
class NullSink final : public stend::RunSink {
 public:
  void add_samples(const stend::ImuSample*, std::size_t) override {}
  void add_truth(double, const std::vector<double>&) override {}
  void add_segment(const stend::Segment&) override {}
  void add_event(const stend::Event&) override {}
  void tick(double) override {}
  void finish(stend::RunStatus, const std::string&) override {}
};

struct Point {
  double t_s, remaining_s;
};

}  // namespace

TEST(EtaSweep, TimeLeftWithinTenPercentAtQuarterHalfAndThreeQuarters) {
  const auto file = stend::testing::source_path("configs/temperature_sweep.yaml");
  const stend::Experiment exp = stend::load_experiment(file.string(), stend::testing::build_tree_plugins());
  std::vector<Point> seen;
  stend::RunPhase last_phase = stend::RunPhase::kNone;
  double last_remaining = -1.0;
  stend::RunOptions opt;
  opt.clock = stend::ClockKind::kSimulated;
  opt.progress_period_s = 0.0;  // every control period: the schedule in run time, not wall time
  opt.on_progress = [&](const stend::RunProgress& p) {
    if (seen.empty() || p.run_time_s - seen.back().t_s >= 1.0) seen.push_back({p.run_time_s, p.remaining_s});
    last_phase = p.phase;
    last_remaining = p.remaining_s;
  };
  NullSink sink;
  const stend::RunResult r = stend::run_experiment_to(exp, stend::testing::build_tree_plugins(), opt, sink);
  ASSERT_EQ(r.status, stend::RunStatus::kComplete) << r.message;
  EXPECT_EQ(last_phase, stend::RunPhase::kDone);
  EXPECT_EQ(last_remaining, 0.0);
  const double total = r.run_time_s;
  ASSERT_GT(total, 3600.0) << "the sweep is expected to take hours of run time";
  for (const double f : {0.25, 0.5, 0.75}) {
    const Point* at = nullptr;
    for (const Point& p : seen)
      if (p.t_s >= f * total) {
        at = &p;
        break;
      }
    ASSERT_NE(at, nullptr);
    const double truly_left = total - at->t_s;
    std::printf("at %2.0f %%: run time %6.0f s, estimated %6.0f s left, truly %6.0f s (error %+.1f %%)\n", f * 100,
                at->t_s, at->remaining_s, truly_left, 100.0 * (at->remaining_s - truly_left) / truly_left);
    EXPECT_LE(std::abs(at->remaining_s - truly_left), 0.1 * truly_left)
        << "at " << f * 100 << " % (run time " << at->t_s << " s of " << total << " s): estimated "
        << at->remaining_s << " s left, truly " << truly_left << " s";
  }
}
