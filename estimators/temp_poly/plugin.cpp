// temp_poly as an estimator plugin (kind estimator): the registry's TempPolyEstimator behind the
// plugin entry point, for hosts that load estimators as plugins.
#include <stend/sdk.hpp>
#include <stend/temp_poly/estimator.hpp>
#include <stend/temp_poly/temp_poly.hpp>


STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, stend::temp_poly::kEstimatorName, stend::temp_poly::kEstimatorVersion,
                    stend::temp_poly::kDescription, stend::temp_poly::TempPolyEstimator::fields(), stend::temp_poly::TempPolyEstimator)
