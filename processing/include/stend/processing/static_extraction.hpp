// Static extraction: the constant part of a signal over a segment, as in the paper's calibration
// procedure (step 3): low-pass with a Butterworth filter, discard a settling time at each end of
// the segment, average what remains. With Filter::kNone the mean is the plain mean of the kept
// samples (what the Ceres calibrations use).
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>

#include "stend/processing/option_problem.hpp"
#include "stend/processing/skip.hpp"

namespace stend::processing {

enum class Filter { kNone, kButterworth };
const char* filter_name(Filter filter);  // "none" | "butterworth"

struct StaticExtractionSettings {
  Filter filter = Filter::kButterworth;
  int filter_order = 6;     // Butterworth order (the paper: 6)
  double cutoff_hz = 1.0;   // −3 dB frequency of the low-pass
  double settle_s = 2.0;    // discarded at the start AND at the end of the segment, after filtering
  bool zero_phase = true;   // forward-backward (no delay) or causal forward filtering

  // The first value out of range (filter_order 1..20, cutoff_hz > 0, settle_s >= 0); IsValid Ceres
  // style, with "KEY: what is wrong" in *message.
  std::optional<OptionProblem> problem() const;
  bool IsValid(std::string* message = nullptr) const;
};

struct StaticValue {
  double mean = 0.0;          // the constant part: mean of the filtered signal over the kept window
                              // (Filter::kNone: = raw_mean)
  double filtered_std = 0.0;  // spread of the filtered signal over the kept window (kNone: raw_std)
  double raw_mean = 0.0;      // mean of the unfiltered samples over the kept window
  double raw_std = 0.0;       // sample standard deviation of the unfiltered samples, kept window
  // raw_std / sqrt(n_used): the standard error of the mean IF the noise is white. Coloured noise
  // (flicker, bias instability, random walk) makes the true error larger.
  double white_std_error = 0.0;
  // The standard error of the raw mean allowing for correlation between nearby samples (a sensor's
  // own low-pass filter): √(Σ_{|k|≤L} γ_k / (n − 2L − 1)), the sample autocovariances γ_k summed to
  // lag L = min(⌈2·n^(1/3)⌉, (n − 1)/4) (untapered: a taper undercounts a filter's correlation;
  // n − 2L − 1: each γ_k about the sample mean falls short by the mean's variance). About
  // white_std_error for white noise (a noisier estimate of it, pooled by its users); slower wander
  // (bias instability) it still misses.
  double correlated_std_error = 0.0;
  std::size_t n_segment = 0;  // samples inside [t_start, t_end]
  std::size_t n_used = 0;     // samples inside the kept window
  double t_first_s = 0.0;     // first and last kept sample times
  double t_last_s = 0.0;
  double sample_rate_hz = 0.0;  // from the median sample interval of the segment
};

// `t` (strictly increasing, seconds) and `x` have the same length. Uses the samples with
// t_start ≤ t ≤ t_end, filters them at the sample rate estimated from their median interval, keeps
// t_start + settle_s ≤ t ≤ t_end − settle_s, and averages. Throws SkipError (a
// std::invalid_argument) with a message saying what to change when the segment has fewer than 8
// samples or its kept window fewer than 2 (settle_s too long for the segment) — kTooFewSamples —,
// or the cutoff is not below the Nyquist frequency — kFilter; std::invalid_argument for
// arrays of different lengths or a negative settle_s.
StaticValue extract_static(std::span<const double> t, std::span<const double> x, double t_start_s,
                           double t_end_s, const StaticExtractionSettings& settings);
// The same for one of several channels sampled at the times t: `sample_rate_hz` is
// segment_sample_rate(t, t_start_s, t_end_s), found once for all of them.
StaticValue extract_static(std::span<const double> t, std::span<const double> x, double t_start_s,
                           double t_end_s, const StaticExtractionSettings& settings, double sample_rate_hz);
// The sample rate extract_static filters at: median_sample_rate of the samples in [t_start, t_end].
double segment_sample_rate(std::span<const double> t, double t_start_s, double t_end_s);

// Estimated sample rate from the median of the positive intervals of t (0 when < 2 samples).
double median_sample_rate(std::span<const double> t);

}  // namespace stend::processing
