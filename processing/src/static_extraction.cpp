// Static extraction of a segment's constant part. See stend/processing/static_extraction.hpp.
#include "stend/processing/static_extraction.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "stend/processing/butterworth.hpp"

#include <Eigen/Core>

namespace stend::processing {

namespace {

// Index of the first time >= t.
std::size_t lower_index(std::span<const double> t, double at) {
  return static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), at) - t.begin());
}

// The standard error of the mean of x (its mean given) from the sample autocovariances summed to lag
// L = min(⌈2·n^(1/3)⌉, (n − 1)/4), untapered, over 1 − (2L + 1)/n: each γ_k about its own sample
// mean falls short by the mean's variance, so the sum does by (2L + 1) of them
// (StaticValue::correlated_std_error).
double correlated_std_error(std::span<const double> x, double mean) {
  const std::size_t n = x.size();
  if (n < 2) return 0.0;
  const auto lags = std::min<std::size_t>((n - 1) / 4, static_cast<std::size_t>(std::ceil(2.0 * std::cbrt(static_cast<double>(n)))));
  const Eigen::ArrayXd d = Eigen::Map<const Eigen::ArrayXd>(x.data(), static_cast<Eigen::Index>(n)) - mean;
  double v = 0.0;
  for (std::size_t k = 0; k <= lags; ++k) {
    const auto m = static_cast<Eigen::Index>(n - k);  // γ_k = Σ d[i]·d[i−k] / n, a vectorised dot product
    const double g = d.tail(m).matrix().dot(d.head(m).matrix());
    v += (k == 0 ? 1.0 : 2.0) * g / static_cast<double>(n);
  }
  v /= 1.0 - static_cast<double>(2 * lags + 1) / static_cast<double>(n);
  return std::sqrt(std::max(0.0, v) / static_cast<double>(n));
}

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// The segment's samples through the configured low-pass (a copy when Filter::kNone).
std::vector<double> low_pass(std::span<const double> xs, const StaticExtractionSettings& settings,
                             double sample_rate_hz, const std::string& where) {
  if (settings.filter == Filter::kNone) return {xs.begin(), xs.end()};
  SosFilter f;
  try {
    f = butterworth_lowpass(settings.filter_order, settings.cutoff_hz, sample_rate_hz);
  } catch (const std::invalid_argument& e) {
    throw SkipError(SkipReason::kFilter, where + " (sample rate " + num(sample_rate_hz) + " Hz): " +
                                             e.what() + "; lower cutoff_hz");
  }
  return settings.zero_phase ? filtfilt(f, xs) : filter(f, xs, InitialState::kSteadyState);
}

}  // namespace

const char* filter_name(Filter filter) { return filter == Filter::kNone ? "none" : "butterworth"; }

double median_sample_rate(std::span<const double> t) {
  std::vector<double> dt;
  for (std::size_t i = 1; i < t.size(); ++i)
    if (t[i] > t[i - 1]) dt.push_back(t[i] - t[i - 1]);
  if (dt.empty()) return 0.0;
  const auto mid = dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2);
  std::nth_element(dt.begin(), mid, dt.end());
  return 1.0 / *mid;
}

namespace {
// The samples of t in [t_start, t_end].
std::span<const double> segment_of(std::span<const double> t, double t_start_s, double t_end_s) {
  const auto lo = std::lower_bound(t.begin(), t.end(), t_start_s);
  const auto hi = std::upper_bound(t.begin(), t.end(), t_end_s);
  return hi > lo ? t.subspan(static_cast<std::size_t>(lo - t.begin()), static_cast<std::size_t>(hi - lo)) : t.subspan(0, 0);
}
}  // namespace

double segment_sample_rate(std::span<const double> t, double t_start_s, double t_end_s) {
  return median_sample_rate(segment_of(t, t_start_s, t_end_s));
}

StaticValue extract_static(std::span<const double> t, std::span<const double> x, double t_start_s,
                           double t_end_s, const StaticExtractionSettings& settings) {
  return extract_static(t, x, t_start_s, t_end_s, settings, segment_sample_rate(t, t_start_s, t_end_s));
}

StaticValue extract_static(std::span<const double> t, std::span<const double> x, double t_start_s,
                           double t_end_s, const StaticExtractionSettings& settings, double sample_rate_hz) {
  if (t.size() != x.size())
    throw std::invalid_argument("extract_static: time and value arrays differ in length");
  if (!(t_end_s > t_start_s))
    throw SkipError(SkipReason::kTooFewSamples,
                    "extract_static: segment [" + num(t_start_s) + ", " + num(t_end_s) + "] s is empty");
  if (!(settings.settle_s >= 0.0))
    throw std::invalid_argument("extract_static: settle_s must be >= 0");
  const std::span<const double> ts = segment_of(t, t_start_s, t_end_s);
  StaticValue out;
  out.n_segment = ts.size();
  const std::string where = "segment [" + num(t_start_s) + ", " + num(t_end_s) + "] s";
  if (out.n_segment < 8)
    throw SkipError(SkipReason::kTooFewSamples, where + " holds " + std::to_string(out.n_segment) +
                                                    " samples; static extraction needs at least 8");
  const std::span<const double> xs = x.subspan(static_cast<std::size_t>(ts.data() - t.data()), out.n_segment);
  out.sample_rate_hz = sample_rate_hz;
  const std::vector<double> y = low_pass(xs, settings, out.sample_rate_hz, where);

  const double keep_lo = t_start_s + settings.settle_s, keep_hi = t_end_s - settings.settle_s;
  double sum = 0.0, raw_sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < ts.size(); ++i) {
    if (ts[i] < keep_lo || ts[i] > keep_hi) continue;
    if (n == 0) out.t_first_s = ts[i];
    out.t_last_s = ts[i];
    sum += y[i];
    raw_sum += xs[i];
    ++n;
  }
  if (n < 2)
    throw SkipError(SkipReason::kTooFewSamples,
                    where + ": discarding settle_s = " + num(settings.settle_s) + " s at each end leaves " +
                        std::to_string(n) + " samples; shorten settle_s or lengthen the segment");
  out.n_used = n;
  out.mean = sum / static_cast<double>(n);
  out.raw_mean = raw_sum / static_cast<double>(n);
  double ss = 0.0, raw_ss = 0.0;
  for (std::size_t i = 0; i < ts.size(); ++i) {
    if (ts[i] < keep_lo || ts[i] > keep_hi) continue;
    ss += (y[i] - out.mean) * (y[i] - out.mean);
    raw_ss += (xs[i] - out.raw_mean) * (xs[i] - out.raw_mean);
  }
  out.filtered_std = std::sqrt(ss / static_cast<double>(n - 1));
  out.raw_std = std::sqrt(raw_ss / static_cast<double>(n - 1));
  out.white_std_error = out.raw_std / std::sqrt(static_cast<double>(n));
  out.correlated_std_error = correlated_std_error(xs.subspan(lower_index(ts, keep_lo), n), out.raw_mean);
  return out;
}

}  // namespace stend::processing
