// Truth means over a window. See stend/processing/truth.hpp.
#include "stend/processing/truth.hpp"

#include <cmath>
#include <limits>

namespace stend::processing {

TruthMean truth_mean(const Recording& rec, std::span<const int> columns, double t0_s, double t1_s) {
  TruthMean out;
  out.values.assign(columns.size(), 0.0);
  const auto truth = rec.recorded_truth();
  const TruthRows r = truth_rows_in(*truth, t0_s, t1_s);
  for_each_truth_row(*truth, r.lo, r.hi, [&](double, const double* values, bool whole) {
    if (!whole) return;
    for (std::size_t c = 0; c < columns.size(); ++c) out.values[c] += values[columns[c]];
    ++out.rows;
  });
  if (out.rows > 0) {
    for (double& v : out.values) v /= static_cast<double>(out.rows);
    out.found = true;
    return out;
  }
  // None inside: the last snapshot before the window, when it is whole.
  if (r.lo > 0) {
    for_each_truth_row(*truth, r.lo - 1, r.lo, [&](double, const double* values, bool whole) {
      if (!whole) return;
      for (std::size_t c = 0; c < columns.size(); ++c) out.values[c] = values[columns[c]];
      out.found = true;
    });
  }
  if (!out.found) out.values.assign(columns.size(), std::numeric_limits<double>::quiet_NaN());
  return out;
}

double truth_mean(const Recording& rec, int column, double t0_s, double t1_s) {
  if (column < 0) return std::numeric_limits<double>::quiet_NaN();
  const int cols[1] = {column};
  return truth_mean(rec, cols, t0_s, t1_s).values[0];
}

double truth_slope(const Recording& rec, int column, double t0_s, double t1_s) {
  if (column < 0) return 0.0;
  const auto truth = rec.recorded_truth();
  const TruthRows r = truth_rows_in(*truth, t0_s, t1_s);
  double n = 0.0, st = 0.0, sy = 0.0, stt = 0.0, sty = 0.0;
  for_each_truth_row(*truth, r.lo, r.hi, [&](double t, const double* values, bool whole) {
    if (!whole) return;
    const double y = values[column];
    st += t;
    sy += y;
    stt += t * t;
    sty += t * y;
    n += 1.0;
  });
  const double den = n * stt - st * st;
  return n >= 2.0 && den > 0.0 ? (n * sty - st * sy) / den : 0.0;
}

}  // namespace stend::processing
