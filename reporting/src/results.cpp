// Run-folder results: identity, fingerprint and parameters of every estimator (see results.hpp).
#include "stend/reporting/results.hpp"

#include "stend/errors.hpp"
#include "stend/estimation/registry.hpp"
#include "stend/recording/recording.hpp"
#include "stend/reporting/fingerprint.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace stend::reporting {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

double num_or_nan(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return NAN;
  return j[key].get<double>();
}
std::string str_or(const json& j, const char* key, const std::string& def = "") {
  if (!j.is_object() || !j.contains(key) || !j[key].is_string()) return def;
  return j[key].get<std::string>();
}
json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw IoError(p.string() + ": cannot open for reading; check that it exists and is readable");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

const ParameterResult* RunResults::find(const std::string& estimator, const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name && (estimator.empty() || p.estimator == estimator)) return &p;
  return nullptr;
}

std::vector<ParameterResult> parameters_of(const json& doc, const std::string& file_stem,
                                           const estimation::Registry& registry, EstimatorUse* use) {
  const estimation::FitSummary summary = registry.summarize(doc, file_stem + ".json");
  EstimatorUse u;
  u.name = summary.estimator.empty() ? file_stem : summary.estimator;
  u.version = summary.version;
  u.status = estimation::to_string(summary.status);
  u.message = summary.message;
  std::vector<ParameterResult> out;
  if (use) *use = u;
  // A failed (or not applicable) fit is marked (its status and why) and its numbers excluded: none
  // is a result.
  if (!summary.ok()) return out;
  // A gyroscope model's results (temp_poly-gyroscope.json) are told apart from the accelerometer's.
  const std::string instrument_suffix = "-gyroscope";
  const bool gyro_file = file_stem.size() > instrument_suffix.size() &&
                         file_stem.compare(file_stem.size() - instrument_suffix.size(), std::string::npos, instrument_suffix) == 0;
  for (const auto& p : summary.parameters) {
    ParameterResult r;
    r.estimator = gyro_file ? u.name + instrument_suffix : u.name;
    r.name = p.name;
    r.unit = p.unit;
    r.identifiable = p.identifiable;
    r.value = p.value;
    r.std_error = p.std_error;
    r.lo = p.lower;
    r.hi = p.upper;
    r.confidence = summary.confidence;
    r.reason = p.reason;
    out.push_back(std::move(r));
  }
  if (use) *use = u;
  return out;
}

namespace {

// gap.json, kept whole when it parses (else a note, as for any results file).
void add_gap_document(RunResults& r) {
  const fs::path f = r.dir / kGapResultsFile;
  if (!fs::exists(f)) return;
  try {
    const json doc = json::parse(read_text(f));
    r.documents.push_back({"gap", kGapResultsFile, str_or(doc, "status"), doc.dump()});
  } catch (const std::exception& e) {
    r.notes.push_back(std::string(kGapResultsFile) + " not read: " + e.what());
  }
}

}  // namespace

