// Sliding-variance static-interval detector. See stend/processing/static_detector.hpp.
#include "stend/processing/static_detector.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace stend::processing {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kInitSegmentLabel = "initialization";  // an importer's still start
constexpr double kNoisePercentile = 0.10;
constexpr std::size_t kQuadricUnknowns = 9;  // symmetric Q (6) and p (3) in uᵀQu + pᵀu = 1

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

DetectedInterval interval_of(const Recording& rec, std::size_t first, std::size_t last) {
  DetectedInterval iv;
  iv.first = first;
  iv.last = last;
  iv.t_start_s = rec.samples[first].t_s;
  iv.t_end_s = rec.samples[last].t_s;
  for (std::size_t i = first; i <= last; ++i) {
    iv.accel_mean_mps2 += rec.samples[i].accel_mps2;
    iv.gyro_mean_radps += rec.samples[i].gyro_radps;
  }
  const double n = static_cast<double>(last - first + 1);
  iv.accel_mean_mps2 /= n;
  iv.gyro_mean_radps /= n;
  return iv;
}

// Sum of the three accelerometer variances over the centred window of every sample (the window is
// cut at the ends of the recording), from prefix sums of the centred values.
std::vector<double> window_variance(const Recording& rec, std::size_t half) {
  const std::size_t n = rec.samples.size();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& s : rec.samples) mean += s.accel_mps2;
  mean /= static_cast<double>(n);
  std::vector<Eigen::Vector3d> s1(n + 1, Eigen::Vector3d::Zero()), s2(n + 1, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = rec.samples[i].accel_mps2 - mean;
    s1[i + 1] = s1[i] + d;
    s2[i + 1] = s2[i] + d.cwiseAbs2();
  }
  std::vector<double> var(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= half ? i - half : 0, b = std::min(n, i + half + 1);
    const double m = static_cast<double>(b - a);
    const Eigen::Vector3d mu = (s1[b] - s1[a]) / m;
    var[i] = ((s2[b] - s2[a]) / m - mu.cwiseAbs2()).sum() * m / std::max(1.0, m - 1.0);
  }
  return var;
}

