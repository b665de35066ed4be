// stend — drive a characterization bench from an experiment file and analyse its recordings.
#include "commands.hpp"
#include "live_view.hpp"
#include "progress.hpp"

#include "stend/estimators/builtin.hpp"
#include "stend/core/experiment.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/recording/recording.hpp"
#include "stend/core/runner.hpp"
#include "stend/recording/version.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <fstream>
#include <sstream>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sys/stat.h>
#include <unistd.h>

namespace {

std::atomic<bool> g_stop{false};

using stend::cli::ExitCode;
using stend::cli::fit_recording;
using stend::cli::fmt_duration;
using stend::cli::human;
using nlohmann::json;

json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

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

// Loads plugins from the default search path. The experiment's own plugin_paths (read before full
// validation so that its plugins are known while validating it) are loaded only when the user
// allows it (--allow-plugins or STEND_ALLOW_PLUGINS=1, docs/plugins.md); otherwise their files
// are listed as not loaded and no code of theirs runs.
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

void scan_plugins(stend::PluginHost& host, const std::vector<std::string>& extra, bool allow_extra) {
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

ExitCode cmd_run(const std::string& file, const std::string& output, const std::string& name, const std::string& clock,
                 const std::string& store, const std::string& db, bool quiet, bool allow_plugins,
                 const stend::cli::LiveArgs& live_args) {
  stend::PluginHost host;
  scan_plugins(host, stend::experiment_plugin_paths(file), allow_plugins);
  const stend::Experiment exp = stend::load_experiment(file, host);
  stend::cli::check_analysis(file);

  stend::RunOptions opt;
  opt.output_dir = output;
  opt.run_name = name;
  if (!clock.empty()) opt.clock = stend::clock_kind_from_string(clock);  // checked by the option
  opt.store.format = *stend::recording_format_from_string(store);  // checked by the option
  opt.stop = &g_stop;
  // The progress line (a terminal only, unless --quiet) and the live view (--live) share the
  // runner's progress reports.
  stend::cli::StatusLine status;
  stend::cli::LiveRun live(live_args, exp.name);
  const bool show = !quiet && status.enabled();
  if (show || live_args.live) {
    opt.progress_period_s = 0.2;
    opt.on_progress = [&](const stend::RunProgress& p) {
      if (show) status.show(stend::cli::run_progress_line(p, stend::cli::terminal_columns()));
      live.update(p);
    };
  }
  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_sigint);
  const stend::RunResult r = stend::run_experiment(exp, host, opt);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  status.keep();  // the final line stays: "100% | done | …"
  live.finish(r.status, r.message);

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
    summary["exit_code"] = stend::cli::to_int(code);
    stend::cli::print_json(summary);
    return code;
  };
  if (!r.unsafe.empty()) return finish(ExitCode::kIoFailure);
  if (r.status != stend::RunStatus::kComplete)
    return finish(r.status == stend::RunStatus::kInterrupted ? ExitCode::kStopped : ExitCode::kIoFailure);
  const stend::RunFolderLock lock = stend::cli::lock_run(r.dir);
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
  const std::filesystem::path report = stend::cli::write_run_report(r.dir, db);
  fmt::print(human(), "report:     {}\n", report.string());
  summary["report"] = report.string();
  return finish(ExitCode::kOk);
}

ExitCode cmd_fit(const stend::cli::DatasetArgs& data, const std::string& model, const std::string& out,
            const std::string& estimator, const std::string& db) {
  const stend::RunFolderLock lock = stend::cli::lock_run(data.is_run() ? data.inputs[0] : std::string());
  // A run opened for an estimator that needs no bench truth (allan) leaves the truth in the store.
  const stend::Recording rec =
      data.is_run() && !stend::cli::fit_reads_truth(model, estimator)
          ? stend::Recording::open(data.inputs[0], stend::SampleLoading::kStream, stend::TruthLoading::kSkip)
          : data.open();
  const std::filesystem::path run_dir = data.is_run() ? std::filesystem::path(data.inputs[0]) : std::filesystem::path();
  const stend::cli::FitOutcome fit = fit_recording(data.checked(rec), model, run_dir, out, estimator);
  json doc = fit.to_json();
  doc["report"] = nullptr;
  if (run_dir.empty()) {
    fmt::print(human(), "report:     none (the input is not a run folder; `stend import` makes one)\n");
  } else if (fit.results_file.empty()) {
    fmt::print(human(), "report:     {} not updated (no results written)\n", (run_dir / "report.html").string());
  } else if (stend::cli::results_in_run(run_dir, fit.results_file)) {
    // A failed fit too: its results file now says so and the report drops its earlier numbers —
    // unless it was written beside a good results file that it kept (write_results): the report
    // shows that one. The run is recorded in the results store (--db, else the default) as it now
    // stands.
    const std::filesystem::path report = stend::cli::write_run_report(run_dir, db);
    fmt::print(human(), "report:     {} (updated)\n", report.string());
    doc["report"] = report.string();
  } else {
    fmt::print(human(), "report:     {} not updated (--out put the results outside the run folder)\n",
               (run_dir / "report.html").string());
  }
  stend::cli::print_json(doc);
  return fit.exit_code();
}

