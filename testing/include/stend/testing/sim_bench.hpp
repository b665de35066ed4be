// Experiments run in-process, through the real runner and recording store, with this build tree's
// plugins: the simulated bench, or real drivers against their emulators.
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/core/plugin_host.hpp>
#include <stend/core/runner.hpp>

#include <filesystem>

namespace stend::testing {

// The plugins of this build tree (lib/stend/plugins), scanned once per test program. Pass it where
// an experiment is loaded or parsed: stend::parse_experiment(yaml, "x.yaml", build_tree_plugins()).
PluginHost& build_tree_plugins();

// Runs `experiment` with the build tree's plugins; the run folder goes under `output_dir`
// (options.output_dir is replaced by it).
RunResult run_in_process(const Experiment& experiment, const std::filesystem::path& output_dir,
                         RunOptions options = {});

// Loads the experiment file against the build tree's plugins and runs it as above.
RunResult run_in_process(const std::filesystem::path& experiment_file, const std::filesystem::path& output_dir,
                         RunOptions options = {});

}  // namespace stend::testing
