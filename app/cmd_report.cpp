// `stend report RUN` — (re)builds RUN/report.html and records the run in the results database.
// Also defines write_run_report(), which `stend run` calls at the end of a run.
#include "commands.hpp"

#include "stend/estimators/builtin.hpp"
#include "stend/reporting/results_store.hpp"
#include "stend/reporting/run_report.hpp"

#include <fmt/format.h>

#include <cstdio>

namespace stend::cli {

std::string record_in_store(const std::filesystem::path& run_dir, const std::string& db) {
  stend::reporting::ResultsStore store(stend::reporting::results_store_location(db, run_dir));
  const auto r = stend::reporting::load_run_results(run_dir, estimators::builtin());
  store.add(r);
  fmt::print(human(), "results db: {} (run {}, procedure {}, {} parameter(s))\n", store.where(), r.run_name,
             r.procedure_fingerprint.empty() ? "unknown" : r.procedure_fingerprint.substr(0, 16), r.parameters.size());
  return store.where();
}

void add_report_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("report", "Build RUN/report.html (plots, parameter tables) and record the run in the "
                                           "results database");
  static std::string run, db;
  static bool no_db = false;
  sub->add_option("run", run, "Run folder")->required();
  sub->add_option("--db", db, kDbOptionHelp);
  sub->add_flag("--no-db", no_db, "Do not record the run in the results database");
  add_json_flag(sub, "the report and database written");
  out.push_back({sub, [] {
                   const RunFolderLock lock = lock_run(run);
                   stend::reporting::require_whole_results(run, estimators::builtin());
                   const auto path = stend::reporting::write_run_report(run, estimators::builtin());
                   fmt::print(human(), "report:     {}\n", path.string());
                   const std::string where = no_db ? std::string() : record_in_store(run, db);
                   // docs/schemas/report.schema.json
                   print_json({{"report", path.string()},
                               {"results_db", where.empty() ? nlohmann::json(nullptr) : nlohmann::json(where)}});
                   return ExitCode::kOk;
                 }});
}

std::filesystem::path write_run_report(const std::filesystem::path& run_dir, const std::string& db) {
  const std::filesystem::path path = stend::reporting::write_run_report(run_dir, estimators::builtin());
  try {
    record_in_store(run_dir, db);
  } catch (const std::exception& e) {
    fmt::print(stderr, "run not recorded in the results database: {}\n", e.what());
  }
  return path;
}

}  // namespace stend::cli
