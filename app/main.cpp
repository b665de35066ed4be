// stend — drive a characterization bench from an experiment file and analyse its recordings.
#include "commands.hpp"

#include "stend/estimators/builtin.hpp"
#include "stend/experiment.hpp"
#include "stend/plugin_host.hpp"
#include "stend/recording.hpp"
#include "stend/runner.hpp"
#include "stend/version.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <atomic>
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
using stend::cli::fit_recording;

extern "C" void on_sigint(int) {
  if (g_stop.load()) {  // second Ctrl-C: stop now
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
  }
  g_stop.store(true);
}

std::string fmt_duration(double s) {
  if (!std::isfinite(s)) return "?";
  const long t = static_cast<long>(s + 0.5);
  if (t >= 3600) return fmt::format("{}h{:02}m{:02}s", t / 3600, (t / 60) % 60, t % 60);
  if (t >= 60) return fmt::format("{}m{:02}s", t / 60, t % 60);
  return fmt::format("{}s", t);
}

// Loads plugins from the default search path. The experiment's own plugin_paths (read before full
// validation so that its plugins are known while validating it) are loaded only when the user
// allows it (--allow-plugins or STEND_ALLOW_PLUGINS=1, docs/plugins.md); otherwise their files
// are listed as not loaded and no code of theirs runs.
void scan_plugins(stend::PluginHost& host, const std::vector<std::string>& extra, bool allow_extra) {
  if (const char* env = std::getenv("STEND_ALLOW_PLUGINS")) allow_extra = allow_extra || std::string(env) == "1";
  if (allow_extra) return host.scan(stend::PluginHost::default_search_path(extra));
  host.scan(stend::PluginHost::default_search_path());
  std::vector<stend::SearchDir> unvetted;
  for (const auto& dir : extra) unvetted.push_back({dir, "experiment"});
  host.list_unloaded(unvetted, "not loaded: plugin folders named by an experiment file are loaded only with "
                               "--allow-plugins (or STEND_ALLOW_PLUGINS=1)");
}

ExitCode cmd_plugins(const std::vector<std::string>& paths) {
  stend::PluginHost host;
  scan_plugins(host, paths, true);  // folders the user named on the command line
  std::cout << host.describe();
  return ExitCode::kOk;
}

ExitCode cmd_validate(const std::string& file, bool allow_plugins) {
  stend::PluginHost host;
  scan_plugins(host, stend::experiment_plugin_paths(file), allow_plugins);
  const stend::Experiment exp = stend::load_experiment(file, host);
  stend::Bench bench(exp, host);  // stage 2: procedure against the fixtures' declared limits
  const stend::RunEstimate estimate = stend::estimate_run(exp, bench, {});
  stend::check_run_limits(exp, estimate, exp.outputs.directory);
  std::size_t orientations = 0;
  for (const auto& s : exp.procedure) orientations += s.orientations.size();
  fmt::print("{}: ok — experiment '{}', sensor {}, {} fixture(s), {} step(s), {} orientation(s), g = {:.6f} m/s^2; {}\n",
             file, exp.name, exp.sensor.plugin, exp.fixtures.size(), exp.procedure.size(), orientations,
             exp.gravity.resolved_mps2, estimate.str());
  return ExitCode::kOk;
}

void print_progress(const stend::RunProgress& p, bool tty) {
  std::string item = p.item_count > 0 ? fmt::format(" {} {}/{}", p.step_kind == "rates" ? "rate" : "orientation", p.item, p.item_count) : "";
  std::string temp = std::isfinite(p.air_c) ? fmt::format(" | air {:.2f} °C die {:.2f} °C", p.air_c, p.die_c) : "";
  std::string line = fmt::format("step {}/{} {}{} [{}] | t {} | ~{} left{} | {} samples", p.step, p.step_count,
                                 p.step_kind, item, p.phase, fmt_duration(p.run_time_s), fmt_duration(p.time_left_s()),
                                 temp, p.samples);
  if (tty) fmt::print(stderr, "\r\033[K{}", line);
  else fmt::print(stderr, "{}\n", line);
  std::fflush(stderr);
}

