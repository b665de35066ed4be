// Accelerometer calibration with the orientations known: the table's truth columns
// f_x_mps2 f_y_mps2 f_z_mps2, or its encoder angles with their zero offsets estimated; residual
// ȳ − measure(θ, f_k), all 12 parameters. See stend/ceres_nonlinear/calibration.hpp.
#include "accelerometer.hpp"

#include <stend/physics/gravity.hpp>
#include <stend/physics/table_chain.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <stdexcept>

namespace stend::ceres_nonlinear {

using namespace detail;

namespace {

// Residual rows: `W` (3×3) maps ȳ − measure(θ, f) to whitened residuals (identity when the
// orientations are exact). With a tilt (`tilted`: orientation_sigma_deg > 0) the reading is
// calibrated instead, c = A⁻¹(ȳ − b) (the model's affine form), and compared with the stated f in
// the parts a tilt does not move and moves: its magnitude |c| − |f| (a tilted face still reads g:
// no cosine loss), and its components across f, W's rows 1 and 2 (row 0 scales the magnitude).
struct KnownCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  Eigen::Vector3d y, f;
  Eigen::Matrix3d W;
  bool tilted = false;
  template <typename T>
  STEND_CERES_COST_INLINE bool operator()(const T* const p, T* residual) const {
    T theta[kFull];
    expand(p, free_index, theta);
    if (tilted) {
      const model::Vec3<T> c = m->affine<T>(theta).correct(y.cast<T>());
      residual[0] = (c.norm() - T(f.norm())) * T(W.row(0).norm());
      for (int i = 1; i < 3; ++i) residual[i] = W.row(i).cast<T>().dot(c);
      return true;
    }
    model::Stimulus<T> s;
    s.input = f.cast<T>();
    s.specific_force = s.input;
    const model::Vec3<T> d = m->measure<T>(theta, s) - y.cast<T>();
    const model::Vec3<T> w = W.cast<T>() * d;
    for (int i = 0; i < 3; ++i) residual[i] = w[i];
    return true;
  }
};

// Specific force of gravity g [m/s²] on the sensor (mounting M = R_sensor_from_mount) for the
// table's tilt h and rotation δ [deg]: M · paper_table(h, δ) · [0, 0, g] (stend/physics; the
// azimuth does not move gravity). Templated for Jets.
template <typename T>
model::Vec3<T> table_gravity(const Eigen::Matrix3d& M, const T& tilt_deg, const T& rotation_deg, double g) {
  const physics::Mat3<T> C = physics::paper_table<T>(tilt_deg * physics::kDegToRad, rotation_deg * physics::kDegToRad);
  return M.cast<T>() * physics::gravity_specific_force<T>(C, T(g));
}

// Known orientations from the table encoders with angle zero offsets: p = [12 model parameters,
// offsets in deg for the axes flagged in offset_tilt / offset_rotation (in that order)]:
//   f = table_gravity(M, h + dh, δ + dδ, g)
struct KnownOffsetCost {
  const model::ErrorModel* m;
  Eigen::Vector3d y;
  double tilt_deg, rotation_deg, g;
  Eigen::Matrix3d M, W;
  bool offset_tilt, offset_rotation;
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    const T* x = p[0];
    int k = kFull;
    T h = T(tilt_deg), d = T(rotation_deg);
    if (offset_tilt) h = h + x[k++];
    if (offset_rotation) d = d + x[k++];
    const model::Vec3<T> f = table_gravity<T>(M, h, d, g);
    model::Stimulus<T> s;
    s.input = f;
    s.specific_force = f;
    const model::Vec3<T> r = W.cast<T>() * (m->measure<T>(x, s) - y.cast<T>());
    for (int i = 0; i < 3; ++i) residual[i] = r[i];
    return true;
  }
};

}  // namespace

