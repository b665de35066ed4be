// Sliding-variance static-interval detector. See stend/processing/static_detector.hpp.
#include "stend/processing/static_detector.hpp"

#include "stend/model/terms.hpp"
#include "stend/recording/instruments.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>

namespace stend::processing {

namespace {

constexpr const char* kInitSegmentLabel = "initialization";  // an importer's still start
constexpr double kNoisePercentile = 0.10;
constexpr std::size_t kQuadricUnknowns = 9;  // symmetric Q (6) and p (3) in uᵀQu + pᵀu = 1

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

double quantile(std::vector<double> v, double q) {
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

// The samples, read a chunk at a time, and their count.
struct Stream {
  const SampleSource& src;
  std::size_t chunk;
  std::uint64_t size() const { return src.size(); }
};

// Plain means of samples first..last (inclusive); `saturated` tells whether any is flagged
// saturated.
struct Means {
  DetectedInterval iv;
  bool saturated = false;
};
Means interval_means(const Stream& in, std::size_t first, std::size_t last) {
  Means m;
  DetectedInterval& iv = m.iv;
  iv.first = first;
  iv.last = last;
  for_each_chunk(in.src, first, last + 1, [&](const ImuSample* c, std::size_t n, std::uint64_t at) {
    if (at == first) iv.t_start_s = c[0].t_s;
    if (at + n == last + 1) iv.t_end_s = c[n - 1].t_s;
    for (std::size_t i = 0; i < n; ++i) {
      iv.accel_mean_mps2 += c[i].accel_mps2;
      iv.gyro_mean_radps += c[i].gyro_radps;
      m.saturated = m.saturated || (c[i].flags & (kAccelSaturated | kGyroSaturated));
    }
  }, in.chunk);
  const double n = static_cast<double>(last - first + 1);
  iv.accel_mean_mps2 /= n;
  iv.gyro_mean_radps /= n;
  return m;
}

// The triad whose window variance tells still from moving: the accelerometer's, or the gyroscope's
// when the recording has no accelerometer.
using Triad = Eigen::Vector3d ImuSample::*;
Triad still_triad(const SensorInfo& info) {
  return has_instrument(info, model::Instrument::kAccelerometer) ? &ImuSample::accel_mps2 : &ImuSample::gyro_radps;
}

// Calls fn(i, sample_i, var_i, rate_i) for the samples i < end in order: var_i is the sum of the
// three variances of `triad` (the accelerometer's, or the gyroscope's) over the centred window of
// 2·half + 1 samples (cut at the ends of the recording), from prefix sums of the values centred on
// `mean`; rate_i [rad/s] is the norm of the window-mean gyro reading less `*bias` (0 when bias is
// null). The prefix sums of the last 2·half + 2 indices and the last half + 1 samples are kept, so
// memory is the window's.
// fn: void(std::uint64_t i, const ImuSample& s, double var, double rate), called inline per sample.
// `memo`, when given, holds var_i for every sample: filled by a pass over all of them, then read
// instead of the triad's sums.
template <class WindowFn>
void for_each_window(const Stream& in, std::size_t half, Triad triad, const Eigen::Vector3d& mean,
                     const Eigen::Vector3d* bias, std::uint64_t end, std::vector<double>* memo, const WindowFn& fn) {
  const std::uint64_t n = in.size();
  end = std::min(end, n);
  const bool reuse = memo != nullptr && memo->size() == n, keep = memo != nullptr && !reuse && end == n;
  if (keep) memo->resize(static_cast<std::size_t>(n));
  // Rings of at least 2·half + 2 and half + 1 entries, their sizes powers of two (index & mask).
  const std::uint64_t R = std::bit_ceil(2 * half + 2) - 1, H = std::bit_ceil(half + 1) - 1;
  std::vector<Eigen::Vector3d> s1(R + 1, Eigen::Vector3d::Zero()), s2(R + 1, Eigen::Vector3d::Zero()),
      g1(R + 1, Eigen::Vector3d::Zero());
  // The last half + 1 samples, for fn: where the source holds its samples in memory its chunks
  // stay valid and are pointed to; else copied (the next chunk reuses the buffer).
  const bool held = held_samples(in.src) != nullptr;
  std::vector<ImuSample> copies(held ? 0 : H + 1);
  std::vector<const ImuSample*> recent(H + 1);
  auto emit = [&](std::uint64_t i) {
    const std::uint64_t a = i >= half ? i - half : 0, b = std::min(n, i + half + 1);
    const double m = static_cast<double>(b - a);
    double var = 0.0;
    if (reuse) {
      var = (*memo)[static_cast<std::size_t>(i)];
    } else {
      const Eigen::Vector3d mu = (s1[b & R] - s1[a & R]) / m;
      var = ((s2[b & R] - s2[a & R]) / m - mu.cwiseAbs2()).sum() * m / std::max(1.0, m - 1.0);
      if (keep) (*memo)[static_cast<std::size_t>(i)] = var;
    }
    const double rate = bias ? ((g1[b & R] - g1[a & R]) / m).norm() : 0.0;
    fn(i, *recent[i & H], var, rate);
  };
  std::uint64_t next = 0;  // next sample to emit
  const std::uint64_t read_end = std::min(n, end + half);
  for_each_chunk(in.src, 0, read_end, [&](const ImuSample* c, std::size_t count, std::uint64_t at) {
    for (std::size_t k = 0; k < count; ++k) {
      const std::uint64_t j = at + k;
      if (!reuse) {
        const Eigen::Vector3d d = c[k].*triad - mean;
        s1[(j + 1) & R] = s1[j & R] + d;
        s2[(j + 1) & R] = s2[j & R] + d.cwiseAbs2();
      }
      if (bias) g1[(j + 1) & R] = g1[j & R] + (c[k].gyro_radps - *bias);
      if (held) {
        recent[j & H] = &c[k];
      } else {
        copies[j & H] = c[k];
        recent[j & H] = &copies[j & H];
      }
      if (j >= half && next < end) emit(next++);
    }
  }, in.chunk);
  if (read_end == n)
    while (next < end) emit(next++);
}

// The exact q-quantile of values fed in repeated identical passes: the element of rank
// ⌊q·(count − 1)⌋, as nth_element picks it. One pass when at most kHeld values; past that, each
// pass narrows the candidates by 16 bits of the values' order-preserving bit patterns until they
// fit in memory.
class StreamSelect {
 public:
  // `most`: at most how many values a pass adds (its room is taken at once, so the values are
  // neither copied nor their pages faulted in twice as they grow).
  StreamSelect(double q, std::uint64_t most) : q_(q) { held_.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(most, kHeld + 1))); }
  void add(double v) {
    const std::uint64_t key = key_of(v);
    if (level_ > 0 && (key >> (64 - level_)) != prefix_) return;
    ++seen_;
    if (!overflow_) {
      held_.push_back(v);
      if (held_.size() <= kHeld) return;
      overflow_ = true;
      hist_.assign(kBins, 0);
      for (double h : held_) ++hist_[bin_of(key_of(h))];
      held_.clear();
      held_.shrink_to_fit();
      return;
    }
    ++hist_[bin_of(key)];
  }
  // Ends a pass; true when the value is known (then value() and count() hold).
  bool end_pass() {
    if (level_ == 0) {
      count_ = seen_;
      if (count_ == 0) return done_ = true;
      rank_ = static_cast<std::uint64_t>(q_ * static_cast<double>(count_ - 1));
    }
    if (!overflow_) {
      const auto k = static_cast<std::ptrdiff_t>(rank_);
      std::nth_element(held_.begin(), held_.begin() + k, held_.end());
      value_ = held_[static_cast<std::size_t>(k)];
      return done_ = true;
    }
    std::uint64_t below = 0, b = 0;
    while (below + hist_[b] <= rank_) below += hist_[b++];
    rank_ -= below;
    prefix_ = (prefix_ << kBits) | b;
    level_ += kBits;
    if (level_ == 64) {
      value_ = value_of_key(prefix_);
      return done_ = true;
    }
    seen_ = 0;
    overflow_ = false;
    hist_.clear();
    return false;
  }
  bool done() const { return done_; }
  double value() const { return value_; }
  std::uint64_t count() const { return count_; }

