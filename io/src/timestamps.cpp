// Timestamp repair. See stend/io/timestamps.hpp.
#include <stend/io/timestamps.hpp>

#include "import_event.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>
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
// disjoint spans, k = n/8 clamped to 1 … max_k (spans long enough to average rounding out, and many
// enough that a few gaps do not move the median).
double robust_interval(const std::vector<ImuSample>& s, std::size_t max_k = 32) {
  const std::size_t k = std::clamp<std::size_t>(s.size() / 8, 1, max_k);
  std::vector<double> spans;
  for (std::size_t i = 0; i + k < s.size(); i += k) spans.push_back((s[i + k].t_s - s[i].t_s) / static_cast<double>(k));
  return median(spans);
}


// Start index of every gap-free run (the first is 0): a run starts after an interval longer than
// gap_s [s].
std::vector<std::size_t> run_starts(const std::vector<ImuSample>& s, double gap_s) {
  std::vector<std::size_t> starts{0};
  for (std::size_t i = 1; i < s.size(); ++i)
    if (s[i].t_s - s[i - 1].t_s > gap_s) starts.push_back(i);
  return starts;
}

// run_starts, with the sample after each gap flagged, and s[0] when it follows prev_t [s] (the
// sample before the window; NaN: none) by more than gap_s.
std::vector<std::size_t> flag_gaps(std::vector<ImuSample>& s, double gap_s, double prev_t = kNoPrevious) {
  const std::vector<std::size_t> starts = run_starts(s, gap_s);
  if (!s.empty() && s[0].t_s - prev_t > gap_s) s[0].flags |= kGapBefore;
  for (std::size_t r = 1; r < starts.size(); ++r) s[starts[r]].flags |= kGapBefore;
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

std::string ms(double seconds) { return num(seconds * 1e3) + " ms"; }

// A rough figure of a pattern: three significant digits.
std::string rough(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// Δt of consecutive samples [s].
std::vector<double> intervals(const std::vector<ImuSample>& s) {
  std::vector<double> d;
  d.reserve(s.size() > 0 ? s.size() - 1 : 0);
  for (std::size_t i = 1; i < s.size(); ++i) d.push_back(s[i].t_s - s[i - 1].t_s);
  return d;
}

// Whether intervals `d` with mean interval T [s] are bursty: the median below kBurstInside·T and
// fewer than kBurstMiddleShare of them between kBurstInside·T and kBurstBetween·T.
bool bimodal_below_mean(const std::vector<double>& d, double T) {
  const auto middle = std::count_if(d.begin(), d.end(), [T](double x) {
    return x >= kBurstInside * T && x <= kBurstBetween * T;
  });
  return median(d) < kBurstInside * T && static_cast<double>(middle) < kBurstMiddleShare * static_cast<double>(d.size());
}

// The intervals inside bursts (below kBurstInside·T) and between them (above kBurstBetween·T).
std::pair<std::vector<double>, std::vector<double>> split_modes(const std::vector<double>& d, double T) {
  std::pair<std::vector<double>, std::vector<double>> modes;
  for (const double x : d) {
    if (x < kBurstInside * T) modes.first.push_back(x);
    if (x > kBurstBetween * T) modes.second.push_back(x);
  }
  return modes;
}

// Median |x − centre| over `v`.
double median_distance(const std::vector<double>& v, double centre) {
  std::vector<double> d;
  d.reserve(v.size());
  for (const double x : v) d.push_back(std::abs(x - centre));
  return median(std::move(d));
}

// Median |Δt − T| [s]: how far logged intervals stray from the rate (0 for clean times).
double jitter(const std::vector<ImuSample>& s, double T) { return median_distance(intervals(s), T); }

}  // namespace

std::string Bursts::describe() const {
  return "timestamps come in bursts of ~" + rough(samples) + " samples every " + rough(samples * mean_interval_s * 1e3) +
         " ms (" + rough(inside_s * 1e3) + " ms apart inside a burst, " + rough(between_s * 1e3) + " ms between bursts)";
}

std::string Bursts::rate_text() const {
  return "rate taken as the mean rate " + num(rate_hz()) + " Hz (a line through the logged times), not 1 / the " +
         "median interval" + (inside_s > 0.0 ? " (" + num(1.0 / inside_s) + " Hz)" : std::string());
}

std::optional<Bursts> find_bursts(const std::vector<ImuSample>& s) {
  const std::vector<double> d = intervals(s);
  if (d.size() < kBurstMinIntervals) return std::nullopt;
  const double T = robust_interval(s, kBurstSpan);
  if (!(T > 0.0) || !bimodal_below_mean(d, T)) return std::nullopt;
  const auto [inside, between] = split_modes(d, T);
  if (between.empty()) return std::nullopt;
  Bursts b;
  b.inside_s = median(inside);
  b.between_s = median(between);
  b.gap_s = gap_threshold(b.between_s, median_distance(between, b.between_s));
  b.samples = static_cast<double>(s.size()) / static_cast<double>(between.size() + 1);
  b.mean_interval_s = pooled_slope(s, run_starts(s, b.gap_s));
  if (!(b.mean_interval_s > 0.0)) return std::nullopt;
  return b;
}

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

// The rule, from the first window: T, J, the gap threshold, T' (see stend/io/timestamps.hpp).
void TimestampRepairStream::fix_rule(const std::vector<ImuSample>& s) {
  given_ = rate_hz_ > 0.0;
  bursts_ = find_bursts(s);
  T_ = given_ ? 1.0 / rate_hz_ : bursts_ ? bursts_->mean_interval_s : robust_interval(s);
  if (!(T_ > 0.0)) return;
  J_ = jitter(s, T_);
  gap_s_ = bursts_ ? bursts_->gap_s : gap_threshold(T_, J_);
  const bool fit_slope = !given_ && !bursts_ && needs_repair(s, kNoPrevious);
  T_used_ = fit_slope ? pooled_slope(s, run_starts(s, gap_s_)) : T_;
  result_.rate_hz = 1.0 / T_used_;
  result_.bursts = bursts_;
  if (rec_->header.info.output_rate_hz <= 0.0) rec_->header.info.output_rate_hz = result_.rate_hz;
}

bool TimestampRepairStream::too_short(double dt) const { return bursts_ ? dt <= 0.0 : dt < 0.5 * T_; }

// Any interval too_short, s[0] after prev_t included.
bool TimestampRepairStream::needs_repair(const std::vector<ImuSample>& s, double prev_t) const {
  if (!s.empty() && too_short(s[0].t_s - prev_t)) return true;
  for (std::size_t i = 1; i < s.size(); ++i)
    if (too_short(s[i].t_s - s[i - 1].t_s)) return true;
  return false;
}

// Every window is flagged at its gaps and, when it needs it, rebuilt.
void TimestampRepairStream::process(std::vector<ImuSample>& s, bool first, double prev_t) {
  if (first && s.size() >= 3) fix_rule(s);
  if (!(T_used_ > 0.0)) return;
  const bool gap_first = !s.empty() && s[0].t_s - prev_t > gap_s_;
  const std::vector<std::size_t> starts = flag_gaps(s, gap_s_, prev_t);
  result_.gaps += starts.size() - 1 + (gap_first ? 1 : 0);
  if (needs_repair(s, prev_t)) {
    rebuild(s, starts, T_used_, result_);
    repaired_ = true;
  }
}

namespace {

// What became of the times: moved (how many, the largest correction) or kept.
std::string times_text(const TimestampRepair& r, bool repaired, std::uint64_t samples) {
  if (!repaired) return "the samples' own times are kept";
  return std::to_string(r.repaired) + " of " + std::to_string(samples) + " sample times rebuilt from the rate " +
         num(r.rate_hz) + " Hz";
}

}  // namespace

void TimestampRepairStream::add_warnings() {
  const std::string largest = ", largest correction " + ms(result_.max_correction_s);
  if (bursts_)
    add_import_event(*rec_,
                     bursts_->describe() + ": " +
                         (given_ ? "rate " + num(result_.rate_hz) + " Hz as given" : bursts_->rate_text()) + "; " +
                         (repaired_ ? "the times repeat inside a burst, so " : "") +
                         times_text(result_, repaired_, samples()) + (repaired_ ? largest : ""),
                     "warning");
  else if (repaired_)
    add_import_event(*rec_,
                     "timestamps repeat or jitter (logged intervals stray by " + ms(J_) + " median from " + ms(T_) +
                         "): " + times_text(result_, true, samples()) + " (" +
                         (given_ ? "given" : "fitted to the logged times") + ")" + largest,
                     "warning");
  if (result_.gaps > 0)
    add_import_event(*rec_, std::to_string(result_.gaps) + " gap(s) in the logged times (intervals longer than " +
                                ms(gap_s_) + ") flagged, not filled",
                     "warning");
}

TimestampRepair TimestampRepairStream::finish() {
  pass_rest();
  add_warnings();
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
