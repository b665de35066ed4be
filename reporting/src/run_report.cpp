// The per-run HTML report: the page — its head and style sheet, the run's identity, then the
// sections in order (see run_report.hpp).
#include "stend/reporting/run_report.hpp"

#include "stend/estimation/fit_report.hpp"
#include "stend/estimation/registry.hpp"
#include "stend/recording/files.hpp"
#include "stend/recording/recording.hpp"
#include "stend/reporting/results.hpp"
#include "stend/reporting/svg_plot.hpp"
#include "gap_section.hpp"
#include "overview_section.hpp"
#include "section_html.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace stend::reporting {

namespace fs = std::filesystem;
using nlohmann::json;
using svg::escape;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Parses RUN/<name>; a parse failure becomes an error paragraph in `body` (and false).
bool load(const fs::path& dir, const std::string& name, json& out, std::string& body) {
  try {
    out = json::parse(read_text(dir / name));
    return true;
  } catch (const std::exception& e) {
    body += fmt::format("<p class=\"bad\">{}: not readable ({})</p>\n", escape(name), escape(e.what()));
    return false;
  }
}

// The run's identity: experiment, folder, status, sensor, procedure, the estimators whose results
// are in the folder; a warning when the recording is not complete, and the results' notes.
std::string identity(const RunResults& rr) {
  std::string body = fmt::format("<h1>Stend report — {}</h1>\n", escape(rr.run_name));
  body += "<table class=\"meta\">\n";
  auto row = [&](const std::string& k, const std::string& v) {
    body += "<tr><th>" + escape(k) + "</th><td>" + escape(v) + "</td></tr>\n";
  };
  row("experiment", rr.experiment);
  row("run folder", rr.dir.string());
  row("status", rr.run_status);
  row("started (UTC)", rr.start_time_utc);
  row("sensor", rr.vendor + " " + rr.model + (rr.serial.empty() ? "" : " serial " + rr.serial));
  row("procedure fingerprint", rr.procedure_fingerprint.empty() ? "—" : rr.procedure_fingerprint);
  std::string ests;
  for (const auto& e : rr.estimators)
    ests += (ests.empty() ? "" : "; ") + e.name + " " + e.version + " (" + e.file + ", " + e.status + ")";
  row("estimators", ests.empty() ? "none: no results file in this folder (run `stend fit RUN -m MODEL`)" : ests);
  row("stend", rr.stend_version);
  body += "</table>\n";
  if (rr.run_status != to_string(RunStatus::kComplete))
    body += "<p class=\"bad\">This recording is not complete (status " + escape(rr.run_status) +
            "): results describe the data present only.</p>\n";
  for (const auto& n : rr.notes) body += "<p class=\"warn\">" + escape(n) + "</p>\n";
  return body;
}

// Every estimator's results file in the run folder, found through the registry (each entry's
// files, results_files_of), read back as its typed result and drawn as its entry's section (the
// generic one when it has none): error models, then temperature models, then noise, each in the
// registry's order. A file that does not parse is said so first.
std::string estimator_sections(const fs::path& dir, const estimation::Registry& registry) {
  std::string body;
  std::vector<estimation::ReportSection> sections;
  for (const auto& entry : registry.entries())
    for (const auto& name : estimation::results_files_of(entry.results_file)) {
      json doc;
      if (!fs::exists(dir / name) || !load(dir, name, doc, body)) continue;
      const estimation::FitResult result = registry.read(doc, name);
      const estimation::EstimatorEntry* e = registry.for_results(doc, name);
      estimation::ReportSection s =
          e != nullptr && e->report ? e->report(result) : estimation::generic_report_section(result);
      s.file = name;
      sections.push_back(std::move(s));
    }
  std::stable_sort(sections.begin(), sections.end(),
                   [](const auto& a, const auto& b) { return a.topic < b.topic; });
  for (const auto& s : sections) body += detail::section_html(s);
  return body;
}

}  // namespace

std::string html_page(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" + escape(title) +
         "</title>\n<style>\n"
         "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}\n"
         "h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:2em}h3{font-size:1.05em}\n"
         "table{border-collapse:collapse;margin:.5em 0;font-size:.9em}td,th{border:1px solid #ccc;padding:2px 6px;"
         "text-align:left}th{background:#f2f2f2}\n"
         "tr.nid td{color:#a00}.bad{color:#b00;font-weight:bold}.warn{color:#a60}.file{color:#888;font-weight:normal;"
         "font-size:.8em}\n"
         "figure{display:inline-block;margin:.5em 1em .5em 0;vertical-align:top}figcaption{font-size:.8em;color:#555;"
         "max-width:760px}\n"
         "code{background:#f4f4f4;padding:0 3px}\n"
         "</style></head><body>\n" +
         body + "</body></html>\n";
}

std::string run_report_html(const fs::path& run_dir, const estimation::Registry& registry) {
  const RunResults rr = load_run_results(run_dir, registry);
  std::string body = identity(rr);
  bool temperature_recorded = true;  // the gap section's temperature plots need one
  body += detail::section_html(detail::overview_section(rr.dir, temperature_recorded));
  body += estimator_sections(rr.dir, registry);
  json gap;
  if (fs::exists(rr.dir / kGapResultsFile) && load(rr.dir, kGapResultsFile, gap, body)) {
    estimation::ReportSection s = detail::gap_section(gap, temperature_recorded);
    s.file = kGapResultsFile;
    body += detail::section_html(s);
  }
  body += "<p class=\"file\">Written by stend report. Plots are inline SVG; this file needs nothing else.</p>\n";
  return html_page("Stend report — " + rr.run_name, body);
}

fs::path write_run_report(const fs::path& run_dir, const estimation::Registry& registry) {
  const std::string html = run_report_html(run_dir, registry);
  const fs::path out = run_dir / "report.html";
  write_file_atomic(out, html);
  return out;
}

}  // namespace stend::reporting
