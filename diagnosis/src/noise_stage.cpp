// stend gap: noise- and output-stage candidates. See noise_stage.hpp for the tests and levels.
#include "noise_stage.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <sstream>

#include "samples.hpp"
#include "stend/noise/noise_model.hpp"
#include "stend/stats/distributions.hpp"
#include "text.hpp"

namespace stend::diagnosis::noise_stage {

namespace {

constexpr int kGroups = 8, kPerGroup = 8, kSub = kGroups * kPerGroup;  // 64 sub-blocks
// The kind of coloured noise is read from the slope of the Allan variance above white over the
// last four octaves of τ (τ_max/16 … τ_max).
constexpr double kSlopeSpan = 16.5;

// Bias bound of a mean of a quantized Gaussian signal: first harmonic of the rounding error
// (a sawtooth with Fourier series Σ (−1)^k (LSB/πk) sin(2πk x/LSB)) damped by the noise's
// characteristic function at 2π/LSB.
double dither_bias_bound(double sigma, double lsb) {
  return lsb / std::numbers::pi * std::exp(-2.0 * std::numbers::pi * std::numbers::pi * sigma * sigma / (lsb * lsb));
}

// Whether a sample counts as clipped on axis a: by the instrument's saturation flag, charged to
// the axis nearest its range; else (no sample of the recording flags) by |value| ≥ range − LSB/2.
bool clipped_sample(const GapInput& in, const ImuSample& x, bool accel, std::uint32_t flag, bool flags_used, int a) {
  bool c = false;
  if (x.flags & flag) {
    int worst = 0;
    for (int b = 1; b < 3; ++b)
      if (std::abs(axis_value(x, accel, b)) > std::abs(axis_value(x, accel, worst))) worst = b;
    c = worst == a;
  }
  if (!flags_used && in.range > 0 && std::abs(axis_value(x, accel, a)) >= in.range - 0.5 * in.lsb) c = true;
  return c;
}

// One axis of a static segment, accumulated a sample at a time: clipped samples (clipped_sample),
// sum, sum of squares and extremes.
struct ClipSums {
  std::size_t clipped = 0;
  double sum = 0, sum2 = 0, vmax = -HUGE_VAL, vmin = HUGE_VAL;
  void add(double v) {
    sum += v;
    sum2 += v * v;
    vmax = std::max(vmax, v);
    vmin = std::min(vmin, v);
  }
};

// Range unknown: the extremes of a window of n samples that count as piles of identical values
// (a run of ≥ 3) when within 2.5 std of the mean (an unclipped Gaussian window of ≥ 16 samples
// reaches beyond that once or twice); a second pass counts their runs and occurrences.
struct PileAtExtremes {
  std::array<double, 2> ext{kNaN, kNaN};  // vmax, vmin; NaN: not a candidate
  std::array<std::size_t, 2> run{0, 0}, best{0, 0}, at{0, 0};
  PileAtExtremes(const ClipSums& s, std::size_t n) {
    const double mean = s.sum / static_cast<double>(n);
    const double sd = std::sqrt(std::max(0.0, s.sum2 / static_cast<double>(n) - mean * mean));
    const double e[2] = {s.vmax, s.vmin};
    for (std::size_t k = 0; k < 2; ++k)
      if (sd > 0 && !(std::abs(e[k] - mean) > 2.5 * sd)) ext[k] = e[k];
  }
  void add(double v) {
    for (std::size_t k = 0; k < 2; ++k) {
      const bool eq = v == ext[k];
      at[k] += eq ? 1 : 0;
      run[k] = eq ? run[k] + 1 : 0;
      best[k] = std::max(best[k], run[k]);
    }
  }
  std::size_t clipped() const { return (best[0] >= 3 ? at[0] : 0) + (best[1] >= 3 ? at[1] : 0); }
};

// Clipped and total samples per axis over the static segments of the model's segment kinds (≥ 16
// samples each), read a chunk at a time. A recording whose sensor flags saturation is judged by
// the flag alone (a value near the range may be an unclipped sample rounded up); otherwise by the
// value.
void count_clipped(GapInput& in, const Recording& rec, bool accel) {
  const std::uint32_t flag = accel ? kAccelSaturated : kGyroSaturated;
  in.clipped_samples.setZero();
  in.static_samples.setZero();
  bool flags_used = false;
  for_each_chunk(rec.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t) {
    flags_used = flags_used || std::any_of(c, c + n, [&](const ImuSample& x) { return (x.flags & flag) != 0; });
  });
  for (const auto& seg : rec.segments) {
    if (!in.spec.processing.selects(seg.kind)) continue;
    const IndexRange w = window_range(rec, seg.t_start_s, seg.t_end_s);
    const auto n = static_cast<std::size_t>(w.size());
    if (n < 16) continue;
    std::array<ClipSums, 3> sums;
    for_each_sample(rec, w, [&](const ImuSample& x) {
      for (int a = 0; a < 3; ++a) {
        auto& s = sums[static_cast<std::size_t>(a)];
        s.clipped += clipped_sample(in, x, accel, flag, flags_used, a) ? 1 : 0;
        s.add(axis_value(x, accel, a));
      }
    });
    if (in.range <= 0) {
      std::array<PileAtExtremes, 3> piles{PileAtExtremes(sums[0], n), PileAtExtremes(sums[1], n),
                                          PileAtExtremes(sums[2], n)};
      for_each_sample(rec, w, [&](const ImuSample& x) {
        for (int a = 0; a < 3; ++a) piles[static_cast<std::size_t>(a)].add(axis_value(x, accel, a));
      });
      for (std::size_t a = 0; a < 3; ++a) sums[a].clipped += piles[a].clipped();
    }
    for (int a = 0; a < 3; ++a) {
      in.static_samples[a] += static_cast<double>(n);
      in.clipped_samples[a] += static_cast<double>(sums[static_cast<std::size_t>(a)].clipped);
    }
  }
}

// Excess Allan deviation over white on axis a: the largest, as bias instability B = excess / 0.664
// with that point's interval, and the weighted slope of ln(avar − white) against ln τ over the
// last four octaves (var(ln avar) ≈ 2/EDF, through the white subtraction ×(avar/e)²).
void allan_excess(GapInput& in, const noise::ChannelResult& r, int a) {
  const double nw = r.model.white.fitted;
  double best = 0.0;
  const double tau_max = r.curve.points.back().tau_s;
  double sw = 0, swx = 0, swy = 0, swxx = 0, swxy = 0;
  int used = 0;
  for (const auto& p : r.curve.points) {
    const double white = nw * nw / p.tau_s;
    const double e = p.avar - white;
    if (e > best * best && std::isfinite(p.adev_lo)) {
      best = std::sqrt(e);
      in.allan_bias_instability[a] = best / noise::kFlickerFloor;
      in.allan_bias_instability_lo[a] = std::sqrt(std::max(0.0, p.adev_lo * p.adev_lo - white)) / noise::kFlickerFloor;
      in.allan_bias_instability_hi[a] = std::sqrt(std::max(0.0, p.adev_hi * p.adev_hi - white)) / noise::kFlickerFloor;
    }
    if (p.tau_s < tau_max / kSlopeSpan || !(e > 0) || !(p.edf > 0)) continue;
    const double w = 1.0 / (2.0 / p.edf * (p.avar / e) * (p.avar / e));
    const double x = std::log(p.tau_s), yy = std::log(e);
    sw += w;
    swx += w * x;
    swy += w * yy;
    swxx += w * x * x;
    swxy += w * x * yy;
    ++used;
  }
  const double det = sw * swxx - swx * swx;
  if (used >= 2 && det > 0) {
    in.allan_slope[a] = (sw * swxy - swx * swy) / det;
    in.allan_slope_se[a] = std::sqrt(sw / det);
  }
}

// Allan deviation of the longest kept window, when ≥ 100 s and ≥ 1000 samples long enough to see
// slopes beyond white: white N, random walk K and the excess over white per axis.
void allan_evidence(GapInput& in, const Recording& rec, bool accel) {
  const SegmentData* longest = nullptr;
  for (const auto& d : in.segments)
    if (!longest || d.averaging_s > longest->averaging_s) longest = &d;
  if (!longest || longest->averaging_s < 100.0) return;
  const SampleSource& src = rec.sample_source();
  const IndexRange w = window_range(rec, longest->point.t_start_s, longest->point.t_end_s);
  const auto n = static_cast<std::size_t>(w.size());
  if (n < 1000) return;
  const std::vector<double> t = read_column(src, Channel::kTime, w.first, w.first + 1),
                            t_last = read_column(src, Channel::kTime, w.last - 1, w.last);
  const double rate = static_cast<double>(n - 1) / (t_last[0] - t[0]);  // [Hz]
  in.allan_window_s = longest->averaging_s;
  noise::AnalysisOptions ao;
  ao.confidence = 0.95;
  for (int a = 0; a < 3; ++a) {
    const auto c = static_cast<Channel>(static_cast<int>(accel ? Channel::kAx : Channel::kGx) + a);
    noise::OverlappingAllanStream stream(ao.max_m, n);  // one axis of one window, a chunk at a time
    std::vector<double> y(std::min(n, kDefaultChunkSamples));
    for (std::uint64_t i = w.first; i < w.last; i += y.size()) {
      const auto take = static_cast<std::size_t>(std::min<std::uint64_t>(y.size(), w.last - i));
      src.read_column(c, i, take, y.data());
      stream.add(y.data(), take);
    }
    noise::ChannelInfo ch;
    ch.name = std::string(accel ? "a" : "g") + "xyz"[a];
    ch.instrument = accel ? noise::Instrument::kAccelerometer : noise::Instrument::kGyroscope;
    const noise::ChannelResult r = noise::analyze(stream, rate, ch, ao);
    const noise::NoiseModel& m = r.model;
    if (!m.ok || r.curve.points.empty()) continue;
    in.allan_white[a] = m.white.fitted;
    in.allan_random_walk[a] = m.random_walk.fitted;
    in.allan_random_walk_se[a] = m.random_walk.fitted_sigma;
    allan_excess(in, r, a);
  }
}

// The quantizer's LSB [unit] and where it came from (header, else the median smallest spacing of
// the sample values when that is a visible part of the noise); the spacings seen and the median
// sample std [unit].
struct Lattice {
  double lsb = 0.0;
  std::string from = "header";
  std::vector<double> steps;  // sorted
  double median_std = kNaN;
};
Lattice lattice(const GapInput& in, const std::vector<int>& axes) {
  Lattice l;
  l.lsb = in.lsb;
  std::vector<double> stds;
  for (const auto& s : in.segments)
    for (int a : axes) {
      if (std::isfinite(s.value_step[a])) l.steps.push_back(s.value_step[a]);
      if (std::isfinite(s.raw_std[a])) stds.push_back(s.raw_std[a]);
    }
  std::sort(l.steps.begin(), l.steps.end());
  std::sort(stds.begin(), stds.end());
  l.median_std = stds.empty() ? kNaN : stds[stds.size() / 2];
  if (!(l.lsb > 0) && !l.steps.empty()) {
    const double st = l.steps[l.steps.size() / 2];
    if (st > 1e-3 * l.median_std || l.median_std == 0.0) {
      l.lsb = st;
      l.from = "smallest spacing of the sample values";
    }
  }
  return l;
}

// Undithered (segment, axis) pairs: rounding-bias bound over the mean's floor, the worst one.
struct DitherCheck {
  int flagged = 0, total = 0;
  double worst = 0.0, worst_std = kNaN, worst_floor = kNaN;
  std::string axis = "-";
};
DitherCheck dither_check(const GapInput& in, const std::vector<int>& axes, double lsb) {
  DitherCheck d;
  for (const auto& s : in.segments)
    for (int a : axes) {
      if (!std::isfinite(s.raw_std[a])) continue;
      ++d.total;
      const double fl = std::isfinite(s.mean_std_error[a]) ? s.mean_std_error[a] : 0.0;
      const double ratio = fl > 0 ? dither_bias_bound(s.raw_std[a], lsb) / fl : HUGE_VAL;
      if (ratio > 1.0) ++d.flagged;
      if (ratio > d.worst) {
        d.worst = ratio;
        d.worst_std = s.raw_std[a];
        d.worst_floor = fl;
        d.axis = std::string(1, "xyz"[a]);
      }
    }
  return d;
}

// Quantization: significant when the rounding-bias bound exceeds the mean's floor anywhere; size
// the LSB, interval the spacings seen within LSB/2 of it.
CandidateResult quantization(const GapInput& in, const std::vector<int>& axes, const Lattice& l,
                             const std::string& unit) {
  CandidateResult q;
  q.term = "quantization";
  q.noise_stage = true;
  q.size_unit = unit;
  q.size_param = "lsb";
  if (!(l.lsb > 0)) {
    q.reason = "LSB unknown for this source and the sample values show no lattice";
    return q;
  }
  const double lsb = l.lsb;
  const DitherCheck d = dither_check(in, axes, lsb);
  q.evaluated = true;
  q.axis = d.axis;
  q.significant = d.flagged > 0;
  q.size = lsb;
  q.ci_lo = q.ci_hi = lsb;
  for (double st : l.steps)
    if (st >= 0.5 * lsb && st <= 1.5 * lsb) {
      q.ci_lo = std::min(q.ci_lo, st);
      q.ci_hi = std::max(q.ci_hi, st);
    }
  q.reason = "LSB " + fmt(lsb) + " " + unit + " (" + l.from + "); median sample std " + fmt(l.median_std / lsb, 3) +
             " LSB; " + std::to_string(d.flagged) + "/" + std::to_string(d.total) +
             " segment-axes where the undithered-rounding bias bound (LSB/pi)exp(-2pi^2 std^2/LSB^2) exceeds "
             "the mean's floor " +
             (d.worst > 0 ? "(worst: std " + fmt(d.worst_std / lsb, 3) + " LSB, bound/floor " + fmt(d.worst, 3) +
                                ", floor " + fmt(d.worst_floor) + ")"
                          : std::string("(the bound underflows: far below every floor)")) +
             (q.significant ? ": the noise does not dither the quantizer, means biased by up to LSB/2"
                            : ": the noise dithers the quantizer, means unbiased");
  return q;
}

// Saturation: significant on any clipped static sample or segment skipped for saturation; size
// the clipped fraction on the worst axis with its Wilson interval; evidence the largest |mean|
// and its headroom to the range in sample std.
CandidateResult saturation(const GapInput& in, const std::vector<int>& axes, const std::string& unit) {
  CandidateResult s;
  s.term = "saturation";
  s.noise_stage = true;
  s.size_param = "fraction of static samples clipped";
  s.size_unit = "1";
  double peak = 0, peak_std = kNaN;
  for (const auto& d : in.segments)
    for (int a : axes)
      if (std::abs(d.point.axes(in.spec.model.instrument).mean[a]) > peak) {
        peak = std::abs(d.point.axes(in.spec.model.instrument).mean[a]);
        peak_std = d.raw_std[a];
      }
  s.evaluated = in.static_samples.maxCoeff() > 0 || in.saturated_segments > 0;
  int worst_axis = axes.empty() ? 0 : axes.front();
  double worst_frac = -1;
  double clipped_total = 0;
  for (int a : axes) {
    clipped_total += in.clipped_samples[a];
    const double f = in.static_samples[a] > 0 ? in.clipped_samples[a] / in.static_samples[a] : 0.0;
    if (f > worst_frac) {
      worst_frac = f;
      worst_axis = a;
    }
  }
  s.axis = std::string(1, "xyz"[worst_axis]);
  s.size = std::max(0.0, worst_frac);
  const stats::Interval wi = stats::wilson_interval(in.clipped_samples[worst_axis], in.static_samples[worst_axis], stats::kZ95);
  s.ci_lo = wi.lo;
  s.ci_hi = wi.hi;
  s.significant = clipped_total > 0 || in.saturated_segments > 0;
  const double headroom = in.range > 0 && peak_std > 0 ? (in.range - peak) / peak_std : kNaN;
  s.reason = fmt(clipped_total, 6) + " clipped sample(s) in the static segments (worst axis " + s.axis + ": " +
             fmt(100 * s.size, 3) + " %), " + std::to_string(in.saturated_segments) +
             " segment(s) skipped for saturated samples; largest |mean| " + fmt(peak) + " " + unit + " of range " +
             (in.range > 0 ? fmt(in.range) : std::string("unknown")) +
             (std::isfinite(headroom) ? " (headroom " + fmt(headroom, 3) + " sample std)" : std::string()) +
             (s.significant ? ": clipped tails bias the means of those segments (skipped or not)"
                            : std::isfinite(headroom) && headroom < 5
                                  ? ": nothing clipped, but within 5 std of the range"
                                  : ": nothing clipped");
  return s;
}

// The within-segment F test of one axis, pooled over its K segments: F(7K, 56K) under white noise.
struct AxisF {
  int axis = -1, segments = 0;
  double f = kNaN, p = 1.0;
};
// Segments whose noise does not dither the quantizer (std < LSB/2, lsb > 0) are left out: their
// sub-block means are not noise.
AxisF within_segment_f(const GapInput& in, int a, double lsb) {
  AxisF r;
  double sb = 0, sw = 0;
  for (const auto& d : in.segments) {
    if (!std::isfinite(d.ss_between[a]) || !(d.ss_within[a] > 0)) continue;
    if (lsb > 0 && d.raw_std[a] < 0.5 * lsb) continue;
    sb += d.ss_between[a];
    sw += d.ss_within[a];
    ++r.segments;
  }
  if (r.segments == 0) return r;
  const double k = r.segments;
  r.axis = a;
  r.f = (sb / (7.0 * k)) / (sw / (56.0 * k));
  r.p = stats::f_sf(r.f, 7.0 * k, 56.0 * k);
  return r;
}

// The kind of coloured noise from the Allan variance slope above white (τ_max/16 … τ_max), pooled
// over the axes whose own test is significant (Bonferroni p < level): > 0.5 random walk K
// [unit/√s], else bias instability B [unit]; fills size, interval and reason of c.
void name_coloured_kind(const GapInput& in, const std::vector<AxisF>& tested, int best_axis, double level,
                        std::size_t n_axes, const std::string& unit, CandidateResult& c) {
  double pw = 0, ps = 0;
  int a = -1;
  for (const auto& t : tested) {
    const int b = t.axis;
    if (!(t.p * static_cast<double>(n_axes) < level) || !std::isfinite(in.allan_slope[b]) || !(in.allan_slope_se[b] > 0))
      continue;
    const double w = 1.0 / (in.allan_slope_se[b] * in.allan_slope_se[b]);
    pw += w;
    ps += w * in.allan_slope[b];
    if (a < 0 || b == best_axis) a = b;
  }
  if (!(in.allan_window_s >= 100.0 && pw > 0)) {
    c.reason += "; kind not named (no static window >= 100 s, or no Allan slope on a significant axis)";
    return;
  }
  const double slope = ps / pw, slope_se = 1.0 / std::sqrt(pw);
  const std::string sl = "Allan variance above white over the last four octaves of the " +
                         fmt(in.allan_window_s, 4) + " s window has slope " + fmt(slope, 3) + " +- " +
                         fmt(1.96 * slope_se, 2) + " (random walk +1, flat 0, Gauss-Markov past its peak < 0)";
  c.axis = std::string(1, "xyz"[a]);
  if (slope > 0.5) {
    c.size_param = "random_walk K";
    c.size_unit = unit + "/sqrt(s)";
    c.size = in.allan_random_walk[a];
    c.ci_lo = std::max(0.0, c.size - 1.96 * in.allan_random_walk_se[a]);
    c.ci_hi = c.size + 1.96 * in.allan_random_walk_se[a];
    c.reason += "; " + sl + ": random walk, K = " + fmt(c.size) + " " + c.size_unit + " (axis " + c.axis + ")";
  } else {
    c.size_param = "bias_instability B";
    c.size_unit = unit;
    c.size = in.allan_bias_instability[a];
    c.ci_lo = in.allan_bias_instability_lo[a];
    c.ci_hi = in.allan_bias_instability_hi[a];
    c.reason += "; " + sl + ": bias instability, B = largest Allan deviation above white / 0.664 = " +
                fmt(c.size) + " " + unit + " (axis " + c.axis + "; a Gauss-Markov sigma = 1.076 B)";
  }
}

// Coloured noise: the within-segment F test on the axis with the smallest p (Bonferroni over the
// axes tested, level alpha/3); size √F (batch-means over white standard error of a segment mean)
// with its F interval; the kind named when significant.
CandidateResult coloured_noise(const GapInput& in, const std::vector<int>& axes, double lsb, double level,
                               const std::string& unit) {
  CandidateResult c;
  c.term = "coloured_noise";
  c.noise_stage = true;
  c.size_param = "batch-means / white standard error of a segment mean";
  c.size_unit = "1";
  std::vector<AxisF> tested;
  AxisF best;
  std::ostringstream per_axis;
  for (int a : axes) {
    const AxisF t = within_segment_f(in, a, lsb);
    if (t.axis < 0) continue;
    tested.push_back(t);
    per_axis << " " << "xyz"[a] << ": F=" << fmt(t.f, 3) << " p=" << fmt(t.p, 2) << ";";
    if (best.axis < 0 || t.p < best.p || (t.p == best.p && t.f > best.f)) best = t;
  }
  if (best.axis < 0) {
    c.reason = "no (segment, axis) with >= 128 samples whose noise dithers the quantizer (std >= LSB/2): "
               "the within-segment test needs noise to test";
    return c;
  }
  c.evaluated = true;
  c.axis = std::string(1, "xyz"[best.axis]);
  c.f_stat = best.f;
  c.p_value = std::min(1.0, best.p * static_cast<double>(tested.size()));  // Bonferroni over the axes
  c.significant = c.p_value < level;
  const double d1 = 7.0 * best.segments, d2 = 56.0 * best.segments;
  c.size = std::sqrt(best.f);
  c.ci_lo = std::sqrt(best.f / stats::f_upper_quantile(0.025, d1, d2));
  c.ci_hi = std::sqrt(best.f / stats::f_upper_quantile(0.975, d1, d2));
  c.reason = "within-segment test (64 sub-block means in 8 groups, pooled over " + std::to_string(best.segments) +
             " segments; F(" + fmt(d1, 6) + ", " + fmt(d2, 6) + ") under white noise, level " + fmt(level, 3) +
             " Bonferroni over axes):" + per_axis.str();
  c.reason += c.significant ? " noise correlated over seconds inside segments (bias instability, random walk — "
                              "or a drift inside segments)"
                            : " consistent with white noise inside segments";
  if (c.significant) name_coloured_kind(in, tested, best.axis, level, axes.size(), unit, c);
  return c;
}

}  // namespace