namespace {

// Which table angle zero offsets are estimated (tilt, rotation); the azimuth cannot be (gravity
// does not depend on it) and other names are refused.
struct TableOffsets {
  bool tilt = false, rotation = false;
  int count() const { return (tilt ? 1 : 0) + (rotation ? 1 : 0); }
};

TableOffsets table_offsets(const std::vector<std::string>& names) {
  TableOffsets t;
  for (const auto& a : names) {
    if (a == "tilt") t.tilt = true;
    else if (a == "rotation") t.rotation = true;
    else if (a == "azimuth")
      throw std::invalid_argument("table offset 'azimuth' cannot be estimated: gravity does not depend on the "
                                  "azimuth angle (only tilt and rotation)");
    else
      throw std::invalid_argument("unknown table offset axis '" + a + "' (expected tilt or rotation)");
  }
  return t;
}

// Gravity [m/s²]: the option when given, else the mean magnitude of the truth vectors.
double known_gravity(const std::vector<Eigen::Vector3d>& truth_f, const CalibrationOptions& o) {
  if (o.gravity_mps2 > 0.0) return o.gravity_mps2;
  double g = 0.0;
  for (const auto& f : truth_f) g += f.norm();
  return g / static_cast<double>(std::max<std::size_t>(1, truth_f.size()));
}

// Residual weighting of interval k: identity; the stated noise of a table's row (`held_se`, its
// standard error per axis, absolute or relative: held_weights) as 1/se per axis; or with
// orientation_sigma_deg > 0 the tilt of the true orientation, each of its two components ~ N(0, σ²):
// across gravity the residual gets the extra variance (g·σ)² [m/s²]², along gravity (the magnitude,
// which no tilt changes) only the noise of the mean.
Eigen::Matrix3d residual_weight(const processing::StaticPoint& iv, const Eigen::Vector3d& truth_f, double g,
                                const CalibrationOptions& o, double correlation, const Eigen::Vector3d* held_se) {
  Eigen::Matrix3d W = Eigen::Matrix3d::Identity();
  if (!(o.orientation_sigma_deg > 0.0 && truth_f.norm() > 0.0)) {
    if (held_se) W = held_se->cwiseInverse().asDiagonal();
    return W;
  }
  const Eigen::Vector3d e0 = truth_f.normalized();
  const Eigen::Vector3d e1 = e0.unitOrthogonal(), e2 = e0.cross(e1);
  const double n_sd = std::max(1e-6, correlation * iv.accel.std_error.mean());
  const double t_sd = std::hypot(n_sd, g * o.orientation_sigma_deg * physics::kDegToRad);
  W.row(0) = e0.transpose() / n_sd;
  W.row(1) = e1.transpose() / t_sd;
  W.row(2) = e2.transpose() / t_sd;
  return W;
}

// The known-orientation residual blocks: truth vectors, or encoder angles with offsets [deg].
void add_known_residuals(const std::vector<processing::StaticPoint>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
                         const std::vector<std::array<double, 2>>& angles, const Eigen::Matrix3d& M,
                         const TableOffsets& off, const std::vector<int>& free_index, const CalibrationOptions& o,
                         const HeldWeights& held, const CalibrationResult& r, ceres::Problem& problem,
                         std::vector<double>& x) {
  const int p = static_cast<int>(free_index.size());
  const double correlation = noise_correlation_factor(intervals, false);
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const Eigen::Vector3d* held_se = held.kind == HeldWeighting::kNone ? nullptr : &held.std_error[k];
    const Eigen::Matrix3d W = residual_weight(intervals[k], truth_f[k], r.gravity_mps2, o, correlation, held_se);
    if (off.count() == 0) {
      auto* f = new KnownCost{&r.model, free_index, intervals[k].accel.mean, truth_f[k], W, o.orientation_sigma_deg > 0.0};
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<KnownCost, 3, kFull>(f), make_loss(o), x.data());
    } else {
      auto* c = new ceres::DynamicAutoDiffCostFunction<KnownOffsetCost, 4>(new KnownOffsetCost{
          &r.model, intervals[k].accel.mean, angles[k][0], angles[k][1], r.gravity_mps2, M, W, off.tilt, off.rotation});
      c->AddParameterBlock(p);
      c->SetNumResiduals(3);
      problem.AddResidualBlock(c, make_loss(o), x.data());
    }
  }
}

// Per-axis residual RMS against the truth, offset-corrected when offsets were estimated
// (x = the solution: 12 model parameters, then the offsets [deg]).
void known_axis_rms(const std::vector<processing::StaticPoint>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
                    const std::vector<std::array<double, 2>>& angles, const Eigen::Matrix3d& M,
                    const TableOffsets& off, const std::vector<double>& x, CalibrationResult& r) {
  std::vector<Eigen::Vector3d> truth = truth_f, reading;
  if (off.count() > 0 && r.ok()) {
    const double dh = off.tilt ? x[kFull] : 0.0, dd = off.rotation ? x[static_cast<std::size_t>(kFull + (off.tilt ? 1 : 0))] : 0.0;
    for (std::size_t k = 0; k < truth.size(); ++k)
      truth[k] = table_gravity(M, angles[k][0] + dh, angles[k][1] + dd, r.gravity_mps2);
  }
  for (const auto& iv : intervals) reading.push_back(iv.accel.mean);
  axis_rms_against(r, truth, reading, truth);
}