double quantile(std::vector<double> v, double q) {
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

// The still start: init_duration_s, else the recording's initialization segment starting at its
// first sample; 0 when neither.
double init_duration(const Recording& rec, const StaticDetectorOptions& o) {
  if (o.init_duration_s > 0.0) return o.init_duration_s;
  for (const Segment& s : rec.segments)
    if (s.label == kInitSegmentLabel && s.t_start_s <= rec.samples.front().t_s && s.t_end_s > s.t_start_s)
      return s.t_end_s - rec.samples.front().t_s;
  return 0.0;
}

// Samples within `duration` of the first.
std::size_t samples_within(const Recording& rec, double duration) {
  std::size_t b = 0;
  while (b < rec.samples.size() && rec.samples[b].t_s - rec.samples[0].t_s <= duration) ++b;
  return b;
}

// Norm of the centred window mean of the gyro reading less `bias` [rad/s], per sample.
std::vector<double> window_rate(const Recording& rec, std::size_t half, const Eigen::Vector3d& bias) {
  const std::size_t n = rec.samples.size();
  std::vector<Eigen::Vector3d> s1(n + 1, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < n; ++i) s1[i + 1] = s1[i] + (rec.samples[i].gyro_radps - bias);
  std::vector<double> rate(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= half ? i - half : 0, b = std::min(n, i + half + 1);
    rate[i] = ((s1[b] - s1[a]) / static_cast<double>(b - a)).norm();
  }
  return rate;
}

// The settings and the per-sample window variance (and gyro rate) every threshold works on.
struct Prepared {
  std::vector<double> var;
  std::vector<double> rate;  // window_rate with the chosen bias; empty: no gyro gate
  std::size_t window = 0;  // samples
  std::size_t init = 0;    // samples of the still start (0: none usable)
  double trim_s = 0.0;
};

Prepared prepare(const Recording& rec, const StaticDetectorOptions& o, DetectionSummary& s) {
  const std::size_t n = rec.samples.size();
  const double dt = (rec.samples.back().t_s - rec.samples.front().t_s) / static_cast<double>(n - 1);
  if (!(dt > 0.0)) throw std::invalid_argument("detect_static_intervals: sample times do not increase");
  s.rate_hz = 1.0 / dt;
  s.window_s = o.window_s > 0.0 ? o.window_s : std::max(kAutoWindowS, kMinWindowSamples * dt);
  const auto half = static_cast<std::size_t>(std::max(1.0, std::round(0.5 * s.window_s / dt)));
  s.min_duration_s = o.min_duration_s > 0.0 ? o.min_duration_s : std::max(kAutoMinDurationS, 2.0 * s.window_s);
  Prepared p;
  p.window = 2 * half + 1;
  p.var = window_variance(rec, half);
  p.trim_s = o.trim_s;
  const double init_s = init_duration(rec, o);
  const std::size_t init_n = init_s > 0.0 ? samples_within(rec, init_s) : 0;
  if (init_n >= 2 * p.window) {
    p.init = init_n;
    s.init_duration_s = init_s;
  }
  return p;
}

// The base variance the multiplier scales.
void choose_noise(const Prepared& p, DetectionSummary& s) {
  if (p.init > 0) {
    const std::size_t h = p.window / 2;
    s.noise_variance = quantile({p.var.begin() + static_cast<std::ptrdiff_t>(h),
                                 p.var.begin() + static_cast<std::ptrdiff_t>(p.init - h)}, 0.5);
    s.noise_source = "median window variance over the first " + num(s.init_duration_s) + " s";
  } else {
    s.noise_variance = quantile(p.var, kNoisePercentile);
    s.noise_source = "10th percentile of the window variance over the recording";
  }
}

// The gyro's zero-rate offset from still data: the mean over the still start, else the per-axis
// median over the samples whose window variance is at most `still_threshold`.
void choose_gyro_bias(const Recording& rec, const Prepared& p, double still_threshold, DetectionSummary& s) {
  if (p.init > 0) {
    s.gyro_bias_radps = interval_of(rec, 0, p.init - 1).gyro_mean_radps;
    s.gyro_bias_source = "mean over the first " + num(s.init_duration_s) + " s";
    return;
  }
  std::array<std::vector<double>, 3> still;
  for (std::size_t i = 0; i < rec.samples.size(); ++i)
    if (p.var[i] <= still_threshold)
      for (int a = 0; a < 3; ++a) still[static_cast<std::size_t>(a)].push_back(rec.samples[i].gyro_radps[a]);
  if (still[0].empty()) {
    s.gyro_bias_source = "none (no still sample)";
    return;
  }
  for (int a = 0; a < 3; ++a) s.gyro_bias_radps[a] = quantile(still[static_cast<std::size_t>(a)], 0.5);
  s.gyro_bias_source = "per-axis median over the " + std::to_string(still[0].size()) + " stillest samples";
}

struct Pass {
  std::vector<DetectedInterval> intervals;
  std::array<std::size_t, 4> rejected{};
  void reject(Rejection r) { ++rejected[static_cast<std::size_t>(r)]; }
};

// Samples i..j (still by both gates): accepted, or rejected as too short or saturated.
void take_run(const Recording& rec, std::size_t i, std::size_t j, std::size_t trim, double min_duration_s, Pass& out) {
  const std::size_t a = i + trim, b = j >= trim ? j - trim : 0;
  if (b < a || rec.samples[b].t_s - rec.samples[a].t_s < min_duration_s) return out.reject(Rejection::kTooShort);
  for (std::size_t k = a; k <= b; ++k)
    if (rec.samples[k].flags & (kAccelSaturated | kGyroSaturated)) return out.reject(Rejection::kSaturated);
  out.intervals.push_back(interval_of(rec, a, b));
}

// The runs whose window variance is at most `threshold` (split at gaps), each cut where the
// window-mean gyro rate less its bias exceeds the gate (counted once per run as kGyroRate), the
// pieces accepted or rejected with their reason.
Pass detect_at(const Recording& rec, const Prepared& p, double threshold, const DetectionSummary& s) {
  const std::size_t n = rec.samples.size();
  const auto trim = static_cast<std::size_t>(std::round(p.trim_s * s.rate_hz));
  auto turning = [&](std::size_t k) { return !p.rate.empty() && p.rate[k] > s.max_gyro_radps; };
  Pass out;
  std::size_t i = 0;
  while (i < n) {
    if (!(p.var[i] <= threshold)) { ++i; continue; }
    std::size_t j = i;
    while (j + 1 < n && p.var[j + 1] <= threshold && !(rec.samples[j + 1].flags & kGapBefore)) ++j;
    if (j + 1 < n && p.var[j + 1] <= threshold) out.reject(Rejection::kGap);
    bool cut = false;
    for (std::size_t k = i; k <= j;) {
      if (turning(k)) { cut = true; ++k; continue; }
      std::size_t e = k;
      while (e + 1 <= j && !turning(e + 1)) ++e;
      take_run(rec, k, e, trim, s.min_duration_s, out);
      k = e + 1;
    }
    if (cut) out.reject(Rejection::kGyroRate);
    i = j + 1;
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

// Scans kScanMultipliers; sets s.multiplier, s.multiplier_choice and s.scan.
void scan_multipliers(const Recording& rec, const Prepared& p, DetectionSummary& s) {
  std::size_t most = 0;
  for (double k : kScanMultipliers) {
    const Pass pass = detect_at(rec, p, k * s.noise_variance, s);
    const std::size_t distinct = poses(pass.intervals);  // noise splits do not determine a quadric
    s.scan.push_back({k, pass.intervals.size(), distinct, distinct > kQuadricUnknowns ? quadric_rms(pass.intervals) : kNaN});
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
    return;
  }
  s.multiplier_choice = "scanned " + num(kScanMultipliers.front()) + ".." + num(kScanMultipliers.back()) +
                        ": of those keeping the most distinct poses (" + std::to_string(most) +
                        "), the least quadric (ellipsoid) residual of the interval means, " + num(least) + " m/s^2";
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

std::string DetectionSummary::print() const {
  std::string out = "static detection: " + std::to_string(found) + " intervals; window " + num(window_s) +
                    " s at " + num(rate_hz) + " Hz, min duration " + num(min_duration_s) + " s\n";
  out += "  noise variance " + num(noise_variance) + " (m/s^2)^2 (" + noise_source + ")\n";
  out += "  threshold " + num(threshold) + " (m/s^2)^2" +
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
         gyro_bias_source == o.gyro_bias_source;
}

Detection detect_static(const Recording& rec, const StaticDetectorOptions& o) {
  Detection out;
  DetectionSummary& s = out.summary;
  if (rec.samples.size() < 3) return out;
  Prepared p = prepare(rec, o, s);
  s.max_gyro_radps = o.max_gyro_radps;
  const bool given = o.variance_threshold > 0.0;
  if (given) {
    s.threshold = o.variance_threshold;
    s.noise_source = "given";
  } else {
    choose_noise(p, s);
  }
  choose_gyro_bias(rec, p, given ? s.threshold : kScanMultipliers.front() * s.noise_variance, s);
  if (s.max_gyro_radps > 0.0) p.rate = window_rate(rec, p.window / 2, s.gyro_bias_radps);
  if (!given && o.threshold_multiplier > 0.0) {
    s.multiplier = o.threshold_multiplier;
    s.multiplier_choice = "given";
  } else if (!given) {
    scan_multipliers(rec, p, s);
  }
  if (!given) s.threshold = s.multiplier * s.noise_variance;
  Pass pass = detect_at(rec, p, s.threshold, s);
  out.intervals = std::move(pass.intervals);
  s.rejected = pass.rejected;
  s.found = out.intervals.size();
  return out;
}

std::vector<DetectedInterval> detect_static_intervals(const Recording& rec, const StaticDetectorOptions& o) {
  return detect_static(rec, o).intervals;
}

}  // namespace stend::processing
