// Timestamp repair. See stend/io/timestamps.hpp.
#include <stend/io/timestamps.hpp>

#include "import_event.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace stend::io {

namespace {

constexpr double kNoPrevious = std::numeric_limits<double>::quiet_NaN();

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

// Start index of every gap-free run (the first is 0); flags the sample after each gap, and s[0]
// when it follows prev_t [s] (the sample before the window; NaN: none) by more than gap_s.
std::vector<std::size_t> flag_gaps(std::vector<ImuSample>& s, double gap_s, double prev_t = kNoPrevious) {
  std::vector<std::size_t> starts{0};
  if (!s.empty() && s[0].t_s - prev_t > gap_s) s[0].flags |= kGapBefore;
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

// Any interval shorter than 0.5·T [s] (a repeat or strong jitter), s[0] after prev_t included.
bool needs_repair(const std::vector<ImuSample>& s, double T, double prev_t) {
  if (!s.empty() && s[0].t_s - prev_t < 0.5 * T) return true;
  for (std::size_t i = 1; i < s.size(); ++i)
    if (s[i].t_s - s[i - 1].t_s < 0.5 * T) return true;
  return false;
}

}  // namespace

void WindowSink::add_samples(const ImuSample* samples, std::size_t count) {
  for (std::size_t i = 0; i < count;) {
    const std::size_t take = std::min(count - i, kTimestampWindow - window_.size());
    window_.insert(window_.end(), samples + i, samples + i + take);
    i += take;
    if (window_.size() == kTimestampWindow) pass_window();
  }
}

void WindowSink::pass_rest() {
  if (!window_.empty() || windows_ == 0) pass_window();
}

void WindowSink::pass_window() {
  const double logged_last = window_.empty() ? last_t_ : window_.back().t_s;
  process(window_, windows_ == 0, windows_ == 0 ? kNoPrevious : last_t_);
  ++windows_;
  last_t_ = logged_last;
  samples_ += window_.size();
  out_->add_samples(window_.data(), window_.size());
  window_.clear();
}

TimestampRepairStream::TimestampRepairStream(Recording& rec, SampleSink& out, double rate_hz)
    : WindowSink(out), rec_(&rec), rate_hz_(rate_hz) {}

// The first window fixes the rule (T, J, the gap threshold, T'); every window is then flagged and,
// when it needs it, rebuilt.
void TimestampRepairStream::process(std::vector<ImuSample>& s, bool first, double prev_t) {
  if (first && s.size() >= 3) {
    given_ = rate_hz_ > 0.0;
    T_ = given_ ? 1.0 / rate_hz_ : robust_interval(s);
    if (T_ > 0.0) {
      J_ = jitter(s, T_);
      gap_s_ = 1.5 * T_ + 2.0 * J_;
      T_used_ = needs_repair(s, T_, kNoPrevious) && !given_ ? pooled_slope(s, flag_gaps(s, gap_s_)) : T_;
      result_.rate_hz = 1.0 / T_used_;
      if (rec_->header.info.output_rate_hz <= 0.0) rec_->header.info.output_rate_hz = result_.rate_hz;
    }
  }
  if (!(T_used_ > 0.0)) return;
  const bool gap_first = !s.empty() && s[0].t_s - prev_t > gap_s_;
  const std::vector<std::size_t> starts = flag_gaps(s, gap_s_, prev_t);
  result_.gaps += starts.size() - 1 + (gap_first ? 1 : 0);
  if (needs_repair(s, T_, prev_t)) {
    rebuild(s, starts, T_used_, result_);
    repaired_ = true;
  }
}

TimestampRepair TimestampRepairStream::finish() {
  pass_rest();
  if (repaired_)
    add_import_event(*rec_,
                     "timestamps repeat or jitter (logged intervals stray by " + num(J_ * 1e3) + " ms median from " +
                         num(T_ * 1e3) + " ms): " + std::to_string(result_.repaired) + " of " +
                         std::to_string(samples()) + " sample times rebuilt from the rate " + num(result_.rate_hz) +
                         " Hz (" + (given_ ? "given" : "fitted to the logged times") + "), largest correction " +
                         num(result_.max_correction_s * 1e3) + " ms",
                     "warning");
  if (result_.gaps > 0)
    add_import_event(*rec_, std::to_string(result_.gaps) + " gap(s) in the logged times (intervals longer than " +
                                num(gap_s_ * 1e3) + " ms) flagged, not filled",
                     "warning");
  return result_;
}

TimestampRepair repair_timestamps(Recording& rec, double rate_hz) {
  std::vector<ImuSample> logged = std::move(rec.samples);
  rec.samples.clear();
  rec.samples.reserve(logged.size());
  VectorSink sink(rec.samples);
  TimestampRepairStream stream(rec, sink, rate_hz);
  stream.add_samples(logged.data(), logged.size());
  logged = {};
  return stream.finish();
}

}  // namespace stend::io
