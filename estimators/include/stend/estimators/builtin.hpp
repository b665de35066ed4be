// The registry of the estimators built into this Stend (one per folder of estimators/).
#pragma once

#include <stend/estimation/registry.hpp>

namespace stend::estimators {

estimation::Registry builtin();

}  // namespace stend::estimators
