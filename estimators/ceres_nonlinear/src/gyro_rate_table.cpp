// Gyroscope calibration on a rate table (known rates): for every rate segment (and every static
// orientation segment, ω = the truth's Earth rate) the mean reading ȳ_k against measure(θ, ω_k,
// f_k). See stend/ceres_nonlinear/calibration.hpp.
#include "gyro.hpp"

#include <stend/recording/truth_columns.hpp>

#include <fmt/format.h>

#include <algorithm>

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
  if (!finite_intervals(intervals)) return done("non-finite (NaN) readings in an interval");
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
  std::vector<int> free_index(static_cast<std::size_t>(p));
  for (int i = 0; i < p; ++i) free_index[static_cast<std::size_t>(i)] = i;
  solve(problem, x, free_index, 3 * n, o, r);
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