 private:
  static constexpr std::size_t kHeld = std::size_t{1} << 20;
  static constexpr int kBits = 16;
  static constexpr std::size_t kBins = std::size_t{1} << kBits;
  static std::uint64_t key_of(double v) {
    const auto bits = std::bit_cast<std::uint64_t>(v);
    return (bits >> 63) ? ~bits : bits | (std::uint64_t{1} << 63);
  }
  static double value_of_key(std::uint64_t key) {
    return std::bit_cast<double>((key >> 63) ? key & ~(std::uint64_t{1} << 63) : ~key);
  }
  std::size_t bin_of(std::uint64_t key) const {
    return static_cast<std::size_t>((key >> (64 - level_ - kBits)) & (kBins - 1));
  }
  double q_;
  int level_ = 0;            // leading key bits fixed so far
  std::uint64_t prefix_ = 0;  // their value
  std::uint64_t rank_ = 0;    // rank sought among the values with that prefix
  std::uint64_t seen_ = 0, count_ = 0;
  bool overflow_ = false, done_ = false;
  std::vector<double> held_;
  std::vector<std::uint64_t> hist_;
  double value_ = kNaN;
};

// Runs `pass(selectors)` until every selector knows its value.
void select_all(std::vector<StreamSelect>& sel, const std::function<void()>& pass) {
  for (bool done = false; !done;) {
    pass();
    done = true;
    for (auto& s : sel)
      if (!s.done()) done = s.end_pass() && done;
  }
}

// The still start: init_duration_s, else the recording's initialization segment starting at its
// first sample; 0 when neither.
double init_duration(const Recording& rec, double t0_s, const StaticDetectorOptions& o) {
  if (o.init_duration_s > 0.0) return o.init_duration_s;
  for (const Segment& s : rec.segments)
    if (s.label == kInitSegmentLabel && s.t_start_s <= t0_s && s.t_end_s > s.t_start_s) return s.t_end_s - t0_s;
  return 0.0;
}

// Samples within `duration` of the first (read from the start until one is later).
std::size_t samples_within(const Stream& in, double duration) {
  const std::uint64_t n = in.size();
  std::vector<ImuSample> buf(std::min<std::uint64_t>(in.chunk, n));
  const double t0 = time_at(in.src, 0);
  for (std::uint64_t at = 0; at < n; at += buf.size()) {
    const auto count = static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), n - at));
    in.src.read(at, count, buf.data());
    for (std::size_t k = 0; k < count; ++k)
      if (!(buf[k].t_s - t0 <= duration)) return at + k;
  }
  return n;
}

