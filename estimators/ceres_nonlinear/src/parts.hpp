// Internal to ceres_nonlinear: a model-file fit as its parts (accelerometer, gyroscope) — a part
// whose instrument the recording lacks is not applicable, never a failure (estimation::why_absent),
// and the fit's status comes from its parts' (estimation::combined_status).
#pragma once

#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/estimation/instrument_model.hpp>  // why_absent

#include <string>

namespace stend::ceres_nonlinear::detail {

// A part that was not fitted because its instrument is absent: kNotApplicable, `why` its message,
// no parameters.
CalibrationResult not_applicable_part(model::ErrorModel model, const std::string& why);

// f.status from its parts', each not applicable part named in f.notes ("gyroscope: not applicable
// — why"), then the accelerometer's |a| − g check when it is no measure of accuracy
// (norm_check_caveat), and f.message from them when no part applies (a failure's message is the
// caller's).
void conclude(ModelFileFit& f);

// The report's last line: "ceres_nonlinear: ok", "…: FAILED — why" or "…: not applicable — why",
// then the notes.
std::string status_line(const ModelFileFit& f);

}  // namespace stend::ceres_nonlinear::detail
