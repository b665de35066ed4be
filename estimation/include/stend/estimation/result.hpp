// The typed result of an estimator, end to end: what `stend fit` prints and writes, and what the
// reports, the results database, `stend compare`, `stend apply` and the exports read back — all
// through the estimator's registry entry (registry.hpp), never by guessing an estimator from a
// document's shape.
//
//   recording ──entry.fit──► FitResult (typed parts + the results document the estimator wrote)
//   results document ──entry.read──► FitResult ──► report section, calibration, exports
//
// An estimator's results document (its own schema) and its reader live in its own folder
// (estimators/<name>/), beside its one writer; a result carries the document (`document`), so the
// estimator's own report code can reach its details, and the typed parts every consumer reads:
//   summary      status, message, every parameter with its verdict (summary.hpp);
//   accelerometer, gyroscope   the fitted error model of each instrument (instrument_model.hpp);
//   noise        the noise coefficients of each channel (noise.hpp).
#pragma once

#include <stend/estimation/instrument_model.hpp>
#include <stend/estimation/noise.hpp>
#include <stend/estimation/summary.hpp>

#include <nlohmann/json.hpp>

#include <iosfwd>
#include <optional>
#include <string>

namespace stend::estimation {

struct FitResult {
  FitSummary summary;  // status, message, every parameter with its verdict, notes
  std::optional<InstrumentModel> accelerometer, gyroscope;  // the instruments the fit modelled
  std::optional<NoiseResult> noise;                         // a noise analysis's coefficients
  std::string text;          // the report table `stend fit` prints
  std::string results_file;  // default results file name in the run folder, e.g. "fit.json"
  nlohmann::json document;   // the results document (the estimator's own schema)
  // The document as the estimator serialized it (its key order and layout), when the result comes
  // from a fit: what `stend fit` writes. Empty for a result read back from a file.
  std::string document_text;

  FitStatus status() const { return summary.status; }
  bool ok() const { return summary.ok(); }
  // The model of `instrument`, nullptr when the fit has none.
  const InstrumentModel* instrument(model::Instrument instrument) const;
  // The document to write: document_text, else the document itself (2-space indent).
  std::string written_document() const;

  std::string BriefReport() const { return summary.BriefReport(); }
  // BriefReport, the parameter table and notes, then each instrument model and the noise.
  std::string FullReport() const;
  void print(std::ostream& os) const;  // = FullReport
  // Same summary, instrument models and noise (the document and the texts are not compared).
  bool equals(const FitResult& other, double rel_tol = 1e-9, double abs_tol = 0.0) const;
};
std::ostream& operator<<(std::ostream& os, const FitResult& r);  // = print

}  // namespace stend::estimation
