// allan as an estimator plugin (kind estimator): the registry's AllanEstimator behind the plugin
// entry point, for hosts that load estimators as plugins.
#include <stend/allan/allan.hpp>
#include <stend/allan/estimator.hpp>
#include <stend/sdk.hpp>

#include <cmath>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", stend::allan::kResultsFile, NAN, NAN, nullptr,
     "default name of the results file"},
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::allan::kEstimatorName, stend::allan::kEstimatorVersion,
                    stend::allan::kDescription, kParams, stend::allan::AllanEstimator)
