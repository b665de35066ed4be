// The per-run report: one self-contained HTML file (inline CSS and SVG, no script, no external
// resource) with the plots and parameter tables of every results file in a run folder:
//   fit.json / ceres.json  residual against orientation, static means against truth, parameter
//                          table with standard errors, intervals and identifiability
//   temp_poly.json         zero offset and scale against temperature with the fitted polynomials
//                          (band = the fit's interval), order selection, hysteresis
//   allan.json             Allan deviation with its confidence band, fitted model, slope lines
//   gap.json               where the sim-to-real gap lies and how it shrinks term by term
#pragma once

#include <filesystem>
#include <string>

namespace stend::reporting {

// HTML text of the report of `run_dir`. Throws std::runtime_error when run.json is unreadable;
// a results file that does not parse is reported inside the page.
std::string run_report_html(const std::filesystem::path& run_dir);

// Writes run_dir/report.html (replacing it) and returns its path.
std::filesystem::path write_run_report(const std::filesystem::path& run_dir);

// Shared page frame: <!DOCTYPE html> … with the report style sheet; `body` is inserted as is.
std::string html_page(const std::string& title, const std::string& body);

}  // namespace stend::reporting
