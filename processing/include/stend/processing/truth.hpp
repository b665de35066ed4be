// The bench truth over a window of a recording — the one rule every estimator and the diagnosis
// use: the mean of the truth snapshots inside the window, else the last snapshot before it (the
// bench held that state). Snapshots are rec.recorded_truth()'s rows in time order, as the
// recording store writes them (read a window at a time: only the rows of the window); a row whose
// width differs from header.truth_columns (a truncated line) is ignored.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "stend/recording/recording.hpp"

namespace stend::processing {

struct TruthMean {
  bool found = false;          // false: no snapshot inside the window and none before it
  std::vector<double> values;  // one per requested column (NaN when not found)
  std::size_t rows = 0;        // snapshots averaged; 0 when the last one before was held
};

// Means of the truth columns `columns` (indices into header.truth_columns, each ≥ 0) over
// [t0_s, t1_s].
TruthMean truth_mean(const Recording& rec, std::span<const int> columns, double t0_s, double t1_s);
// One column; NaN when column < 0 or nothing is found.
double truth_mean(const Recording& rec, int column, double t0_s, double t1_s);

// Least-squares slope [column unit / s] of a truth column over the snapshots inside
// [t0_s, t1_s]; 0 with fewer than two.
double truth_slope(const Recording& rec, int column, double t0_s, double t1_s);

}  // namespace stend::processing