// The settings every threshold works on.
struct Prepared {
  std::size_t half = 0;    // window = 2·half + 1 samples
  std::size_t window = 0;  // samples
  std::size_t init = 0;    // samples of the still start (0: none usable)
  double trim_s = 0.0;
  Triad triad = &ImuSample::accel_mps2;                  // whose variance: still_triad
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();        // of that triad over the recording [m/s², rad/s]
  // Where the samples are held in memory, the window variance of each, kept by the first pass over
  // them all for the next passes (n doubles beside the samples' n × 104 bytes).
  bool held = false;
  mutable std::vector<double> window_var;
  std::vector<double>* var_memo() const { return held ? &window_var : nullptr; }
};

Prepared prepare(const Recording& rec, const Stream& in, const StaticDetectorOptions& o, DetectionSummary& s) {
  const std::uint64_t n = in.size();
  const double t0 = time_at(in.src, 0);
  const double dt = (time_at(in.src, n - 1) - t0) / static_cast<double>(n - 1);
  if (!(dt > 0.0)) throw std::invalid_argument("detect_static_intervals: sample times do not increase");
  s.rate_hz = 1.0 / dt;
  s.window_s = o.window_s > 0.0 ? o.window_s : std::max(kAutoWindowS, kMinWindowSamples * dt);
  Prepared p;
  p.half = static_cast<std::size_t>(std::max(1.0, std::round(0.5 * s.window_s / dt)));
  s.min_duration_s = o.min_duration_s > 0.0 ? o.min_duration_s : std::max(kAutoMinDurationS, 2.0 * s.window_s);
  p.window = 2 * p.half + 1;
  p.triad = still_triad(rec.header.info);
  p.held = held_samples(in.src) != nullptr;
  s.by_gyroscope = p.triad == &ImuSample::gyro_radps;
  for_each_chunk(in.src, [&](const ImuSample* c, std::size_t count, std::uint64_t) {
    for (std::size_t k = 0; k < count; ++k) p.mean += c[k].*p.triad;
  }, in.chunk);
  p.mean /= static_cast<double>(n);
  p.trim_s = o.trim_s;
  const double init_s = init_duration(rec, t0, o);
  const std::size_t init_n = init_s > 0.0 ? samples_within(in, init_s) : 0;
  if (init_n >= 2 * p.window) {
    p.init = init_n;
    s.init_duration_s = init_s;
  }
  return p;
}