SegmentEvidence::SegmentEvidence(std::size_t n, bool accel)
    : n_(n), accel_(accel), sub_(3, BlockSums(n, kSub)), distinct_(n >= 2 * kSub ? 3 : 0) {}

void SegmentEvidence::add(const ImuSample& x) {
  if (n_ < 2 * kSub) return;
  for (std::size_t a = 0; a < 3; ++a) {
    const double v = axis_value(x, accel_, static_cast<int>(a));
    sub_[a].add(v);
    if (distinct_[a].size() <= kMaxDistinct) distinct_[a].insert(v);
  }
}

void SegmentEvidence::fill(SegmentData& d) const {
  const std::size_t n = n_;
  d.raw_samples = n;
  if (n < 2 * kSub) return;
  for (int a = 0; a < 3; ++a) {
    const BlockSums& sub = sub_[static_cast<std::size_t>(a)];
    // Sub-block means, grouped 8 × 8.
    double m[kSub];
    for (int j = 0; j < kSub; ++j) m[j] = sub.sum(j) / static_cast<double>(sub.size(j));
    double grand = 0.0, gm[kGroups];
    for (int g = 0; g < kGroups; ++g) {
      gm[g] = 0.0;
      for (int k = 0; k < kPerGroup; ++k) gm[g] += m[g * kPerGroup + k];
      gm[g] /= kPerGroup;
      grand += gm[g] / kGroups;
    }
    double ssb = 0.0, ssw = 0.0;
    for (int g = 0; g < kGroups; ++g) {
      ssb += kPerGroup * (gm[g] - grand) * (gm[g] - grand);
      for (int k = 0; k < kPerGroup; ++k) ssw += (m[g * kPerGroup + k] - gm[g]) * (m[g * kPerGroup + k] - gm[g]);
    }
    const double len = static_cast<double>(n) / kSub;  // sub-block length [samples]
    d.ss_between[a] = ssb * len;
    d.ss_within[a] = ssw * len;
    // Distinct values and their smallest spacing (the LSB when the output is quantized).
    const std::set<double>& v = distinct_[static_cast<std::size_t>(a)];
    if (v.size() > kMaxDistinct) continue;  // no lattice to see: both stay NaN
    std::size_t distinct = 1;
    double step = kNaN;
    const double tol = 1e-12 * std::max(std::abs(*v.begin()), std::abs(*v.rbegin()));
    for (auto prev = v.begin(), it = std::next(prev); it != v.end(); prev = it++) {
      const double dv = *it - *prev;
      if (dv > tol) {
        ++distinct;
        if (!(dv >= step)) step = dv;
      }
    }
    d.distinct_values[a] = static_cast<double>(distinct);
    d.value_step[a] = step;
  }
}

void recording_evidence(GapInput& in, const Recording& rec) {
  const bool accel = in.spec.model.instrument == model::Instrument::kAccelerometer;
  count_clipped(in, rec, accel);
  allan_evidence(in, rec, accel);
}

std::vector<CandidateResult> candidates(const GapInput& in, const std::vector<int>& axes, const std::string& unit,
                                        double alpha) {
  const double level = alpha / 3.0;  // each noise-stage candidate; the family at alpha
  const Lattice l = lattice(in, axes);
  return {quantization(in, axes, l, unit), saturation(in, axes, unit), coloured_noise(in, axes, l.lsb, level, unit)};
}

}  // namespace stend::diagnosis::noise_stage
