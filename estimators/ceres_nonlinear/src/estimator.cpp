// ceres_nonlinear as an Estimator and its registry entry (see stend/ceres_nonlinear/estimator.hpp).
#include "stend/ceres_nonlinear/estimator.hpp"
#include "report_section.hpp"

#include "stend/ceres_nonlinear/model_file.hpp"

#include <nlohmann/json.hpp>

#include <stdexcept>

namespace stend::ceres_nonlinear {

namespace {

// The typed fit: the results document as ceres.json holds it, read back by read_results, so a fit
// and its results file give the same typed result (the document holds no value its text would
// change: non-finite numbers are written as null).
estimation::FitResult fit_typed(const EstimatorRequest& req) {
  if (req.recording == nullptr) throw std::invalid_argument("ceres_nonlinear: no recording given");
  const ModelFileFit f = fit_model_file(*req.recording, load_model_file(req.model_file));
  estimation::FitResult r = read_results(f.document);
  r.document_text = f.document.dump(2);
  r.text = f.text;
  return r;
}

}  // namespace

CeresNonlinearEstimator::CeresNonlinearEstimator(const Params& p) : config_(fields().read(p)) {}

const stend::fields::Table<estimation::EstimatorConfig>& CeresNonlinearEstimator::fields() {
  static const stend::fields::Table<estimation::EstimatorConfig> table(
      kEstimatorName, estimation::estimator_fields(), {kResultsFile});
  return table;
}

EstimatorResult CeresNonlinearEstimator::fit(const EstimatorRequest& req) {
  const estimation::FitResult r = fit_typed(req);
  return {r.ok(), r.summary.message, r.document_text, r.text, config_.results_file};
}

estimation::EstimatorEntry estimator_entry() {
  estimation::EstimatorEntry e;
  e.name = kEstimatorName;
  e.version = kEstimatorVersion;
  e.description = kDescription;
  e.results_file = kResultsFile;
  e.claims = [](const YAML::Node& root) { return root.IsMap() && root["ceres_nonlinear"]; };
  e.create = [] { return PluginPtr<Estimator>(new CeresNonlinearEstimator(), [](Estimator* p) { delete p; }); };
  e.report = report_section;
  e.fit = fit_typed;
  e.read = read_results;
  return e;
}

}  // namespace stend::ceres_nonlinear
