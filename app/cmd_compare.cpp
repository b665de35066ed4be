// `stend compare [--db F] [RUN...] [--procedure FP] [-o HTML]` — compares units and vendors across
// runs measured with the same procedure (same procedure fingerprint), and refuses otherwise.
#include "commands.hpp"

#include "stend/errors.hpp"
#include "stend/files.hpp"
#include "stend/reporting/compare.hpp"
#include "stend/reporting/results_db.hpp"

#include <fmt/format.h>

#include <cstdlib>
#include <iostream>
#include <optional>

namespace stend::cli {

namespace {

namespace fs = std::filesystem;
namespace rp = stend::reporting;

// The database to read: --db (recorded into), else $STEND_RESULTS_DB, else the one beside the
// first run folder; "" when none is named and none exists (nothing is created unasked).
fs::path database_of(const std::vector<std::string>& runs, const std::string& db) {
  if (!db.empty()) return db;
  if (const char* env = std::getenv("STEND_RESULTS_DB"); env && *env) return env;
  if (!runs.empty() && fs::is_directory(runs.front())) {
    const fs::path beside = rp::default_db_path(runs.front());
    if (fs::exists(beside)) return beside;
  }
  return {};
}

// The runs to compare: run folders read directly (and recorded into an explicit --db), names
// looked up in the database, and every run of --procedure; all runs of the database when none.
std::vector<rp::RunResults> select_runs(const std::vector<std::string>& runs, const std::string& procedure,
                                        const fs::path& dbfile, bool record) {
  std::optional<rp::ResultsDb> store;
  if (!dbfile.empty() && (record || fs::exists(dbfile))) store.emplace(dbfile);
  const auto need_db = [&](const std::string& why) -> rp::ResultsDb& {
    if (!store)
      throw InputError("stend compare: " + why + " needs a results database: give --db FILE (or $STEND_RESULTS_DB)" +
                       (dbfile.empty() ? std::string() : "; there is none at " + dbfile.string()));
    return *store;
  };
  std::vector<rp::RunResults> selected;
  for (const auto& r : runs) {
    if (fs::is_directory(r)) {
      rp::RunResults rr = rp::load_run_results(r);
      if (record && store) store->add(rr);
      selected.push_back(std::move(rr));
      continue;
    }
    rp::RunResults rr = need_db("the run name '" + r + "'").find_run(r);
    if (rr.dir.empty())
      throw InputError("stend compare: '" + r + "' is neither a run folder nor a run in " + dbfile.string());
    selected.push_back(std::move(rr));
  }
  if (!procedure.empty()) {
    auto more = need_db("--procedure").with_fingerprint(procedure);
    if (more.empty())
      throw InputError("stend compare: no run in " + dbfile.string() + " has procedure fingerprint " + procedure);
    for (auto& m : more) {
      bool dup = false;
      for (const auto& s : selected) dup = dup || s.dir == m.dir;
      if (!dup) selected.push_back(std::move(m));
    }
  }
  if (runs.empty() && procedure.empty()) selected = need_db("comparing without run folders").all();
  return selected;
}

ExitCode run_compare(const std::vector<std::string>& runs, const std::string& db, const std::string& procedure,
                     const std::string& html) {
  const fs::path dbfile = database_of(runs, db);
  const rp::Comparison c = rp::compare_runs(select_runs(runs, procedure, dbfile, !db.empty()));  // refused: input error
  human_stream() << rp::comparison_text(c);
  nlohmann::json doc = rp::comparison_json(c);
  doc["report"] = nullptr;
  if (!html.empty()) {
    write_file_atomic(html, rp::comparison_html(c));
    fmt::print(human(), "report:     {}\n", html);
    doc["report"] = html;
  } else {
    fmt::print(human(), "report:     none (-o FILE.html writes the HTML report)\n");
  }
  if (!db.empty()) fmt::print(human(), "results db: {}\n", dbfile.string());
  print_json(doc);
  return ExitCode::kOk;
}

}  // namespace

void add_compare_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand(
      "compare", "Compare units and vendors measured with the same procedure (table + HTML report)");
  static std::vector<std::string> runs;
  static std::string db, procedure, html;
  sub->add_option("runs", runs, "Run folders, or run names already in the database");
  sub->add_option("--db", db, "Results database: the run folders given are recorded into it (default, read only: "
                              "$STEND_RESULTS_DB, else stend-results.sqlite beside the first run folder when it exists)");
  sub->add_option("--procedure", procedure, "Compare every run in the database with this procedure fingerprint "
                                            "(or a prefix of at least 8 hex digits)");
  sub->add_option("-o,--out", html, "Write the HTML report to this file (none without it)");
  add_json_flag(sub, "the comparison");
  out.push_back({sub, [] { return run_compare(runs, db, procedure, html); }});
}

}  // namespace stend::cli