namespace {

// Line and column (from 1) of byte `offset` of `text`.
std::pair<std::size_t, std::size_t> line_col(const std::string& text, std::size_t offset) {
  offset = std::min(offset, text.size());
  std::size_t line = 1, col = 1;
  for (std::size_t i = 0; i < offset; ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return {line, col};
}

// Refuses `file` when its text is not one whole JSON document.
void require_whole_json(const fs::path& file) {
  const std::string text = read_text(file);
  try {
    [[maybe_unused]] const json doc = json::parse(text);
  } catch (const json::parse_error& e) {
    const std::size_t at = e.byte > 0 ? e.byte - 1 : 0;  // nlohmann counts from 1
    const auto [line, col] = line_col(text, at);
    const bool cut = at >= text.size();
    const std::string what = e.what();
    const auto colon = what.find(": ", what.find("column"));
    throw InputError(fmt::format("{}:{}:{}: {} — run the command that wrote it again (`stend fit`, `stend gap`), or "
                                 "remove it",
                                 file.string(), line, col,
                                 cut ? std::string("the results file is cut off (a write that did not finish): it "
                                                   "ends inside its JSON document")
                                     : "not a JSON document: " + excerpt(what.substr(colon == std::string::npos ? 0 : colon + 2))));
  }
}

}  // namespace

void require_whole_results(const fs::path& run_dir, const estimation::Registry& registry) {
  std::vector<std::string> names = {kGapResultsFile};
  for (const auto& entry : registry.entries())
    for (const auto& name : estimation::results_files_of(entry.results_file)) names.push_back(name);
  for (const auto& name : names)
    if (fs::is_regular_file(run_dir / name)) require_whole_json(run_dir / name);
}

RunResults load_run_results(const fs::path& run_dir, const estimation::Registry& registry) {
  RunResults r;
  r.dir = fs::absolute(run_dir).lexically_normal();
  if (!r.dir.has_filename()) r.dir = r.dir.parent_path();
  r.run_name = r.dir.filename().string();
  // Opened as `stend info` and `stend fit` open it: a folder they refuse is refused here too.
  const Recording rec = Recording::open(r.dir, SampleLoading::kStream, TruthLoading::kSkip);
  const RecordingHeader& h = rec.header;
  r.experiment = h.experiment_name;
  r.run_status = to_string(h.status);
  r.start_time_utc = h.start_time_utc;
  r.stend_version = h.stend_version;
  r.vendor = h.identity.vendor;
  r.model = h.identity.model;
  r.serial = h.identity.serial;
  if (!rec.experiment_yaml.empty()) {
    try {
      r.procedure_canonical = canonical_procedure(rec.experiment_yaml);
      r.procedure_fingerprint = sha256_hex(r.procedure_canonical);
    } catch (const std::exception& e) {
      r.notes.push_back(std::string("no procedure fingerprint: ") + e.what());
    }
  } else {
    r.notes.push_back("no experiment.yaml: no procedure fingerprint");
  }
  for (const auto& entry : registry.entries())
    for (const auto& name : estimation::results_files_of(entry.results_file)) {
      const fs::path f = r.dir / name;
      const std::string stem = f.stem().string();
      if (!fs::exists(f)) continue;
      try {
        EstimatorUse use;
        auto ps = parameters_of(json::parse(read_text(f)), stem, registry, &use);
        use.file = f.filename().string();
        r.estimators.push_back(use);
        r.parameters.insert(r.parameters.end(), ps.begin(), ps.end());
      } catch (const std::exception& e) {
        r.notes.push_back(f.filename().string() + " not read: " + e.what());
      }
    }
  add_gap_document(r);
  return r;
}

json to_json(const RunResults& r) {
  json j;
  j["schema"] = kResultsSchema;
  j["run"] = {{"dir", r.dir.string()},           {"name", r.run_name},
              {"experiment", r.experiment},      {"status", r.run_status},
              {"start_time_utc", r.start_time_utc}, {"stend_version", r.stend_version}};
  j["sensor"] = {{"vendor", r.vendor}, {"model", r.model}, {"serial", r.serial}};
  j["procedure"] = {{"fingerprint", r.procedure_fingerprint}, {"algorithm", "sha256"},
                    {"canonical", r.procedure_canonical}};
  j["estimators"] = json::array();
  for (const auto& e : r.estimators)
    j["estimators"].push_back(
        {{"name", e.name}, {"version", e.version}, {"file", e.file}, {"status", e.status}, {"message", e.message}});
  j["parameters"] = json::array();
  for (const auto& p : r.parameters) {
    json q = {{"estimator", p.estimator},
              {"name", p.name},
              {"unit", p.unit},
              {"identifiable", p.identifiable},
              {"value", finite_or_null(p.value)},
              {"std_error", finite_or_null(p.std_error)},
              {"interval", std::isfinite(p.lo) && std::isfinite(p.hi) ? json::array({p.lo, p.hi}) : json(nullptr)},
              {"confidence", finite_or_null(p.confidence)}};
    if (!p.reason.empty()) q["reason"] = p.reason;
    j["parameters"].push_back(std::move(q));
  }
  if (!r.documents.empty()) {  // optional: absent in a document without any
    j["documents"] = json::array();
    for (const auto& d : r.documents)
      j["documents"].push_back({{"kind", d.kind},
                                {"file", d.file},
                                {"status", d.status},
                                {"document", json::parse(d.document, nullptr, false)}});
  }
  j["notes"] = r.notes;
  return j;
}

RunResults from_json(const json& j) {
  if (str_or(j, "schema") != kResultsSchema)
    throw InputError("not a " + std::string(kResultsSchema) + " document (schema '" + str_or(j, "schema") +
                     "'): give the results JSON that `stend export RUN --to json` writes");
  RunResults r;
  const json& run = j.at("run");
  r.dir = str_or(run, "dir");
  r.run_name = str_or(run, "name");
  r.experiment = str_or(run, "experiment");
  r.run_status = str_or(run, "status");
  r.start_time_utc = str_or(run, "start_time_utc");
  r.stend_version = str_or(run, "stend_version");
  r.vendor = str_or(j.at("sensor"), "vendor");
  r.model = str_or(j.at("sensor"), "model");
  r.serial = str_or(j.at("sensor"), "serial");
  r.procedure_fingerprint = str_or(j.at("procedure"), "fingerprint");
  r.procedure_canonical = str_or(j.at("procedure"), "canonical");
  for (const auto& e : j.at("estimators"))
    r.estimators.push_back({str_or(e, "name"), str_or(e, "version"), str_or(e, "file"), str_or(e, "status"),
                            str_or(e, "message")});
  for (const auto& p : j.at("parameters")) {
    ParameterResult q;
    q.estimator = str_or(p, "estimator");
    q.name = str_or(p, "name");
    q.unit = str_or(p, "unit");
    q.identifiable = p.value("identifiable", false);
    q.value = num_or_nan(p, "value");
    q.std_error = num_or_nan(p, "std_error");
    if (p.contains("interval") && p["interval"].is_array()) {
      q.lo = p["interval"][0].get<double>();
      q.hi = p["interval"][1].get<double>();
    }
    q.confidence = num_or_nan(p, "confidence");
    q.reason = str_or(p, "reason");
    r.parameters.push_back(std::move(q));
  }
  if (j.contains("documents"))
    for (const auto& d : j["documents"])
      r.documents.push_back({str_or(d, "kind"), str_or(d, "file"), str_or(d, "status"),
                             d.contains("document") ? d["document"].dump() : std::string("null")});
  if (j.contains("notes"))
    for (const auto& n : j["notes"]) r.notes.push_back(n.get<std::string>());
  return r;
}

}  // namespace stend::reporting