// The base variance the multiplier scales.
void choose_noise(const Stream& in, const Prepared& p, DetectionSummary& s) {
  const bool init = p.init > 0;
  const std::uint64_t from = init ? p.half : 0, to = init ? p.init - p.half : in.size();
  std::vector<StreamSelect> sel;  // built in place: a copy would not keep the room taken
  sel.emplace_back(init ? 0.5 : kNoisePercentile, to - from);
  select_all(sel, [&] {
    for_each_window(in, p.half, p.triad, p.mean, nullptr, to, p.var_memo(), [&](std::uint64_t i, const ImuSample&, double var, double) {
      if (i >= from) sel[0].add(var);
    });
  });
  s.noise_variance = sel[0].value();
  s.noise_source = init ? "median window variance over the first " + num(s.init_duration_s) + " s"
                        : "10th percentile of the window variance over the recording";
}

// The gyro's zero-rate offset from still data: the mean over the still start, else the per-axis
// median over the samples whose window variance is at most `still_threshold`.
void choose_gyro_bias(const Stream& in, const Prepared& p, double still_threshold, DetectionSummary& s) {
  if (p.init > 0) {
    s.gyro_bias_radps = interval_means(in, 0, p.init - 1).iv.gyro_mean_radps;
    s.gyro_bias_source = "mean over the first " + num(s.init_duration_s) + " s";
    return;
  }
  std::vector<StreamSelect> axis;
  for (int a = 0; a < 3; ++a) axis.emplace_back(0.5, in.size());
  select_all(axis, [&] {
    for_each_window(in, p.half, p.triad, p.mean, nullptr, in.size(), p.var_memo(), [&](std::uint64_t, const ImuSample& x, double var, double) {
      if (var <= still_threshold)
        for (int a = 0; a < 3; ++a) axis[static_cast<std::size_t>(a)].add(x.gyro_radps[a]);
    });
  });
  if (axis[0].count() == 0) {
    s.gyro_bias_source = "none (no still sample)";
    return;
  }
  for (int a = 0; a < 3; ++a) s.gyro_bias_radps[a] = axis[static_cast<std::size_t>(a)].value();
  s.gyro_bias_source = "per-axis median over the " + std::to_string(axis[0].count()) + " stillest samples";
}

struct Pass {
  std::vector<DetectedInterval> intervals;
  std::array<std::size_t, 4> rejected{};
  void reject(Rejection r) { ++rejected[static_cast<std::size_t>(r)]; }
};

// One threshold's runs, found sample by sample: the runs whose window variance is at most the
// threshold (split at gaps: counted as kGap), each cut where the window-mean gyro rate less its
// bias exceeds the gate (counted once per run as kGyroRate); the pieces kept as index ranges to be
// judged when the pass is over.
struct Runs {
  double threshold = 0.0;
  std::vector<std::pair<std::size_t, std::size_t>> pieces;  // first, last (inclusive)
  Pass pass;
  bool in_run = false, in_piece = false, cut = false;
  std::size_t piece_first = 0;

