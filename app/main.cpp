// stend — drive a characterization bench from an experiment file and analyse its recordings.
#include "commands.hpp"
#include "live_view.hpp"
#include "progress.hpp"

#include "stend/estimators/builtin.hpp"
#include "stend/core/experiment.hpp"
#include "stend/core/memory.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/recording/recording.hpp"
#include "stend/core/runner.hpp"
#include "stend/recording/version.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <optional>
#include <fstream>
#include <sstream>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <unistd.h>

namespace {

std::atomic<bool> g_stop{false};

using stend::cli::ExitCode;
using stend::cli::human;
using stend::cli::scan_plugins;
using nlohmann::json;

const char* kind_name(long kind) {
  switch (kind) {
    case STEND_KIND_SENSOR: return "sensor";
    case STEND_KIND_FIXTURE: return "fixture";
    case STEND_KIND_ESTIMATOR: return "estimator";
    default: return "unknown";
  }
}

// docs/schemas/plugins.schema.json
json plugins_json(const stend::PluginHost& host) {
  json j;
  j["search_path"] = json::array();
  for (const auto& d : host.search_path()) j["search_path"].push_back({{"path", d.path}, {"origin", d.origin}});
  j["plugins"] = json::array();
  for (const auto& r : host.records()) {
    json p = {{"file", r.file}, {"origin", r.origin}, {"loaded", r.info != nullptr && r.refusal.empty()}};
    if (r.info != nullptr) {
      p["name"] = r.info->name;
      p["version"] = r.info->version;
      p["kind"] = kind_name(static_cast<long>(r.info->kind));
      p["description"] = r.info->description != nullptr ? r.info->description : "";
    }
    if (!r.refusal.empty()) p["refusal"] = r.refusal;
    if (!r.shadowed_by.empty()) p["shadowed_by"] = r.shadowed_by;
    j["plugins"].push_back(std::move(p));
  }
  return j;
}

extern "C" void on_sigint(int) {
  if (g_stop.load()) {  // second Ctrl-C: stop now
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
  }
  g_stop.store(true);
}

// `stend run`: the progress line (a terminal only, unless --quiet) and the live view (--live) share
// the runner's progress reports; Ctrl-C stops the run cleanly.
ExitCode cmd_run(const stend::cli::RunArgs& args, bool quiet, const stend::cli::LiveArgs& live_args) {
  stend::cli::StatusLine status;
  std::optional<stend::cli::LiveRun> live;
  const bool show = !quiet && status.enabled();
  stend::cli::RunHooks hooks;
  hooks.stop = &g_stop;
  hooks.on_loaded = [&](const stend::Experiment& exp) {
    live.emplace(live_args, exp.name);
    std::signal(SIGINT, on_sigint);  // from here Ctrl-C stops the run cleanly
    std::signal(SIGTERM, on_sigint);
  };
  if (show || live_args.live)
    hooks.on_progress = [&](const stend::RunProgress& p) {
      if (show) status.show(stend::cli::run_progress_line(p, stend::cli::terminal_columns()));
      if (live) live->update(p);
    };
  hooks.on_finished = [&](const stend::RunResult& r) {
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    status.keep();  // the final line stays: "100% | done | …"
    if (live) live->finish(r.status, r.message);
  };
  const stend::cli::Outcome o = stend::cli::run_run(args, hooks);
  stend::cli::print_json(o.doc);
  return o.code;
}

ExitCode cmd_plugins(const std::vector<std::string>& paths) {
  stend::PluginHost host;
  scan_plugins(host, paths, true);  // folders the user named on the command line
  fmt::print(human(), "{}", host.describe());
  stend::cli::print_json(plugins_json(host));
  return ExitCode::kOk;
}

// A file with no sensor: the procedure of a recording made elsewhere (stend import --experiment).
ExitCode validated_procedure(const stend::Experiment& exp) {
  fmt::print(human(), "{}: ok — procedure '{}' for a recording made elsewhere, {} step(s), g = {:.6f} m/s^2; "
                      "give it to `stend import LOG --experiment {} -o RUN`\n",
             exp.file, exp.name, exp.procedure.size(), exp.gravity.resolved_mps2, exp.file);
  stend::cli::print_json({{"file", exp.file},
                          {"ok", true},
                          {"experiment", exp.name},
                          {"procedure_only", true},
                          {"steps", exp.procedure.size()},
                          {"gravity_mps2", exp.gravity.resolved_mps2}});
  return ExitCode::kOk;
}

ExitCode cmd_validate(const std::string& file, bool allow_plugins) {
  stend::PluginHost host;
  scan_plugins(host, stend::experiment_plugin_paths(file), allow_plugins);
  const stend::Experiment exp = stend::load_experiment(file, host);
  stend::cli::check_analysis(file);
  if (exp.sensor.plugin.empty()) return validated_procedure(exp);
  stend::Bench bench(exp, host);  // stage 2: procedure against the fixtures' declared limits
  const stend::RunEstimate estimate = stend::estimate_run(exp, bench, {});
  stend::check_run_limits(exp, estimate, exp.outputs.directory);
  std::size_t orientations = 0;
  for (const auto& s : exp.procedure) orientations += s.orientations.size();
  fmt::print(human(), "{}: ok — experiment '{}', sensor {}, {} fixture(s), {} step(s), {} orientation(s), g = {:.6f} m/s^2; {}\n",
             file, exp.name, exp.sensor.plugin, exp.fixtures.size(), exp.procedure.size(), orientations,
             exp.gravity.resolved_mps2, estimate.str());
  json fixtures = json::array();
  for (const auto& f : exp.fixtures) fixtures.push_back(f.plugin);
  stend::cli::print_json({{"file", file},
                          {"ok", true},
                          {"experiment", exp.name},
                          {"sensor", exp.sensor.plugin},
                          {"fixtures", fixtures},
                          {"steps", exp.procedure.size()},
                          {"orientations", orientations},
                          {"gravity_mps2", exp.gravity.resolved_mps2},
                          {"estimate", {{"run_time_s", estimate.run_time_s},
                                        {"samples", estimate.samples},
                                        {"bytes", estimate.bytes},
                                        {"store", stend::to_string(estimate.format)}}}});
  return ExitCode::kOk;
}

// A command's --json document printed; its exit code.
ExitCode printed(const stend::cli::Outcome& o) {
  stend::cli::print_json(o.doc);
  return o.code;
}

// `stend --version`: the version and where plugins are found.
std::string version_text() {
  std::string text = std::string("stend ") + stend::version() + "\nplugins searched, first wins (docs/plugins.md):\n" +
                     stend::PluginHost::describe_search_path(stend::PluginHost::default_search_path());
  if (!text.empty() && text.back() == '\n') text.pop_back();  // CLI11 ends the line
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  stend::keep_freed_memory();  // a command's passes reuse their buffers' pages (stend/core/memory.hpp)
  CLI::App app{"stend — characterize MEMS inertial sensors on a lab bench"};
  app.set_version_flag("--version", version_text);
  app.require_subcommand(1);

  std::vector<std::string> plugin_paths;
  auto* plugins = app.add_subcommand("plugins", "List the plugins found on the search path and why any file was refused");
  plugins->add_option("--path", plugin_paths, "Extra plugin directory (searched first)");
  stend::cli::add_json_flag(plugins, "the search path and every plugin file");

  std::string file;
  auto* validate = app.add_subcommand("validate", "Check an experiment file without running it");
  validate->add_option("experiment", file, "Experiment YAML")->required();
  bool allow_plugins = false;
  const std::string allow_help = "Load the plugin folders the experiment's plugin_paths name (their code runs); "
                                 "also STEND_ALLOW_PLUGINS=1";
  validate->add_flag("--allow-plugins", allow_plugins, allow_help);
  stend::cli::add_json_flag(validate, "what was checked");

  stend::cli::RunArgs run_args;
  bool quiet = false;
  auto* run = app.add_subcommand("run", "Run an experiment and record it");
  run->add_option("experiment", run_args.file, "Experiment YAML")->required();
  run->add_option("-o,--output", run_args.output, "Folder for run folders (default: the experiment's outputs.directory)");
  run->add_option("--name", run_args.name, "Run folder name (default: <experiment>-<UTC time>)")
      ->check([](const std::string& given) {  // a name, not a path: refused as a usage error
        try {
          stend::check_run_name(given);
          return std::string();
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
      });
  run->add_option("--clock", run_args.clock, "Override the clock")->check(CLI::IsMember({"simulated", "wall"}));
  run->add_option("--store", run_args.store, "How the run folder stores its data: hdf5 (run.h5, default) or csv (the CSV files)")
      ->check(CLI::IsMember({"hdf5", "csv"}));
  run->add_option("--db", run_args.db, stend::cli::kDbOptionHelp);
  run->add_flag("-q,--quiet", quiet, "No progress display");
  run->add_flag("--allow-plugins", run_args.allow_plugins, allow_help);
  stend::cli::LiveArgs live_args;
  live_args.add_to(run, true);
  stend::cli::add_json_flag(run, "the run's summary (folder, status, fit, report)");

  std::string dir;
  auto* info = app.add_subcommand("info", "Summarize a recording (run folder)");
  info->add_option("run", dir, "Run folder")->required();
  stend::cli::add_json_flag(info, "the recording's summary");

  stend::cli::FitArgs fit_args;
  auto* fit = app.add_subcommand("fit", "Fit an error model (or the Allan noise model) to a recording or dataset");
  fit_args.data.add_to(fit);
  fit_args.data.add_accept_damaged(fit);
  fit->add_option("-m,--model", fit_args.model, "Model YAML (instrument, axes, terms, extraction)")->required();
  fit->add_option("--estimator", fit_args.estimator,
                  "auto (the one the model file is written for) | " + stend::estimators::builtin().names() +
                      " | the name of an estimator plugin on the search path");
  fit->add_option("-o,--out", fit_args.out,
                  "Where to write the results (default: the estimator's results file in the run folder, e.g. "
                  "RUN/fit.json, RUN/temp_poly-gyroscope.json; a dataset file's are written only with --out)");
  stend::cli::add_json_flag(fit, "the fit's outcome and results document");
  fit->add_option("--db", fit_args.db, std::string(stend::cli::kDbOptionHelp) +
                                  "; the run folder fitted is recorded there with its refreshed report");

  std::vector<stend::cli::Command> commands;
  stend::cli::add_gap_command(app, commands);
  stend::cli::add_report_command(app, commands);
  stend::cli::add_compare_command(app, commands);
  stend::cli::add_export_command(app, commands);
  stend::cli::add_emulate_command(app, commands);
  stend::cli::add_import_command(app, commands);
  stend::cli::add_apply_command(app, commands);
  stend::cli::add_watch_command(app, commands);
  stend::cli::add_db_command(app, commands);
  stend::cli::add_batch_command(app, commands);
  stend::cli::add_deviations_command(app, commands);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end here too (exit code 0 from CLI11); every other parse error is usage.
    return app.exit(e) == 0 ? to_int(ExitCode::kOk) : to_int(ExitCode::kUsage);
  }
  return to_int([&] {
    try {
      for (const auto& c : commands)
        if (*c.sub) return c.run();
      if (*plugins) return cmd_plugins(plugin_paths);
      if (*validate) return cmd_validate(file, allow_plugins);
      if (*run) return cmd_run(run_args, quiet, live_args);
      if (*info) return printed(stend::cli::run_info(dir));
      if (*fit) {
        const stend::cli::FitCommandOutcome o = stend::cli::run_fit(fit_args);
        stend::cli::print_json(o.doc);
        return o.fit.exit_code();
      }
    } catch (...) {
      return stend::cli::exit_code_of_current_exception();
    }
    return ExitCode::kOk;
  }());
}
