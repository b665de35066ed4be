// Gyroscope calibration on a rate table (known rates): for every rate segment (and every static
// orientation segment, ω = the truth's Earth rate) the mean reading ȳ_k against measure(θ, ω_k,
// f_k). See stend/ceres_nonlinear/calibration.hpp.
#include "gyro.hpp"

#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/truth_columns.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace stend::ceres_nonlinear {

using namespace detail;

model::ErrorModel gyroscope_model(bool g_sensitivity) {
  model::ErrorModel m;
  m.instrument = model::Instrument::kGyroscope;
  m.terms = {{model::TermKind::kBias}, {model::TermKind::kScale}, {model::TermKind::kCrossAxis}};
  if (g_sensitivity) m.terms.push_back({model::TermKind::kGSensitivity});
  return m;
}

namespace {

// Rate-table residual ȳ − measure(θ, ω, f); p = the model's full parameter vector (12 or 21).
template <int N>
struct RateCost {
  const model::ErrorModel* m;
  Eigen::Vector3d y, w, f;
  template <typename T>
  STEND_CERES_COST_INLINE bool operator()(const T* const p, T* residual) const {
    model::Stimulus<T> s;
    s.input = w.cast<T>();
    s.specific_force = f.cast<T>();
    const model::Vec3<T> d = m->measure<T>(p, s) - y.cast<T>();
    for (int i = 0; i < 3; ++i) residual[i] = d[i];
    return true;
  }
};

// Mean magnitude of the finite vectors (0 when none).
double mean_finite_norm(const std::vector<Eigen::Vector3d>& v) {
  double sum = 0.0;
  int n = 0;
  for (const auto& f : v)
    if (f.allFinite()) {
      sum += f.norm();
      ++n;
    }
  return n > 0 ? sum / n : 0.0;
}

// Each vector, or 0 where it is not finite.
std::vector<Eigen::Vector3d> finite_or_zero(const std::vector<Eigen::Vector3d>& v) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& f : v) out.push_back(f.allFinite() ? f : Eigen::Vector3d::Zero());
  return out;
}

// Interval k of a rate table whose axes are known to σ [rad] (rate_axis_sigma_deg > 0): ȳ_k
// against measure(θ, (1 − σ²/2)·ω_k, f_k), whitened by the noise of the mean (the interval's own
// sample std, per axis), the axis's uncertainty (|ω|·σ across the rate, |ω|·σ² along it: the cosine
// loss, half of it taken off) and the Earth rate the truth leaves out (a rate leg: its horizontal
// part turns with the table, at most Ω_e on each horizontal axis; a still: earth_rate_covariance).
GyroObservation rate_observation(const processing::StaticPoint& iv, const Eigen::Vector3d& w, const Eigen::Vector3d& f,
                                 double sigma_rad, double correlation, Eigen::Matrix3d& c) {
  GyroObservation obs;
  obs.stimulus.input = (1.0 - 0.5 * sigma_rad * sigma_rad) * w;
  obs.stimulus.specific_force = f;
  obs.reading = iv.gyro.mean;
  const double n = static_cast<double>(std::max<std::size_t>(1, iv.samples_used));
  c = Eigen::Vector3d(iv.gyro.sample_std.cwiseAbs2() * (correlation * correlation) / n).cwiseMax(1e-20).asDiagonal();
  const double rate = w.norm();
  if (rate > 0.0) {
    const Eigen::Vector3d a = w / rate;
    const Eigen::Matrix3d along = a * a.transpose();
    c += std::pow(rate * sigma_rad, 2) * (Eigen::Matrix3d::Identity() - along) +
         std::pow(rate * sigma_rad * sigma_rad, 2) * along;
  }
  if (iv.segment.kind == SegmentKind::kRate) {
    const double earth_sq = physics::kEarthRateRadps * physics::kEarthRateRadps;
    const Eigen::Vector3d up = f.allFinite() && f.norm() > 0.0 ? Eigen::Vector3d(f.normalized()) : Eigen::Vector3d::Zero();
    c += earth_sq * (Eigen::Matrix3d::Identity() - up * up.transpose());
  } else {
    c += earth_rate_covariance(w, f);
  }
  return obs;
}

