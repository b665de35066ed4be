// Timestamp repair. See stend/io/timestamps.hpp.
#include <stend/io/timestamps.hpp>

#include "import_event.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace stend::io {

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Sample interval [s] that rounding cannot bias much: the median of (t[i+k] − t[i]) / k over
// disjoint spans, k = n/8 clamped to 1 … 32 (spans long enough to average rounding out, and many
// enough that a few gaps do not move the median).
double robust_interval(const std::vector<ImuSample>& s) {
  const std::size_t k = std::clamp<std::size_t>(s.size() / 8, 1, 32);
  std::vector<double> spans;
  for (std::size_t i = 0; i + k < s.size(); i += k) spans.push_back((s[i + k].t_s - s[i].t_s) / static_cast<double>(k));
  return median(spans);
}

// Median |Δt − T| [s]: how far logged intervals stray from the rate (0 for clean times).
double jitter(const std::vector<ImuSample>& s, double T) {
  std::vector<double> d;
  for (std::size_t i = 1; i < s.size(); ++i) d.push_back(std::abs(s[i].t_s - s[i - 1].t_s - T));
  return median(d);
}

// Start index of every gap-free run (the first is 0); flags the sample after each gap.
std::vector<std::size_t> flag_gaps(std::vector<ImuSample>& s, double gap_s) {
  std::vector<std::size_t> starts{0};
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (s[i].t_s - s[i - 1].t_s > gap_s) {
      s[i].flags |= kGapBefore;
      starts.push_back(i);
    }
  }
  return starts;
}

// Least-squares slope of t against the sample index, pooled over the runs (each its own intercept).
double pooled_slope(const std::vector<ImuSample>& s, const std::vector<std::size_t>& starts) {
  double sxy = 0.0, sxx = 0.0;
  for (std::size_t r = 0; r < starts.size(); ++r) {
    const std::size_t a = starts[r], b = r + 1 < starts.size() ? starts[r + 1] : s.size();
    const double n = static_cast<double>(b - a), ibar = 0.5 * (n - 1.0);
    double tbar = 0.0;
    for (std::size_t i = a; i < b; ++i) tbar += s[i].t_s / n;
    for (std::size_t i = a; i < b; ++i) {
      const double x = static_cast<double>(i - a) - ibar;
      sxy += x * (s[i].t_s - tbar);
      sxx += x * x;
    }
  }
  return sxx > 0.0 ? sxy / sxx : 0.0;
}

// Rebuilds each run as t = a_run + i·T (a_run: the least-squares intercept); fills the counts.
void rebuild(std::vector<ImuSample>& s, const std::vector<std::size_t>& starts, double T, TimestampRepair& out) {
  for (std::size_t r = 0; r < starts.size(); ++r) {
    const std::size_t a = starts[r], b = r + 1 < starts.size() ? starts[r + 1] : s.size();
    double intercept = 0.0;
    for (std::size_t i = a; i < b; ++i) intercept += (s[i].t_s - static_cast<double>(i - a) * T) / static_cast<double>(b - a);
    for (std::size_t i = a; i < b; ++i) {
      const double t = intercept + static_cast<double>(i - a) * T;
      const double c = std::abs(t - s[i].t_s);
      if (c > 1e-6) ++out.repaired;
      out.max_correction_s = std::max(out.max_correction_s, c);
      s[i].t_s = t;
    }
  }
}

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

TimestampRepair repair_timestamps(Recording& rec, double rate_hz) {
  TimestampRepair out;
  auto& s = rec.samples;
  if (s.size() < 3) return out;
  const bool given = rate_hz > 0.0;
  const double T = given ? 1.0 / rate_hz : robust_interval(s);
  if (!(T > 0.0)) return out;  // no time passes: nothing to rebuild from (the caller's checks say so)
  const double J = jitter(s, T);
  const std::vector<std::size_t> starts = flag_gaps(s, 1.5 * T + 2.0 * J);
  out.gaps = starts.size() - 1;
  bool needs_repair = false;
  for (std::size_t i = 1; i < s.size() && !needs_repair; ++i) needs_repair = s[i].t_s - s[i - 1].t_s < 0.5 * T;
  const double T_used = needs_repair && !given ? pooled_slope(s, starts) : T;
  out.rate_hz = 1.0 / T_used;
  if (needs_repair) {
    rebuild(s, starts, T_used, out);
    add_import_event(rec,
              "timestamps repeat or jitter (logged intervals stray by " + num(J * 1e3) + " ms median from " +
                  num(T * 1e3) + " ms): " + std::to_string(out.repaired) + " of " + std::to_string(s.size()) +
                  " sample times rebuilt from the rate " + num(out.rate_hz) + " Hz (" +
                  (given ? "given" : "fitted to the logged times") + "), largest correction " +
                  num(out.max_correction_s * 1e3) + " ms",
              "warning");
  }
  if (out.gaps > 0)
    add_import_event(rec, std::to_string(out.gaps) + " gap(s) in the logged times (intervals longer than " +
                              num((1.5 * T + 2.0 * J) * 1e3) + " ms) flagged, not filled",
                     "warning");
  if (rec.header.info.output_rate_hz <= 0.0) rec.header.info.output_rate_hz = out.rate_hz;
  return out;
}

}  // namespace stend::io
