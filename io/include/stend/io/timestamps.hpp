// Timestamp repair shared by every importer: a log's own times are kept when they are usable, and
// rebuilt from the sample rate when they repeat or jitter (e.g. printed with two decimals at
// 200 Hz, so consecutive samples share a time). Real gaps are flagged, never filled.
#pragma once

#include <stend/recording.hpp>

#include <cstddef>

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
TimestampRepair repair_timestamps(Recording& rec, double rate_hz = 0.0);

}  // namespace stend::io
