// The results store: for every recorded run, the sensor identity (vendor, model, serial), the
// procedure fingerprint, the estimators (name, version) and every parameter with its standard
// error, interval and identifiability. One interface, the schema and its versioned migrations
// written once (results_store.cpp), two backends:
//   - SQLite (default, one bench): a file path, e.g. runs/stend-results.sqlite;
//   - PostgreSQL (a lab, several benches): a libpq URL, postgresql://user@host:port/db.
// Credentials come only from libpq's environment (PGPASSWORD, PGSERVICE) or ~/.pgpass, never from
// experiment files; every location printed goes through redact_url. docs/reports.md (schema),
// docs/lab-scale.md (PostgreSQL, campaigns).
//
// Writes are idempotent upserts keyed by the run (its absolute folder, `run_dir`) and the result
// kind (the estimator): recording a run again replaces its rows, from any number of writers at
// once, without losing or duplicating one.
#pragma once

#include "stend/reporting/results.hpp"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace stend::reporting {

namespace sql {
class Connection;
}

// The schema version this Stend writes (meta.schema_version); older stores are migrated.
// 1: runs, estimators, parameters. 2: one row per (run, estimator), insertion order kept (seq),
// indexes for vendor/model and parameter name. 3: whole results documents by (run, kind): gap.json.
inline constexpr int kResultsStoreSchemaVersion = 3;

// Where a command records or reads results: `given` (--db) when not empty, else
// $STEND_RESULTS_DB, else `stend-results.sqlite` in the folder that holds `run_dir` (the runs of
// one output directory share one database), else (no run_dir) ./stend-results.sqlite.
std::string results_store_location(const std::string& given, const std::filesystem::path& run_dir = {});

// A PostgreSQL URL (postgresql:// or postgres://) rather than an SQLite file path.
bool is_postgres_location(const std::string& location);

// `location` as it may be printed or logged: the password of a URL (user:PASSWORD@) and any
// password=… parameter replaced by ***.
std::string redact_url(const std::string& location);

// What `stend db check` finds.
struct StoreCheck {
  int schema_version = 0;
  long long runs = 0, estimators = 0, parameters = 0, documents = 0;
  long long duplicate_runs = 0;        // run folders held more than once
  long long duplicate_estimators = 0;  // (run, estimator) held more than once
  long long duplicate_parameters = 0;  // (run, estimator, parameter) held more than once
  long long duplicate_documents = 0;   // (run, kind) held more than once
  long long orphan_estimators = 0;     // estimator rows without their run
  long long orphan_parameters = 0;     // parameter rows without their (run, estimator)
  long long orphan_documents = 0;      // document rows without their run
  bool ok() const;
  std::string print() const;
  bool equals(const StoreCheck& o) const;
};

struct MigrationReport {
  int from = 0, to = 0;  // schema versions before and after
  std::string print() const;
};

class ResultsStore {
 public:
  // How the store is opened. kMigrate: bring the schema up to date first (SQLite: always, as a
  // single bench expects). kRequireCurrent: refuse (InputError naming `stend db migrate`) a store
  // whose schema is older — what a PostgreSQL writer does, so that schema changes are made once,
  // on purpose, by a role allowed to make them. kAsIs: neither (`stend db migrate|check`).
  // kDefault: kMigrate for SQLite, kRequireCurrent for PostgreSQL.
  enum class Open { kDefault, kMigrate, kRequireCurrent, kAsIs };

  // Opens (an SQLite file is created when missing). Throws IoError naming the (redacted) location
  // when it cannot be reached, InputError when its schema is newer than this Stend's or (PostgreSQL,
  // kDefault) older.
  explicit ResultsStore(const std::string& location, Open open = Open::kDefault);
  ~ResultsStore();
  ResultsStore(const ResultsStore&) = delete;
  ResultsStore& operator=(const ResultsStore&) = delete;

  // Applies the migrations this store lacks, each version in one transaction.
  MigrationReport migrate();
  int schema_version() const;

  // Upserts one run with its estimators, parameters and documents (gap.json) in one transaction;
  // returns its row id.
  long long add(const RunResults& r);
  // Every run, or those with a fingerprint (exact, or a prefix of at least 8 hex digits).
  std::vector<RunResults> all() const;
  std::vector<RunResults> with_fingerprint(const std::string& fingerprint) const;
  // A run by folder (absolute path) or by folder name; an empty `dir` when absent.
  RunResults find_run(const std::string& dir_or_name) const;
  StoreCheck check() const;

  // The location as it may be printed (redact_url).
  std::string where() const;
  bool is_postgres() const;

 private:
  std::vector<RunResults> query(const std::string& where, const std::vector<std::string>& args) const;
  std::unique_ptr<sql::Connection> db_;
};

}  // namespace stend::reporting