// docs/schemas/info.schema.json
json info_json(const stend::Recording& rec, std::uint64_t n, const stend::ImuSample& first, const stend::ImuSample& last) {
  const auto& h = rec.header;
  json j = {{"recording", rec.dir.string()},
            {"format", stend::to_string(rec.format)},
            {"experiment", h.experiment_name},
            {"stend_version", h.stend_version},
            {"status", stend::to_string(h.status)},
            {"complete", rec.complete()},
            {"sensor", {{"vendor", h.identity.vendor},
                        {"model", h.identity.model},
                        {"serial", h.identity.serial},
                        {"who_am_i", h.identity.who_am_i},
                        {"output_rate_hz", h.info.output_rate_hz}}},
            {"gravity_mps2", h.gravity_mps2},
            {"clock", h.clock},
            {"seed", h.seed},
            {"samples", n},
            {"t_first_s", n > 0 ? finite_or_null(first.t_s) : json(nullptr)},
            {"t_last_s", n > 0 ? finite_or_null(last.t_s) : json(nullptr)},
            {"gaps", rec.gap_count >= 0 ? json(rec.gap_count) : json(nullptr)},
            {"truth_rows", rec.truth_rows},
            {"damage", rec.damage}};
  j["segments"] = json::array();
  for (const auto& s : rec.segments)
    j["segments"].push_back({{"id", s.id},
                             {"kind", stend::to_string(s.kind)},
                             {"t_start_s", finite_or_null(s.t_start_s)},
                             {"t_end_s", finite_or_null(s.t_end_s)},
                             {"settled", s.settled},
                             {"complete", s.complete},
                             {"label", s.label},
                             {"targets", s.targets}});
  j["events"] = json::array();
  for (const auto& e : rec.events)
    j["events"].push_back({{"t_s", finite_or_null(e.t_s)}, {"level", e.level}, {"source", e.source}, {"message", e.message}});
  return j;
}

ExitCode cmd_info(const std::string& dir) {
  // Header, extents and the first and last samples only: no scan of the samples.
  const stend::Recording rec =
      stend::Recording::open(dir, stend::SampleLoading::kStream, stend::TruthLoading::kSkip);
  const auto& h = rec.header;
  std::FILE* out = human();
  fmt::print(out, "recording:  {} ({})\nexperiment: {} (stend {})\nstatus:     {}{}\n", rec.dir.string(),
             stend::to_string(rec.format), h.experiment_name, h.stend_version, stend::to_string(h.status),
             rec.complete() ? "" : " (incomplete)");
  fmt::print(out, "sensor:     {} {} serial '{}' WHO_AM_I {} at {} Hz\n", h.identity.vendor, h.identity.model,
             h.identity.serial, h.identity.who_am_i, h.info.output_rate_hz);
  fmt::print(out, "gravity:    {:.6f} m/s^2; clock {}; seed {}\n", h.gravity_mps2, h.clock, h.seed);
  const auto& src = rec.sample_source();
  const std::uint64_t n = src.size();
  fmt::print(out, "data:       {} samples", n);
  stend::ImuSample first, last;
  if (n > 0) {
    src.read(0, 1, &first);
    src.read(n - 1, 1, &last);
    fmt::print(out, " from {:.3f} s to {:.3f} s", first.t_s, last.t_s);
  }
  if (rec.gap_count >= 0) fmt::print(out, ", {} gaps", rec.gap_count);
  fmt::print(out, ", {} truth rows, {} segments, {} events\n", rec.truth_rows, rec.segments.size(), rec.events.size());
  if (!rec.damage.empty())
    fmt::print(out, "damaged:    {} of {} samples are readable: {}\n", n, rec.written_samples, rec.damage);
  for (const auto& s : rec.segments)
    fmt::print(out, "  #{:<3} {:<15} {:>7.2f}–{:<8.2f} s {}{}{}  {}\n", s.id, stend::to_string(s.kind), s.t_start_s, s.t_end_s,
               s.settled ? "" : "[unsettled] ", s.complete ? "" : "[incomplete] ", s.label, s.targets);
  for (const auto& e : rec.events) fmt::print(out, "  event {:.3f} s {} {}: {}\n", e.t_s, e.level, e.source, e.message);
  stend::cli::print_json(info_json(rec, n, first, last));
  return ExitCode::kOk;
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
  stend::cli::LiveArgs live_args;
  live_args.add_to(run, true);
  stend::cli::add_json_flag(run, "the run's summary (folder, status, fit, report)");

  std::string dir;
  auto* info = app.add_subcommand("info", "Summarize a recording (run folder)");
  info->add_option("run", dir, "Run folder")->required();
  stend::cli::add_json_flag(info, "the recording's summary");

  std::string model, fit_out;
  stend::cli::DatasetArgs fit_data;
  auto* fit = app.add_subcommand("fit", "Fit an error model (or the Allan noise model) to a recording or dataset");
  fit_data.add_to(fit);
  fit_data.add_accept_damaged(fit);
  fit->add_option("-m,--model", model, "Model YAML (instrument, axes, terms, extraction)")->required();
  std::string estimator = "auto";
  fit->add_option("--estimator", estimator,
                  "auto (the one the model file is written for) | " + stend::estimators::builtin().names() +
                      " | the name of an estimator plugin on the search path");
  fit->add_option("-o,--out", fit_out,
                  "Where to write the results (default: the estimator's results file in the run folder, e.g. "
                  "RUN/fit.json, RUN/temp_poly-gyroscope.json; a dataset file's are written only with --out)");
  stend::cli::add_json_flag(fit, "the fit's outcome and results document");
  fit->add_option("--db", db, std::string(stend::cli::kDbOptionHelp) +
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
      if (*run) return cmd_run(file, output, name, clock, store, db, quiet, allow_plugins, live_args);
      if (*info) return cmd_info(dir);
      if (*fit) return cmd_fit(fit_data, model, fit_out, estimator, db);
    } catch (...) {
      return stend::cli::exit_code_of_current_exception();
    }
    return ExitCode::kOk;
  }());
}
