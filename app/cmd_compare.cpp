// `stend compare [--db F] [RUN...] [--procedure FP] [-o HTML]` — compares units and vendors across
// runs measured with the same procedure (same procedure fingerprint), and refuses otherwise.
#include "commands.hpp"

#include "stend/files.hpp"
#include "stend/reporting/compare.hpp"
#include "stend/reporting/results_store.hpp"

#include <fmt/format.h>

#include <iostream>
#include <set>

namespace stend::cli {

void add_compare_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand(
      "compare", "Compare units and vendors measured with the same procedure (table + HTML report)");
  static std::vector<std::string> runs;
  static std::string db, procedure, html;
  sub->add_option("runs", runs, "Run folders (recorded into the database first) or run names already in it");
  sub->add_option("--db", db, kDbOptionHelp);
  sub->add_option("--procedure", procedure, "Compare every run in the database with this procedure fingerprint "
                                            "(or a prefix of at least 8 hex digits)");
  sub->add_option("-o,--output", html, "HTML report (default: compare-<fingerprint>.html beside the database)");
  out.push_back({sub, [] {
                   namespace fs = std::filesystem;
                   namespace rp = stend::reporting;
                   const std::string location = rp::results_store_location(
                       db, !runs.empty() && fs::is_directory(runs.front()) ? fs::path(runs.front()) : fs::path());
                   if (runs.empty() && !rp::is_postgres_location(location) && !fs::exists(location)) {
                     fmt::print(stderr, "stend compare: no results database at {} (give --db, or run folders)\n",
                                location);
                     return ExitCode::kInvalidInput;
                   }
                   rp::ResultsStore store(location);
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
                                    store.where());
                         return ExitCode::kInvalidInput;
                       }
                       selected.push_back(std::move(rr));
                     }
                   }
                   if (!procedure.empty()) {
                     auto more = store.with_fingerprint(procedure);
                     if (more.empty()) {
                       fmt::print(stderr, "stend compare: no run in {} has procedure fingerprint {}\n", store.where(),
                                  procedure);
                       return ExitCode::kInvalidInput;
                     }
                     std::set<std::string> have;  // a set, not a scan per run: campaigns hold thousands
                     for (const auto& s : selected) have.insert(s.dir.string());
                     for (auto& m : more)
                       if (have.insert(m.dir.string()).second) selected.push_back(std::move(m));
                   }
                   if (runs.empty() && procedure.empty()) selected = store.all();
                   const rp::Comparison c = rp::compare_runs(selected);  // ComparisonRefused: an input error
                   std::cout << rp::comparison_text(c);
                   fs::path report = html;
                   if (report.empty())
                     report = (store.is_postgres() ? fs::current_path() : fs::absolute(location).parent_path()) / fmt::format("compare-{}.html", c.fingerprint.substr(0, 16));
                   write_file_atomic(report, rp::comparison_html(c));
                   fmt::print("report:     {}\nresults db: {}\n", report.string(), store.where());
                   return ExitCode::kOk;
                 }});
}

}  // namespace stend::cli