// The whitened rate-table fit (rate_axis_sigma_deg > 0) on the free parameters x: each interval's
// own covariance (rate_observation) and, without the g-sensitivity in the model, the one it adds
// unmodelled (g_sensitivity_sigma_dps_per_g: shared by the intervals at one orientation).
int add_whitened_rate_residuals(const std::vector<processing::StaticPoint>& intervals,
                                const std::vector<Eigen::Vector3d>& truth_w, const std::vector<Eigen::Vector3d>& f_used,
                                const GyroOptions& go, const CalibrationOptions& o, CalibrationResult& r,
                                ceres::Problem& problem, std::vector<double>& x) {
  const double sigma = go.rate_axis_sigma_deg * physics::kDegToRad;
  const double sigma_g = go.estimate_g_sensitivity ? 0.0
                                                   : go.g_sensitivity_sigma_dps_per_g * physics::kDegPerSecond /
                                                         physics::kStandardGravity;
  std::vector<GyroObservation> obs;
  const double correlation = noise_correlation_factor(intervals, true);
  Eigen::MatrixXd c = g_sensitivity_covariance(f_used, sigma_g);
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    Eigen::Matrix3d ck;
    obs.push_back(rate_observation(intervals[k], truth_w[k], f_used[k], sigma, correlation, ck));
    c.block(3 * static_cast<Eigen::Index>(k), 3 * static_cast<Eigen::Index>(k), 3, 3) += ck;
  }
  std::vector<int> free_index(x.size());
  for (std::size_t i = 0; i < free_index.size(); ++i) free_index[i] = static_cast<int>(i);
  r.whitened = true;
  r.uncertainty = fmt::format("a-priori sigmas: the noise of each interval mean (its sample std/√N × {2:.3g}, the "
                              "samples' correlation); the rate axis known to {0} deg: |ω|·{0} deg across the rate, |ω|·({0} deg)² along it (the cosine "
                              "loss, half of it taken off the stated rate); the Earth rate the truth leaves out{1}",
                              go.rate_axis_sigma_deg,
                              sigma_g > 0.0 ? fmt::format("; an unmodelled g-sensitivity of {} (deg/s)/g per term, "
                                                          "shared by the intervals at one orientation",
                                                          go.g_sensitivity_sigma_dps_per_g)
                                            : std::string(),
                              correlation);
  if (const std::string note = joint_loss_note(o); !note.empty()) r.notes.push_back(note);
  return add_joint_gyro_observations(obs, c, r.model, free_index, o, problem, x);
}

}  // namespace

namespace detail {

void init_gyro_parameters(CalibrationResult& r) {
  std::vector<int> all(static_cast<std::size_t>(r.model.size()));
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  init_parameters(r, all);
}

}  // namespace detail

