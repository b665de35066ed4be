// batch_lsq as an estimator plugin (kind estimator): the registry's BatchLsqEstimator behind the
// plugin entry point, for hosts that load estimators as plugins.
#include <stend/batch_lsq/batch_lsq.hpp>
#include <stend/batch_lsq/estimator.hpp>
#include <stend/sdk.hpp>

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::batch_lsq::kEstimatorName, stend::batch_lsq::kEstimatorVersion,
                    stend::batch_lsq::kDescription, stend::batch_lsq::BatchLsqEstimator::fields(), stend::batch_lsq::BatchLsqEstimator)