  void feed(std::size_t k, double var, bool gap, bool turning) {
    const bool still = var <= threshold;
    if (in_run && (!still || gap)) {
      close(k - 1);
      if (still) pass.reject(Rejection::kGap);
    }
    if (!still) return;
    in_run = true;
    if (turning) {
      if (in_piece) pieces.emplace_back(piece_first, k - 1);
      in_piece = false;
      cut = true;
    } else if (!in_piece) {
      in_piece = true;
      piece_first = k;
    }
  }
  void close(std::size_t last) {
    if (in_piece) pieces.emplace_back(piece_first, last);
    if (cut) pass.reject(Rejection::kGyroRate);
    in_run = in_piece = cut = false;
  }
};

// Pieces i..j (still by both gates), trimmed: accepted, or rejected as too short or saturated.
// Means are read once per distinct trimmed range (thresholds share most of them).
class PieceJudge {
 public:
  PieceJudge(const Stream& in, std::size_t trim, double min_duration_s) : in_(in), trim_(trim), min_s_(min_duration_s) {}
  void take(std::size_t i, std::size_t j, Pass& out) {
    const std::size_t a = i + trim_, b = j >= trim_ ? j - trim_ : 0;
    if (b < a || time_at(in_.src, b) - time_at(in_.src, a) < min_s_) return out.reject(Rejection::kTooShort);
    auto it = seen_.find({a, b});
    if (it == seen_.end()) it = seen_.emplace(std::make_pair(a, b), interval_means(in_, a, b)).first;
    if (it->second.saturated) return out.reject(Rejection::kSaturated);
    out.intervals.push_back(it->second.iv);
  }

 private:
  const Stream& in_;
  std::size_t trim_;
  double min_s_;
  std::map<std::pair<std::size_t, std::size_t>, Means> seen_;
};

// detect at each threshold, in one pass over the samples.
std::vector<Pass> detect_at(const Stream& in, const Prepared& p, const std::vector<double>& thresholds,
                            const DetectionSummary& s) {
  std::vector<Runs> runs(thresholds.size());
  for (std::size_t t = 0; t < thresholds.size(); ++t) runs[t].threshold = thresholds[t];
  const bool gate = s.max_gyro_radps > 0.0;
  for_each_window(in, p.half, p.triad, p.mean, gate ? &s.gyro_bias_radps : nullptr, in.size(), p.var_memo(),
                  [&](std::uint64_t i, const ImuSample& x, double var, double rate) {
                    const bool turning = gate && rate > s.max_gyro_radps;
                    for (Runs& r : runs) r.feed(i, var, x.flags & kGapBefore, turning);
                  });
  PieceJudge judge(in, static_cast<std::size_t>(std::round(p.trim_s * s.rate_hz)), s.min_duration_s);
  std::vector<Pass> out;
  for (Runs& r : runs) {
    if (r.in_run) r.close(in.size() - 1);
    for (const auto& [i, j] : r.pieces) judge.take(i, j, r.pass);
    out.push_back(std::move(r.pass));
  }
  return out;
}

// RMS residual [m/s²] of the quadric uᵀQu + pᵀu = 1 through the interval means (the surface a
// calibration maps onto the sphere |a| = g), with n − 9 degrees of freedom; NaN when fewer than
// 10 intervals or the means do not determine the quadric (e.g. six axis-aligned poses).
double quadric_rms(const std::vector<DetectedInterval>& ivs) {
  const std::size_t n = ivs.size();
  if (n < kQuadricUnknowns + 1) return kNaN;
  std::vector<double> norms;
  for (const auto& iv : ivs) norms.push_back(iv.accel_mean_mps2.norm());
  const double scale = quantile(norms, 0.5);
  if (!(scale > 0.0)) return kNaN;
  Eigen::MatrixXd A(n, kQuadricUnknowns);
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d u = ivs[k].accel_mean_mps2 / scale;
    A.row(static_cast<Eigen::Index>(k)) << u.x() * u.x(), u.y() * u.y(), u.z() * u.z(), 2 * u.x() * u.y(),
        2 * u.x() * u.z(), 2 * u.y() * u.z(), u.x(), u.y(), u.z();
  }
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(n));
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < static_cast<Eigen::Index>(kQuadricUnknowns)) return kNaN;
  const Eigen::VectorXd r = ones - A * qr.solve(ones);
  double rss = 0.0;  // δ|u| ≈ r·|u|/2 near the unit surface
  for (std::size_t k = 0; k < n; ++k) rss += std::pow(0.5 * r[static_cast<Eigen::Index>(k)] * norms[k], 2);
  return std::sqrt(rss / static_cast<double>(n - kQuadricUnknowns));
}

