// The estimator registry (see stend/estimation/registry.hpp).
#include "stend/estimation/registry.hpp"

#include "stend/errors.hpp"
#include "stend/estimation/result_io.hpp"
#include "stend/yaml/reader.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <stdexcept>

namespace stend::estimation {

std::vector<fields::Field<EstimatorConfig>> estimator_fields() {
  return {fields::Field<EstimatorConfig>("results_file", &EstimatorConfig::results_file, "",
                                         "default name of the results file")};
}

bool EstimatorConfig::IsValid(std::string* error) const {
  const std::filesystem::path p(results_file);
  if (results_file.empty() || p.filename() != p || p == "." || p == "..")
    return invalid(error, "results_file '" + results_file + "' must be a file name in the run folder, with no folder part");
  return true;
}

namespace {
constexpr const char* kGyroscope = "gyroscope";
}  // namespace

std::string results_file_for(const std::string& results_file, const std::string& instrument) {
  if (instrument != kGyroscope) return results_file;
  const std::filesystem::path p(results_file);
  return p.stem().string() + "-" + instrument + p.extension().string();
}

std::vector<std::string> results_files_of(const std::string& results_file) {
  return {results_file, results_file_for(results_file, kGyroscope)};
}

std::string model_instrument(const YAML::Node& model_root) {
  if (!model_root.IsMap()) return {};
  const YAML::Node n = model_root["instrument"];
  return n && n.IsScalar() ? n.as<std::string>() : std::string();
}

std::vector<std::string> model_temperature_terms(const YAML::Node& model_root) {
  std::vector<std::string> out;
  if (!model_root.IsMap()) return out;
  const auto add = [&out](const std::string& name) {
    const auto kind = model::term_from_name(name);
    if (kind && model::reads_temperature(*kind)) out.push_back(name);
  };
  if (const YAML::Node terms = model_root["terms"]; terms && terms.IsSequence())
    for (const YAML::Node& t : terms) {
      if (t.IsScalar()) add(t.as<std::string>());
      if (t.IsMap())
        for (const auto& kv : t) add(kv.first.as<std::string>());
    }
  for (const char* key : {"bias_temperature", "scale_temperature"})
    if (const YAML::Node n = model_root[key]; n && n.IsScalar() && n.as<std::string>() == "true") out.push_back(key);
  return out;
}

void Registry::add(EstimatorEntry entry) {
  if (find(entry.name) != nullptr) throw std::logic_error("estimator '" + entry.name + "' registered twice");
  entries_.push_back(std::move(entry));
}

const EstimatorEntry* Registry::find(const std::string& name) const {
  for (const auto& e : entries_)
    if (e.name == name) return &e;
  return nullptr;
}

const EstimatorEntry& Registry::for_model(const YAML::Node& root, const std::string& model_file) const {
  const EstimatorEntry* claimed = nullptr;
  const EstimatorEntry* fallback = nullptr;
  for (const auto& e : entries_) {
    if (e.fallback) fallback = &e;
    if (!e.claims || !e.claims(root)) continue;
    if (claimed != nullptr)
      throw InputError(model_file + ": both '" + claimed->name + "' and '" + e.name +
                               "' read this model file; name one with --estimator");
    claimed = &e;
  }
  if (claimed != nullptr) return *claimed;
  if (fallback != nullptr) return *fallback;
  throw InputError(model_file + ": no estimator reads this model file (estimators: " + names() +
                           "); name one with --estimator");
}

const EstimatorEntry* Registry::for_results(const nlohmann::json& doc, const std::string& file_name) const {
  std::string name;
  if (doc.contains("estimator") && doc["estimator"].is_string()) name = doc["estimator"];
  if (doc.contains("estimator") && doc["estimator"].is_object()) name = doc["estimator"].value("name", "");
  if (const EstimatorEntry* e = find(name)) return e;
  for (const auto& e : entries_)
    for (const auto& f : results_files_of(e.results_file))
      if (f == file_name) return &e;
  return nullptr;
}

namespace {

// The estimator's name, version and default results file where the result does not state them.
void fill_in(const EstimatorEntry& e, FitResult& r) {
  if (r.summary.estimator.empty()) r.summary.estimator = e.name;
  if (r.summary.version.empty()) r.summary.version = e.version;
  if (r.results_file.empty()) r.results_file = e.results_file;
}

}  // namespace

FitResult Registry::read(const nlohmann::json& doc, const std::string& file_name) const {
  const EstimatorEntry* e = for_results(doc, file_name);
  FitResult r = e != nullptr && e->read ? e->read(doc) : read_fit_document(doc);
  r.document = doc;
  if (e != nullptr) fill_in(*e, r);
  if (r.results_file.empty()) r.results_file = file_name;
  return r;
}

FitSummary Registry::summarize(const nlohmann::json& doc, const std::string& file_name) const {
  return read(doc, file_name).summary;
}

namespace {

// A YAML model file's root; nullopt when the file is not YAML (the estimator reads it and says
// what is wrong).
std::optional<YAML::Node> model_root_of(const std::string& model_file) {
  try {
    return yaml::load_file(model_file, "model file");
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The model of a model file whose `instrument:` the recording lacks (why_absent), or whose
// temperature terms it cannot feed (why_no_temperature), not applicable; nullopt when the file names
// no instrument or the recording has what it needs.
std::optional<InstrumentModel> absent_instrument(const EstimatorRequest& request) {
  if (request.recording == nullptr || request.model_file.empty()) return std::nullopt;
  const auto root = model_root_of(request.model_file);
  if (!root) return std::nullopt;
  const auto inst = instrument_from_name(model_instrument(*root));
  if (!inst) return std::nullopt;
  std::string why = why_absent(request.recording->header.info, *inst);
  if (why.empty()) why = why_no_temperature(request.recording->header.info, model_temperature_terms(*root));
  if (why.empty()) return std::nullopt;
  model::ErrorModel m;
  m.instrument = *inst;
  return not_applicable(m, why);
}

}  // namespace

FitResult fit(const EstimatorEntry& entry, const EstimatorRequest& request) {
  if (auto absent = absent_instrument(request)) {
    FitResult r = not_applicable_fit(entry.name, entry.version, std::move(*absent));
    r.text = r.summary.FullReport();
    fill_in(entry, r);
    return r;
  }
  if (entry.fit) {
    FitResult r = entry.fit(request);
    fill_in(entry, r);
    return r;
  }
  const EstimatorResult out = entry.create()->fit(request);
  FitResult r;
  if (out.json.empty() && !out.ok) {
    r = failed_fit(entry.name, entry.version, out.message);
  } else {
    const nlohmann::json doc = nlohmann::json::parse(out.json, nullptr, false);
    const nlohmann::json readable = doc.is_discarded() ? nlohmann::json::object() : doc;
    r = entry.read ? entry.read(readable) : read_fit_document(readable);
    r.document = readable;
    r.document_text = out.json;  // written as the plugin gave it
    // The plugin's own word on its success.
    r.summary.status = out.ok ? FitStatus::kOk : FitStatus::kFailed;
    if (!out.message.empty()) r.summary.message = out.message;
  }
  r.text = out.text;
  r.results_file = out.json_name;
  fill_in(entry, r);
  return r;
}

std::string Registry::names() const {
  std::string out;
  for (const auto& e : entries_) out += (out.empty() ? "" : ", ") + e.name;
  return out;
}

}  // namespace stend::estimation