ExitCode cmd_run(const std::string& file, const std::string& output, const std::string& name, const std::string& clock,
                 const std::string& store, const std::string& db, bool quiet, bool allow_plugins) {
  stend::PluginHost host;
  scan_plugins(host, stend::experiment_plugin_paths(file), allow_plugins);
  const stend::Experiment exp = stend::load_experiment(file, host);

  stend::RunOptions opt;
  opt.output_dir = output;
  opt.run_name = name;
  opt.clock = clock;
  opt.store.format = *stend::recording_format_from_string(store);  // checked by the option
  opt.stop = &g_stop;
  const bool tty = isatty(STDERR_FILENO) != 0;
  if (!quiet) {
    opt.progress_period_s = tty ? 0.2 : 5.0;
    opt.on_progress = [tty](const stend::RunProgress& p) { print_progress(p, tty); };
  }
  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_sigint);
  const stend::RunResult r = stend::run_experiment(exp, host, opt);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (!quiet && tty) fmt::print(stderr, "\n");

  fmt::print("run folder: {}\n", r.dir.string());
  fmt::print("status:     {}{}\n", stend::to_string(r.status), r.message.empty() ? "" : " — " + r.message);
  fmt::print("recorded:   {} samples, {} segments, {} of run time in {:.2f} s wall ({:.0f}x real time)\n", r.samples,
             r.segments, fmt_duration(r.run_time_s), r.wall_time_s, r.wall_time_s > 0 ? r.run_time_s / r.wall_time_s : 0.0);
  for (const std::string& why : r.unsafe)
    fmt::print(stderr, "error: safe state NOT confirmed, check the bench by hand: {}\n", why);
  if (!r.unsafe.empty()) return ExitCode::kIoFailure;
  if (r.status != stend::RunStatus::kComplete)
    return r.status == stend::RunStatus::kInterrupted ? ExitCode::kStopped : ExitCode::kIoFailure;
  if (exp.estimation && exp.estimation["model"]) {
    // The experiment names its model: fit it now, relative paths from the experiment's folder.
    std::filesystem::path model = exp.estimation["model"].as<std::string>();
    if (model.is_relative()) model = std::filesystem::path(file).parent_path() / model;
    fmt::print("\n");
    if (!fit_recording(stend::Recording::open(r.dir, stend::SampleLoading::kStream), model.string(), r.dir, ""))
      return ExitCode::kFitFailed;
  }
  fmt::print("report:     {}\n", stend::cli::write_run_report(r.dir, db).string());
  return ExitCode::kOk;
}

ExitCode cmd_fit(const stend::cli::DatasetArgs& data, const std::string& model, const std::string& json,
            const std::string& estimator, const std::string& db) {
  // A run opened for an estimator that needs no bench truth (allan) leaves the truth in the store.
  const stend::Recording rec =
      data.is_run() && !stend::cli::fit_reads_truth(model, estimator)
          ? stend::Recording::open(data.inputs[0], stend::SampleLoading::kStream, stend::TruthLoading::kSkip)
          : data.open();
  const bool ok = fit_recording(data.checked(rec), model,
                                data.is_run() ? std::filesystem::path(data.inputs[0]) : std::filesystem::path(), json,
                                estimator);
  // With --db the run is recorded in the store as it now stands (a failed fit: its status, no numbers).
  if (!db.empty() && data.is_run() && json.empty()) stend::cli::record_in_store(data.inputs[0], db);
  return ok ? ExitCode::kOk : ExitCode::kFitFailed;
}

