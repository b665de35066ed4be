// The results database: one SQLite file holding, for every recorded run, the sensor identity
// (vendor, model, serial), the procedure fingerprint, the estimators (name, version) and every
// parameter with its standard error, interval and identifiability. Schema in docs/reports.md
// (table `meta` holds schema_version = 1).
//
// Default location: $STEND_RESULTS_DB when set, otherwise `stend-results.sqlite` in the folder that
// holds the run folder (so the runs of one output directory share one database).
#pragma once

#include "stend/reporting/results.hpp"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

struct sqlite3;

namespace stend::reporting {

inline constexpr int kResultsDbSchemaVersion = 1;

// Where `stend run` / `stend report` record a run folder by default (see above).
std::filesystem::path default_db_path(const std::filesystem::path& run_dir);

class ResultsDb {
 public:
  // Opens (creating when missing) the database file. Throws std::runtime_error naming the file.
  explicit ResultsDb(const std::filesystem::path& file);
  ~ResultsDb();
  ResultsDb(const ResultsDb&) = delete;
  ResultsDb& operator=(const ResultsDb&) = delete;

  // Inserts or replaces (same absolute run folder) one run with its estimators and parameters, in
  // one transaction. Returns the run's row id.
  long long add(const RunResults& r);
  // Every run, or those with a fingerprint / in a list of run folders (absolute or as recorded).
  std::vector<RunResults> all() const;
  std::vector<RunResults> with_fingerprint(const std::string& fingerprint) const;
  // A run by folder (absolute path) or by folder name; nullopt-like: empty dir when absent.
  RunResults find_run(const std::string& dir_or_name) const;
  const std::filesystem::path& file() const { return file_; }

 private:
  std::vector<RunResults> query(const std::string& where, const std::string& arg) const;
  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
};

}  // namespace stend::reporting
