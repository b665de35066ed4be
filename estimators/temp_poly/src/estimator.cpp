// temp_poly as an Estimator and its registry entry (see stend/temp_poly/estimator.hpp).
#include "stend/temp_poly/estimator.hpp"
#include "report_section.hpp"

#include "stend/temp_poly/temp_poly.hpp"

#include <nlohmann/json.hpp>

#include <sstream>
#include <stdexcept>

namespace stend::temp_poly {

TempPolyEstimator::TempPolyEstimator(const Params& p) : config_(fields().read(p)) {}

const stend::fields::Table<estimation::EstimatorConfig>& TempPolyEstimator::fields() {
  static const stend::fields::Table<estimation::EstimatorConfig> table(
      kEstimatorName, estimation::estimator_fields(), {kResultsFile});
  return table;
}

EstimatorResult TempPolyEstimator::fit(const EstimatorRequest& req) {
  if (req.recording == nullptr) throw std::invalid_argument("temp_poly: no recording given");
  const TempPolyResult r = fit_temperature_model(*req.recording, load_options(req.model_file));
  std::ostringstream text;
  print_report(text, r);
  return {r.ok, r.message, to_json(r), text.str(), config_.results_file};
}

namespace {

// Each fitted axis carries a stend.fit/1 document: the summary is their parameters together.
estimation::FitSummary summarize(const nlohmann::json& doc) {
  estimation::FitSummary s = estimation::summary_from_json(doc);
  s.parameters.clear();
  if (!s.ok()) return s;
  for (const auto& axis : doc.value("axes", nlohmann::json::array())) {
    if (!axis.contains("fit") || !axis["fit"].is_object()) continue;
    const estimation::FitSummary a = estimation::summary_from_json(axis["fit"]);
    if (!a.ok()) continue;
    if (!std::isfinite(s.confidence)) s.confidence = a.confidence;
    s.parameters.insert(s.parameters.end(), a.parameters.begin(), a.parameters.end());
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
  e.claims = [](const YAML::Node& root) { return root.IsMap() && (root["selection"] || root["max_order"]); };
  e.create = [] { return PluginPtr<Estimator>(new TempPolyEstimator(), [](Estimator* p) { delete p; }); };
  e.summarize = summarize;
  e.report = report_section;
  return e;
}

}  // namespace stend::temp_poly
