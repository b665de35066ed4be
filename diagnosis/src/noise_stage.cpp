// stend gap: noise- and output-stage candidates. See noise_stage.hpp for the tests and levels.
#include "noise_stage.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "stats.hpp"
#include "text.hpp"
#include "stend/allan/allan.hpp"

namespace stend::diagnosis::noise_stage {

namespace {

constexpr int kGroups = 8, kPerGroup = 8, kSub = kGroups * kPerGroup;  // 64 sub-blocks
// The kind of coloured noise is read from the slope of the Allan variance above white over the
// last four octaves of τ (τ_max/16 … τ_max).
constexpr double kSlopeSpan = 16.5;

double axis_value(const ImuSample& s, bool accel, int a) { return accel ? s.accel_mps2[a] : s.gyro_radps[a]; }


// x with P(F_{d1,d2} > x) = q, by bisection on log x.
double f_quantile_upper(double q, double d1, double d2) {
  double lo = 1e-6, hi = 1e6;
  for (int i = 0; i < 200; ++i) {
    const double mid = std::sqrt(lo * hi);
    if (stats::f_sf(mid, d1, d2) > q)
      lo = mid;
    else
      hi = mid;
  }
  return std::sqrt(lo * hi);
}

// Bias bound of a mean of a quantized Gaussian signal: first harmonic of the rounding error
// (a sawtooth with Fourier series Σ (−1)^k (LSB/πk) sin(2πk x/LSB)) damped by the noise's
// characteristic function at 2π/LSB.
double dither_bias_bound(double sigma, double lsb) {
  return lsb / std::numbers::pi * std::exp(-2.0 * std::numbers::pi * std::numbers::pi * sigma * sigma / (lsb * lsb));
}

// Wilson 95 % interval of a binomial fraction.
std::pair<double, double> wilson(double k, double n) {
  if (!(n > 0)) return {kNaN, kNaN};
  const double z = 1.959964, p = k / n, z2 = z * z;
  const double c = (p + z2 / (2 * n)) / (1 + z2 / n);
  const double h = z * std::sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n);
  return {std::max(0.0, c - h), std::min(1.0, c + h)};
}

}  // namespace

