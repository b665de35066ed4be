// Magnitude form of the gap (orientations unknown, only |g| known): helpers shared by
// input_magnitude.cpp (building the form) and gap.cpp (diagnosing it). See GapInput::magnitude.
#pragma once

#include "stend/diagnosis/input.hpp"
#include "stend/estimation/static_fit.hpp"

namespace stend::diagnosis {

// Standard error of the segment mean along the estimated gravity direction û [m/s²]:
// sqrt(Σ_a û_a²·se_a²) (axes' noise taken as independent).
double magnitude_std_error(const SegmentData& segment);

// The model as given, fitted on one row per segment: û·(measured − g·û) = û·R(θ; stimulus)·θ
// (R the vocabulary's regressor), uniform weights 1/floor². The fit holds every model parameter
// (param_index = 0…p−1); rotations of the sensor frame come out not identifiable. known_variance:
// the weights as known variances (covariance (AᵀWA)⁺, defined without residual degrees of freedom).
estimation::StaticFit fit_magnitude_rows(const GapInput& input, bool known_variance = false);

}  // namespace stend::diagnosis
