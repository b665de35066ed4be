// The `stend` program's subcommands. main.cpp owns run/validate/info/plugins/fit; every other
// subcommand lives in its own cmd_<name>.cpp and registers itself through add_<name>_command.
#pragma once

#include "exit_codes.hpp"
#include "stend/allan/deviation_report.hpp"
#include "stend/calibration/calibration.hpp"
#include "stend/calibration/validation.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/core/runner.hpp"
#include "stend/estimation/registry.hpp"
#include "stend/estimation/result.hpp"
#include "stend/estimation/summary.hpp"
#include "stend/reporting/exports.hpp"
#include "stend/io/formats.hpp"
#include "stend/io/series.hpp"
#include "stend/recording/files.hpp"
#include "stend/recording/recording.hpp"

#include <CLI/CLI.hpp>
#include <atomic>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace stend::cli {

// A registered subcommand: `run` is called after parsing when `sub` was given on the command
// line; its return value is the process exit code (exit_codes.hpp). An exception it throws is
// mapped to one by exit_code_of_current_exception().
struct Command {
  CLI::App* sub = nullptr;
  std::function<ExitCode()> run;
};

// ---- range checks of numeric options (app/checks.cpp) ------------------------------------------
// A value outside is refused while parsing (a usage error, exit 1) with the allowed range:
// "--alpha: 7 is outside the allowed range (0, 1)".
CLI::Validator at_least(double lo);                   // [lo, inf)
CLI::Validator above(double lo);                      // (lo, inf)
CLI::Validator within(double lo, double hi);          // [lo, hi]
CLI::Validator strictly_within(double lo, double hi);  // (lo, hi)

// ---- machine-readable output (app/output.cpp) ---------------------------------------------------
// `--json` on a command that prints results or status: it prints one JSON document on stdout (its
// schema in docs/schemas/<command>.schema.json, docs/json-output.md) and its human-readable lines
// go to stderr instead, so that `stend CMD --json > out.json` is parseable.
void add_json_flag(CLI::App* sub, const std::string& what);
bool json_output();                 // whether --json was given
std::FILE* human();                 // where human-readable lines go: stdout, or stderr under --json
std::ostream& human_stream();       // the same as a stream
void print_json(const nlohmann::json& doc);  // the document on stdout (under --json only)
// Quiet: the human-readable lines are dropped (a caller that reads the results, python/).
void set_quiet(bool quiet);

// What a command gave: its exit code and its --json document (the caller prints it).
struct Outcome {
  ExitCode code = ExitCode::kOk;
  nlohmann::json doc;
};

// ---- shared analysis helpers (app/fit.cpp) -----------------------------------------------------

// What a command reads: a run folder, or dataset files through the io/ format registry, with
// --format (default: detected from the content), --mapping FILE and one flag per import key
// (io::import_keys(): --accel, --accel-lsb, --time-unit, ...). Flags override the mapping file.
struct DatasetArgs {
  std::vector<std::string> inputs;
  std::string format = "auto";
  std::string mapping;
  std::map<std::string, std::string> flags;  // import key → value as given
  bool accept_damaged = false;  // analyse the readable part of a damaged run (else it is refused)
  std::string experiment;       // --experiment: the procedure a dataset file was recorded with

  // Adds the INPUT positional (one file or folder; two for IMU-TK's accelerometer and gyro files),
  // --format, --mapping and the import flags to `sub`; the input is required unless `required`
  // is false (a command with subcommands of its own).
  void add_to(CLI::App* sub, bool required = true);
  // Adds --accept-damaged (for the analyses; without it open() and checked() refuse a damaged run).
  void add_accept_damaged(CLI::App* sub);
  io::ImportOptions options() const;
  io::Inputs paths() const;
  // The input, refused when it is a damaged run unless --accept-damaged; a dataset file's import
  // warnings (repaired or bursty timestamps, gaps) and what was read printed (print_warnings, print_read).
  stend::Recording open() const;
  // `rec` (opened from the input), refused when damaged unless --accept-damaged.
  const stend::Recording& checked(const stend::Recording& rec) const;
  // The single input is a run folder (results may be written into it).
  bool is_run() const;
};

