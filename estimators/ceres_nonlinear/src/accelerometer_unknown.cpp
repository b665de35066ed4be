// Accelerometer calibration with the orientations unknown, only |g| known (IMU-TK / Ferraris
// style): for every static interval the residual |u_k(θ)| − g. See
// stend/ceres_nonlinear/calibration.hpp.
#include "accelerometer.hpp"

#include <stend/errors.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cstddef>

namespace stend::ceres_nonlinear {

using namespace detail;

namespace {

// The input u that the (affine) accelerometer model maps to y (the model's affine form, built
// from measure<T> only, so the terms are not re-derived here).
template <typename T>
model::Vec3<T> invert_affine(const model::ErrorModel& m, const T* theta, const Eigen::Vector3d& y) {
  return m.affine<T>(theta).correct(y.cast<T>());
}

struct NormCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  Eigen::Vector3d y;
  double g;
  double weight = 1.0;  // 1 / the residual's standard error (held_weights), or 1
  template <typename T>
  STEND_CERES_COST_INLINE bool operator()(const T* const p, T* residual) const {
    T theta[kFull];
    expand(p, free_index, theta);
    const model::Vec3<T> u = invert_affine<T>(*m, theta, y);
    using std::sqrt;
    residual[0] = (sqrt(u.squaredNorm()) - T(g)) * T(weight);
    return true;
  }
};

// The standard error of |ȳ| − g for a mean with per-axis standard errors `se`: its part along the
// mean's direction, √Σ (ŷ_i·se_i)² (first order; the calibration is within a few percent of the
// identity, so the direction of ȳ stands for that of the calibrated mean).
double norm_std_error(const Eigen::Vector3d& y, const Eigen::Vector3d& se) {
  return y.normalized().cwiseProduct(se).norm();
}

// The too-few message: intervals detected in a record, or the rows of a table of means.
std::string too_few(int n, int p, int spare, bool table) {
  if (table)
    return fmt::format("too few rows in the table of means: {} for {} accelerometer parameters{}; give at least {} "
                       "rows (orientations)",
                       n, p,
                       spare > 0 ? " plus one degree of freedom for the spread the residuals give (the table states "
                                   "no n and sigma)"
                                 : "",
                       p + spare);
  return fmt::format("too few static intervals: {} found, need at least {} for {} accelerometer "
                     "parameters plus one degree of freedom for the noise ({} minimum to "
                     "determine them at all); record more orientations",
                     n, p + 1, p, p);
}

// Adapter for a parameter count only known at run time.
struct DynamicNormCost {
  NormCost inner;
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    return inner(p[0], residual);
  }
};

// What a fit is for: a calibration (its residual sets its uncertainty, so it needs a degree of
// freedom left over) or a prediction of a held-out interval (its point estimate only: as many
// intervals as parameters will do, solved with unit a-priori sigmas whose covariance nobody reads).
enum class Purpose { kCalibration, kPrediction };

// The free parameters' places in the model: every one but the cross-axis terms the options hold at 0.
std::vector<int> free_parameters(const model::ErrorModel& m, const CalibrationOptions& o) {
  const auto info = m.params();
  std::vector<int> free_index;
  for (int i = 0; i < kFull; ++i)
    if (std::find(o.fixed_cross_axis.begin(), o.fixed_cross_axis.end(), info[static_cast<std::size_t>(i)].name) ==
        o.fixed_cross_axis.end())
      free_index.push_back(i);
  return free_index;
}

// Intervals a fit needs beyond its parameters: one for the spread its residuals give; none for a
// prediction, or for a table of means whose rows state n and sigma (a-priori sigmas).
int spare_intervals(Purpose purpose, HeldWeighting held) {
  return purpose == Purpose::kCalibration && held != HeldWeighting::kAbsolute ? 1 : 0;
}

// A table of means too short for the fit is refused as input (InputError: the rows are the
// table's, not a detection's), saying how many rows it needs.
void require_enough_rows(const Recording& rec, const std::vector<processing::StaticPoint>& rows,
                         const CalibrationOptions& o) {
  const int p = static_cast<int>(free_parameters(accelerometer_model(), o).size());
  const int n = static_cast<int>(rows.size());
  const int spare = spare_intervals(Purpose::kCalibration, held_weights(rows).kind);
  if (n < p + spare) throw InputError(rec.dir.string() + ": " + too_few(n, p, spare, true));
}

