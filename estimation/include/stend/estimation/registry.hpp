// The estimator registry: the one way the program, the diagnosis and the reports reach an
// estimator, built in or plugin alike.
//
// Each estimator folder (estimators/<name>/) defines `stend::<name>::estimator_entry()` and lists
// itself with stend_add_estimator() in its CMakeLists.txt; the build generates the registry of
// built-in estimators from those calls (stend/estimators/builtin.hpp, library stend_estimators),
// so adding an estimator needs no edit anywhere else. Estimator plugins found on the plugin
// search path join the registry under their own name.
//
// A model file is matched to its estimator by the entries' `claims` (e.g. a top-level `allan:`
// mapping), or named with `--estimator NAME`.
//
// Results are typed (result.hpp). A built-in entry fits with `fit` and reads its own results
// document back with `read` (its reader beside its one writer, in its folder). An estimator plugin
// (the SDK's Estimator interface, a separate .so) returns its results document as JSON
// (EstimatorResult); estimation::fit adapts it, and Registry::read reads it with the generic
// reader (result_io.hpp: the summary fields, and a `stend.fit/1`-shaped `model` section where the
// document has one) — the contract written in sdk.hpp.
#pragma once

#include <stend/estimation/model_spec.hpp>
#include <stend/estimation/report_section.hpp>
#include <stend/estimation/result.hpp>
#include <stend/estimation/summary.hpp>
#include <stend/fields.hpp>
#include <stend/sdk.hpp>

#include <nlohmann/json_fwd.hpp>
#include <yaml-cpp/yaml.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace stend::estimation {

// What every estimator plugin is configured with (its field table: estimator_fields()).
struct EstimatorConfig {
  std::string results_file;  // default name of the results file in the run folder

  // results_file is a bare file name ("allan.json"): no folder part, so results stay in the run
  // folder.
  bool IsValid(std::string* error = nullptr) const;
};
std::vector<fields::Field<EstimatorConfig>> estimator_fields();

// One results file per instrument and estimator in a run folder: `results_file` as named for an
// accelerometer model (or a model of no single instrument, e.g. Allan over all channels), with
// "-gyroscope" before the extension for a gyroscope model ("temp_poly.json" and
// "temp_poly-gyroscope.json"), so that a gyroscope fit never overwrites the accelerometer's.
std::string results_file_for(const std::string& results_file, const std::string& instrument);
// Every results file name of `results_file` that results_file_for can give, accelerometer first.
std::vector<std::string> results_files_of(const std::string& results_file);
// The instrument a model file's root names ("" when it names none).
std::string model_instrument(const YAML::Node& model_root);
// The terms a model file's root names that read the temperature (model::reads_temperature): in its
// `terms:` list, or temp_poly's switches `bias_temperature: true` / `scale_temperature: true`.
std::vector<std::string> model_temperature_terms(const YAML::Node& model_root);

struct EstimatorEntry {
  std::string name;          // as in `stend fit --estimator NAME` and the results' "estimator"
  std::string version;
  std::string description;   // one line
  std::string results_file;  // default results file in the run folder, e.g. "fit.json"
  // Whether a model file (its parsed YAML root) is written for this estimator. Null: reached by
  // name only. `fallback`: claims what no other entry claims (batch_lsq's plain model files).
  std::function<bool(const YAML::Node& model_root)> claims;
  bool fallback = false;
  // A new estimator object behind the SDK's interface (the same class its plugin exports; for a
  // plugin entry, the plugin's).
  std::function<PluginPtr<Estimator>()> create;
  // The typed fit: the results, the report text and the document it writes. Null: the fit goes
  // through `create` and the estimator's JSON is read back (estimation::fit).
  std::function<FitResult(const EstimatorRequest& request)> fit;
  // Reads this estimator's results document back as the typed result (reports, database, compare,
  // `stend apply`, the exports). Null: the generic reader (estimation::read_fit_document).
  std::function<FitResult(const nlohmann::json& doc)> read;
  // Whether its fit reads the bench truth; false lets `stend fit` open a run without it (a noise
  // analysis of a day-long run need not hold the day's truth in memory).
  bool reads_truth = true;
  // For an estimator whose model file is a linear error model (model_spec.hpp): the file read as
  // that model — what `stend gap` fits, replays and extends. Null: no linear model to diagnose.
  std::function<ModelSpec(const std::string& model_file)> linear_model;
  // This estimator's section of the run report, from its results read back (Registry::read): the
  // page sets the section's `file` to the results file it read. Null: the generic section, the
  // parameter table of the summary (estimation::generic_report_section, fit_report.hpp).
  std::function<ReportSection(const FitResult& result)> report;
};

class Registry {
 public:
  // Adds an entry; throws std::logic_error on a second entry of the same name.
  void add(EstimatorEntry entry);

  const EstimatorEntry* find(const std::string& name) const;  // nullptr when absent
  // The entry a model file is for: the one claiming it, else the fallback. Throws
  // stend::InputError naming the file when none or several claim it.
  const EstimatorEntry& for_model(const YAML::Node& model_root, const std::string& model_file) const;
  // The entry whose results a document is: its "estimator" name, else the one whose results
  // file is `file_name`. nullptr when neither matches.
  const EstimatorEntry* for_results(const nlohmann::json& doc, const std::string& file_name) const;
  // A results document read back as the typed result, through the entry that wrote it (its
  // reader, else the generic one; the estimator's name, version and default results file filled
  // in from the entry where the document does not state them).
  FitResult read(const nlohmann::json& doc, const std::string& file_name) const;
  // read(doc, file_name).summary.
  FitSummary summarize(const nlohmann::json& doc, const std::string& file_name) const;

  const std::vector<EstimatorEntry>& entries() const { return entries_; }
  std::string names() const;  // "batch_lsq, temp_poly, …" for messages

 private:
  std::vector<EstimatorEntry> entries_;
};

// Fits through an entry: its typed `fit`, else its SDK estimator (`create`) with the JSON it
// returns read back by the entry's reader or the generic one; a plugin's ok and message are
// taken as it states them, and a failed fit without a document gets the summary fields
// (failed_fit). A model file whose `instrument:` the recording does not have (why_absent) is not
// fitted: its result is not applicable (not_applicable_fit). Throws what the estimator throws (a
// bad model file, unreadable input).
FitResult fit(const EstimatorEntry& entry, const EstimatorRequest& request);

}  // namespace stend::estimation
