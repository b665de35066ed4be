// The results database of one bench: the SQLite backend of the results store (results_store.hpp),
// under the name the reports and tests have always used.
#pragma once

#include "stend/reporting/results_store.hpp"

#include <filesystem>

namespace stend::reporting {

// Where `stend run` / `stend report` record a run folder by default: $STEND_RESULTS_DB when set,
// otherwise `stend-results.sqlite` in the folder that holds the run folder.
inline std::filesystem::path default_db_path(const std::filesystem::path& run_dir) {
  return results_store_location("", run_dir);
}

using ResultsDb = ResultsStore;

}  // namespace stend::reporting
