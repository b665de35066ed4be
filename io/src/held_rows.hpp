// The rows of a table of means, held (the static_table and means_table importers): each row's mean
// becomes an orientation segment of kStaticTableHold_s at kStaticTableRate_hz repeating it, with
// its known input where the table has one, and what the table states of the mean's noise — the
// count n and the standard deviation sigma of the samples averaged — held over it in the held-mean
// truth columns (stend/recording/truth_columns.hpp). Processing turns those into the point's noise
// (the standard error of a row's mean is sigma/√n), so the fits weight the rows by them.
#pragma once

#include "import_common.hpp"

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace stend::io::detail {

// A column name as the tables are matched: lower case, split into words at '_', '-', '.' and
// blanks; a last word naming a unit ("mps2", "g") is taken off into `unit`, as is a bracketed unit
// ("ax [g]", "ax (m/s^2)"; another bracket is a comment). "a_x_mps2" → key "ax", unit "mps2";
// "Sigma X" → key "sigmax".
struct ColumnKey {
  std::string key;
  std::string unit;  // "mps2" | "g" | "" (none stated)
};
ColumnKey column_key(const std::string& name);

// Where a table states a row's noise (−1: absent): n, the samples averaged ("n", "count",
// "samples"), and sigma, their standard deviation — one column for all axes ("sigma", "std", "sd")
// or one per axis ("sigma_x", "ax_std", …). Per-axis and scalar sigma are not mixed.
struct SpreadColumns {
  int n = -1;
  int sigma = -1;
  std::array<int, 3> sigma_axis{-1, -1, -1};
  bool per_axis() const { return sigma_axis[0] >= 0; }
  bool has_sigma() const { return sigma >= 0 || per_axis(); }
  // Whether column i is one of them.
  bool uses(int i) const;
  // "n (samples per row) and sigma (one per row, all axes)"; "none" without either.
  std::string describe(const std::vector<std::string>& names) const;
};

// The spread columns among `names`; fails at r's line when a sigma is given both ways, per axis only
// partly, or twice.
SpreadColumns spread_columns(const LineReader& r, const std::vector<std::string>& names);

// One row's stated noise: n (NaN: not stated) and sigma per axis in SI (NaN: not stated).
struct RowSpread {
  double n = kNaN;
  Eigen::Vector3d sigma = Eigen::Vector3d::Constant(kNaN);
};

// The row's spread from its fields `f`, sigma × `sigma_si` (SI per table unit); fails at r's line
// for an n that is not a count ≥ 1 or a sigma that is not a positive number.
RowSpread row_spread(const LineReader& r, const std::vector<std::string_view>& f, const SpreadColumns& c,
                     const std::vector<std::string>& names, double sigma_si);

// Holds one row in `rec`: a new orientation segment labelled `label` whose samples repeat `mean`
// [m/s²] (NaN on an axis the table lacks), and truth snapshots of `inputs` (the values of the truth
// columns before the held-mean ones: none, or kTruthColumns') followed by the row's spread.
void hold_row(Recording& rec, const std::string& label, const Eigen::Vector3d& mean, const std::vector<double>& inputs,
              const RowSpread& spread);

// The header's truth columns for a table whose known inputs are `inputs` (kTruthColumns, or none):
// them, then the held-mean columns.
std::vector<std::string> held_truth_columns(const std::vector<std::string>& inputs);

// After the last row: each segment's orientation count, the rate, no gyroscope, no temperature.
void finish_held_rows(Recording& rec);

// What the import event says of the rows: "each row held as an orientation segment of 20 s at 10 Hz
// repeating its mean (the samples' spread is zero and says nothing about noise); the noise of a row's
// mean: …" — sigma/√n, relative weights, or the fit's residuals — from the columns found.
std::string held_rows_text(const SpreadColumns& c);

}  // namespace stend::io::detail
