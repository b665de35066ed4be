// Run-folder results: identity, fingerprint and parameters of every estimator (see results.hpp).
#include "stend/reporting/results.hpp"

#include "stend/reporting/fingerprint.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>
#include <stdexcept>

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
  if (!in) throw std::runtime_error(p.string() + ": cannot open");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// "stend.fit/1"-shaped parameters (batch_lsq, ceres_nonlinear and each temp_poly axis).
void fit_parameters(const json& fit, const std::string& estimator, std::vector<ParameterResult>& out) {
  if (!fit.is_object() || !fit.contains("parameters") || !fit["parameters"].is_array()) return;
  double confidence = NAN;
  if (fit.contains("solution") && fit["solution"].is_object()) confidence = num_or_nan(fit["solution"], "confidence");
  if (!std::isfinite(confidence)) confidence = num_or_nan(fit, "confidence");
  for (const auto& p : fit["parameters"]) {
    ParameterResult r;
    r.estimator = estimator;
    r.name = str_or(p, "name");
    r.unit = str_or(p, "unit");
    r.identifiable = p.value("identifiable", false);
    r.value = num_or_nan(p, "value");
    r.std_error = num_or_nan(p, "std_error");
    if (p.contains("interval") && p["interval"].is_array() && p["interval"].size() == 2 &&
        p["interval"][0].is_number() && p["interval"][1].is_number()) {
      r.lo = p["interval"][0].get<double>();
      r.hi = p["interval"][1].get<double>();
    }
    r.confidence = confidence;
    r.reason = str_or(p, "reason");
    if (!r.identifiable && r.reason.empty()) r.reason = "not identifiable";
    if (!r.identifiable) r.value = r.std_error = r.lo = r.hi = NAN;  // never a default
    out.push_back(std::move(r));
  }
}

}  // namespace

const ParameterResult* RunResults::find(const std::string& estimator, const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name && (estimator.empty() || p.estimator == estimator)) return &p;
  return nullptr;
}

std::vector<ParameterResult> parameters_of(const json& doc, const std::string& file_stem, EstimatorUse* use) {
  std::vector<ParameterResult> out;
  EstimatorUse u;
  const std::string schema = str_or(doc, "schema");
  if (doc.contains("estimator") && doc["estimator"].is_string()) u.name = doc["estimator"].get<std::string>();
  if (doc.contains("estimator") && doc["estimator"].is_object()) {
    u.name = str_or(doc["estimator"], "name");
    u.version = str_or(doc["estimator"], "version");
  }
  if (schema.rfind("stend.temp_poly/", 0) == 0) {
    if (u.name.empty()) u.name = "temp_poly";
    const bool ok = doc.value("ok", false);
    u.status = ok ? "ok" : "failed";
    u.message = str_or(doc, "message");
    if (ok && doc.contains("axes"))
      for (const auto& ax : doc["axes"])
        if (ax.value("ok", false) && ax.contains("fit")) fit_parameters(ax["fit"], u.name, out);
  } else if (doc.contains("channels") && doc.contains("kalibr")) {  // allan.json
    if (u.name.empty()) u.name = "allan";
    u.status = "ok";
    for (const auto& ch : doc["channels"]) {
      const std::string c = str_or(ch, "channel");
      if (!ch.contains("model") || !ch["model"].is_object()) continue;
      const json& m = ch["model"];
      if (!m.value("ok", false)) {
        u.message += fmt::format("{}: {}; ", c, str_or(m, "message"));
        continue;
      }
      for (const char* sym : {"N", "K", "B"}) {
        if (!m.contains(sym)) continue;
        const json& k = m[sym];
        ParameterResult r;
        r.estimator = u.name;
        r.name = std::string(sym) + "_" + c;
        r.unit = str_or(k, "unit");
        r.identifiable = k.value("identified", false);
        r.confidence = 0.95;
        if (r.identifiable) {
          r.value = num_or_nan(k, "value");
          r.std_error = num_or_nan(k, "sigma");
          r.lo = r.value - 1.959963984540054 * r.std_error;  // normal, the fit's 1-σ (approximate)
          r.hi = r.value + 1.959963984540054 * r.std_error;
        } else {
          const double ub = num_or_nan(k, "upper_bound");
          r.reason = std::isfinite(ub) ? fmt::format("not identified; upper bound {:.4g} {}", ub, r.unit)
                                       : "not identified";
        }
        out.push_back(std::move(r));
      }
    }
  } else {  // stend.fit/1 (batch_lsq) or a ceres document with the same parameter shape
    if (u.name.empty()) u.name = file_stem == "ceres" ? "ceres_nonlinear" : file_stem == "fit" ? "batch_lsq" : file_stem;
    const std::string status = doc.contains("status") && doc["status"].is_string() ? doc["status"].get<std::string>()
                               : doc.value("ok", true)                              ? "ok"
                                                                                    : "failed";
    u.status = status == "ok" ? "ok" : "failed";
    u.message = str_or(doc, "message");
    if (u.status == "ok") fit_parameters(doc, u.name, out);
  }
  if (use) *use = u;
  return out;
}

RunResults load_run_results(const fs::path& run_dir) {
  RunResults r;
  r.dir = fs::absolute(run_dir).lexically_normal();
  if (!r.dir.has_filename()) r.dir = r.dir.parent_path();
  r.run_name = r.dir.filename().string();
  json run;
  try {
    run = json::parse(read_text(r.dir / "run.json"));
  } catch (const json::exception& e) {
    throw std::runtime_error((r.dir / "run.json").string() + ": " + e.what());
  }
  r.experiment = str_or(run, "experiment_name");
  r.run_status = str_or(run, "status");
  r.start_time_utc = str_or(run, "start_time_utc");
  r.stend_version = str_or(run, "stend_version");
  if (run.contains("sensor") && run["sensor"].contains("identity")) {
    const json& id = run["sensor"]["identity"];
    r.vendor = str_or(id, "vendor");
    r.model = str_or(id, "model");
    r.serial = str_or(id, "serial");
  }
  if (fs::exists(r.dir / "experiment.yaml")) {
    try {
      r.procedure_canonical = canonical_procedure(read_text(r.dir / "experiment.yaml"));
      r.procedure_fingerprint = sha256_hex(r.procedure_canonical);
    } catch (const std::exception& e) {
      r.notes.push_back(std::string("no procedure fingerprint: ") + e.what());
    }
  } else {
    r.notes.push_back("no experiment.yaml: no procedure fingerprint");
  }
  for (const char* stem : {"fit", "ceres", "temp_poly", "allan"}) {
    const fs::path f = r.dir / (std::string(stem) + ".json");
    if (!fs::exists(f)) continue;
    try {
      EstimatorUse use;
      auto ps = parameters_of(json::parse(read_text(f)), stem, &use);
      use.file = f.filename().string();
      r.estimators.push_back(use);
      r.parameters.insert(r.parameters.end(), ps.begin(), ps.end());
    } catch (const std::exception& e) {
      r.notes.push_back(f.filename().string() + " not read: " + e.what());
    }
  }
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
  j["notes"] = r.notes;
  return j;
}

RunResults from_json(const json& j) {
  if (str_or(j, "schema") != kResultsSchema)
    throw std::runtime_error("not a " + std::string(kResultsSchema) + " document (schema '" + str_or(j, "schema") + "')");
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
  if (j.contains("notes"))
    for (const auto& n : j["notes"]) r.notes.push_back(n.get<std::string>());
  return r;
}

}  // namespace stend::reporting
