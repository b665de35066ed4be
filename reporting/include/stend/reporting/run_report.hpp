// The per-run report: one self-contained HTML file (inline CSS and SVG, no script, no external
// resource): the run's identity, an overview of the recording, then the section of every results
// file in the run folder, each written by its estimator (the registry entry's `report`,
// stend/estimation/report_section.hpp) — e.g.
//   fit.json / ceres.json  residual against orientation, static means against truth, parameter
//                          table with standard errors, intervals and identifiability
//   temp_poly.json         zero offset and scale against temperature with the fitted polynomials
//                          (band = the fit's interval), order selection, hysteresis
//   allan.json             Allan deviation with its confidence band, fitted model, slope lines
// — and last gap.json: where the sim-to-real gap lies and how it shrinks term by term.
#pragma once

#include <filesystem>
#include <string>

namespace stend::estimation {
class Registry;
}

namespace stend::reporting {

// HTML text of the report of `run_dir`, its results files read through `registry`. Throws
// InputError when the folder is not a readable recording; a results file that does not parse is
// reported inside the page.
std::string run_report_html(const std::filesystem::path& run_dir, const estimation::Registry& registry);

// Writes run_dir/report.html (replacing it) and returns its path.
std::filesystem::path write_run_report(const std::filesystem::path& run_dir, const estimation::Registry& registry);

// Shared page frame: <!DOCTYPE html> … with the report style sheet; `body` is inserted as is.
std::string html_page(const std::string& title, const std::string& body);

}  // namespace stend::reporting
