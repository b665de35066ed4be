// temp_poly as an Estimator and its registry entry (see stend/temp_poly/estimator.hpp).
#include "stend/temp_poly/estimator.hpp"
#include "report_section.hpp"

#include "stend/temp_poly/temp_poly.hpp"

#include <nlohmann/json.hpp>

#include <sstream>
#include <stdexcept>

namespace stend::temp_poly {

namespace {

// The typed fit: the document written, then read back by read_results, so a fit and its results
// file give the same typed result.
estimation::FitResult fit_typed(const EstimatorRequest& req) {
  if (req.recording == nullptr) throw std::invalid_argument("temp_poly: no recording given");
  const TempPolyResult r = fit_temperature_model(*req.recording, load_options(req.model_file));
  const std::string document = to_json(r);
  estimation::FitResult out = read_results(nlohmann::json::parse(document));
  out.document_text = document;
  std::ostringstream text;
  print_report(text, r);
  out.text = text.str();
  return out;
}

}  // namespace

TempPolyEstimator::TempPolyEstimator(const Params& p) : config_(fields().read(p)) {}

const stend::fields::Table<estimation::EstimatorConfig>& TempPolyEstimator::fields() {
  static const stend::fields::Table<estimation::EstimatorConfig> table(
      kEstimatorName, estimation::estimator_fields(), {kResultsFile});
  return table;
}

EstimatorResult TempPolyEstimator::fit(const EstimatorRequest& req) {
  const estimation::FitResult r = fit_typed(req);
  return {r.ok(), r.summary.message, r.document_text, r.text, config_.results_file};
}

estimation::EstimatorEntry estimator_entry() {
  estimation::EstimatorEntry e;
  e.name = kEstimatorName;
  e.version = kEstimatorVersion;
  e.description = kDescription;
  e.results_file = kResultsFile;
  e.claims = [](const YAML::Node& root) { return root.IsMap() && (root["selection"] || root["max_order"]); };
  e.create = [] { return PluginPtr<Estimator>(new TempPolyEstimator(), [](Estimator* p) { delete p; }); };
  e.report = report_section;
  e.fit = fit_typed;
  e.read = read_results;
  return e;
}

}  // namespace stend::temp_poly
