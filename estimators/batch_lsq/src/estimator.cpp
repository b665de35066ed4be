// batch_lsq as an Estimator and its registry entry (see stend/batch_lsq/estimator.hpp).
#include "stend/batch_lsq/estimator.hpp"
#include "report_section.hpp"

#include "stend/batch_lsq/batch_lsq.hpp"

#include <sstream>
#include <stdexcept>

namespace stend::batch_lsq {

BatchLsqEstimator::BatchLsqEstimator(const Params& p) : config_(fields().read(p)) {}

const stend::fields::Table<estimation::EstimatorConfig>& BatchLsqEstimator::fields() {
  static const stend::fields::Table<estimation::EstimatorConfig> table(
      kEstimatorName, estimation::estimator_fields(), {kResultsFile});
  return table;
}

EstimatorResult BatchLsqEstimator::fit(const EstimatorRequest& req) {
  if (req.recording == nullptr) throw std::invalid_argument("batch_lsq: no recording given");
  const FitResult r = fit_recording(*req.recording, estimation::load_model_spec(req.model_file));
  std::ostringstream text;
  print_table(text, r);
  return {r.ok, r.message, to_json(r), text.str(), config_.results_file};
}

estimation::EstimatorEntry estimator_entry() {
  estimation::EstimatorEntry e;
  e.name = kEstimatorName;
  e.version = kEstimatorVersion;
  e.description = kDescription;
  e.results_file = kResultsFile;
  e.fallback = true;
  e.linear_model = [](const std::string& file) { return estimation::load_model_spec(file); };
  e.create = [] { return PluginPtr<Estimator>(new BatchLsqEstimator(), [](Estimator* p) { delete p; }); };
  e.report = report_section;
  return e;
}

}  // namespace stend::batch_lsq
