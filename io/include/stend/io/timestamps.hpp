// Timestamp repair shared by every importer: a log's own times are kept when they are usable, and
// rebuilt from the sample rate when they repeat or jitter (e.g. printed with two decimals at
// 200 Hz, so consecutive samples share a time). Real gaps are flagged, never filled.
#pragma once

#include <stend/io/sample_sink.hpp>
#include <stend/recording/recording.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace stend::io {

struct TimestampRepair {
  double rate_hz = 0.0;           // the rate used: given, else fitted over the gap-free runs
  std::size_t repaired = 0;       // samples whose time was rebuilt (moved by more than 1 µs)
  double max_correction_s = 0.0;  // largest |rebuilt − logged| [s]
  std::size_t gaps = 0;           // samples flagged kGapBefore
};

// Rules, with T = 1/rate (rate_hz > 0: given; else the median over k-sample spans of span / k, k ≤ 32):
//   jitter J = median |Δt − T| over all intervals;
//   a gap is an interval longer than 1.5·T + 2·J: its second sample is flagged kGapBefore;
//   the times need repair when an interval is shorter than 0.5·T (a repeat or strong jitter);
//   then every gap-free run is rebuilt as t = a_run + i·T', a_run the least-squares intercept of
//   the run and T' = T when the rate was given, else the least-squares slope pooled over the runs;
//   a warning event (source "import") says how many samples moved and the largest correction.
// Times that only go forward by about T are left as logged (gaps still flagged). Fewer than
// three samples: nothing to do. Sets header.info.output_rate_hz when it is 0.
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
  Recording* rec_;
  double rate_hz_;
  bool given_ = false, repaired_ = false;
  double T_ = 0.0, J_ = 0.0, gap_s_ = 0.0, T_used_ = 0.0;  // [s]; T_used_ = 0: nothing to repair
  TimestampRepair result_;
};

}  // namespace stend::io
