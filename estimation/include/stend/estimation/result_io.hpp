// Reading results documents back as typed results (result.hpp): the parts every estimator's
// reader shares, and the generic reader the registry uses for an entry without its own (estimator
// plugins, registry.hpp).
//
// A `stend.fit/1`-shaped document (estimators/batch_lsq/README.md) carries, beside the summary
// fields (summary.hpp), one instrument's linear error model:
//   "model": {"instrument": "accelerometer" | "gyroscope",
//             "axes": ["x", "y", "z"],                 the output axes fitted (default: all three)
//             "terms": [{"kind": "bias"}, {"kind": "bias_temperature", "order": 2, "reference_c": 25}, …]},
//   "parameters": [{"name": "bias_x", …}, …],           parameters of the model, by the vocabulary's
//                                                        names; the model's others are held at 0 (not in this fit)
//   "correlation": [[1, …], …]                           optional: over "parameters", in their order
// Such a document is an axis-wise fit (Coverage::kAxes).
#pragma once

#include <stend/estimation/result.hpp>

#include <nlohmann/json_fwd.hpp>

#include <optional>
#include <string>

namespace stend::estimation {

// The generic reader: the summary fields, and the `model` section where the document has one.
FitResult read_fit_document(const nlohmann::json& doc);

// The instrument model of a stend.fit/1-shaped document; nullopt when it has no `model` section
// naming an accelerometer or a gyroscope. A failed fit gives a failed model (no numbers); an
// unknown term kind a failed model that names it.
std::optional<InstrumentModel> read_fit_model(const nlohmann::json& doc);

// The typed result of a fit that failed before its estimator wrote a document: its status and
// why, no numbers; its document holds the summary fields.
FitResult failed_fit(const std::string& estimator, const std::string& version, const std::string& message);

// The typed result of a fit whose only instrument is absent from the recording (why_absent): status
// kNotApplicable with the model's message, the model in its slot, no numbers; its document holds
// the summary fields.
FitResult not_applicable_fit(const std::string& estimator, const std::string& version, InstrumentModel model);

// The model slot of `r` for `m`'s instrument (accelerometer or gyroscope), filled with m.
void set_instrument(FitResult& r, InstrumentModel m);

}  // namespace stend::estimation