// The options with a placement sigma only when the intervals' noise is known: whitening by the
// noise of a mean needs a spread of the samples, and a table of means has none unless it states n
// and sigma (its standard errors would come out of the 1e-6 m/s^2 floor). Without one the residuals are unweighted and the
// covariance comes from their scatter (σ² = RSS/(n − p), Student t), said in r.notes.
CalibrationOptions without_unknown_noise(const CalibrationOptions& o, const std::vector<processing::StaticPoint>& intervals,
                                         CalibrationResult& r) {
  if (!(o.orientation_sigma_deg > 0.0) || !mean_noise_unknown(intervals, false)) return o;
  CalibrationOptions unweighted = o;
  unweighted.orientation_sigma_deg = 0.0;
  r.notes.push_back(fmt::format("orientation_sigma_deg {} not used: the noise of the intervals' means is unknown (a table "
                                "of means that does not state both n and sigma: its held rows do not spread); the "
                                "residuals are not whitened and the standard errors come from their scatter",
                                o.orientation_sigma_deg));
  return unweighted;
}

// Known orientations, shared by the truth-vector and the encoder-angle (offset) variants.
// `angles` (tilt, rotation deg per interval) and M are used only when offsets are estimated.
CalibrationResult known_impl(const std::vector<processing::StaticPoint>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
                             const std::vector<std::array<double, 2>>& angles, const Eigen::Matrix3d& M,
                             const CalibrationOptions& options) {
  CalibrationResult r;
  r.method = Method::kKnownOrientations;
  r.model = accelerometer_model();
  r.intervals = intervals;
  r.gravity_mps2 = known_gravity(truth_f, options);
  const CalibrationOptions o = without_unknown_noise(options, intervals, r);
  // A table's stated noise weights the rows when no placement sigma whitens them (held_weights).
  const HeldWeights held = o.orientation_sigma_deg > 0.0 ? HeldWeights{} : held_weights(intervals);
  r.whitened = o.orientation_sigma_deg > 0.0 || held.kind == HeldWeighting::kAbsolute;
  const TableOffsets off = table_offsets(o.table_offsets);
  const int p = kFull + off.count();
  std::vector<int> free_index(static_cast<std::size_t>(p));
  for (int i = 0; i < p; ++i) free_index[static_cast<std::size_t>(i)] = i;
  init_parameters(r, std::vector<int>(free_index.begin(), free_index.begin() + kFull));
  for (const char* ax : {"tilt", "rotation"}) {
    if ((std::string(ax) == "tilt" && !off.tilt) || (std::string(ax) == "rotation" && !off.rotation)) continue;
    estimation::ParameterEstimate prm;
    prm.name = std::string("table_offset_") + ax;
    prm.unit = "deg";
    r.parameters.push_back(prm);
  }
  estimate_gyro_bias(r, o);
  const int n = static_cast<int>(intervals.size());
  r.observations = 3 * n;
  r.estimated = p;
  r.dof = 3 * n - p;
  auto done = [&](const std::string& why) {
    fail_all(r, why);
    norm_rms(r);
    if (truth_f.size() == intervals.size()) known_axis_rms(intervals, truth_f, angles, M, off, {}, r);  // raw
    return r;
  };
  if (truth_f.size() != intervals.size() || (off.count() > 0 && angles.size() != intervals.size()))
    return done("known orientations: one truth vector (or encoder angle pair) per static interval is needed");
  if (!finite_accel_means(intervals)) return done("non-finite (NaN) readings in a static interval");
  if (3 * n < p + 1)
    return done(fmt::format("too few static intervals: {} found, need at least {} (3 equations each) for {} "
                            "parameters plus noise",
                            n, (p + 1 + 2) / 3, p));
  std::vector<double> x(static_cast<std::size_t>(p), 0.0);
  ceres::Problem problem;
  add_known_residuals(intervals, truth_f, angles, M, off, free_index, o, held, r, problem, x);
  // With a stated placement sigma the residuals are whitened by a-priori sigmas, the placement's a
  // bound: the reduced χ² may widen the intervals, never narrow them. A table's stated sigma/√n
  // likewise (it leaves out what drifts between rows).
  if (held.kind != HeldWeighting::kNone)
    r.uncertainty = held.text();
  else if (r.whitened)
    r.uncertainty = fmt::format("a-priori sigmas: the noise of each interval mean (sample std/√N or a table's "
                                "sigma/√n, × {:.3g}, the samples' correlation) on the calibrated magnitude (no tilt "
                                "changes it) and across gravity, there plus g·{} deg (the placement)",
                                noise_correlation_factor(intervals, false), o.orientation_sigma_deg);
  solve(problem, x, free_index, 3 * n, o, r, r.whitened ? Weighting::kAPrioriAtLeast : Weighting::kRelative);
  norm_rms(r);
  known_axis_rms(intervals, truth_f, angles, M, off, x, r);
  return r;
}

}  // namespace