// Prints each warning event of `rec` as "warning:    …" (human()) and returns their messages.
std::vector<std::string> print_warnings(const stend::Recording& rec);
// Prints what the importer found and did (its format and "imported …" events) as `read:` lines;
// returns the "imported …" message ("" when there is none: a run folder).
std::string print_read(const stend::Recording& rec);

// Where results were written: `file` (and its .txt beside it); `kept`: the good results file that
// a failed fit left in place (empty when none). Both empty when nothing was written.
struct WrittenResults {
  std::filesystem::path file, kept;
};

// Where a failed fit's results go when `json` holds a good result: beside it, "failed-<name>"
// (RUN/ceres.json → RUN/failed-ceres.json: no estimator's results file starts so, so the reports,
// exports and results database never read it as a result).
std::filesystem::path failed_results_path(const std::filesystem::path& json);

// Writes the results document to `json` and the printed text beside it (.txt), each through
// write_file_atomic (a failed write throws IoError: no "results:" line is printed); with no path
// (the input is a dataset file, not a run folder, and no --out was given) writes nothing and says
// so. `failed`: the document states a failed fit and is said to hold no results; it replaces an
// earlier failed or unreadable document at `json`, but never a good one (status "ok"): that one is
// kept byte for byte, the failure written to failed_results_path(json), and stderr says so, naming
// both files.
WrittenResults write_results(std::filesystem::path json, const std::string& document, const std::string& text,
                             bool failed = false);

// Whether the estimator `stend fit` would use for this model file reads the bench truth.
bool fit_reads_truth(const std::string& model_file, const std::string& estimator = "auto");

// What a fit gave: whether it succeeded, where its results went ("" when not written), its
// estimator and its results document (the failure document when it failed: status and why).
struct FitOutcome {
  bool ok = false;
  estimation::FitStatus status = estimation::FitStatus::kFailed;  // not applicable: nothing written
  std::filesystem::path results_file;
  std::filesystem::path kept_results_file;  // a good results file this failed fit did not replace
  std::string estimator;
  nlohmann::json document;
  estimation::FitResult result;  // the typed result (summary, instrument models with covariance, noise)
  nlohmann::json to_json() const;  // docs/schemas/fit.schema.json
  // kOk; kInvalidInput when nothing in the model applies to the recording (not applicable: an
  // instrument it lacks); kFitFailed otherwise.
  ExitCode exit_code() const;
};

// Fits `model_file` to `rec` with the estimator named `estimator` ("auto": the one the model file
// is written for, through the estimator registry), prints the report (human()) and writes the
// results JSON (+ a .txt copy) to `json_out`, or to out_dir/<the estimator's results file for the
// model's instrument> (estimation::results_file_for) when empty. A failed fit says why, with no
// numbers.
FitOutcome fit_recording(const stend::Recording& rec, const std::string& model_file, const std::filesystem::path& out_dir,
                   const std::string& json_out, const std::string& estimator = "auto");

// Whether `results_file` lies in the run folder `run_dir` (then the run's report shows it).
bool results_in_run(const std::filesystem::path& run_dir, const std::filesystem::path& results_file);

// What is wrong with a run folder `stend import` began and did not finish (its experiment.yaml has
// the import: block, its status is not complete: stopped or killed while it wrote): the message,
// or "" for any other run. The analyses refuse such a run (DatasetArgs::checked) and a new import
// into its folder says what it is.
std::string unfinished_import(const stend::Recording& rec);

// The lock of a run folder a command reads and rewrites (fit, report, gap, apply, export): a
// second command on the same run waits its turn, saying so on stderr (RunFolderLock). A path that
// is not a run folder (a dataset file) is not locked.
RunFolderLock lock_run(const std::filesystem::path& run_dir);

