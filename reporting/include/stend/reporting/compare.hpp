// Comparison of units and vendors, only across runs measured with the same procedure
// (same procedure fingerprint, see fingerprint.hpp).
//
// For every (estimator, parameter) found in the runs: each unit's value with its interval, and per
// vendor the mean over its units, the unit-to-unit spread (sample standard deviation), the
// interval of the vendor mean (Student t, n − 1 dof, from the unit-to-unit spread) and the median
// of the units' own standard errors (to tell real unit-to-unit spread from measurement noise).
#pragma once

#include "stend/errors.hpp"
#include "stend/reporting/results.hpp"

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace stend::reporting {

// Thrown when the runs were not measured the same way; the message names the fingerprints and the
// runs behind each.
class ComparisonRefused : public InputError {
 public:
  using InputError::InputError;
};

struct UnitValue {
  std::string run_name, vendor, model, serial;
  ParameterResult p;
};

struct VendorStats {
  std::string vendor;  // "vendor model"
  int runs = 0;               // runs with this parameter
  int units = 0;              // … of distinct units (by serial; a run without a serial is a unit of its own)
  int identified = 0;         // runs where it was identifiable
  double mean = NAN;          // over identified runs
  double spread_sd = NAN;     // run-to-run sample SD (NaN with < 2 runs): unit-to-unit when each unit ran once
  std::string count_text() const;  // "3 units", "1 unit (3 runs)"
  double mean_lo = NAN, mean_hi = NAN;  // 95 % interval of the vendor mean
  double median_std_error = NAN;        // typical within-unit 1-σ
};

struct ParameterComparison {
  std::string estimator, name, unit;
  std::vector<VendorStats> vendors;
  std::vector<UnitValue> units;  // grouped by vendor
};

struct Comparison {
  std::string fingerprint;
  std::vector<RunResults> runs;
  std::vector<ParameterComparison> parameters;
  const ParameterComparison* find(const std::string& estimator, const std::string& name) const;
};

// Throws ComparisonRefused when the runs' fingerprints differ (or a run has none), or when fewer
// than one run is given.
Comparison compare_runs(const std::vector<RunResults>& runs);

// Plain-text comparison table (one row per parameter and vendor).
std::string comparison_text(const Comparison& c);
// The comparison as JSON (`stend compare --json`, docs/schemas/compare.schema.json): fingerprint,
// runs, and per parameter the vendors' statistics and the units' values (null where not finite).
nlohmann::json comparison_json(const Comparison& c);

// Self-contained HTML report: table and one plot per parameter (units with intervals, grouped by
// vendor, vendor means with their intervals).
std::string comparison_html(const Comparison& c);

}  // namespace stend::reporting
