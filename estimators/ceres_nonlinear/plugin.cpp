// ceres_nonlinear as an estimator plugin (kind estimator): the registry's CeresNonlinearEstimator
// behind the plugin entry point, for hosts that load estimators as plugins.
#include <stend/ceres_nonlinear/estimator.hpp>
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/sdk.hpp>

#include <cmath>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", stend::ceres_nonlinear::kResultsFile, NAN, NAN, nullptr,
     "default name of the results file"},
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::ceres_nonlinear::kEstimatorName,
                    stend::ceres_nonlinear::kEstimatorVersion, stend::ceres_nonlinear::kDescription, kParams,
                    stend::ceres_nonlinear::CeresNonlinearEstimator)
