// Internal: the run report's section of the sim-to-real gap diagnosis (gap.json, schema
// stend.gap/1, docs/gap-diagnosis.md) — the diagnosis's document, not an estimator's.
#pragma once

#include "stend/estimation/report_section.hpp"

#include <nlohmann/json_fwd.hpp>

namespace stend::reporting::detail {

// Where the gap lies, the segment residuals against temperature and time, how far it shrinks term
// by term, the candidate terms and what stays unexplained. `temperature_recorded`: whether the
// recording has a temperature (without one, the temperature places and plots are left out).
estimation::ReportSection gap_section(const nlohmann::json& gap, bool temperature_recorded);

}  // namespace stend::reporting::detail
