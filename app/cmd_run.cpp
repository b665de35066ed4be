// `stend run EXPERIMENT`: the experiment on its bench (real or simulated), recorded into a new run
// folder, its model fitted when the experiment names one, and the run's report written.
#include "commands.hpp"
#include "progress.hpp"

#include "stend/core/experiment.hpp"
#include "stend/errors.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <sys/stat.h>

namespace stend::cli {

using nlohmann::json;

// Loads plugins from the default search path. The experiment's own plugin_paths (read before full
// validation so that its plugins are known while validating it) are loaded only when the user
// allows it (--allow-plugins or STEND_ALLOW_PLUGINS=1, docs/plugins.md); otherwise their files
// are listed as not loaded and no code of theirs runs.
namespace {

// What makes a loaded plugin's code replaceable by any user of the machine: the file or its
// folder world-writable (a sticky folder such as /tmp still lets anyone add a plugin beside it).
// Empty when neither is.
std::string writable_by_others(const std::string& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) == 0 && (st.st_mode & S_IWOTH) != 0)
    return fmt::format("{}: the plugin file is world-writable: anyone on this machine can replace the code stend "
                       "runs (chmod o-w {})", file, file);
  const std::string dir = std::filesystem::path(file).parent_path().string();
  if (::stat(dir.empty() ? "." : dir.c_str(), &st) == 0 && (st.st_mode & S_IWOTH) != 0)
    return fmt::format("{}: its folder {} is world-writable: anyone on this machine can put code there that stend "
                       "loads (chmod o-w {}, or keep plugins in a folder only you can write)", file, dir, dir);
  return {};
}

// Says on stderr, for every plugin loaded, when anyone could have replaced it (docs/plugins.md).
void warn_of_writable_plugins(const stend::PluginHost& host) {
  for (const auto& r : host.records())
    if (r.info != nullptr)
      if (const std::string why = writable_by_others(r.file); !why.empty()) fmt::print(stderr, "warning: {}\n", why);
}

}  // namespace

void scan_plugins(PluginHost& host, const std::vector<std::string>& extra, bool allow_extra) {
  if (const char* env = std::getenv("STEND_ALLOW_PLUGINS")) allow_extra = allow_extra || std::string(env) == "1";
  if (allow_extra) {
    host.scan(stend::PluginHost::default_search_path(extra));
    return warn_of_writable_plugins(host);
  }
  host.scan(stend::PluginHost::default_search_path());
  std::vector<stend::SearchDir> unvetted;
  for (const auto& dir : extra) unvetted.push_back({dir, "experiment"});
  host.list_unloaded(unvetted, "not loaded: plugin folders named by an experiment file are loaded only with "
                               "--allow-plugins (or STEND_ALLOW_PLUGINS=1)");
  warn_of_writable_plugins(host);
}

Outcome run_run(const RunArgs& a, const RunHooks& hooks) {
  const std::string& file = a.file;
  stend::PluginHost host;
  scan_plugins(host, stend::experiment_plugin_paths(file), a.allow_plugins);
  const stend::Experiment exp = stend::load_experiment(file, host);
  check_analysis(file);  // the fit's checks, before the bench moves
  if (hooks.on_loaded) hooks.on_loaded(exp);

  stend::RunOptions opt;
  opt.output_dir = a.output;
  opt.run_name = a.name;
  if (!a.clock.empty()) opt.clock = stend::clock_kind_from_string(a.clock);  // checked by the option
  const auto format = stend::recording_format_from_string(a.store);
  if (!format) throw Refusal(ExitCode::kUsage, "--store: '" + a.store + "' is not a store (hdf5 | csv)");
  opt.store.format = *format;
  opt.stop = hooks.stop;
  if (hooks.on_progress) {
    opt.progress_period_s = hooks.period_s;
    opt.on_progress = hooks.on_progress;
  }
  const stend::RunResult r = stend::run_experiment(exp, host, opt);
  if (hooks.on_finished) hooks.on_finished(r);

  fmt::print(human(), "run folder: {}\n", r.dir.string());
  fmt::print(human(), "status:     {}{}\n", stend::to_string(r.status), r.message.empty() ? "" : " — " + r.message);
  fmt::print(human(), "recorded:   {} samples, {} segments, {} of run time in {:.2f} s wall ({:.0f}x real time)\n", r.samples,
             r.segments, fmt_duration(r.run_time_s), r.wall_time_s, r.wall_time_s > 0 ? r.run_time_s / r.wall_time_s : 0.0);
  for (const std::string& why : r.unsafe)
    fmt::print(stderr, "error: safe state NOT confirmed, check the bench by hand: {}\n", why);
  // docs/schemas/run.schema.json
  json summary = {{"run_dir", r.dir.string()},
                  {"status", stend::to_string(r.status)},
                  {"message", r.message},
                  {"samples", r.samples},
                  {"segments", r.segments},
                  {"run_time_s", r.run_time_s},
                  {"wall_time_s", r.wall_time_s},
                  {"unsafe", r.unsafe},
                  {"fit", nullptr},
                  {"report", nullptr}};
  const auto finish = [&summary](ExitCode code) {
    summary["exit_code"] = to_int(code);
    return Outcome{code, summary};
  };
  if (!r.unsafe.empty()) return finish(ExitCode::kIoFailure);
  if (r.status != stend::RunStatus::kComplete)
    return finish(r.status == stend::RunStatus::kInterrupted ? ExitCode::kStopped : ExitCode::kIoFailure);
  const RunFolderLock lock = lock_run(r.dir);  // the fit and the report take their turn on the new run
  if (exp.estimation && exp.estimation["model"]) {
    // The experiment names its model: fit it now, relative paths from the experiment's folder.
    std::filesystem::path model = exp.estimation["model"].as<std::string>();
    if (model.is_relative()) model = std::filesystem::path(file).parent_path() / model;
    fmt::print(human(), "\n");
    const stend::cli::FitOutcome fit =
        fit_recording(stend::Recording::open(r.dir, stend::SampleLoading::kStream, stend::TruthLoading::kStream),
                      model.string(), r.dir, "");
    summary["fit"] = fit.to_json();
    if (!fit.ok) return finish(fit.exit_code());
  }
  const std::filesystem::path report = stend::cli::write_run_report(r.dir, a.db);
  fmt::print(human(), "report:     {}\n", report.string());
  summary["report"] = report.string();
  return finish(ExitCode::kOk);
}

}  // namespace stend::cli