// The checks the run's fit will make, made before the bench moves (`stend validate`, `stend run`):
// the experiment's processing: section read as the fit reads it, and the model file that
// estimation: model: names present and read by the estimator it is written for. Throws
// ExperimentError at file:line:col (analysis_check.cpp).
void check_analysis(const std::string& experiment_file);

// ---- the commands as functions: the program's subcommands and the Python module (python/) --------
// Each takes the options its subcommand parses, prints its human-readable lines (human()) and
// returns its exit code and --json document; refusals and errors are thrown (exit_codes.hpp).

// `stend fit` (main.cpp's options): the fit, its results written as fit_recording says, the
// run's report refreshed when they went into the run folder.
struct FitArgs {
  DatasetArgs data;
  std::string model, out, estimator = "auto", db;
};
struct FitCommandOutcome {
  FitOutcome fit;
  nlohmann::json doc;  // docs/schemas/fit.schema.json
};
FitCommandOutcome run_fit(const FitArgs& a);

// `stend import` (cmd_import.cpp).
struct ImportArgs {
  DatasetArgs data;
  std::string output, name;
};
Outcome run_import(const ImportArgs& a);

// `stend apply` (cmd_apply.cpp).
struct ApplyArgs {
  std::string cal, output, json;
  DatasetArgs data;  // the recording to calibrate
  bool validate = false;
  std::vector<std::string> rotations;
  std::vector<std::string> assumptions;  // NAME=VALUE[,NAME=VALUE…], repeatable
  calibration::ValidationOptions options;
};
Outcome run_apply(const ApplyArgs& a);
// The results file CAL names: the file itself, or the one estimator results file in a run folder.
std::filesystem::path calibration_results_file(const std::filesystem::path& cal, const estimation::Registry& registry);
// The calibration CAL names (a results file or a run folder holding one) with the --assume values.
calibration::Calibration load_stated_calibration(const std::string& cal, const std::vector<std::string>& assumptions);

// `stend gap` (cmd_gap.cpp); the validate fields are `stend gap validate`'s.
struct GapArgs {
  DatasetArgs data;
  std::string model, json, fold_by = "auto", db, family_rule = "by";
  int max_steps = 4, max_folds = 12;
  double alpha = 0.05;
  // validate
  int seeds = 20, null_runs = 40, oov_runs = 20, positions = 0;
  std::vector<double> sizes = {1, 2, 5, 10};
  std::vector<std::string> only;
  std::string vjson;
  std::uint64_t seed = 1;
  int noise_seeds = 10, noise_null_runs = 40;  // noise-stage experiments (sample level)
  int design_runs = 20;  // design cases (folds, aliases, placement): runs per case
};
Outcome run_gap(const GapArgs& a);

// `stend export` (cmd_export.cpp).
struct ExportArgs {
  std::string run, format, output, db, procedure;
  reporting::ExportOptions options;
  std::vector<std::string> assumptions;  // --assume NAME=VALUE[,NAME=VALUE…], repeatable
};
Outcome run_export(const ExportArgs& a);

// `stend deviations` (cmd_deviations.cpp): every deviation kind of a plain series with its
// intervals; deviations_of the values read already (the file's name and column as given in `a`).
struct DeviationsArgs {
  std::string file;
  io::SeriesColumn column;
  bool phase = false;
  double tau0_s = 0.0, rate_hz = 0.0;
  std::vector<std::string> kinds;
  std::string tau = allan::to_string(allan::TauSpacing::kOctave);
  std::uint64_t max_m = allan::OverlappingAllanStream::kDefaultMaxM;
  double confidence = stats::kOneSigma;
  std::string unit;
};
Outcome run_deviations(const DeviationsArgs& a);
Outcome deviations_of(const io::SeriesValues& series, const DeviationsArgs& a);

