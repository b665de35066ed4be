// The noise-stage section of `stend gap validate` (validate_noise.cpp): text and JSON. Internal
// to stend_gap_validation.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <iosfwd>
#include <vector>

#include "stend/diagnosis/validate.hpp"

namespace stend::diagnosis::noise_stage {

void print_validation(std::ostream& os, const std::vector<NoiseStageValidation>& v, double seconds);
void add_json(nlohmann::json& j, const std::vector<NoiseStageValidation>& v, double seconds);

}  // namespace stend::diagnosis::noise_stage