void segment_evidence(SegmentData& d, const ImuSample* first, const ImuSample* last, bool accel) {
  const auto n = static_cast<std::size_t>(last - first);
  d.raw_samples = n;
  if (n < 2 * kSub) return;
  std::vector<double> v(n);
  for (int a = 0; a < 3; ++a) {
    for (std::size_t i = 0; i < n; ++i) v[i] = axis_value(first[i], accel, a);
    // Sub-block means, grouped 8 × 8.
    double m[kSub];
    for (int j = 0; j < kSub; ++j) {
      const std::size_t b0 = n * static_cast<std::size_t>(j) / kSub, b1 = n * static_cast<std::size_t>(j + 1) / kSub;
      double s = 0.0;
      for (std::size_t i = b0; i < b1; ++i) s += v[i];
      m[j] = s / static_cast<double>(b1 - b0);
    }
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
    std::sort(v.begin(), v.end());
    std::size_t distinct = 1;
    double step = kNaN;
    const double tol = 1e-12 * std::max(std::abs(v.front()), std::abs(v.back()));
    for (std::size_t i = 1; i < n; ++i) {
      const double dv = v[i] - v[i - 1];
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
  const std::uint32_t flag = accel ? kAccelSaturated : kGyroSaturated;
  const auto& S = rec.samples;
  in.clipped_samples.setZero();
  in.static_samples.setZero();
  // A recording whose sensor flags saturation is judged by the flag alone (a value near the range
  // may be an unclipped sample rounded up); otherwise by the value.
  const bool flags_used = std::any_of(S.begin(), S.end(), [&](const ImuSample& x) { return (x.flags & flag) != 0; });
  for (const auto& seg : rec.segments) {
    const auto& kinds = in.spec.processing.segment_kinds;
    if (std::find(kinds.begin(), kinds.end(), seg.kind) == kinds.end())
      continue;
    const auto lo = std::lower_bound(S.begin(), S.end(), seg.t_start_s,
                                     [](const ImuSample& s, double t) { return s.t_s < t; });
    const auto hi = std::upper_bound(S.begin(), S.end(), seg.t_end_s,
                                     [](double t, const ImuSample& s) { return t < s.t_s; });
    const auto n = hi - lo;
    if (n < 16) continue;
    for (int a = 0; a < 3; ++a) {
      in.static_samples[a] += static_cast<double>(n);
      double sum = 0, sum2 = 0, vmax = -HUGE_VAL, vmin = HUGE_VAL;
      std::size_t clipped = 0;
      for (auto it = lo; it != hi; ++it) {
        const double v = axis_value(*it, accel, a);
        sum += v;
        sum2 += v * v;
        vmax = std::max(vmax, v);
        vmin = std::min(vmin, v);
        bool c = false;
        if (it->flags & flag) {
          // The flag is per instrument: charge it to the axis nearest its range.
          int worst = 0;
          for (int b = 1; b < 3; ++b)
            if (std::abs(axis_value(*it, accel, b)) > std::abs(axis_value(*it, accel, worst))) worst = b;
          c = worst == a;
        }
        if (!flags_used && in.range > 0 && std::abs(v) >= in.range - 0.5 * in.lsb) c = true;
        clipped += c ? 1 : 0;
      }
      if (in.range <= 0) {
        // Range unknown: a pile of identical values at the window's extreme, within 2.5 std of
        // the mean (an unclipped Gaussian window of ≥ 16 samples reaches beyond that once or twice).
        const double mean = sum / static_cast<double>(n);
        const double sd = std::sqrt(std::max(0.0, sum2 / static_cast<double>(n) - mean * mean));
        for (const double ext : {vmax, vmin}) {
          if (!(sd > 0) || std::abs(ext - mean) > 2.5 * sd) continue;
          std::size_t run = 0, best = 0, at = 0;
          for (auto it = lo; it != hi; ++it) {
            const bool eq = axis_value(*it, accel, a) == ext;
            at += eq ? 1 : 0;
            run = eq ? run + 1 : 0;
            best = std::max(best, run);
          }
          if (best >= 3) clipped += at;
        }
      }
      in.clipped_samples[a] += static_cast<double>(clipped);
    }
  }

  // Allan deviation of the longest kept window, when long enough to see slopes beyond white.
  const SegmentData* longest = nullptr;
  for (const auto& d : in.segments)
    if (!longest || d.averaging_s > longest->averaging_s) longest = &d;
  if (!longest || longest->averaging_s < 100.0) return;
  const auto lo = std::lower_bound(S.begin(), S.end(), longest->point.t_start_s,
                                   [](const ImuSample& s, double t) { return s.t_s < t; });
  const auto hi = std::upper_bound(S.begin(), S.end(), longest->point.t_end_s,
                                   [](double t, const ImuSample& s) { return t < s.t_s; });
  const auto n = static_cast<std::size_t>(hi - lo);
  if (n < 1000) return;
  const double rate = static_cast<double>(n - 1) / ((hi - 1)->t_s - lo->t_s);
  in.allan_window_s = longest->averaging_s;
  std::vector<double> y(n);
  allan::AllanOptions ao;
  ao.confidence = 0.95;
  for (int a = 0; a < 3; ++a) {
    for (std::size_t i = 0; i < n; ++i) y[i] = axis_value(lo[static_cast<std::ptrdiff_t>(i)], accel, a);
    allan::ChannelInfo ch;
    ch.name = std::string(accel ? "a" : "g") + "xyz"[a];
    ch.instrument = accel ? allan::Instrument::kAccelerometer : allan::Instrument::kGyroscope;
    const allan::ChannelResult r = allan::analyze(y.data(), n, 1, rate, ch, ao);
    const allan::NoiseModel& m = r.model;
    if (!m.ok || r.curve.points.empty()) continue;
    const double nw = m.white.fitted;
    in.allan_white[a] = nw;
    in.allan_random_walk[a] = m.random_walk.fitted;
    in.allan_random_walk_se[a] = m.random_walk.fitted_sigma;
    // Excess over white: the largest, and the slope over the last four octaves.
    double best = 0.0;
    const double tau_max = r.curve.points.back().tau_s;
    double sw = 0, swx = 0, swy = 0, swxx = 0, swxy = 0;
    int used = 0;
    for (const auto& p : r.curve.points) {
      const double white = nw * nw / p.tau_s;
      const double e = p.avar - white;
      if (e > best * best && std::isfinite(p.adev_lo)) {
        best = std::sqrt(e);
        in.allan_bias_instability[a] = best / allan::kFlickerFloor;
        in.allan_bias_instability_lo[a] = std::sqrt(std::max(0.0, p.adev_lo * p.adev_lo - white)) / allan::kFlickerFloor;
        in.allan_bias_instability_hi[a] = std::sqrt(std::max(0.0, p.adev_hi * p.adev_hi - white)) / allan::kFlickerFloor;
      }
      if (p.tau_s < tau_max / kSlopeSpan || !(e > 0) || !(p.edf > 0)) continue;
      // var(ln avar) ≈ 2/EDF; through the white subtraction ×(avar/e)².
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
}

std::vector<CandidateResult> candidates(const GapInput& in, const std::vector<int>& axes, const std::string& unit,
                                        double alpha) {
  const double level = alpha / 3.0;  // each noise-stage candidate; the family at alpha
  std::vector<CandidateResult> out;

  // --- quantization -----------------------------------------------------------------------
  CandidateResult q;
  q.term = "quantization";
  q.noise_stage = true;
  q.size_unit = unit;
  q.size_param = "lsb";
  double lsb = in.lsb;
  std::string lsb_from = "header";
  std::vector<double> steps, stds;
  for (const auto& s : in.segments)
    for (int a : axes) {
      if (std::isfinite(s.value_step[a])) steps.push_back(s.value_step[a]);
      if (std::isfinite(s.raw_std[a])) stds.push_back(s.raw_std[a]);
    }
  std::sort(steps.begin(), steps.end());
  std::sort(stds.begin(), stds.end());
  const double med_std = stds.empty() ? kNaN : stds[stds.size() / 2];
  if (!(lsb > 0) && !steps.empty()) {
    // The values lie on a lattice when their smallest spacing is a visible part of the noise.
    const double st = steps[steps.size() / 2];
    if (st > 1e-3 * med_std || med_std == 0.0) {
      lsb = st;
      lsb_from = "smallest spacing of the sample values";
    }
  }
  if (lsb > 0) {
    q.evaluated = true;
    double worst = 0.0, worst_std = kNaN, worst_floor = kNaN;
    int flagged = 0, total = 0;
    for (const auto& s : in.segments)
      for (int a : axes) {
        if (!std::isfinite(s.raw_std[a])) continue;
        ++total;
        const double fl = std::isfinite(s.mean_std_error[a]) ? s.mean_std_error[a] : 0.0;
        const double bound = dither_bias_bound(s.raw_std[a], lsb);
        const double ratio = fl > 0 ? bound / fl : HUGE_VAL;
        if (ratio > 1.0) ++flagged;
        if (ratio > worst) {
          worst = ratio;
          worst_std = s.raw_std[a];
          worst_floor = fl;
          q.axis = std::string(1, "xyz"[a]);
        }
      }
    q.significant = flagged > 0;
    q.size = lsb;
    q.ci_lo = q.ci_hi = lsb;
    for (double st : steps)
      if (st >= 0.5 * lsb && st <= 1.5 * lsb) {
        q.ci_lo = std::min(q.ci_lo, st);
        q.ci_hi = std::max(q.ci_hi, st);
      }
    q.reason = "LSB " + fmt(lsb) + " " + unit + " (" + lsb_from + "); median sample std " + fmt(med_std / lsb, 3) +
               " LSB; " + std::to_string(flagged) + "/" + std::to_string(total) +
               " segment-axes where the undithered-rounding bias bound (LSB/pi)exp(-2pi^2 std^2/LSB^2) exceeds "
               "the mean's floor " +
               (worst > 0 ? "(worst: std " + fmt(worst_std / lsb, 3) + " LSB, bound/floor " + fmt(worst, 3) + ", floor " +
                                fmt(worst_floor) + ")"
                          : std::string("(the bound underflows: far below every floor)")) +
               (q.significant ? ": the noise does not dither the quantizer, means biased by up to LSB/2"
                              : ": the noise dithers the quantizer, means unbiased");
  } else {
    q.reason = "LSB unknown for this source and the sample values show no lattice";
  }
  out.push_back(q);

  // --- saturation --------------------------------------------------------------------------
  CandidateResult s;
  s.term = "saturation";
  s.noise_stage = true;
  s.size_param = "fraction of static samples clipped";
  s.size_unit = "1";
  double peak = 0, peak_std = kNaN;
  for (const auto& d : in.segments)
    for (int a : axes)
      if (std::abs(d.point.measured[a]) > peak) {
        peak = std::abs(d.point.measured[a]);
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
  const auto wi = wilson(in.clipped_samples[worst_axis], in.static_samples[worst_axis]);
  s.ci_lo = wi.first;
  s.ci_hi = wi.second;
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
  out.push_back(s);

  // --- coloured noise ------------------------------------------------------------------------
  CandidateResult c;
  c.term = "coloured_noise";
  c.noise_stage = true;
  c.size_param = "batch-means / white standard error of a segment mean";
  c.size_unit = "1";
  double best_p = 1.0, best_f = kNaN;
  int best_axis = -1, best_k = 0, m_axes = 0;
  std::vector<std::pair<int, double>> axis_p;  // axis, Bonferroni p
  std::ostringstream per_axis;
  for (int a : axes) {
    double sb = 0, sw = 0;
    int k = 0;
    for (const auto& d : in.segments) {
      if (!std::isfinite(d.ss_between[a]) || !(d.ss_within[a] > 0)) continue;
      if (lsb > 0 && q.evaluated && d.raw_std[a] < 0.5 * lsb) continue;  // not dithered: not noise
      sb += d.ss_between[a];
      sw += d.ss_within[a];
      ++k;
    }
    if (k == 0) continue;
    ++m_axes;
    const double f = (sb / (7.0 * k)) / (sw / (56.0 * k));
    const double p = stats::f_sf(f, 7.0 * k, 56.0 * k);
    per_axis << " " << "xyz"[a] << ": F=" << fmt(f, 3) << " p=" << fmt(p, 2) << ";";
    axis_p.push_back({a, p * static_cast<double>(axes.size())});
    if (best_axis < 0 || p < best_p || (p == best_p && f > best_f)) {
      best_p = p;
      best_f = f;
      best_axis = a;
      best_k = k;
    }
  }
  if (best_axis >= 0) {
    c.evaluated = true;
    c.axis = std::string(1, "xyz"[best_axis]);
    c.f_stat = best_f;
    c.p_value = std::min(1.0, best_p * m_axes);  // Bonferroni over the axes
    c.significant = c.p_value < level;
    const double d1 = 7.0 * best_k, d2 = 56.0 * best_k;
    c.size = std::sqrt(best_f);
    c.ci_lo = std::sqrt(best_f / f_quantile_upper(0.025, d1, d2));
    c.ci_hi = std::sqrt(best_f / f_quantile_upper(0.975, d1, d2));
    c.reason = "within-segment test (64 sub-block means in 8 groups, pooled over " + std::to_string(best_k) +
               " segments; F(" + fmt(d1, 6) + ", " + fmt(d2, 6) + ") under white noise, level " + fmt(level, 3) +
               " Bonferroni over axes):" + per_axis.str();
    c.reason += c.significant ? " noise correlated over seconds inside segments (bias instability, random walk — "
                                "or a drift inside segments)"
                              : " consistent with white noise inside segments";
    // The kind, from the Allan deviation of a long static window: the slope of the variance above
    // white over the last four octaves, pooled over the axes whose own test is significant (τ_max/16 … τ_max).
    double pw = 0, ps = 0;
    int best_slope_axis = -1;
    for (std::size_t i = 0; i < axis_p.size(); ++i) {
      const int a = axis_p[i].first;
      if (!(axis_p[i].second < level) || !std::isfinite(in.allan_slope[a]) || !(in.allan_slope_se[a] > 0)) continue;
      const double w = 1.0 / (in.allan_slope_se[a] * in.allan_slope_se[a]);
      pw += w;
      ps += w * in.allan_slope[a];
      if (best_slope_axis < 0 || a == best_axis) best_slope_axis = a;
    }
    if (in.allan_window_s >= 100.0 && c.significant && pw > 0) {
      const int a = best_slope_axis;
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
    } else if (c.significant) {
      c.reason += "; kind not named (no static window >= 100 s, or no Allan slope on a significant axis)";
    }
  } else {
    c.reason = "no (segment, axis) with >= 128 samples whose noise dithers the quantizer (std >= LSB/2): "
               "the within-segment test needs noise to test";
  }
  out.push_back(c);
  return out;
}

}  // namespace stend::diagnosis::noise_stage
