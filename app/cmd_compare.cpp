// `stend compare [--db F] [RUN...] [--procedure FP] [-o HTML]` — compares units and vendors across
// runs measured with the same procedure (same procedure fingerprint), and refuses otherwise.
#include "commands.hpp"

#include "stend/files.hpp"
#include "stend/reporting/compare.hpp"
#include "stend/reporting/results_db.hpp"

#include <fmt/format.h>

#include <iostream>

namespace stend::cli {

void add_compare_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand(
      "compare", "Compare units and vendors measured with the same procedure (table + HTML report)");
  static std::vector<std::string> runs;
  static std::string db, procedure, html;
  sub->add_option("runs", runs, "Run folders (recorded into the database first) or run names already in it");
  sub->add_option("--db", db, "Results database (default: $STEND_RESULTS_DB, else stend-results.sqlite beside the "
                              "first run folder, else ./stend-results.sqlite)");
  sub->add_option("--procedure", procedure, "Compare every run in the database with this procedure fingerprint "
                                            "(or a prefix of at least 8 hex digits)");
  sub->add_option("-o,--output", html, "HTML report (default: compare-<fingerprint>.html beside the database)");
  out.push_back({sub, [] {
                   namespace fs = std::filesystem;
                   namespace rp = stend::reporting;
                   fs::path dbfile = db;
                   if (dbfile.empty()) {
                     if (!runs.empty() && fs::is_directory(runs.front())) dbfile = rp::default_db_path(runs.front());
                     else if (const char* env = std::getenv("STEND_RESULTS_DB"); env && *env) dbfile = env;
                     else dbfile = "stend-results.sqlite";
                   }
                   if (runs.empty() && !fs::exists(dbfile)) {
                     fmt::print(stderr, "stend compare: no results database at {} (give --db, or run folders)\n",
                                dbfile.string());
                     return ExitCode::kInvalidInput;
                   }
                   rp::ResultsDb store(dbfile);
                   std::vector<rp::RunResults> selected;
                   for (const auto& r : runs) {
                     if (fs::is_directory(r)) {
                       rp::RunResults rr = rp::load_run_results(r);
                       store.add(rr);
                       selected.push_back(std::move(rr));
                     } else {
                       rp::RunResults rr = store.find_run(r);
                       if (rr.dir.empty()) {
                         fmt::print(stderr, "stend compare: '{}' is neither a run folder nor a run in {}\n", r,
                                    dbfile.string());
                         return ExitCode::kInvalidInput;
                       }
                       selected.push_back(std::move(rr));
                     }
                   }
                   if (!procedure.empty()) {
                     auto more = store.with_fingerprint(procedure);
                     if (more.empty()) {
                       fmt::print(stderr, "stend compare: no run in {} has procedure fingerprint {}\n", dbfile.string(),
                                  procedure);
                       return ExitCode::kInvalidInput;
                     }
                     for (auto& m : more) {
                       bool dup = false;
                       for (const auto& s : selected) dup = dup || s.dir == m.dir;
                       if (!dup) selected.push_back(std::move(m));
                     }
                   }
                   if (runs.empty() && procedure.empty()) selected = store.all();
                   const rp::Comparison c = rp::compare_runs(selected);  // ComparisonRefused: an input error
                   std::cout << rp::comparison_text(c);
                   fs::path report = html;
                   if (report.empty())
                     report = fs::absolute(dbfile).parent_path() / fmt::format("compare-{}.html", c.fingerprint.substr(0, 16));
                   write_file_atomic(report, rp::comparison_html(c));
                   fmt::print("report:     {}\nresults db: {}\n", report.string(), dbfile.string());
                   return ExitCode::kOk;
                 }});
}

}  // namespace stend::cli