// `stend info` (cmd_info.cpp): the recording's summary, docs/schemas/info.schema.json.
Outcome run_info(const std::string& dir);
// The summary `stend info --json` prints, of any recording (a run folder or a dataset opened).
nlohmann::json recording_summary(const Recording& rec);

// `stend run` (cmd_run.cpp).
struct RunArgs {
  std::string file, output, name, clock, store = "hdf5", db;
  bool allow_plugins = false;
};
// What the caller sees while the run goes: progress every period_s of wall time, a flag that stops
// the run cleanly, and the run's result as soon as the bench is done (before the fit and report).
struct RunHooks {
  std::function<void(const RunProgress&)> on_progress;
  double period_s = 0.2;  // [s] wall time between progress calls
  const std::atomic<bool>* stop = nullptr;
  std::function<void(const Experiment&)> on_loaded;  // the experiment, read and validated
  std::function<void(const RunResult&)> on_finished;
};
Outcome run_run(const RunArgs& a, const RunHooks& hooks);
// Loads plugins from the default search path; the experiment's own plugin_paths only when allowed
// (--allow-plugins or STEND_ALLOW_PLUGINS=1, docs/plugins.md).
void scan_plugins(PluginHost& host, const std::vector<std::string>& extra, bool allow_extra);

// ---- subcommands in their own files ------------------------------------------------------------
void add_gap_command(CLI::App& app, std::vector<Command>& out);      // cmd_gap.cpp
void add_report_command(CLI::App& app, std::vector<Command>& out);   // cmd_report.cpp
void add_compare_command(CLI::App& app, std::vector<Command>& out);  // cmd_compare.cpp
void add_export_command(CLI::App& app, std::vector<Command>& out);   // cmd_export.cpp
void add_emulate_command(CLI::App& app, std::vector<Command>& out);  // cmd_emulate.cpp
void add_import_command(CLI::App& app, std::vector<Command>& out);   // cmd_import.cpp
void add_apply_command(CLI::App& app, std::vector<Command>& out);    // cmd_apply.cpp
void add_watch_command(CLI::App& app, std::vector<Command>& out);    // cmd_watch.cpp

// Builds RUN/report.html from what the run folder holds and records the run in the results
// store `db` (--db; "" for the default, results_store_location) — called at the end of `stend run`.
// Returns the report path; throws when the report cannot be written; a store that cannot take the
// run is said on stderr (the report stands).
std::filesystem::path write_run_report(const std::filesystem::path& run_dir, const std::string& db = "");

// Help of --assume (stend apply, stend export): a value for a parameter the fit did not determine.
inline constexpr const char* kAssumeHelp =
    "NAME=VALUE[,NAME=VALUE...]: the value to use for a parameter the fit did not determine (e.g. bias_x=0; "
    "accel_bias_x / gyro_bias_x where both instruments have it), in the unit the refusal lists (the results "
    "file's SI unit: m/s^2, rad/s, 1); recorded (repeatable)";

// ---- the results store (cmd_report.cpp, cmd_db.cpp) -------------------------------------------
// The help of every command's --db option, written once.
inline constexpr const char* kDbOptionHelp =
    "Results store: an SQLite file or postgresql://user@host:port/db (password from PGPASSWORD or ~/.pgpass); "
    "default $STEND_RESULTS_DB, else stend-results.sqlite beside the run folder";
// Records the run folder in the results store at results_store_location(db, run_dir) and says so
// (the location printed with any password redacted); returns that printable location. Throws when
// the store cannot take it.
std::string record_in_store(const std::filesystem::path& run_dir, const std::string& db);
void add_db_command(CLI::App& app, std::vector<Command>& out);     // cmd_db.cpp
void add_batch_command(CLI::App& app, std::vector<Command>& out);  // cmd_batch.cpp
void add_deviations_command(CLI::App& app, std::vector<Command>& out);  // cmd_deviations.cpp

}  // namespace stend::cli
