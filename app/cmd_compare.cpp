// `stend compare [--db F] [RUN...] [--procedure FP] [-o HTML]` — compares units and vendors across
// runs measured with the same procedure (same procedure fingerprint), and refuses otherwise.
#include "commands.hpp"

#include "stend/errors.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/recording/files.hpp"
#include "stend/reporting/compare.hpp"
#include "stend/reporting/results_store.hpp"

#include <fmt/format.h>

#include <algorithm>

#include <cstdlib>
#include <iostream>
#include <optional>
#include <set>

namespace stend::cli {

namespace {

namespace fs = std::filesystem;
namespace rp = stend::reporting;

// The store to read: --db (recorded into), else $STEND_RESULTS_DB, else the SQLite file beside
// the first run folder (results_store_location); "" when that is an SQLite file that does not
// exist and none was named (nothing is created unasked); an SQLite --db that does not exist is
// created only to record the run folders given, else refused (reading creates no store).
std::string store_of(const std::vector<std::string>& runs, const std::string& db) {
  const bool records = std::any_of(runs.begin(), runs.end(), [](const std::string& r) { return fs::is_directory(r); });
  if (!db.empty() && !rp::is_postgres_location(db) && !fs::exists(db) && !records)
    throw InputError("stend compare: no results store at " + db + " (reading creates none; `stend db migrate --db " +
                     db + "` creates one, and run folders given to compare are recorded into it)");
  const bool beside_run = !runs.empty() && fs::is_directory(runs.front());
  const std::string location = rp::results_store_location(db, beside_run ? fs::path(runs.front()) : fs::path());
  if (!db.empty() || rp::is_postgres_location(location) || fs::exists(location)) return location;
  return {};
}

// The runs to compare: run folders read directly (and recorded into an explicit --db), names
// looked up in the database, and every run of --procedure; all runs of the database when none.
std::vector<rp::RunResults> select_runs(const std::vector<std::string>& runs, const std::string& procedure,
                                        const std::string& location, bool record) {
  std::optional<rp::ResultsStore> store;
  if (!location.empty()) store.emplace(location);
  const auto need_db = [&](const std::string& why) -> rp::ResultsStore& {
    if (!store)
      throw InputError("stend compare: " + why +
                       " needs a results store: give --db FILE|postgresql://… (or $STEND_RESULTS_DB)");
    return *store;
  };
  std::vector<rp::RunResults> selected;
  for (const auto& r : runs) {
    if (fs::is_directory(r)) {
      rp::RunResults rr = rp::load_run_results(r, estimators::builtin());
      if (record && store) store->add(rr);
      selected.push_back(std::move(rr));
      continue;
    }
    rp::RunResults rr = need_db("the run name '" + r + "'").find_run(r);
    if (rr.dir.empty())
      throw InputError("stend compare: '" + r + "' is neither a run folder nor a run in " + store->where());
    selected.push_back(std::move(rr));
  }
  if (!procedure.empty()) {
    auto more = need_db("--procedure").with_fingerprint(procedure);
    if (more.empty())
      throw InputError("stend compare: no run in " + store->where() + " has procedure fingerprint " + procedure);
    std::set<std::string> have;  // a set, not a scan per run: campaigns hold thousands
    for (const auto& s : selected) have.insert(s.dir.string());
    for (auto& m : more)
      if (have.insert(m.dir.string()).second) selected.push_back(std::move(m));
  }
  if (runs.empty() && procedure.empty()) selected = need_db("comparing without run folders").all();
  return selected;
}

ExitCode run_compare(const std::vector<std::string>& runs, const std::string& db, const std::string& procedure,
                     const std::string& html) {
  const std::string location = store_of(runs, db);
  const rp::Comparison c = rp::compare_runs(select_runs(runs, procedure, location, !db.empty()));  // refused: input error
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
  if (!db.empty()) fmt::print(human(), "results db: {}\n", rp::redact_url(location));
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
  sub->add_option("--db", db, std::string(kDbOptionHelp) + "; run folders given are recorded into --db only, "
                              "the default store is only read (and only when it exists)");
  sub->add_option("--procedure", procedure, "Compare every run in the database with this procedure fingerprint "
                                            "(or a prefix of at least 8 hex digits)");
  sub->add_option("-o,--out", html, "Write the HTML report to this file (none without it)");
  add_json_flag(sub, "the comparison");
  out.push_back({sub, [] { return run_compare(runs, db, procedure, html); }});
}

}  // namespace stend::cli