// Distinct poses among the intervals: consecutive intervals whose mean directions differ by less
// than kSamePoseDeg are one pose split by noise.
std::size_t poses(const std::vector<DetectedInterval>& ivs) {
  std::size_t n = ivs.empty() ? 0 : 1;
  for (std::size_t k = 1; k < ivs.size(); ++k) {
    const Eigen::Vector3d a = ivs[k - 1].accel_mean_mps2.normalized(), b = ivs[k].accel_mean_mps2.normalized();
    if (std::atan2(a.cross(b).norm(), a.dot(b)) > kSamePoseDeg * physics::kDegToRad) ++n;
  }
  return n;
}

// Detects at every multiplier of kScanMultipliers; sets s.multiplier, s.multiplier_choice and
// s.scan; returns the passes, one per multiplier.
std::vector<Pass> scan_multipliers(const Stream& in, const Prepared& p, DetectionSummary& s) {
  std::vector<double> thresholds;
  for (double k : kScanMultipliers) thresholds.push_back(k * s.noise_variance);
  std::vector<Pass> passes = detect_at(in, p, thresholds, s);
  std::size_t most = 0;
  for (std::size_t m = 0; m < passes.size(); ++m) {
    const Pass& pass = passes[m];
    const std::size_t distinct = poses(pass.intervals);  // noise splits do not determine a quadric
    s.scan.push_back({kScanMultipliers[m], pass.intervals.size(), distinct,
                      distinct > kQuadricUnknowns ? quadric_rms(pass.intervals) : kNaN});
    if (std::isfinite(s.scan.back().quadric_rms_mps2)) most = std::max(most, s.scan.back().poses);
  }
  double least = kNaN;
  for (const auto& step : s.scan)
    if (step.poses == most && std::isfinite(step.quadric_rms_mps2) && !(step.quadric_rms_mps2 >= least)) {
      least = step.quadric_rms_mps2;
      s.multiplier = step.multiplier;
    }
  if (!std::isfinite(least)) {
    s.multiplier = kFallbackMultiplier;
    s.multiplier_choice = "fallback: no multiplier in " + num(kScanMultipliers.front()) + ".." +
                          num(kScanMultipliers.back()) + " gave >= 10 distinct poses determining a quadric";
    return passes;
  }
  s.multiplier_choice = "scanned " + num(kScanMultipliers.front()) + ".." + num(kScanMultipliers.back()) +
                        ": of those keeping the most distinct poses (" + std::to_string(most) +
                        "), the least quadric (ellipsoid) residual of the interval means, " + num(least) + " m/s^2";
  return passes;
}

}  // namespace

const char* rejection_name(Rejection r) {
  switch (r) {
    case Rejection::kTooShort: return "too_short";
    case Rejection::kGyroRate: return "gyro_rate";
    case Rejection::kSaturated: return "saturated";
    case Rejection::kGap: break;
  }
  return "gap";
}

std::string DetectionSummary::rejections() const {
  std::size_t total = 0;
  std::string reasons;
  for (Rejection r : kAllRejections) {
    total += count(r);
    if (count(r) > 0) reasons += std::string(reasons.empty() ? ": " : ", ") + std::to_string(count(r)) + " " + rejection_name(r);
  }
  return "the detector rejected " + std::to_string(total) + " still run(s)" + reasons;
}

