// Truth means over a window. See stend/processing/truth.hpp.
#include "stend/processing/truth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace stend::processing {

namespace {

struct RowRange {
  std::size_t lo = 0, hi = 0;  // snapshots with t0 ≤ t ≤ t1: lo..hi−1
};

RowRange rows_inside(const Recording& rec, double t0_s, double t1_s) {
  const auto& t = rec.truth_t;
  return {static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), t0_s) - t.begin()),
          static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), t1_s) - t.begin())};
}

bool whole(const Recording& rec, std::size_t row) {
  return rec.truth[row].size() == rec.header.truth_columns.size();
}

}  // namespace

TruthMean truth_mean(const Recording& rec, std::span<const int> columns, double t0_s, double t1_s) {
  TruthMean out;
  out.values.assign(columns.size(), 0.0);
  const RowRange r = rows_inside(rec, t0_s, t1_s);
  for (std::size_t i = r.lo; i < r.hi; ++i) {
    if (!whole(rec, i)) continue;
    for (std::size_t c = 0; c < columns.size(); ++c)
      out.values[c] += rec.truth[i][static_cast<std::size_t>(columns[c])];
    ++out.rows;
  }
  if (out.rows > 0) {
    for (double& v : out.values) v /= static_cast<double>(out.rows);
    out.found = true;
  } else if (r.lo > 0 && whole(rec, r.lo - 1)) {
    for (std::size_t c = 0; c < columns.size(); ++c)
      out.values[c] = rec.truth[r.lo - 1][static_cast<std::size_t>(columns[c])];
    out.found = true;
  } else {
    out.values.assign(columns.size(), std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

double truth_mean(const Recording& rec, int column, double t0_s, double t1_s) {
  if (column < 0) return std::numeric_limits<double>::quiet_NaN();
  const int cols[1] = {column};
  return truth_mean(rec, cols, t0_s, t1_s).values[0];
}

double truth_slope(const Recording& rec, int column, double t0_s, double t1_s) {
  if (column < 0) return 0.0;
  const RowRange r = rows_inside(rec, t0_s, t1_s);
  double n = 0.0, st = 0.0, sy = 0.0, stt = 0.0, sty = 0.0;
  for (std::size_t i = r.lo; i < r.hi; ++i) {
    if (!whole(rec, i)) continue;
    const double t = rec.truth_t[i], y = rec.truth[i][static_cast<std::size_t>(column)];
    st += t;
    sy += y;
    stt += t * t;
    sty += t * y;
    n += 1.0;
  }
  const double den = n * stt - st * st;
  return n >= 2.0 && den > 0.0 ? (n * sty - st * sy) / den : 0.0;
}

}  // namespace stend::processing
