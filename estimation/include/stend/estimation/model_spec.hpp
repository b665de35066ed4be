// The model file of a linear error-model fit (batch_lsq, temp_poly, the gap diagnosis), read from
// YAML:
//
//   instrument: accelerometer          # or gyroscope
//   axes: [z]                          # output axes whose equations enter the fit (default x, y, z)
//   terms:                             # the error-model vocabulary (stend/model/terms.hpp)
//     - bias
//     - scale
//     - cross_axis: {}
//     - bias_temperature: {order: 2, reference_c: 25}
//   extraction:                        # static extraction per segment (paper step 3)
//     filter_order: 6                  # Butterworth order
//     cutoff_hz: 1.0                   # −3 dB frequency
//     settle_s: 2.0                    # discarded at each end of the segment
//     zero_phase: true                 # forward-backward filtering
//   segments: [orientation]            # which segment kinds are static points
//   weighting: none                    # or segment_noise (1/σ² of each segment's mean)
//   confidence: 0.95                   # interval level
//   tolerances: {accel_bias_mg: 1}     # precision tolerances of the verdicts (identifiability.hpp)
//
// extraction, segments (and intervals, detector) are the processing stage's keys
// (stend/processing/options.hpp); those the file does not state come from the recording's
// experiment `processing:` section when it gives them, else from the defaults above (a gyroscope's
// segments default to [rate, orientation]).
//
// Errors are stend::ExperimentError with "FILE:LINE:COLUMN: error: …" messages.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stend/estimation/identifiability.hpp"
#include "stend/model/terms.hpp"
#include "stend/processing/options.hpp"

namespace stend::estimation {

enum class Weighting {
  kNone,          // unit weights; σ² from the residuals (the paper's batch LSQ)
  kSegmentNoise,  // weights 1/se² from each segment's white-noise standard error, still rescaled
                  // by the residual variance
};

struct ModelSpec {
  model::ErrorModel model;
  std::vector<int> axes = {0, 1, 2};  // 0 = x, 1 = y, 2 = z
  processing::ProcessingOptions processing;  // static intervals and extraction (paper steps 1–3)
  Weighting weighting = Weighting::kNone;
  double confidence = 0.95;
  PrecisionTolerances tolerances;  // of each parameter's verdict
  std::string source;  // file the spec came from ("" when built in code)

  // At least one term, each once (g-sensitivity only for a gyroscope), temperature orders 1..6;
  // axes 0..2, each once, at least one; confidence in (0, 1); the tolerances and processing
  // options valid.
  bool IsValid(std::string* error = nullptr) const;
};

ModelSpec parse_model_spec(const std::string& yaml_text, const std::string& source_name = "<model>");
ModelSpec load_model_spec(const std::filesystem::path& file);

// Back to YAML (round-trips through parse_model_spec).
std::string to_yaml(const ModelSpec& spec);

const char* instrument_name(model::Instrument inst);  // "accelerometer" | "gyroscope"
// The instrument instrument_name() names; nullopt for any other name.
std::optional<model::Instrument> instrument_from_name(const std::string& name);
const char* weighting_name(Weighting w);               // "none" | "segment_noise"
char axis_name(int axis);                              // 'x' 'y' 'z'

}  // namespace stend::estimation
