// batch_lsq as an Estimator and its registry entry (see stend/batch_lsq/estimator.hpp).
#include "stend/batch_lsq/estimator.hpp"
#include "report_section.hpp"

#include "stend/batch_lsq/batch_lsq.hpp"
#include "stend/estimation/result_io.hpp"

#include <nlohmann/json.hpp>

#include <sstream>
#include <stdexcept>

namespace stend::batch_lsq {

namespace {

// The typed fit: fit.json (stend.fit/1) is read back by the generic reader of that shape, so a
// fit and its results file give the same typed result.
estimation::FitResult fit_typed(const EstimatorRequest& req) {
  if (req.recording == nullptr) throw std::invalid_argument("batch_lsq: no recording given");
  const FitResult r = fit_recording(*req.recording, estimation::load_model_spec(req.model_file));
  const std::string document = to_json(r);
  estimation::FitResult out = estimation::read_fit_document(nlohmann::json::parse(document));
  out.document_text = document;
  std::ostringstream text;
  print_table(text, r);
  out.text = text.str();
  out.results_file = kResultsFile;
  return out;
}

}  // namespace

BatchLsqEstimator::BatchLsqEstimator(const Params& p) : config_(fields().read(p)) {}

const stend::fields::Table<estimation::EstimatorConfig>& BatchLsqEstimator::fields() {
  static const stend::fields::Table<estimation::EstimatorConfig> table(
      kEstimatorName, estimation::estimator_fields(), {kResultsFile});
  return table;
}

EstimatorResult BatchLsqEstimator::fit(const EstimatorRequest& req) {
  const estimation::FitResult r = fit_typed(req);
  return {r.ok(), r.summary.message, r.document_text, r.text, config_.results_file};
}

estimation::EstimatorEntry estimator_entry() {
  estimation::EstimatorEntry e;
  e.name = kEstimatorName;
  e.version = kEstimatorVersion;
  e.description = kDescription;
  e.results_file = kResultsFile;
  e.fallback = true;
  e.linear_model = [](const std::string& file) { return estimation::load_model_spec(file); };
  e.fit = fit_typed;
  e.read = estimation::read_fit_document;  // fit.json is the stend.fit/1 shape
  e.create = [] { return PluginPtr<Estimator>(new BatchLsqEstimator(), [](Estimator* p) { delete p; }); };
  e.report = report_section;
  return e;
}

}  // namespace stend::batch_lsq
