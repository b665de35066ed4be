// Timestamp repair shared by every importer: a log's own times are kept when they are usable, and
// rebuilt from the sample rate when they repeat or jitter (e.g. printed with two decimals at
// 200 Hz, so consecutive samples share a time). Real gaps are flagged, never filled. A log written
// in bursts is recognised (find_bursts): its rate is its mean rate, never the rate inside a burst.
#pragma once

#include <stend/io/sample_sink.hpp>
#include <stend/recording/recording.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace stend::io {

// An interval longer than this is a gap [s]: 1.5 periods plus twice the intervals' jitter (both [s];
// the one gap rule of every importer's timestamps).
constexpr double gap_threshold(double period_s, double jitter_s) { return 1.5 * period_s + 2.0 * jitter_s; }

// A logger that writes in bursts: groups of samples a few ms (or 0 ms) apart, the groups further
// apart (e.g. a FIFO drained every 40 ms, each sample stamped as it is read). The one rule, over
// the first kTimestampWindow samples (at least kBurstMinIntervals intervals), with T̄ the mean
// interval (the median over disjoint spans of up to kBurstSpan samples of span / samples, so that
// a few gaps do not move it):
//   bursty  ⇔  median Δt < kBurstInside·T̄  (most samples follow the previous one much sooner than
//              the mean)
//          and fewer than kBurstMiddleShare of the intervals lie within kBurstInside·T̄ …
//              kBurstBetween·T̄  (Δt is bimodal: inside a burst below, between bursts above).
inline constexpr double kBurstInside = 0.5, kBurstBetween = 1.5, kBurstMiddleShare = 0.1;
inline constexpr std::size_t kBurstMinIntervals = 16, kBurstSpan = 256;
// A clean or jittery log (median ≈ mean) is never bursty. Of a bursty log:
//   the rate is the mean rate 1 / mean_interval_s (a line fitted through the logged times over the
//   gap-free runs), not 1 / the median interval (the rate inside a burst);
//   a gap is an interval longer than gap_s = gap_threshold(between_s, median |Δt − between_s| over
//   the intervals between bursts): a lost burst, not every burst's start.
struct Bursts {
  double mean_interval_s = 0.0;  // T̄ fitted through the logged times [s]
  double inside_s = 0.0;         // median interval inside a burst [s] (0: the times repeat)
  double between_s = 0.0;        // median interval between bursts [s]
  double samples = 0.0;          // mean samples per burst: samples / (intervals between bursts + 1)
  double gap_s = 0.0;            // intervals longer than this are gaps [s]

  double rate_hz() const { return 1.0 / mean_interval_s; }
  // "timestamps come in bursts of ~4 samples every 40 ms (2 ms apart inside a burst, 34 ms between
  // bursts)"
  std::string describe() const;
  // "rate taken as the mean rate 100 Hz (a line through the logged times), not 1 / the median
  // interval (500 Hz)"
  std::string rate_text() const;
};
// The burst pattern of a log's first window (the rule above); nullopt when it is not bursty.
std::optional<Bursts> find_bursts(const std::vector<ImuSample>& window);

struct TimestampRepair {
  double rate_hz = 0.0;           // the rate used: given, else fitted over the gap-free runs
  std::size_t repaired = 0;       // samples whose time was rebuilt (moved by more than 1 µs)
  double max_correction_s = 0.0;  // largest |rebuilt − logged| [s]
  std::size_t gaps = 0;           // samples flagged kGapBefore
  std::optional<Bursts> bursts;   // the burst pattern, when the log is bursty
};

// Rules, with T = 1/rate (rate_hz > 0: given; else the median over k-sample spans of span / k, k ≤ 32):
//   jitter J = median |Δt − T| over all intervals;
//   a gap is an interval longer than gap_threshold(T, J) = 1.5·T + 2·J: its second sample is flagged kGapBefore;
//   the times need repair when an interval is shorter than 0.5·T (a repeat or strong jitter);
//   then every gap-free run is rebuilt as t = a_run + i·T', a_run the least-squares intercept of
//   the run and T' = T when the rate was given, else the least-squares slope pooled over the runs;
//   a warning event (source "import") says how many samples moved and the largest correction.
// Times that only go forward by about T are left as logged (gaps still flagged). Fewer than
// three samples: nothing to do. Sets header.info.output_rate_hz when it is 0.
// A bursty log (find_bursts) instead: T = the given rate's period, else Bursts::mean_interval_s;
// gaps longer than Bursts::gap_s; its times are kept when they increase, and rebuilt as above
// (T' = T) only when they repeat (an interval of 0); a warning event states the pattern, the rate
// and what became of the times.
// A log longer than kTimestampWindow samples is repaired a window at a time (TimestampRepairStream).
TimestampRepair repair_timestamps(Recording& rec, double rate_hz = 0.0);

// The look-ahead of the repair [samples]: 64 Ki samples (≈ 6 MiB), 5.5 min at 200 Hz.
inline constexpr std::size_t kTimestampWindow = std::size_t{1} << 16;

// A stage of a sample stream that looks at kTimestampWindow samples at a time: it holds a window,
// process()es it (first: whether it is the stream's first window; prev_t: the logged time [s] of
// the sample before it, NaN for the first) and passes it on to `out`.
class WindowSink : public SampleSink {
 public:
  explicit WindowSink(SampleSink& out) : out_(&out) {}
  void add_samples(const ImuSample* samples, std::size_t count) final;
  std::uint64_t samples() const { return samples_; }

 protected:
  // Processes and passes on what is held (also when nothing came: process() sees an empty first
  // window).
  void pass_rest();
  virtual void process(std::vector<ImuSample>& window, bool first, double prev_t) = 0;

 private:
  void pass_window();
  SampleSink* out_;
  std::vector<ImuSample> window_;
  std::uint64_t windows_ = 0, samples_ = 0;
  double last_t_ = 0.0;  // logged time of the last sample passed on [s]
};

// The same repair on a stream, with memory bounded by kTimestampWindow: samples pass through a
// window at a time to `out`. The first window fixes the rule (T, J, the gap threshold and the
// fitted T'), and sets rec.header.info.output_rate_hz (when 0) before its samples reach `out`;
// each window is then flagged at its gaps (the first sample of a window against the last of the
// one before) and, when one of its intervals is shorter than 0.5·T, rebuilt run by run — a run
// that crosses a window boundary gets an intercept on each side. A log of at most one window is
// repaired exactly as a whole. finish() passes the rest on and adds the warning events to `rec`.
class TimestampRepairStream final : public WindowSink {
 public:
  TimestampRepairStream(Recording& rec, SampleSink& out, double rate_hz = 0.0);
  TimestampRepair finish();

 private:
  void process(std::vector<ImuSample>& window, bool first, double prev_t) override;
  void fix_rule(const std::vector<ImuSample>& first_window);
  // Whether an interval of dt [s] needs the repair: shorter than 0.5·T, or for bursts, ≤ 0 (NaN: no).
  bool too_short(double dt) const;
  bool needs_repair(const std::vector<ImuSample>& s, double prev_t) const;
  void add_warnings();
  Recording* rec_;
  double rate_hz_;
  bool given_ = false, repaired_ = false;
  double T_ = 0.0, J_ = 0.0, gap_s_ = 0.0, T_used_ = 0.0;  // [s]; T_used_ = 0: nothing to repair
  std::optional<Bursts> bursts_;
  TimestampRepair result_;
};

}  // namespace stend::io