CalibrationResult fit_unknown(const std::vector<processing::StaticPoint>& intervals, double gravity_mps2,
                              const CalibrationOptions& o, Purpose purpose) {
  CalibrationResult r;
  r.method = Method::kUnknownOrientations;
  r.model = accelerometer_model();
  r.intervals = intervals;
  r.gravity_mps2 = gravity_mps2;
  const std::vector<int> free_index = free_parameters(r.model, o);
  init_parameters(r, free_index);
  estimate_gyro_bias(r, o);
  const int p = static_cast<int>(free_index.size());
  const int n = static_cast<int>(intervals.size());
  r.observations = n;
  r.estimated = p;
  r.dof = n - p;
  if (!(gravity_mps2 > 0.0)) {
    fail_all(r, "gravity unknown: set gravity_mps2 (the recording header has none)");
    norm_rms(r);
    return r;
  }
  if (!finite_accel_means(intervals)) {
    fail_all(r, "non-finite (NaN) readings in a static interval");
    norm_rms(r);
    return r;
  }
  // A table of means stating n and sigma has a-priori sigmas: as many rows as parameters will do.
  const HeldWeights held = held_weights(intervals);
  const bool table = std::all_of(intervals.begin(), intervals.end(), [](const auto& iv) { return iv.held.has_value(); });
  const bool a_priori = held.kind == HeldWeighting::kAbsolute;
  const int spare = spare_intervals(purpose, held.kind);
  if (n < p + spare) {
    fail_all(r, too_few(n, p, spare, table && n > 0));
    norm_rms(r);
    return r;
  }
  r.whitened = a_priori;
  r.uncertainty = held.text();
  if (table && held.kind == HeldWeighting::kNone)
    r.notes.push_back("a table of means without n and sigma: its rows weigh the same and the standard errors come "
                      "from their scatter about the fit (the held rows themselves do not spread)");
  std::vector<double> x(static_cast<std::size_t>(p), 0.0);
  ceres::Problem problem;
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const auto& iv = intervals[k];
    NormCost c{&r.model, free_index, iv.accel.mean, gravity_mps2};
    if (held.kind != HeldWeighting::kNone) c.weight = 1.0 / norm_std_error(iv.accel.mean, held.std_error[k]);
    ceres::CostFunction* cf;
    if (p == 9) {
      cf = new ceres::AutoDiffCostFunction<NormCost, 1, 9>(new NormCost(c));
    } else {
      auto* d = new ceres::DynamicAutoDiffCostFunction<DynamicNormCost, 4>(new DynamicNormCost{c});
      d->AddParameterBlock(p);
      d->SetNumResiduals(1);
      cf = d;
    }
    problem.AddResidualBlock(cf, make_loss(o), x.data());
  }
  const Weighting weighting = purpose == Purpose::kPrediction ? Weighting::kAPriori
                              : a_priori                       ? Weighting::kAPrioriAtLeast
                                                               : Weighting::kRelative;
  solve(problem, x, free_index, n, o, r, weighting);
  norm_rms(r);
  return r;
}

}  // namespace

CalibrationResult calibrate_accelerometer_unknown_orientations(const std::vector<processing::StaticPoint>& intervals,
                                                               double gravity_mps2, const CalibrationOptions& o) {
  return fit_unknown(intervals, gravity_mps2, o, Purpose::kCalibration);
}

HeldOutNormError held_out_norm_error(const std::vector<processing::StaticPoint>& intervals, double gravity_mps2,
                                     const CalibrationOptions& options) {
  CalibrationOptions o = options;
  o.estimate_gyro_bias = false;
  return held_out(intervals, std::vector<double>(intervals.size(), gravity_mps2), [&](std::size_t k) {
    std::vector<processing::StaticPoint> others = intervals;
    others.erase(others.begin() + static_cast<std::ptrdiff_t>(k));
    return fit_unknown(others, gravity_mps2, o, Purpose::kPrediction);
  });
}

CalibrationResult calibrate_accelerometer_unknown_orientations(const Recording& rec,
                                                               const CalibrationOptions& o) {
  const double g = o.gravity_mps2 > 0.0          ? o.gravity_mps2
                   : o.standard_gravity_fallback ? rec.header.gravity_or_standard_mps2()
                                                 : rec.header.gravity_mps2;
  const Extracted ex = extract_intervals(rec, o.processing);
  if (processing::holds_means(rec)) require_enough_rows(rec, ex.intervals, o);
  CalibrationResult r = calibrate_accelerometer_unknown_orientations(ex.intervals, g, o);
  r.detection = ex.detection;
  return r;
}

}  // namespace stend::ceres_nonlinear