ExitCode cmd_info(const std::string& dir) {
  // Header, extents and the first and last samples only: no scan of the samples.
  const stend::Recording rec =
      stend::Recording::open(dir, stend::SampleLoading::kStream, stend::TruthLoading::kSkip);
  const auto& h = rec.header;
  fmt::print("recording:  {} ({})\nexperiment: {} (stend {})\nstatus:     {}{}\n", rec.dir.string(),
             stend::to_string(rec.format), h.experiment_name, h.stend_version, stend::to_string(h.status),
             rec.complete() ? "" : " (incomplete)");
  fmt::print("sensor:     {} {} serial '{}' WHO_AM_I {} at {} Hz\n", h.identity.vendor, h.identity.model,
             h.identity.serial, h.identity.who_am_i, h.info.output_rate_hz);
  fmt::print("gravity:    {:.6f} m/s^2; clock {}; seed {}\n", h.gravity_mps2, h.clock, h.seed);
  const auto& src = rec.sample_source();
  const std::uint64_t n = src.size();
  fmt::print("data:       {} samples", n);
  if (n > 0) {
    stend::ImuSample first, last;
    src.read(0, 1, &first);
    src.read(n - 1, 1, &last);
    fmt::print(" from {:.3f} s to {:.3f} s", first.t_s, last.t_s);
  }
  if (rec.gap_count >= 0) fmt::print(", {} gaps", rec.gap_count);
  fmt::print(", {} truth rows, {} segments, {} events\n", rec.truth_rows, rec.segments.size(), rec.events.size());
  if (!rec.damage.empty())
    fmt::print("damaged:    {} of {} samples are readable: {}\n", n, rec.written_samples, rec.damage);
  for (const auto& s : rec.segments)
    fmt::print("  #{:<3} {:<15} {:>7.2f}–{:<8.2f} s {}{}{}  {}\n", s.id, stend::to_string(s.kind), s.t_start_s, s.t_end_s,
               s.settled ? "" : "[unsettled] ", s.complete ? "" : "[incomplete] ", s.label, s.targets);
  for (const auto& e : rec.events) fmt::print("  event {:.3f} s {} {}: {}\n", e.t_s, e.level, e.source, e.message);
  return ExitCode::kOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"stend — characterize MEMS inertial sensors on a lab bench"};
  app.set_version_flag("--version", std::string("stend ") + stend::version());
  app.require_subcommand(1);

  std::vector<std::string> plugin_paths;
  auto* plugins = app.add_subcommand("plugins", "List the plugins found on the search path and why any file was refused");
  plugins->add_option("--path", plugin_paths, "Extra plugin directory (searched first)");

  std::string file;
  auto* validate = app.add_subcommand("validate", "Check an experiment file without running it");
  validate->add_option("experiment", file, "Experiment YAML")->required();
  bool allow_plugins = false;
  const std::string allow_help = "Load the plugin folders the experiment's plugin_paths name (their code runs); "
                                 "also STEND_ALLOW_PLUGINS=1";
  validate->add_flag("--allow-plugins", allow_plugins, allow_help);

  std::string output, name, clock, store = "hdf5";
  bool quiet = false;
  auto* run = app.add_subcommand("run", "Run an experiment and record it");
  run->add_option("experiment", file, "Experiment YAML")->required();
  run->add_option("-o,--output", output, "Folder for run folders (default: the experiment's outputs.directory)");
  run->add_option("--name", name, "Run folder name (default: <experiment>-<UTC time>)")
      ->check([](const std::string& given) {  // a name, not a path: refused as a usage error
        try {
          stend::check_run_name(given);
          return std::string();
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
      });
  run->add_option("--clock", clock, "Override the clock")->check(CLI::IsMember({"simulated", "wall"}));
  run->add_option("--store", store, "How the run folder stores its data: hdf5 (run.h5, default) or csv (the CSV files)")
      ->check(CLI::IsMember({"hdf5", "csv"}));
  std::string db;
  run->add_option("--db", db, stend::cli::kDbOptionHelp);
  run->add_flag("-q,--quiet", quiet, "No progress display");
  run->add_flag("--allow-plugins", allow_plugins, allow_help);

  std::string dir;
  auto* info = app.add_subcommand("info", "Summarize a recording (run folder)");
  info->add_option("run", dir, "Run folder")->required();

  std::string model, json;
  stend::cli::DatasetArgs fit_data;
  auto* fit = app.add_subcommand("fit", "Fit an error model (or the Allan noise model) to a recording or dataset");
  fit_data.add_to(fit);
  fit_data.add_accept_damaged(fit);
  fit->add_option("-m,--model", model, "Model YAML (instrument, axes, terms, extraction)")->required();
  std::string estimator = "auto";
  fit->add_option("--estimator", estimator,
                  "auto (the one the model file is written for) | " + stend::estimators::builtin().names() +
                      " | the name of an estimator plugin on the search path");
  fit->add_option("--json", json, "Where to write the results (default RUN/fit.json)");
  fit->add_option("--db", db, std::string(stend::cli::kDbOptionHelp) +
                                  "; given, a run folder fitted is recorded there (its results as they now stand)");

  std::vector<stend::cli::Command> commands;
  stend::cli::add_gap_command(app, commands);
  stend::cli::add_report_command(app, commands);
  stend::cli::add_compare_command(app, commands);
  stend::cli::add_export_command(app, commands);
  stend::cli::add_emulate_command(app, commands);
  stend::cli::add_import_command(app, commands);
  stend::cli::add_apply_command(app, commands);
  stend::cli::add_db_command(app, commands);
  stend::cli::add_batch_command(app, commands);

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
      if (*run) return cmd_run(file, output, name, clock, store, db, quiet, allow_plugins);
      if (*info) return cmd_info(dir);
      if (*fit) return cmd_fit(fit_data, model, json, estimator, db);
    } catch (...) {
      return stend::cli::exit_code_of_current_exception();
    }
    return ExitCode::kOk;
  }());
}
