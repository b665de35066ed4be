// What the two accelerometer procedures share: the model, the gyro bias from the static intervals
// (gyroscope: bias_only), the |ȳ| − g check. See stend/ceres_nonlinear/calibration.hpp.
#include "accelerometer.hpp"

#include <stend/estimation/linear_lsq.hpp>

#include <algorithm>
#include <cmath>

namespace stend::ceres_nonlinear {

model::ErrorModel accelerometer_model() {
  model::ErrorModel m;
  m.instrument = model::Instrument::kAccelerometer;
  m.terms = {{model::TermKind::kBias}, {model::TermKind::kScale}, {model::TermKind::kCrossAxis}};
  return m;
}

namespace detail {

namespace {

// Whether the intervals hold no gyroscope readings: rows of a table of means (held values), a
// recording without a gyroscope (its values NaN), or gyro samples that do not spread at all.
// Intervals whose spread alone is not known (NaN) hold readings.
bool no_gyro_readings(const std::vector<processing::StaticPoint>& ivs) {
  if (ivs.empty()) return false;
  return std::all_of(ivs.begin(), ivs.end(), [](const processing::StaticPoint& p) {
    const processing::AxesValue& g = p.gyro;
    return p.held.has_value() || !g.mean.allFinite() ||
           (g.sample_std.allFinite() && (g.sample_std.array() <= 1e-12 * g.mean.array().abs()).all());
  });
}

}  // namespace

void estimate_gyro_bias(CalibrationResult& r, const CalibrationOptions& o) {
  r.gyro_bias.clear();
  if (!o.estimate_gyro_bias) return;
  if (no_gyro_readings(r.intervals)) {
    r.notes.push_back("gyroscope bias not estimated: the intervals hold no gyroscope readings (no gyroscope, a "
                      "table of means, or samples that do not spread at all), so there is nothing to average");
    return;
  }
  const std::size_t n = r.intervals.size();
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) {
    estimation::ParameterEstimate p;
    p.name = std::string("gyro_bias_") + ax[i];
    p.unit = "rad/s";
    if (n < 2) {
      p.value = p.std_error = p.lower = p.upper = kNaN;
      p.reason = "fewer than 2 static intervals";
      r.gyro_bias.push_back(p);
      continue;
    }
    double mean = 0.0, w = 0.0;
    for (const auto& iv : r.intervals) {
      mean += iv.gyro.mean[i];
      w += 1.0;
    }
    mean /= w;
    double ss = 0.0;
    for (const auto& iv : r.intervals) ss += (iv.gyro.mean[i] - mean) * (iv.gyro.mean[i] - mean);
    const double se = std::sqrt(ss / (w - 1.0) / w);
    const double q = estimation::interval_quantile(o.confidence, w - 1.0);
    p.value = mean;
    p.std_error = se;
    p.lower = mean - q * se;
    p.upper = mean + q * se;
    p.identifiable = true;
    estimation::judge(p, o.tolerances, {o.confidence, q});
    if (p.verdict == estimation::Verdict::kDetermined)
      p.reason = "mean over static intervals (includes Earth rotation projected on the axis)";
    r.gyro_bias.push_back(p);
  }
}

HeldOutNormError held_out(const std::vector<processing::StaticPoint>& intervals, const std::vector<double>& g_mps2,
                          const std::function<CalibrationResult(std::size_t k)>& fit_without) {
  HeldOutNormError h;
  double ss = 0.0;
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const CalibrationResult r = fit_without(k);
    const double e = r.ok() ? r.correct(intervals[k].accel.mean).norm() - g_mps2[k] : kNaN;
    h.error_mps2.push_back(e);
    if (std::isfinite(e)) {
      ss += e * e;
      ++h.predicted;
    }
  }
  if (h.predicted > 0) h.rms_mps2 = std::sqrt(ss / h.predicted);
  return h;
}

void norm_rms(CalibrationResult& r) {
  double b = 0.0, a = 0.0;
  for (const auto& iv : r.intervals) {
    b += std::pow(iv.accel.mean.norm() - r.gravity_mps2, 2);
    if (r.ok()) a += std::pow(r.correct(iv.accel.mean).norm() - r.gravity_mps2, 2);
  }
  const double n = static_cast<double>(std::max<std::size_t>(1, r.intervals.size()));
  r.norm_error_mps2.before = std::sqrt(b / n);
  r.norm_error_mps2.after = r.ok() ? std::sqrt(a / n) : kNaN;
  // Per axis: (|c| − g)·ĉ, the part of the mean that is not gravity.
  Eigen::Vector3d pb = Eigen::Vector3d::Zero(), pa = Eigen::Vector3d::Zero();
  for (const auto& iv : r.intervals) {
    const Eigen::Vector3d c = iv.accel.mean;
    if (c.norm() > 0.0) pb += ((c.norm() - r.gravity_mps2) * c.normalized()).cwiseAbs2();
    if (r.ok()) {
      const Eigen::Vector3d u = r.correct(iv.accel.mean);
      if (u.norm() > 0.0) pa += ((u.norm() - r.gravity_mps2) * u.normalized()).cwiseAbs2();
    }
  }
  r.norm_error_axis_mps2.before = (pb / n).cwiseSqrt();
  r.norm_error_axis_mps2.after = r.ok() ? Eigen::Vector3d((pa / n).cwiseSqrt()) : Eigen::Vector3d::Constant(kNaN);
}

}  // namespace detail

}  // namespace stend::ceres_nonlinear
