// allan as an estimator plugin (kind estimator): the registry's AllanEstimator behind the plugin
// entry point, for hosts that load estimators as plugins.
#include <stend/allan/allan.hpp>
#include <stend/allan/estimator.hpp>
#include <stend/sdk.hpp>

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::allan::kEstimatorName, stend::allan::kEstimatorVersion,
                    stend::allan::kDescription, stend::allan::AllanEstimator::fields(), stend::allan::AllanEstimator)