CalibrationResult calibrate_gyro_rate_table(const std::vector<processing::StaticPoint>& intervals,
                                            const std::vector<Eigen::Vector3d>& truth_w,
                                            const std::vector<Eigen::Vector3d>& truth_f, const GyroOptions& go) {
  CalibrationResult r;
  r.method = Method::kRateTable;
  r.model = gyroscope_model(go.estimate_g_sensitivity);
  r.intervals = intervals;
  r.gravity_mps2 = mean_finite_norm(truth_f);
  init_gyro_parameters(r);
  const int p = r.model.size();
  const int n = static_cast<int>(intervals.size());
  r.observations = 3 * n;
  r.estimated = p;
  r.dof = 3 * n - p;
  auto done = [&](const std::string& why) {
    fail_all(r, why);
    return r;
  };
  if (truth_w.size() != intervals.size() || truth_f.size() != intervals.size())
    return done("rate table: one truth rate and specific force per interval is needed");
  if (!finite_gyro_means(intervals)) return done("non-finite (NaN) readings in an interval");
  for (std::size_t k = 0; k < truth_w.size(); ++k) {
    if (!truth_w[k].allFinite()) return done("non-finite rate truth (w_*_radps) in an interval");
    if (go.estimate_g_sensitivity && !truth_f[k].allFinite())
      return done("non-finite specific-force truth (f_*_mps2) in an interval: the g-sensitivity needs the specific "
                  "force of every interval (set gyro_g_sensitivity: false, or give the orientations)");
  }
  // Without g-sensitivity the specific force is unused: an unknown one (NaN) is read as 0.
  const std::vector<Eigen::Vector3d> f_used = go.estimate_g_sensitivity ? truth_f : finite_or_zero(truth_f);
  if (3 * n < p + 1)
    return done(fmt::format("too few intervals: {} rate or static intervals, need at least {} (3 equations each) "
                            "for {} gyro parameters plus noise",
                            n, (p + 3) / 3, p));
  std::vector<double> x(static_cast<std::size_t>(p), 0.0);
  ceres::Problem problem;
  const CalibrationOptions o = as_calibration_options(go, go.loss_scale_radps);
  const bool whitened = go.rate_axis_sigma_deg > 0.0;
  if (whitened) {
    add_whitened_rate_residuals(intervals, truth_w, f_used, go, o, r, problem, x);
  } else {
    for (std::size_t k = 0; k < intervals.size(); ++k) {
      ceres::CostFunction* cf;
      if (p == 12)
        cf = new ceres::AutoDiffCostFunction<RateCost<12>, 3, 12>(
            new RateCost<12>{&r.model, intervals[k].gyro.mean, truth_w[k], f_used[k]});
      else
        cf = new ceres::AutoDiffCostFunction<RateCost<21>, 3, 21>(
            new RateCost<21>{&r.model, intervals[k].gyro.mean, truth_w[k], f_used[k]});
      problem.AddResidualBlock(cf, make_loss(o), x.data());
    }
  }
  std::vector<int> free_index(static_cast<std::size_t>(p));
  for (int i = 0; i < p; ++i) free_index[static_cast<std::size_t>(i)] = i;
  // With the axes known only to a stated sigma the weights are a-priori and the sigma a bound: the
  // reduced χ² may widen the intervals, never narrow them.
  solve(problem, x, free_index, 3 * n, o, r, whitened ? Weighting::kAPrioriAtLeast : Weighting::kRelative);
  std::vector<Eigen::Vector3d> reading;
  double before = 0.0, after = 0.0;
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    reading.push_back(intervals[k].gyro.mean);
    before += (intervals[k].gyro.mean - truth_w[k]).squaredNorm();
    if (r.ok()) {
      model::Stimulus<double> st;
      st.specific_force = f_used[k];
      after += (r.model.correct(r.theta.data(), intervals[k].gyro.mean, st) - truth_w[k]).squaredNorm();
    }
  }
  r.rate_error_radps.before = std::sqrt(before / std::max(1, n));
  r.rate_error_radps.after = r.ok() ? std::sqrt(after / std::max(1, n)) : kNaN;
  axis_rms_against(r, truth_w, reading, f_used);
  return r;
}

CalibrationResult calibrate_gyro_rate_table(const Recording& rec, const GyroOptions& go) {
  const std::vector<std::string> columns = truth_column_names({kRateColumns, kSpecificForceColumns});
  const bool have = std::all_of(columns.begin(), columns.end(),
                                [&](const std::string& c) { return rec.truth_column(c) >= 0; });
  std::vector<processing::StaticPoint> kept;
  std::vector<Eigen::Vector3d> w, f;
  if (have) {
    processing::Request request;
    request.truth_columns = columns;
    std::vector<processing::StaticPoint> points = processing::extract(rec, go.processing, request).points;
    std::stable_sort(points.begin(), points.end(), [](const processing::StaticPoint& a, const processing::StaticPoint& b) {
      return a.t_start_s < b.t_start_s;
    });
    for (const auto& p : points) {
      w.emplace_back(p.truth[0], p.truth[1], p.truth[2]);
      f.emplace_back(p.truth[3], p.truth[4], p.truth[5]);
      kept.push_back(p);
      kept.back().segment.label = std::string(to_string(p.segment.kind)) + ": " + p.segment.label;  // as reported
    }
  }
  CalibrationResult r = calibrate_gyro_rate_table(kept, w, f, go);
  if (!have) {
    fail_all(r, "the rate-table gyro calibration needs the truth columns w_x_radps.. and f_x_mps2..; this "
                "recording has none (use the integration method)");
  } else if (!r.ok() && std::none_of(kept.begin(), kept.end(), [](const processing::StaticPoint& iv) {
               return iv.segment.kind == SegmentKind::kRate;
             })) {
    r.message = "no rate segments in the recording (add a `rates:` step): " + r.message;
  }
  return r;
}

}  // namespace stend::ceres_nonlinear