CalibrationResult calibrate_accelerometer_known_orientations(const std::vector<processing::StaticPoint>& intervals,
                                                             const std::vector<Eigen::Vector3d>& truth_f,
                                                             const CalibrationOptions& o) {
  if (!o.table_offsets.empty())
    throw std::invalid_argument("table_offsets need the encoder angles: use the recording overload");
  return known_impl(intervals, truth_f, {}, Eigen::Matrix3d::Identity(), o);
}

HeldOutNormError held_out_norm_error(const std::vector<processing::StaticPoint>& intervals,
                                     const std::vector<Eigen::Vector3d>& truth_f, const CalibrationOptions& options) {
  CalibrationOptions o = options;
  o.estimate_gyro_bias = false;
  std::vector<double> g;
  for (const auto& f : truth_f) g.push_back(f.norm());
  return held_out(intervals, g, [&](std::size_t k) {
    auto others = intervals;
    auto others_f = truth_f;
    others.erase(others.begin() + static_cast<std::ptrdiff_t>(k));
    others_f.erase(others_f.begin() + static_cast<std::ptrdiff_t>(k));
    return calibrate_accelerometer_known_orientations(others, others_f, o);
  });
}

CalibrationResult calibrate_accelerometer_known_orientations(const Recording& rec, const CalibrationOptions& o) {
  CalibrationOptions o2 = o;
  if (!(o2.gravity_mps2 > 0.0)) o2.gravity_mps2 = rec.header.gravity_mps2;
  const bool offsets = !o.table_offsets.empty();
  // The truth of each interval: the table's encoder angles [deg], or the specific force [m/s^2].
  const std::vector<std::string> columns =
      offsets ? std::vector<std::string>{o.table_fixture + ".tilt.meas_deg", o.table_fixture + ".rotation.meas_deg"}
              : std::vector<std::string>{"f_x_mps2", "f_y_mps2", "f_z_mps2"};
  const bool have = std::all_of(columns.begin(), columns.end(),
                                [&](const std::string& c) { return rec.truth_column(c) >= 0; });
  const Extracted ex = extract_intervals(rec, o.processing, have ? columns : std::vector<std::string>{});
  auto fail_missing = [&](const std::string& why) {
    CalibrationResult r;
    r.method = Method::kKnownOrientations;
    r.model = accelerometer_model();
    r.intervals = ex.intervals;
    init_parameters(r, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
    fail_all(r, why);
    return r;
  };
  if (!offsets && !have)
    return fail_missing("known orientations need the truth columns f_x_mps2, f_y_mps2, f_z_mps2; this recording "
                        "has none (use calibrate_accelerometer_unknown_orientations)");
  if (offsets && !have)
    return fail_missing(fmt::format("table offsets need the encoder columns {0}.tilt.meas_deg and "
                                    "{0}.rotation.meas_deg (a three-axis table with fixture id '{0}'); "
                                    "set table_fixture",
                                    o.table_fixture));
  if (offsets && !(o2.gravity_mps2 > 0.0))
    return fail_missing("table offsets need gravity: set gravity_mps2 (the recording header has none)");
  Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
  if (rec.header.mounting_R.size() == 9)
    for (int i = 0; i < 9; ++i) M(i / 3, i % 3) = rec.header.mounting_R[static_cast<std::size_t>(i)];
  std::vector<Eigen::Vector3d> truth;
  std::vector<std::array<double, 2>> angles;
  for (const std::vector<double>& a : ex.truth) {
    Eigen::Vector3d f;
    if (offsets) {
      angles.push_back({a[0], a[1]});
      f = table_gravity(M, a[0], a[1], o2.gravity_mps2);
    } else {
      f = Eigen::Vector3d(a[0], a[1], a[2]);
    }
    truth.push_back(f);
  }
  return known_impl(ex.intervals, truth, angles, M, o2);
}

}  // namespace stend::ceres_nonlinear
