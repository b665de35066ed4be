// The typed result every estimator gives: a status, and each fitted parameter with its unit,
// standard error, interval and whether the data identified it. Each estimator keeps its own
// detailed result type and results document; this is the part the program, the reports, the
// results database and `stend compare` read, whichever estimator wrote it.
//
// JSON (the fields every results document carries, read back by summary_from_json):
//   "status": "ok" | "failed" | "not_applicable", "message": "…",
//   "parameters": [{"name", "unit", "value", "std_error", "interval": [lo, hi],
//                   "identifiable", "verdict", "tolerance", "reason"}, …],   non-finite numbers are null
//   ("verdict": "determined" | "imprecise" | "not identifiable", stend/estimation/identifiability.hpp;
//    "tolerance": the precision tolerance in the parameter's unit, null when none applies)
//   "confidence": 0.95   (or "solution": {"confidence": …})
//   "dof": 7   the fit's residual degrees of freedom (or "solution": {"dof": …}); null or absent where
//              none applies (a noise fit)
#pragma once

#include <stend/estimation/identifiability.hpp>

#include <nlohmann/json_fwd.hpp>

#include <cmath>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace stend::estimation {

enum class FitStatus {
  kOk,      // the fit ran and its numbers are results
  kFailed,  // the fit failed: `message` says why, and no number is a result
  // Nothing to fit: the instrument is absent from the recording (`message` says which and why).
  // Not a failure and not a result: no numbers, and it never makes a fit of several parts fail.
  kNotApplicable,
};
const char* to_string(FitStatus s);             // "ok" | "failed" | "not_applicable"
FitStatus fit_status_from_string(const std::string& s);  // those three; anything else is kFailed
// The status of a fit of several parts (its instruments): kFailed when a part failed, else kOk
// when a part gave a result, else kNotApplicable (every part, or no part).
FitStatus combined_status(const std::vector<FitStatus>& parts);
// How a status reads in a report: "ok", "FAILED", "not applicable".
const char* status_text(FitStatus s);

// One parameter of a fit (the linear solver's, every estimator's summary, the reports').
struct ParameterEstimate {
  std::string name;  // the vocabulary's name ("bias_z", "bias_tc1_x") or Allan "N_ax", "K_gz"
  std::string unit;
  bool identifiable = false;
  std::string reason;  // why not identifiable or imprecise (or an upper bound); "" when determined
  // NaN when not identifiable: never a default presented as a result.
  double value = NAN, std_error = NAN;  // std_error: 1 σ
  double lower = NAN, upper = NAN;      // interval at the fit's confidence
  // How precisely the data determine an identified parameter (identifiability.hpp): kDetermined,
  // or kImprecise when std_error exceeds `tolerance` (set by estimation::judge).
  Verdict verdict = Verdict::kDetermined;
  double tolerance = NAN;  // precision tolerance (1 σ) in `unit`; NaN when none applies
  // Not estimated but held at `value` (0) by the estimator's convention — a frame convention, a
  // temperature order the selection did not choose, an axis outside the fit; `reason` says which.
  // A held parameter is not identifiable (it carries no information from the data).
  bool held = false;
  // Held where applying 0 is right, not a guess: a frame convention (the calibrated output does not
  // depend on it), a term the model selection left out, a parameter of an axis outside the fit
  // (left uncalibrated). False where 0 stands for what the data could not see: `stend apply`
  // refuses such a parameter unless the user states its value (calibration.hpp).
  bool zero_is_exact = false;
  // The verdict as reported: kNotIdentifiable when not identifiable, else `verdict`.
  Verdict judged() const { return identifiable ? verdict : Verdict::kNotIdentifiable; }

  // One table row: name, value, unit, std error, [lower, upper], the verdict ("determined",
  // "imprecise: reason") or "NO: reason".
  void print(std::ostream& os) const;
  // Same name, unit and identifiability; numbers equal within |a − b| ≤ abs_tol +
  // rel_tol·max(|a|, |b|) (NaN matches NaN).
  bool equals(const ParameterEstimate& other, double rel_tol = 1e-9, double abs_tol = 0.0) const;
};
std::ostream& operator<<(std::ostream& os, const ParameterEstimate& p);  // = print
// The header of print()'s table, for an interval at `confidence`.
void print_parameter_header(std::ostream& os, double confidence);

// Whether two numbers agree within abs_tol + rel_tol·max(|a|, |b|); NaN matches NaN. The
// comparison of every result type's equals().
bool nearly_equal(double a, double b, double rel_tol, double abs_tol);

// A number in a text report: printf's %.<digits>g, or %.<digits>f when fixed; "n/a" for NaN.
std::string number_text(double v, int digits = 6, bool fixed = false);

struct FitSummary {
  std::string estimator;  // registry name: "batch_lsq", "temp_poly", "allan", "ceres_nonlinear", …
  std::string version;
  FitStatus status = FitStatus::kFailed;
  std::string message;       // why it failed, or "" when it did not
  double confidence = NAN;   // of the intervals
  std::vector<ParameterEstimate> parameters;  // empty when failed
  std::vector<std::string> notes;             // e.g. per-channel failures of an otherwise ok fit
  // The fit's residual degrees of freedom (observations − estimated parameters; of a fit of
  // several parts, the fewest of its parts'); nullopt where none applies (a noise fit).
  std::optional<int> dof;

  bool ok() const { return status == FitStatus::kOk; }
  const ParameterEstimate* find(const std::string& name) const;

  // One line: "batch_lsq 0.1.0: ok — 9 parameters, 7 identified, 12 dof", "…: FAILED — why" or
  // "…: not applicable — why".
  std::string BriefReport() const;
  // BriefReport, then the parameter table and the notes.
  std::string FullReport() const;
  void print(std::ostream& os) const;  // = FullReport
  bool equals(const FitSummary& other, double rel_tol = 1e-9, double abs_tol = 0.0) const;
};

// What a fit's degrees of freedom say about it, as a note; "" when they are enough (at least
// kFewDegreesOfFreedom, identifiability.hpp). dof ≤ 0: its residual is zero by construction.
std::string degrees_of_freedom_note(int dof);
// Sets s.dof and, when they are few, adds degrees_of_freedom_note to s.notes (once).
void state_degrees_of_freedom(FitSummary& s, std::optional<int> dof);

// The summary fields of a results document (see the top of this file), written and read in this
// one place. A failed fit's parameters are not read: it has no numbers. summary_from_json also
// accepts documents whose success is the older `"ok": true|false`.
nlohmann::json to_json(const FitSummary& s);
FitSummary summary_from_json(const nlohmann::json& doc);
// Whether a results document says its fit succeeded: its "status" (or the older "ok").
FitStatus status_of(const nlohmann::json& doc);

}  // namespace stend::estimation
