// ceres_nonlinear as an estimator plugin (kind estimator): the registry's CeresNonlinearEstimator
// behind the plugin entry point, for hosts that load estimators as plugins.
#include <stend/ceres_nonlinear/estimator.hpp>
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/sdk.hpp>

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::ceres_nonlinear::kEstimatorName,
                    stend::ceres_nonlinear::kEstimatorVersion, stend::ceres_nonlinear::kDescription, stend::ceres_nonlinear::CeresNonlinearEstimator::fields(),
                    stend::ceres_nonlinear::CeresNonlinearEstimator)
