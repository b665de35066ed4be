// allan as an Estimator and its registry entry (see stend/allan/estimator.hpp).
#include "stend/allan/estimator.hpp"
#include "report_section.hpp"

#include "stend/allan/allan.hpp"
#include "stend/allan/deviation_report.hpp"
#include "stend/yaml/reader.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <limits>
#include <sstream>
#include <stdexcept>

namespace stend::allan {

AllanEstimator::AllanEstimator(const Params& p) : config_(fields().read(p)) {}

const stend::fields::Table<estimation::EstimatorConfig>& AllanEstimator::fields() {
  static const stend::fields::Table<estimation::EstimatorConfig> table(
      kEstimatorName, estimation::estimator_fields(), {kResultsFile});
  return table;
}

EstimatorResult AllanEstimator::fit(const EstimatorRequest& req) {
  if (req.recording == nullptr) throw std::invalid_argument("allan: no recording given");
  const YAML::Node root = yaml::load_file(req.model_file, "model file");
  const AllanOptions options = options_from_yaml(root["allan"], req.model_file);
  const DeviationRequest deviations = deviations_from_yaml(root["allan"], req.model_file);
  const AllanReport report = analyze_recording(*req.recording, options);
  if (report_failed(report)) {  // says which channel failed and why; no numbers
    std::string why;
    for (const auto& c : report.channels)
      if (!c.model.ok) why += (why.empty() ? "" : "; ") + c.curve.channel.name + ": " + c.model.message;
    return {false, "allan: noise-model fit failed — " + (why.empty() ? std::string("no channel") : why), {}, {},
            config_.results_file};
  }
  std::ostringstream text, json;
  write_summary_table(text, report);
  write_json(json, report);
  if (deviations.empty()) return {true, {}, json.str(), text.str(), config_.results_file};
  const auto devs = recording_deviations(*req.recording, report, deviations, options);
  write_deviation_table(text, devs);
  nlohmann::json doc = nlohmann::json::parse(json.str());
  add_deviations_json(doc, devs, deviations.tau);
  return {true, {}, doc.dump(2), text.str(), config_.results_file};
}

namespace {

constexpr double kConfidence = 0.95;
constexpr double kNormalQuantile = 1.959963984540054;  // two-sided 95 %

// N, K and B of one channel's noise model: value ± the fit's 1 σ, a normal 95 % interval.
estimation::ParameterEstimate coefficient(const nlohmann::json& k, const std::string& name) {
  estimation::ParameterEstimate p;
  p.name = name;
  p.unit = k.value("unit", "");
  p.identifiable = k.value("identified", false);
  if (!p.identifiable) {
    const auto ub = k.find("upper_bound");
    p.reason = ub != k.end() && ub->is_number()
                   ? fmt::format("not identified; upper bound {:.4g} {}", ub->get<double>(), p.unit)
                   : "not identified";
    return p;
  }
  p.value = k.value("value", std::numeric_limits<double>::quiet_NaN());
  p.std_error = k.value("sigma", std::numeric_limits<double>::quiet_NaN());
  p.lower = p.value - kNormalQuantile * p.std_error;
  p.upper = p.value + kNormalQuantile * p.std_error;
  return p;
}

estimation::FitSummary summarize(const nlohmann::json& doc) {
  estimation::FitSummary s = estimation::summary_from_json(doc);
  if (!doc.contains("status")) s.status = estimation::FitStatus::kOk;  // documents before "status": always ran
  s.parameters.clear();
  s.confidence = kConfidence;
  for (const auto& ch : doc.value("channels", nlohmann::json::array())) {
    const std::string c = ch.value("channel", "");
    if (!ch.contains("model") || !ch["model"].is_object()) continue;
    const nlohmann::json& m = ch["model"];
    if (!m.value("ok", false)) {  // the others' numbers stand; this channel's failure is said
      s.message += c + ": " + m.value("message", "") + "; ";
      continue;
    }
    for (const char* symbol : {"N", "K", "B", "G", "Tc"})
      if (m.contains(symbol)) s.parameters.push_back(coefficient(m[symbol], std::string(symbol) + "_" + c));
  }
  return s;
}

}  // namespace

estimation::EstimatorEntry estimator_entry() {
  estimation::EstimatorEntry e;
  e.name = kEstimatorName;
  e.version = kEstimatorVersion;
  e.description = kDescription;
  e.results_file = kResultsFile;
  e.claims = [](const YAML::Node& root) { return root.IsMap() && root["allan"]; };
  e.create = [] { return PluginPtr<Estimator>(new AllanEstimator(), [](Estimator* p) { delete p; }); };
  e.summarize = summarize;
  e.reads_truth = false;
  e.report = report_section;
  return e;
}

}  // namespace stend::allan
