// batch_lsq as an estimator plugin (kind estimator): the registry's BatchLsqEstimator behind the
// plugin entry point, for hosts that load estimators as plugins.
#include <stend/batch_lsq/batch_lsq.hpp>
#include <stend/batch_lsq/estimator.hpp>
#include <stend/sdk.hpp>

#include <cmath>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", stend::batch_lsq::kResultsFile, NAN, NAN, nullptr,
     "default name of the results file"},
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::batch_lsq::kEstimatorName, stend::batch_lsq::kEstimatorVersion,
                    stend::batch_lsq::kDescription, kParams, stend::batch_lsq::BatchLsqEstimator)
