// temp_poly as an estimator plugin (kind estimator): the registry's TempPolyEstimator behind the
// plugin entry point, for hosts that load estimators as plugins.
#include <stend/sdk.hpp>
#include <stend/temp_poly/estimator.hpp>
#include <stend/temp_poly/temp_poly.hpp>

#include <cmath>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", stend::temp_poly::kResultsFile, NAN, NAN, nullptr,
     "default name of the results file"},
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::temp_poly::kEstimatorName, stend::temp_poly::kEstimatorVersion,
                    stend::temp_poly::kDescription, kParams, stend::temp_poly::TempPolyEstimator)
