// What a run folder says about one unit: sensor identity, the procedure fingerprint, and every
// fitted parameter (with standard error, interval and identifiability) from the results files the
// estimators wrote into the folder (fit.json, temp_poly.json, allan.json, ceres.json, …), each
// read through its estimator's registry entry.
// The same record feeds the results database, `stend compare` and the results-JSON export
// (schema "stend.results/1", docs/reports.md).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace stend::estimation {
class Registry;
}

namespace stend::reporting {

inline constexpr const char* kResultsSchema = "stend.results/1";
// The sim-to-real gap diagnosis `stend gap RUN` writes into the run folder (docs/gap-diagnosis.md).
inline constexpr const char* kGapResultsFile = "gap.json";

struct ParameterResult {
  std::string estimator;  // "batch_lsq", "temp_poly", "allan", "ceres_nonlinear"
  std::string name;       // the vocabulary's name ("bias_z", "bias_tc1_x") or Allan "N_ax", "K_gz"
  std::string unit;
  bool identifiable = false;
  double value = NAN;      // NaN when not identifiable
  double std_error = NAN;  // 1 σ
  double lo = NAN, hi = NAN;  // interval at `confidence`
  double confidence = NAN;
  std::string reason;  // why not identifiable (or an upper bound), "" otherwise
};

struct EstimatorUse {
  std::string name, version;
  std::string file;    // results file in the run folder ("fit.json")
  std::string status;  // "ok" | "failed"
  std::string message;
};

// A results document kept whole, by kind: "gap" (gap.json, schema stend.gap/1) — a diagnosis,
// not parameters; the results store holds one per (run, kind).
struct ResultDocument {
  std::string kind;      // "gap"
  std::string file;      // in the run folder ("gap.json")
  std::string status;    // the document's own: "ok" | "failed"
  std::string document;  // its JSON text
};

struct RunResults {
  std::filesystem::path dir;  // absolute
  std::string run_name;       // folder name
  std::string experiment, run_status, start_time_utc, stend_version;
  std::string vendor, model, serial;
  std::string procedure_fingerprint;  // sha256 hex of procedure_canonical ("" without experiment.yaml)
  std::string procedure_canonical;
  std::vector<EstimatorUse> estimators;
  std::vector<ParameterResult> parameters;
  std::vector<ResultDocument> documents;  // gap.json when present
  std::vector<std::string> notes;  // e.g. a results file that did not parse

  const ParameterResult* find(const std::string& estimator, const std::string& name) const;
};

// Reads the recording's header (through Recording::open, which throws InputError for a folder
// that is not a readable recording: missing or damaged files, an unknown format_version),
// experiment.yaml, the results files of every estimator in `registry` that are present, and
// gap.json; a results file that does not parse becomes a note.
RunResults load_run_results(const std::filesystem::path& run_dir, const estimation::Registry& registry);

// Refuses a run whose results files (every estimator's in `registry`, and gap.json) are not each
// one whole JSON document: InputError at FILE:LINE:COL, saying when the file is cut off (a write
// that did not finish) and how to make it again. `stend report` and `stend export` call it first.
void require_whole_results(const std::filesystem::path& run_dir, const estimation::Registry& registry);

// Parameters of one results document, read through the registry entry that wrote it (its
// summary): the estimator name comes from the document, else from the file name. Exposed for tests.
std::vector<ParameterResult> parameters_of(const nlohmann::json& doc, const std::string& file_stem,
                                           const estimation::Registry& registry, EstimatorUse* use);

// The results JSON (schema stend.results/1, docs/reports.md). Non-finite numbers are null.
// from_json throws InputError for a document of another schema.
nlohmann::json to_json(const RunResults& r);
RunResults from_json(const nlohmann::json& j);

}  // namespace stend::reporting
