// The pieces of the run report every fit shares, written once for every estimator's section
// (report_section.hpp) and for reporting:
//   parameter_table        the parameter table of a FitSummary (display units, verdicts)
//   fit_notes              the aliased groups and warnings of a linear fit (stend.fit/1)
//   static_point_figures   the residual plots of a linear fit on static points (stend.fit/1)
//   temperature_curves     a fitted error model's zero offset and scale-factor error against
//                          temperature, through model::ErrorModel (InstrumentModel::contribution)
//   generic_report_section the section of an estimator that writes none of its own
#pragma once

#include <stend/estimation/instrument_model.hpp>
#include <stend/estimation/report_section.hpp>
#include <stend/estimation/result.hpp>
#include <stend/estimation/summary.hpp>

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

namespace stend::estimation {

// One row per parameter: name, value, unit, standard error, interval (in the parameter's display
// unit, display_unit), and the verdict — "determined", "imprecise: why" or "NO: why"; the rows of
// parameters the data did not identify are marked (Row::Mark::kNotIdentified) and say "not
// estimated" for the value.
Table parameter_table(const FitSummary& summary);

// A stend.fit/1 document's aliased groups (the parameters the data cannot separate, with their
// identified combinations) and its solver warnings, each a warning paragraph.
std::vector<Paragraph> fit_notes(const nlohmann::json& fit);

// A stend.fit/1 document's residual of each static point against the physical quantity the points
// vary in (the tilt, the one true input that varies, or the point number), with ±σ lines; then per
// fitted axis each point's static mean minus the truth against the truth, beside the fitted model.
// `what` starts each title (the estimator's name). None without points and residuals.
std::vector<Figure> static_point_figures(const nlohmann::json& fit, const std::string& what);

// Zero offset [display unit, × display_scale] and scale-factor error [ppm] of output axis k
// (0 x, 1 y, 2 z) against temperature t_lo … t_hi [°C] (81 steps), each as a curve with its interval
// band at the fit's quantile.
struct TemperatureCurves {
  figure::Series offset_band, offset, scale_band, scale;
};
TemperatureCurves temperature_curves(const InstrumentModel& model, double quantile, int k, double t_lo_c,
                                     double t_hi_c, double display_scale);

// The section of a results file whose estimator writes none of its own: its name and version, the
// failure when it failed (no numbers), else the parameter table and the summary's notes.
ReportSection generic_report_section(const FitResult& result);

// The failure paragraph of a failed fit: "<what>: <message> — no numbers are reported." (what: e.g.
// "FIT FAILED").
Paragraph failure_paragraph(const std::string& what, const std::string& message);

}  // namespace stend::estimation
