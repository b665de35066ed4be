// `stend db migrate|push RUN…|check [--db LOCATION]` — the results store itself: bring its schema
// up to date, upload runs recorded offline (or re-record them), and check that no row is lost or
// duplicated (docs/lab-scale.md).
#include "commands.hpp"

#include "stend/errors.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/reporting/results_store.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <filesystem>

namespace stend::cli {

namespace {

namespace rp = stend::reporting;

ExitCode run_migrate(const std::string& location) {
  rp::ResultsStore store(location, rp::ResultsStore::Open::kAsIs);
  const rp::MigrationReport m = store.migrate();
  fmt::print(human(), "results db: {}\n{}", store.where(), m.print());
  // docs/schemas/db.schema.json
  print_json({{"command", "migrate"}, {"ok", true}, {"store", store.where()}, {"schema_from", m.from}, {"schema_to", m.to}});
  return ExitCode::kOk;
}

ExitCode run_check(const std::string& location) {
  // Checking never creates: an SQLite file that is not there is said, not made empty.
  if (!rp::is_postgres_location(location) && !std::filesystem::exists(location))
    throw InputError("stend db check: no results store at " + location + " (`stend db migrate --db " + location +
                     "` creates one)");
  const rp::ResultsStore store(location, rp::ResultsStore::Open::kAsIs);
  const rp::StoreCheck c = store.check();
  fmt::print(human(), "results db: {}\n{}", store.where(), c.print());
  print_json({{"command", "check"}, {"ok", c.ok()}, {"store", store.where()}, {"schema_version", c.schema_version},
              {"schema_current", rp::kResultsStoreSchemaVersion}, {"runs", c.runs}, {"estimators", c.estimators},
              {"parameters", c.parameters}, {"duplicate_runs", c.duplicate_runs},
              {"duplicate_estimators", c.duplicate_estimators}, {"duplicate_parameters", c.duplicate_parameters},
              {"orphan_estimators", c.orphan_estimators}, {"orphan_parameters", c.orphan_parameters}});
  if (c.ok()) return ExitCode::kOk;
  if (c.schema_version != rp::kResultsStoreSchemaVersion)
    fmt::print(stderr, "stend db check: schema {} is not this Stend's ({}): run `stend db migrate`\n", c.schema_version,
               rp::kResultsStoreSchemaVersion);
  return ExitCode::kInvalidInput;
}

// Records every run folder; a folder that cannot be read is said and skipped, the others recorded.
ExitCode run_push(const std::string& location, const std::vector<std::string>& runs) {
  rp::ResultsStore store(location);
  std::size_t pushed = 0, parameters = 0;
  std::vector<std::string> refused;
  for (const auto& run : runs) {
    try {
      const rp::RunResults r = rp::load_run_results(run, estimators::builtin());
      store.add(r);
      ++pushed;
      parameters += r.parameters.size();
    } catch (const InputError& e) {
      fmt::print(stderr, "not pushed: {}\n", e.what());
      refused.push_back(run);
    }
  }
  fmt::print(human(), "results db: {}\npushed:     {} run(s), {} parameter(s){}\n", store.where(), pushed, parameters,
             refused.empty() ? "" : fmt::format("; {} refused (said above)", refused.size()));
  print_json({{"command", "push"}, {"ok", refused.empty()}, {"store", store.where()}, {"pushed", pushed},
              {"parameters", parameters}, {"refused", refused}});
  return refused.empty() ? ExitCode::kOk : ExitCode::kInvalidInput;
}

}  // namespace

void add_db_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("db", "The results store: migrate its schema, push runs recorded offline, check it");
  sub->require_subcommand(1);
  static std::string db;
  static std::vector<std::string> runs;
  auto* migrate = sub->add_subcommand("migrate", "Bring the store's schema up to this Stend's version (creates it)");
  auto* push = sub->add_subcommand("push", "Record run folders in the store (idempotent: a run pushed again is "
                                           "replaced, never duplicated)");
  auto* check = sub->add_subcommand("check", "Check the store: schema version, counts, no duplicated or orphaned row "
                                             "(exit 2 when not consistent)");
  for (auto* s : {migrate, push, check}) {
    s->add_option("--db", db, kDbOptionHelp);
    add_json_flag(s, "the store and what was done or found");
  }
  push->add_option("runs", runs, "Run folders")->required();
  out.push_back({sub, [migrate, push] {
                   const std::string location =
                       reporting::results_store_location(db, runs.empty() ? std::filesystem::path() : std::filesystem::path(runs.front()));
                   if (*migrate) return run_migrate(location);
                   if (*push) return run_push(location, runs);
                   return run_check(location);
                 }});
}

}  // namespace stend::cli
