// The typed result of an estimator, end to end: what `stend fit` prints and writes, and what the
// reports, the results database, `stend compare`, `stend apply` and the exports read back — all
// through the estimator's registry entry (registry.hpp), never by guessing an estimator from a
// document's shape.
//
//   estimator ──fit──► FitResult ──entry.write──► results document (the estimator's own schema)
//   results document ──entry.read──► FitResult ──► report section, calibration, exports
//
// An estimator's results document and its reader live in its own folder (estimators/<name>/); a
// result carries the document it was written as (`document`), so the estimator's own report code
// can reach its details, and the typed parts every consumer reads.
#pragma once

#include <stend/estimation/summary.hpp>

#include <nlohmann/json.hpp>

#include <string>

namespace stend::estimation {

struct FitResult {
  FitSummary summary;        // status, message, every parameter with its verdict, notes
  std::string text;          // the report table `stend fit` prints
  std::string results_file;  // default results file name in the run folder, e.g. "fit.json"
  nlohmann::json document;   // the results document as the estimator writes it

  bool ok() const { return summary.ok(); }
  std::string BriefReport() const { return summary.BriefReport(); }
  std::string FullReport() const { return summary.FullReport(); }
};

}  // namespace stend::estimation
