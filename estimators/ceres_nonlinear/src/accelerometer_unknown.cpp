// Accelerometer calibration with the orientations unknown, only |g| known (IMU-TK / Ferraris
// style): for every static interval the residual |u_k(θ)| − g. See
// stend/ceres_nonlinear/calibration.hpp.
#include "accelerometer.hpp"

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
  template <typename T>
  STEND_CERES_COST_INLINE bool operator()(const T* const p, T* residual) const {
    T theta[kFull];
    expand(p, free_index, theta);
    const model::Vec3<T> u = invert_affine<T>(*m, theta, y);
    using std::sqrt;
    residual[0] = sqrt(u.squaredNorm()) - T(g);
    return true;
  }
};

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

CalibrationResult fit_unknown(const std::vector<processing::StaticPoint>& intervals, double gravity_mps2,
                              const CalibrationOptions& o, Purpose purpose) {
  CalibrationResult r;
  r.method = Method::kUnknownOrientations;
  r.model = accelerometer_model();
  r.intervals = intervals;
  r.gravity_mps2 = gravity_mps2;
  const auto info = r.model.params();
  std::vector<int> free_index;
  for (int i = 0; i < kFull; ++i)
    if (std::find(o.fixed_cross_axis.begin(), o.fixed_cross_axis.end(), info[static_cast<std::size_t>(i)].name) ==
        o.fixed_cross_axis.end())
      free_index.push_back(i);
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
  if (!finite_intervals(intervals)) {
    fail_all(r, "non-finite (NaN) readings in a static interval");
    norm_rms(r);
    return r;
  }
  const int spare = purpose == Purpose::kCalibration ? 1 : 0;  // intervals beyond the parameters
  if (n < p + spare) {
    fail_all(r, fmt::format("too few static intervals: {} found, need at least {} for {} accelerometer "
                            "parameters plus one degree of freedom for the noise ({} minimum to "
                            "determine them at all); record more orientations",
                            n, p + 1, p, p));
    norm_rms(r);
    return r;
  }
  std::vector<double> x(static_cast<std::size_t>(p), 0.0);
  ceres::Problem problem;
  for (const auto& iv : intervals) {
    const NormCost c{&r.model, free_index, iv.accel.mean, gravity_mps2};
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
  solve(problem, x, free_index, n, o, r, purpose == Purpose::kCalibration ? Weighting::kRelative : Weighting::kAPriori);
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
  CalibrationResult r = calibrate_accelerometer_unknown_orientations(ex.intervals, g, o);
  r.detection = ex.detection;
  return r;
}

}  // namespace stend::ceres_nonlinear