std::string DetectionSummary::print() const {
  const std::string unit = by_gyroscope ? " (rad/s)^2" : " (m/s^2)^2";
  std::string out = "static detection: " + std::to_string(found) + " intervals; window " + num(window_s) +
                    " s at " + num(rate_hz) + " Hz, min duration " + num(min_duration_s) + " s\n";
  if (by_gyroscope) out += "  still from the gyroscope alone (the recording has no accelerometer)\n";
  out += "  noise variance " + num(noise_variance) + unit + " (" + noise_source + ")\n";
  out += "  threshold " + num(threshold) + unit +
         (multiplier > 0.0 ? " = " + num(multiplier) + " x noise (" + multiplier_choice + ")" : " (given)") + "\n";
  if (!scan.empty()) {
    out += "  scan (multiplier: intervals, poses, quadric RMS m/s^2):";
    for (const auto& st : scan)
      out += " " + num(st.multiplier) + ": " + std::to_string(st.intervals) + ", " + std::to_string(st.poses) + ", " +
             num(st.quadric_rms_mps2) + ";";
    out += "\n";
  }
  const double dps = 1.0 / physics::kDegPerSecond;
  out += "  gyro bias " + num(gyro_bias_radps.x() * dps) + " " + num(gyro_bias_radps.y() * dps) + " " +
         num(gyro_bias_radps.z() * dps) + " deg/s (" + gyro_bias_source + "), gate " +
         (max_gyro_radps > 0.0 ? num(max_gyro_radps * dps) + " deg/s after removing it" : std::string("none")) + "\n";
  out += "  rejected:";
  for (Rejection r : kAllRejections) out += std::string(" ") + rejection_name(r) + " " + std::to_string(count(r));
  return out;
}

bool DetectionSummary::equals(const DetectionSummary& o, double tol) const {
  auto near = [tol](double a, double b) { return std::abs(a - b) <= tol * std::max(1.0, std::abs(a)); };
  return near(rate_hz, o.rate_hz) && near(window_s, o.window_s) && near(min_duration_s, o.min_duration_s) &&
         near(init_duration_s, o.init_duration_s) && near(noise_variance, o.noise_variance) &&
         near(multiplier, o.multiplier) && near(threshold, o.threshold) &&
         (gyro_bias_radps - o.gyro_bias_radps).norm() <= tol && near(max_gyro_radps, o.max_gyro_radps) &&
         rejected == o.rejected && found == o.found && scan.size() == o.scan.size() &&
         noise_source == o.noise_source && multiplier_choice == o.multiplier_choice &&
         gyro_bias_source == o.gyro_bias_source && by_gyroscope == o.by_gyroscope;
}

Detection detect_static(const Recording& rec, const StaticDetectorOptions& o, std::size_t chunk_samples) {
  Detection out;
  DetectionSummary& s = out.summary;
  const Stream in{rec.sample_source(), chunk_samples};
  if (in.size() < 3) return out;
  const Prepared p = prepare(rec, in, o, s);
  const bool gyro = has_instrument(rec.header.info, model::Instrument::kGyroscope);
  s.max_gyro_radps = gyro ? o.max_gyro_radps : 0.0;  // no gyroscope: no gate
  const bool given = o.variance_threshold > 0.0;
  if (given) {
    s.threshold = o.variance_threshold;
    s.noise_source = "given";
  } else {
    choose_noise(in, p, s);
  }
  if (gyro) {
    choose_gyro_bias(in, p, given ? s.threshold : kScanMultipliers.front() * s.noise_variance, s);
  } else {
    s.gyro_bias_source = "none (the recording has no gyroscope)";
  }
  std::vector<Pass> scanned;
  if (!given && o.threshold_multiplier > 0.0) {
    s.multiplier = o.threshold_multiplier;
    s.multiplier_choice = "given";
  } else if (!given) {
    scanned = scan_multipliers(in, p, s);
  }
  if (!given) s.threshold = s.multiplier * s.noise_variance;
  const auto at = std::find(kScanMultipliers.begin(), kScanMultipliers.end(), s.multiplier);
  Pass pass = !scanned.empty() && at != kScanMultipliers.end()
                  ? std::move(scanned[static_cast<std::size_t>(at - kScanMultipliers.begin())])
                  : std::move(detect_at(in, p, {s.threshold}, s).front());
  out.intervals = std::move(pass.intervals);
  s.rejected = pass.rejected;
  s.found = out.intervals.size();
  return out;
}

std::vector<DetectedInterval> detect_static_intervals(const Recording& rec, const StaticDetectorOptions& o) {
  return detect_static(rec, o).intervals;
}

}  // namespace stend::processing
