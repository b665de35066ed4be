#include "stend/testing/sim_bench.hpp"

#include <utility>

namespace stend::testing {

PluginHost& build_tree_plugins() {
  static PluginHost host;
  static const bool scanned = [] {
    host.scan({{STEND_BUILD_PLUGIN_DIR, "build tree"}});
    return true;
  }();
  (void)scanned;
  return host;
}

RunResult run_in_process(const Experiment& experiment, const std::filesystem::path& output_dir, RunOptions options) {
  options.output_dir = output_dir;
  return run_experiment(experiment, build_tree_plugins(), options);
}

RunResult run_in_process(const std::filesystem::path& experiment_file, const std::filesystem::path& output_dir,
                         RunOptions options) {
  return run_in_process(load_experiment(experiment_file.string(), build_tree_plugins()), output_dir, std::move(options));
}

}  // namespace stend::testing
