// Sliding-variance static-interval detector. See stend/processing/static_detector.hpp.
#include "stend/processing/static_detector.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace stend::processing {

namespace {

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

}  // namespace

std::vector<DetectedInterval> detect_static_intervals(const Recording& rec,
                                                      const StaticDetectorOptions& o) {
  const std::size_t n = rec.samples.size();
  std::vector<DetectedInterval> out;
  if (n < 3) return out;
  const double dt = (rec.samples.back().t_s - rec.samples.front().t_s) / static_cast<double>(n - 1);
  if (!(dt > 0.0)) throw std::invalid_argument("detect_static_intervals: sample times do not increase");
  const auto half = static_cast<std::size_t>(std::max(1.0, std::round(0.5 * o.window_s / dt)));
  // Prefix sums of the centred values (numerically safe).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& s : rec.samples) mean += s.accel_mps2;
  mean /= static_cast<double>(n);
  std::vector<Eigen::Vector3d> s1(n + 1, Eigen::Vector3d::Zero()), s2(n + 1, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = rec.samples[i].accel_mps2 - mean;
    s1[i + 1] = s1[i] + d;
    s2[i + 1] = s2[i] + d.cwiseAbs2();
  }
  auto var_between = [&](std::size_t a, std::size_t b) {  // samples a..b-1
    const double m = static_cast<double>(b - a);
    const Eigen::Vector3d mu = (s1[b] - s1[a]) / m;
    return ((s2[b] - s2[a]) / m - mu.cwiseAbs2()).sum() * m / std::max(1.0, m - 1.0);
  };
  std::vector<double> var(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= half ? i - half : 0, b = std::min(n, i + half + 1);
    var[i] = var_between(a, b);
  }
  double threshold = o.variance_threshold;
  if (!(threshold > 0.0)) {
    double base;
    if (o.init_duration_s > 0.0) {
      std::size_t b = 0;
      while (b < n && rec.samples[b].t_s - rec.samples[0].t_s <= o.init_duration_s) ++b;
      base = var_between(0, std::max<std::size_t>(b, 2));
    } else {
      std::vector<double> sorted = var;
      const auto k = static_cast<std::ptrdiff_t>(sorted.size() / 10);
      std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
      base = sorted[static_cast<std::size_t>(k)];
    }
    threshold = o.threshold_multiplier * base;
  }
  const auto trim = static_cast<std::size_t>(std::round(o.trim_s / dt));
  std::size_t i = 0;
  while (i < n) {
    if (!(var[i] <= threshold)) { ++i; continue; }
    std::size_t j = i;
    while (j + 1 < n && var[j + 1] <= threshold && !(rec.samples[j + 1].flags & kGapBefore)) ++j;
    if (j >= i + 2 * trim + 1) {
      const std::size_t a = i + trim, b = j - trim;
      if (rec.samples[b].t_s - rec.samples[a].t_s >= o.min_duration_s) {
        DetectedInterval iv = interval_of(rec, a, b);
        if (!(o.max_gyro_radps > 0.0) || iv.gyro_mean_radps.norm() <= o.max_gyro_radps) out.push_back(iv);
      }
    }
    i = j + 1;
  }
  return out;
}

}  // namespace stend::processing
