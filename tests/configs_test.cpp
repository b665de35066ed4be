// Every shipped experiment validates completely: structure, plugin configs, and the procedure
// against the limits the simulated fixtures declare.
#include <gtest/gtest.h>

#include "stend/core/bench.hpp"
#include "stend/core/experiment.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/testing/sim_bench.hpp"

#include <filesystem>

namespace fs = std::filesystem;

TEST(Configs, EveryShippedExperimentValidates) {
  const stend::PluginHost& host = stend::testing::build_tree_plugins();
  int n = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(STEND_SOURCE_DIR) / "configs")) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    try {
      const stend::Experiment exp = stend::load_experiment(entry.path().string(), host);
      if (exp.clock == stend::ClockKind::kWall) {  // real drivers: creating the bench opens devices (stage 1 only)
        ++n;
        continue;
      }
      stend::Bench bench(exp, host);
      EXPECT_FALSE(exp.procedure.empty());
      ++n;
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
  }
  EXPECT_GE(n, 5);
}
