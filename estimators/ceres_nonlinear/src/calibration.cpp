#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/estimation/linear_lsq.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/table_chain.hpp>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <tuple>

namespace stend::ceres_nonlinear {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kFull = 12;  // bias 3, scale 3, cross 6

// --------------------------------------------------------------------------------------------
// Cost functors. `free_index[k]` = position in the full 12-vector of free parameter k.

template <typename T>
void expand(const T* free_params, const std::vector<int>& free_index, T* full) {
  for (int i = 0; i < kFull; ++i) full[i] = T(0);
  for (std::size_t k = 0; k < free_index.size(); ++k)
    full[free_index[k]] = free_params[k];
}

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
  bool operator()(const T* const p, T* residual) const {
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

// Residual rows: `W` (3×3) maps ȳ − measure(θ, f) to whitened residuals (identity when the
// orientations are exact; otherwise along-gravity / across-gravity split, see the options).
struct KnownCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  Eigen::Vector3d y, f;
  Eigen::Matrix3d W;
  template <typename T>
  bool operator()(const T* const p, T* residual) const {
    T theta[kFull];
    expand(p, free_index, theta);
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

ceres::LossFunction* make_loss(const CalibrationOptions& o) {
  switch (o.loss) {
    case Loss::kHuber: return new ceres::HuberLoss(o.loss_scale_mps2);
    case Loss::kCauchy: return new ceres::CauchyLoss(o.loss_scale_mps2);
    case Loss::kNone: break;
  }
  return nullptr;
}

// Nominal size of a parameter for the identifiability scaling: a bias in units of g (accel) or
// 1 rad/s (gyro), g-sensitivity in 1/g, an angle offset in 1 rad = 57.3 deg, the rest 1.
double nominal_size(const std::string& name, const CalibrationResult& r) {
  const double g = r.gravity_mps2 > 0.0 ? r.gravity_mps2 : physics::kStandardGravity;
  if (name.rfind("bias", 0) == 0) return r.model.instrument == model::Instrument::kAccelerometer ? g : 1.0;
  if (name.rfind("gsens", 0) == 0) return 1.0 / g;
  if (name.rfind("table_offset", 0) == 0) return physics::kRadToDeg;
  return 1.0;
}

void fail_all(CalibrationResult& r, const std::string& message) {
  r.ok = false;
  r.message = message;
  r.theta.assign(static_cast<std::size_t>(r.model.size()), kNaN);
  for (auto& p : r.parameters) {
    if (p.fixed) continue;
    p.value = p.std_error = p.lower = p.upper = kNaN;
    p.identifiable = false;
    if (p.reason.empty()) p.reason = "fit failed";
  }
}

void init_parameters(CalibrationResult& r, const std::vector<int>& free_index) {
  const auto info = r.model.params();
  r.parameters.clear();
  for (std::size_t i = 0; i < info.size(); ++i) {
    Parameter p;
    p.name = info[i].name;
    p.unit = info[i].unit;
    p.fixed = std::find(free_index.begin(), free_index.end(), static_cast<int>(i)) == free_index.end();
    if (p.fixed) {
      p.value = p.std_error = p.lower = p.upper = 0.0;
      p.identifiable = false;
      p.reason = "held at 0 (frame convention: a rotation is unobservable with unknown orientations)";
    }
    r.parameters.push_back(p);
  }
}

void gyro_bias(CalibrationResult& r, const CalibrationOptions& o) {
  r.gyro_parameters.clear();
  if (!o.estimate_gyro_bias) return;
  const std::size_t n = r.intervals.size();
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) {
    Parameter p;
    p.name = std::string("gyro_bias_") + ax[i];
    p.unit = "rad/s";
    if (n < 2) {
      p.value = p.std_error = p.lower = p.upper = kNaN;
      p.reason = "fewer than 2 static intervals";
      r.gyro_parameters.push_back(p);
      continue;
    }
    double mean = 0.0, w = 0.0;
    for (const auto& iv : r.intervals) {
      mean += iv.gyro_mean[i];
      w += 1.0;
    }
    mean /= w;
    double ss = 0.0;
    for (const auto& iv : r.intervals) ss += (iv.gyro_mean[i] - mean) * (iv.gyro_mean[i] - mean);
    const double se = std::sqrt(ss / (w - 1.0) / w);
    const double q = estimation::student_t_quantile(0.5 + 0.5 * o.confidence, w - 1.0);
    p.value = mean;
    p.std_error = se;
    p.lower = mean - q * se;
    p.upper = mean + q * se;
    p.identifiable = true;
    estimation::judge(p, o.tolerances);
    if (p.verdict == estimation::Verdict::kDetermined)
      p.reason = "mean over static intervals (includes Earth rotation projected on the axis)";
    r.gyro_parameters.push_back(p);
  }
}

// Runs Ceres (dense QR, tight tolerances) on the problem and records the counts in r.
ceres::Solver::Summary run_solver(ceres::Problem& problem, int residual_count, int p, const CalibrationOptions& o,
                                  CalibrationResult& r) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  r.solver_report = summary.BriefReport();
  r.iterations = static_cast<int>(summary.iterations.size());
  r.observations = residual_count;
  r.estimated = p;
  r.dof = residual_count - p;
  return summary;
}

// Dense Jacobian of the residuals at the current parameter values; `cost` = ½·Σ residual².
Eigen::MatrixXd jacobian_at_solution(ceres::Problem& problem, double& cost) {
  ceres::CRSMatrix crs;
  std::vector<double> residuals;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, &residuals, nullptr, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int row = 0; row < crs.num_rows; ++row)
    for (int k = crs.rows[static_cast<std::size_t>(row)]; k < crs.rows[static_cast<std::size_t>(row) + 1]; ++k)
      J(row, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
  return J;
}

// Name of free parameter k.
const std::string& free_name(const CalibrationResult& r, const std::vector<int>& free_index, int k) {
  return r.parameters[static_cast<std::size_t>(free_index[static_cast<std::size_t>(k)])].name;
}

// Parameters that the weak directions of the scaled Jacobian move, and why the directions are weak.
struct WeakParameters {
  std::vector<std::string> names;
  std::string why;
};

// Singular directions of the scaled Jacobian (singular value below `tolerance` × the largest;
// `what` says what that means in the message), each named as a combination of parameters in their own units; a parameter whose unit
// vector has a share ≥ 0.5 inside the singular subspace is not identifiable (if none reaches it,
// the most affected ones). A large standard error alone never makes a direction weak: the
// parameters' verdicts judge precision.
WeakParameters weak_parameters(const Eigen::JacobiSVD<Eigen::MatrixXd>& svd, const Eigen::VectorXd& scale,
                               const std::vector<int>& free_index, double tolerance, const char* what,
                               const CalibrationResult& r) {
  const Eigen::VectorXd sv = svd.singularValues();
  const int p = static_cast<int>(free_index.size());
  std::vector<std::string> names;
  for (int j = 0; j < p; ++j) names.push_back(free_name(r, free_index, j));
  WeakParameters weak;
  std::vector<int> weak_dirs;
  for (int k = 0; k < sv.size(); ++k)
    if (!(sv[k] > tolerance * sv[0])) weak_dirs.push_back(k);
  if (weak_dirs.empty()) return weak;
  // θ = diag(scale)·θ_s, so a direction in the parameters' own units is scale ⊙ v.
  Eigen::MatrixXd basis(p, static_cast<Eigen::Index>(weak_dirs.size()));
  for (std::size_t c = 0; c < weak_dirs.size(); ++c)
    basis.col(static_cast<Eigen::Index>(c)) = scale.cwiseProduct(svd.matrixV().col(weak_dirs[c]));
  std::vector<double> share(static_cast<std::size_t>(p), 0.0);
  for (int j = 0; j < p; ++j)
    for (int k : weak_dirs) share[static_cast<std::size_t>(j)] += std::pow(svd.matrixV()(j, k), 2);
  const double top = *std::max_element(share.begin(), share.end());
  const double cut = std::min(0.5, 0.5 * top);
  for (int j = 0; j < p; ++j)
    if (share[static_cast<std::size_t>(j)] >= cut) weak.names.push_back(names[static_cast<std::size_t>(j)]);
  std::string list;
  for (const auto& c : estimation::null_space_text(basis, names)) list += (list.empty() ? "" : "; ") + c;
  weak.why = fmt::format("{} (smallest singular value ratio {:.2e}): the data do not see {}", what,
                         sv[sv.size() - 1] / sv[0], list);
  return weak;
}

// Fails the fit naming the parameters that the experiment cannot determine.
void fail_not_identifiable(CalibrationResult& r, const WeakParameters& weak) {
  r.not_identifiable = weak.names;
  std::string names;
  for (const auto& w : weak.names) names += (names.empty() ? "" : ", ") + w;
  fail_all(r, "not identifiable from this experiment: " + names + " — " + weak.why +
                  ". The other parameters are coupled to them, so no numbers are reported; add "
                  "orientations that excite these parameters.");
  for (auto& prm : r.parameters)
    if (std::find(weak.names.begin(), weak.names.end(), prm.name) != weak.names.end())
      prm.reason = "not identifiable: " + weak.why;
}

// Covariance σ²·(JᵀJ)⁻¹ of the free parameters, their values, standard errors and confidence
// bounds; fails the fit when Ceres cannot invert JᵀJ.
void fill_parameters(ceres::Problem& problem, std::vector<double>& x, const std::vector<int>& free_index,
                     const CalibrationOptions& o, CalibrationResult& r) {
  const int p = static_cast<int>(free_index.size());
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = 0;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks = {{x.data(), x.data()}};
  Eigen::MatrixXd C(p, p);
  if (!cov.Compute(blocks, &problem) || !cov.GetCovarianceBlock(x.data(), x.data(), C.data())) {
    fail_all(r, "not identifiable: ceres::Covariance could not invert JᵀJ (rank-deficient Jacobian "
                "at the solution); no uncertainties, so no numbers are reported");
    return;
  }
  // Ceres fills the block row-major; C is symmetric so the storage order does not matter.
  C *= r.sigma * r.sigma;
  r.covariance = C;
  r.free_index = free_index;
  r.quantile = estimation::student_t_quantile(0.5 + 0.5 * o.confidence, r.dof);
  r.theta.assign(static_cast<std::size_t>(r.model.size()), 0.0);
  for (int k = 0; k < p; ++k) {
    const auto idx = static_cast<std::size_t>(free_index[static_cast<std::size_t>(k)]);
    auto& prm = r.parameters[idx];
    if (idx < r.theta.size()) r.theta[idx] = x[static_cast<std::size_t>(k)];
    prm.value = x[static_cast<std::size_t>(k)];
    prm.std_error = std::sqrt(std::max(0.0, C(k, k)));
    prm.lower = prm.value - r.quantile * prm.std_error;
    prm.upper = prm.value + r.quantile * prm.std_error;
    prm.identifiable = true;
    estimation::judge(prm, o.tolerances);
  }
  r.ok = true;
}

// Solve, check identifiability, fill the covariance. `free_index` lists the estimated parameters.
void solve(ceres::Problem& problem, std::vector<double>& x, const std::vector<int>& free_index,
           int residual_count, const CalibrationOptions& o, CalibrationResult& r) {
  const int p = static_cast<int>(free_index.size());
  const ceres::Solver::Summary summary = run_solver(problem, residual_count, p, o, r);

  // Identifiability from the Jacobian at the solution (before judging convergence: a flat
  // direction is the more useful explanation of a failure), scaled by the parameters' nominal sizes.
  double cost = 0.0;
  const Eigen::MatrixXd J = jacobian_at_solution(problem, cost);
  Eigen::VectorXd scale(p);
  for (int k = 0; k < p; ++k) scale[k] = nominal_size(free_name(r, free_index, k), r);
  const Eigen::MatrixXd Js = J * scale.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Js, Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  r.condition_number = sv.size() > 0 && sv[sv.size() - 1] > 0.0 ? sv[0] / sv[sv.size() - 1]
                                                                 : std::numeric_limits<double>::infinity();
  if (!std::isfinite(cost) || !J.allFinite()) {
    fail_all(r, "non-finite residuals or Jacobian at the solution (NaN or Inf in the data or the "
                "fit diverged); check the recording for invalid samples");
    return;
  }
  const double rss = 2.0 * cost;
  r.sigma = r.dof > 0 ? std::sqrt(rss / r.dof) : kNaN;
  const WeakParameters weak = weak_parameters(svd, scale, free_index, o.rank_tolerance, "rank-deficient design", r);
  if (!weak.names.empty()) {
    fail_not_identifiable(r, weak);
    return;
  }
  if (summary.termination_type != ceres::CONVERGENCE) {
    // A nonlinear fit whose design is singular to first order (e.g. gravity never along one axis)
    // wanders along the direction the data hardly see: name it as the reason.
    const WeakParameters near = weak_parameters(svd, scale, free_index, std::sqrt(o.rank_tolerance),
                                                "the solver did not converge on a nearly singular design", r);
    if (!near.names.empty()) {
      fail_not_identifiable(r, near);
      return;
    }
    fail_all(r, "the solver did not converge: " + summary.BriefReport() +
                    " (raise max_iterations, check the static intervals and gravity)");
    return;
  }
  if (r.dof <= 0) {
    fail_all(r, fmt::format("no degree of freedom left for the noise ({} residuals, {} parameters): "
                            "add static intervals", residual_count, p));
    return;
  }
  fill_parameters(problem, x, free_index, o, r);
}

void norm_rms(CalibrationResult& r) {
  double b = 0.0, a = 0.0;
  for (const auto& iv : r.intervals) {
    b += std::pow(iv.accel_mean.norm() - r.gravity_mps2, 2);
    if (r.ok) a += std::pow(r.correct(iv.accel_mean).norm() - r.gravity_mps2, 2);
  }
  const double n = static_cast<double>(std::max<std::size_t>(1, r.intervals.size()));
  r.rms_norm_before = std::sqrt(b / n);
  r.rms_norm_after = r.ok ? std::sqrt(a / n) : kNaN;
  // Per axis: (|c| − g)·ĉ, the part of the mean that is not gravity.
  Eigen::Vector3d pb = Eigen::Vector3d::Zero(), pa = Eigen::Vector3d::Zero();
  for (const auto& iv : r.intervals) {
    const Eigen::Vector3d c = iv.accel_mean;
    if (c.norm() > 0.0) pb += ((c.norm() - r.gravity_mps2) * c.normalized()).cwiseAbs2();
    if (r.ok) {
      const Eigen::Vector3d u = r.correct(iv.accel_mean);
      if (u.norm() > 0.0) pa += ((u.norm() - r.gravity_mps2) * u.normalized()).cwiseAbs2();
    }
  }
  r.rms_axis_before = (pb / n).cwiseSqrt();
  r.rms_axis_after = r.ok ? Eigen::Vector3d((pa / n).cwiseSqrt()) : Eigen::Vector3d::Constant(kNaN);
}

// Per-axis RMS of reading − truth, raw and calibrated (known orientations, rate table).
void axis_rms_against(CalibrationResult& r, const std::vector<Eigen::Vector3d>& truth,
                      const std::vector<Eigen::Vector3d>& reading, const std::vector<Eigen::Vector3d>& f) {
  Eigen::Vector3d pb = Eigen::Vector3d::Zero(), pa = Eigen::Vector3d::Zero();
  const std::size_t n = std::min(truth.size(), reading.size());
  for (std::size_t k = 0; k < n; ++k) {
    pb += (reading[k] - truth[k]).cwiseAbs2();
    if (r.ok) {
      model::Stimulus<double> st;
      st.specific_force = k < f.size() ? f[k] : truth[k];
      pa += (r.model.correct(r.theta.data(), reading[k], st) - truth[k]).cwiseAbs2();
    }
  }
  const double d = static_cast<double>(std::max<std::size_t>(1, n));
  r.rms_axis_before = (pb / d).cwiseSqrt();
  r.rms_axis_after = r.ok ? Eigen::Vector3d((pa / d).cwiseSqrt()) : Eigen::Vector3d::Constant(kNaN);
}

bool finite_intervals(const std::vector<StaticInterval>& ivs) {
  for (const auto& iv : ivs)
    if (!iv.accel_mean.allFinite() || !iv.gyro_mean.allFinite()) return false;
  return true;
}

std::string fmt_num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "—"; }

}  // namespace

// ============================================================================================

model::ErrorModel accelerometer_model() {
  model::ErrorModel m;
  m.instrument = model::Instrument::kAccelerometer;
  m.terms = {{model::TermKind::kBias}, {model::TermKind::kScale}, {model::TermKind::kCrossAxis}};
  return m;
}

const char* loss_name(Loss l) {
  switch (l) {
    case Loss::kHuber: return "huber";
    case Loss::kCauchy: return "cauchy";
    case Loss::kNone: break;
  }
  return "none";
}

Loss loss_from_name(const std::string& name) {
  if (name == "none") return Loss::kNone;
  if (name == "huber") return Loss::kHuber;
  if (name == "cauchy") return Loss::kCauchy;
  throw std::invalid_argument("unknown loss '" + name + "' (expected none, huber or cauchy)");
}

StaticInterval make_interval(const Recording& rec, std::size_t first, std::size_t last, std::string label) {
  if (last < first || last >= rec.sample_count())
    throw std::out_of_range("make_interval: bad sample range");
  std::vector<ImuSample> S(last - first + 1);  // one static interval
  rec.sample_source().read(first, S.size(), S.data());
  StaticInterval iv;
  iv.first = first;
  iv.last = last;
  iv.t_start_s = S.front().t_s;
  iv.t_end_s = S.back().t_s;
  iv.count = last - first + 1;
  iv.label = std::move(label);
  Eigen::Vector3d s2 = Eigen::Vector3d::Zero();
  for (const ImuSample& x : S) {
    iv.accel_mean += x.accel_mps2;
    iv.gyro_mean += x.gyro_radps;
  }
  const double n = static_cast<double>(iv.count);
  iv.accel_mean /= n;
  iv.gyro_mean /= n;
  Eigen::Vector3d g2 = Eigen::Vector3d::Zero();
  for (const ImuSample& x : S) {
    s2 += (x.accel_mps2 - iv.accel_mean).cwiseAbs2();
    g2 += (x.gyro_radps - iv.gyro_mean).cwiseAbs2();
  }
  if (iv.count > 1) {
    iv.accel_std = (s2 / (n - 1.0)).cwiseSqrt();
    iv.gyro_std = (g2 / (n - 1.0)).cwiseSqrt();
  }
  return iv;
}

StaticInterval to_interval(const processing::StaticPoint& p) {
  StaticInterval iv;
  iv.first = p.first;
  iv.last = p.last;
  iv.t_start_s = p.t_start_s;
  iv.t_end_s = p.t_end_s;
  iv.count = p.samples_used;
  iv.accel_mean = p.accel.mean;
  iv.accel_std = p.accel.sample_std;
  iv.gyro_mean = p.gyro.mean;
  iv.gyro_std = p.gyro.sample_std;
  iv.label = p.segment.label;
  return iv;
}

processing::ProcessingOptions default_interval_options() {
  processing::ProcessingOptions o;
  o.intervals = processing::IntervalSource::kDetect;
  o.extraction.filter = processing::Filter::kNone;
  o.extraction.settle_s = 0.0;
  return o;
}

processing::ProcessingOptions rate_table_interval_options() {
  processing::ProcessingOptions o;
  o.intervals = processing::IntervalSource::kSegments;
  o.segment_kinds = {"orientation", "rate"};
  o.extraction.filter = processing::Filter::kNone;
  o.extraction.settle_s = 0.5;
  o.stated = {"intervals", "segments"};
  return o;
}

namespace {

struct Extracted {
  std::vector<StaticInterval> intervals;
  std::vector<std::vector<double>> truth;  // per interval, the means of the requested columns
  std::optional<processing::DetectionSummary> detection;
};

Extracted extract_intervals(const Recording& rec, const processing::ProcessingOptions& o,
                            std::vector<std::string> truth_columns = {}) {
  processing::Request request;
  request.truth_columns = std::move(truth_columns);
  Extracted out;
  const processing::Extraction ex = processing::extract(rec, o, request);
  for (const auto& p : ex.points) {
    out.intervals.push_back(to_interval(p));
    out.truth.push_back(p.truth);
  }
  out.detection = ex.detection;
  return out;
}

}  // namespace

std::vector<StaticInterval> static_intervals(const Recording& rec, const processing::ProcessingOptions& options) {
  return extract_intervals(rec, options).intervals;
}

// ============================================================================================

const Parameter& CalibrationResult::parameter(const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name) return p;
  for (const auto& p : gyro_parameters)
    if (p.name == name) return p;
  throw std::out_of_range("no parameter '" + name + "'");
}

Eigen::Vector3d CalibrationResult::correct(const Eigen::Vector3d& y) const {
  if (!ok) throw std::logic_error("CalibrationResult::correct: the calibration failed: " + message);
  return model.correct(theta.data(), y, model::Stimulus<double>{});
}

std::string CalibrationResult::report() const {
  const bool gyro = model.instrument == model::Instrument::kGyroscope;
  std::string s = fmt::format("Ceres {} calibration ({})\n", gyro ? "gyroscope" : "accelerometer", method);
  s += fmt::format("status: {}\n", ok ? "ok" : "FAILED — " + message);
  s += fmt::format("{} intervals: {}, residuals: {}, estimated parameters: {}, dof: {}, condition number {}{}\n",
                   method == "rate_table" ? "rate and static" : "static", intervals.size(), observations, estimated,
                   dof, fmt_num(condition_number),
                   gyro ? std::string() : fmt::format(", g = {} m/s^2", gravity_mps2));
  const char* sigma_unit = whitened ? "(whitened residuals; 1 = as expected)"
                           : method == "integration" ? "rad (gravity direction)"
                           : gyro ? "rad/s" : "m/s^2";
  s += fmt::format("residual sigma: {} {}, solver: {}\n", fmt_num(sigma), sigma_unit, solver_report);
  if (detection) s += detection->print() + "\n";
  if (!gyro) {
    s += fmt::format("RMS of |a| - g over the intervals: raw {} m/s^2, calibrated {} m/s^2\n",
                     fmt_num(rms_norm_before), fmt_num(rms_norm_after));
    s += fmt::format("residual RMS per axis (x y z), calibrated: {} {} {} m/s^2 = {} {} {} mg; raw: {} {} {} mg\n",
                     fmt_num(rms_axis_after[0]), fmt_num(rms_axis_after[1]), fmt_num(rms_axis_after[2]),
                     fmt_num(rms_axis_after[0] / physics::kMilliG), fmt_num(rms_axis_after[1] / physics::kMilliG),
                     fmt_num(rms_axis_after[2] / physics::kMilliG), fmt_num(rms_axis_before[0] / physics::kMilliG),
                     fmt_num(rms_axis_before[1] / physics::kMilliG), fmt_num(rms_axis_before[2] / physics::kMilliG));
  } else if (method == "integration") {
    s += fmt::format("gravity-direction mismatch after each move (RMS): raw {} rad, calibrated {} rad; per axis "
                     "calibrated {} {} {} rad\n",
                     fmt_num(rms_norm_before), fmt_num(rms_norm_after), fmt_num(rms_axis_after[0]),
                     fmt_num(rms_axis_after[1]), fmt_num(rms_axis_after[2]));
  } else {
    const double dps = 1.0 / physics::kDegPerSecond;
    s += fmt::format("residual RMS per axis (x y z), calibrated: {} {} {} rad/s = {} {} {} deg/s; raw: {} {} {} deg/s\n",
                     fmt_num(rms_axis_after[0]), fmt_num(rms_axis_after[1]), fmt_num(rms_axis_after[2]),
                     fmt_num(rms_axis_after[0] * dps), fmt_num(rms_axis_after[1] * dps),
                     fmt_num(rms_axis_after[2] * dps), fmt_num(rms_axis_before[0] * dps),
                     fmt_num(rms_axis_before[1] * dps), fmt_num(rms_axis_before[2] * dps));
  }
  s += fmt::format("{:<22} {:>14} {:<14} {:>12} {:>14} {:>14}  {:<12} {}\n", "parameter", "value", "unit",
                   "std error", "95% lower", "95% upper", "verdict", "note");
  auto row = [&](const Parameter& p) {
    s += fmt::format("{:<22} {:>14} {:<14} {:>12} {:>14} {:>14}  {:<12} {}\n", p.name, fmt_num(p.value), p.unit,
                     fmt_num(p.std_error), fmt_num(p.lower), fmt_num(p.upper),
                     p.fixed ? "fixed" : estimation::to_string(p.judged()), p.reason);
  };
  for (const auto& p : parameters) row(p);
  for (const auto& p : gyro_parameters) row(p);
  return s;
}

namespace {

nlohmann::json detection_json(const processing::DetectionSummary& d) {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json scan = json::array();
  for (const auto& st : d.scan)
    scan.push_back({{"multiplier", st.multiplier}, {"intervals", st.intervals}, {"poses", st.poses},
                    {"quadric_rms_mps2", num(st.quadric_rms_mps2)}});
  json rejected = json::object();
  for (processing::Rejection r : processing::kAllRejections) rejected[processing::rejection_name(r)] = d.count(r);
  return {{"found", d.found},
          {"rate_hz", d.rate_hz},
          {"window_s", d.window_s},
          {"min_duration_s", d.min_duration_s},
          {"init_duration_s", d.init_duration_s},
          {"noise_variance_m2ps4", d.noise_variance},
          {"noise_source", d.noise_source},
          {"threshold_m2ps4", d.threshold},
          {"multiplier", d.multiplier},
          {"multiplier_choice", d.multiplier_choice},
          {"scan", scan},
          {"gyro_bias_dps", {d.gyro_bias_radps.x() / physics::kDegPerSecond, d.gyro_bias_radps.y() / physics::kDegPerSecond,
                             d.gyro_bias_radps.z() / physics::kDegPerSecond}},
          {"gyro_bias_source", d.gyro_bias_source},
          {"max_gyro_dps", d.max_gyro_radps / physics::kDegPerSecond},
          {"rejected", rejected}};
}

}  // namespace

std::string CalibrationResult::to_json() const {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  auto prm = [&](const Parameter& p) {
    return json{{"name", p.name}, {"unit", p.unit}, {"value", num(p.value)},
                {"std_error", num(p.std_error)}, {"ci95", {num(p.lower), num(p.upper)}},
                {"identifiable", p.identifiable}, {"verdict", estimation::to_string(p.judged())},
                {"tolerance", num(p.tolerance)}, {"fixed", p.fixed}, {"reason", p.reason}};
  };
  json j;
  j["ok"] = ok;
  j["message"] = message;
  j["method"] = method;
  j["gravity_mps2"] = gravity_mps2;
  j["observations"] = observations;
  j["estimated"] = estimated;
  j["dof"] = dof;
  j[whitened ? "sigma_whitened" : "sigma_mps2"] = num(sigma);
  const bool gyro = model.instrument == model::Instrument::kGyroscope;
  j["instrument"] = gyro ? "gyroscope" : "accelerometer";
  if (!gyro) {
    j["rms_norm_before_mps2"] = num(rms_norm_before);
    j["rms_norm_after_mps2"] = num(rms_norm_after);
  } else {
    j[method == "integration" ? "rms_direction_before_rad" : "rms_before_radps"] = num(rms_norm_before);
    j[method == "integration" ? "rms_direction_after_rad" : "rms_after_radps"] = num(rms_norm_after);
  }
  const std::string au = method == "integration" ? "rad" : gyro ? "radps" : "mps2";
  j["rms_axis_before_" + au] = {num(rms_axis_before[0]), num(rms_axis_before[1]), num(rms_axis_before[2])};
  j["rms_axis_after_" + au] = {num(rms_axis_after[0]), num(rms_axis_after[1]), num(rms_axis_after[2])};
  if (!gyro) {
    j["rms_axis_before_mg"] = {num(rms_axis_before[0] / physics::kMilliG), num(rms_axis_before[1] / physics::kMilliG),
                               num(rms_axis_before[2] / physics::kMilliG)};
    j["rms_axis_after_mg"] = {num(rms_axis_after[0] / physics::kMilliG), num(rms_axis_after[1] / physics::kMilliG),
                              num(rms_axis_after[2] / physics::kMilliG)};
  }
  j["condition_number"] = num(condition_number);
  j["confidence_quantile"] = num(quantile);
  j["solver"] = solver_report;
  j["not_identifiable"] = not_identifiable;
  j["parameters"] = json::array();
  for (const auto& p : parameters) j["parameters"].push_back(prm(p));
  j["gyro_parameters"] = json::array();
  for (const auto& p : gyro_parameters) j["gyro_parameters"].push_back(prm(p));
  if (detection) j["detection"] = detection_json(*detection);
  j["intervals"] = json::array();
  // Accelerometer: each interval's |ȳ| − g raw and |correct(ȳ)| − g calibrated [m/s^2].
  for (const auto& iv : intervals) {
    json e = {{"label", iv.label}, {"t_start_s", iv.t_start_s}, {"t_end_s", iv.t_end_s}, {"samples", iv.count}};
    if (!gyro) {
      e["norm_error_before_mps2"] = num(iv.accel_mean.norm() - gravity_mps2);
      e["norm_error_after_mps2"] = ok ? num(correct(iv.accel_mean).norm() - gravity_mps2) : json(nullptr);
    }
    j["intervals"].push_back(e);
  }
  // Gyro integration: each move's gravity-direction mismatch raw and calibrated [rad].
  if (!moves.empty()) {
    j["moves"] = json::array();
    for (const auto& m : moves)
      j["moves"].push_back({{"t_end_s", m.t_end_s}, {"mismatch_before_rad", num(m.before_rad)},
                            {"mismatch_after_rad", num(m.after_rad)}});
  }
  return j.dump(2);
}

// ============================================================================================

CalibrationResult calibrate_accelerometer_unknown_orientations(const std::vector<StaticInterval>& intervals,
                                                               double gravity_mps2,
                                                               const CalibrationOptions& o) {
  CalibrationResult r;
  r.method = "unknown_orientations";
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
  gyro_bias(r, o);
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
  if (n < p + 1) {
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
    const NormCost c{&r.model, free_index, iv.accel_mean, gravity_mps2};
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
  solve(problem, x, free_index, n, o, r);
  norm_rms(r);
  return r;
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

// Residual weighting of interval k: identity, or with orientation_sigma_deg > 0 the tilt of the
// true orientation ~ N(0, σ_tilt²): the residual across gravity gets the extra variance
// (g·σ_tilt)² [m/s²]², the one along gravity only the noise of the mean.
Eigen::Matrix3d residual_weight(const StaticInterval& iv, const Eigen::Vector3d& truth_f, double g,
                                const CalibrationOptions& o) {
  Eigen::Matrix3d W = Eigen::Matrix3d::Identity();
  if (!(o.orientation_sigma_deg > 0.0 && truth_f.norm() > 0.0)) return W;
  const Eigen::Vector3d e0 = truth_f.normalized();
  const Eigen::Vector3d e1 = e0.unitOrthogonal(), e2 = e0.cross(e1);
  const double n_sd = std::max(1e-6, iv.accel_std.mean() / std::sqrt(static_cast<double>(std::max<std::size_t>(1, iv.count))));
  const double t_sd = std::hypot(n_sd, g * o.orientation_sigma_deg * physics::kDegToRad);
  W.row(0) = e0.transpose() / n_sd;
  W.row(1) = e1.transpose() / t_sd;
  W.row(2) = e2.transpose() / t_sd;
  return W;
}

// The known-orientation residual blocks: truth vectors, or encoder angles with offsets [deg].
void add_known_residuals(const std::vector<StaticInterval>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
                         const std::vector<std::array<double, 2>>& angles, const Eigen::Matrix3d& M,
                         const TableOffsets& off, const std::vector<int>& free_index, const CalibrationOptions& o,
                         const CalibrationResult& r, ceres::Problem& problem, std::vector<double>& x) {
  const int p = static_cast<int>(free_index.size());
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const Eigen::Matrix3d W = residual_weight(intervals[k], truth_f[k], r.gravity_mps2, o);
    if (off.count() == 0) {
      auto* f = new KnownCost{&r.model, free_index, intervals[k].accel_mean, truth_f[k], W};
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<KnownCost, 3, kFull>(f), make_loss(o), x.data());
    } else {
      auto* c = new ceres::DynamicAutoDiffCostFunction<KnownOffsetCost, 4>(new KnownOffsetCost{
          &r.model, intervals[k].accel_mean, angles[k][0], angles[k][1], r.gravity_mps2, M, W, off.tilt, off.rotation});
      c->AddParameterBlock(p);
      c->SetNumResiduals(3);
      problem.AddResidualBlock(c, make_loss(o), x.data());
    }
  }
}

// Per-axis residual RMS against the truth, offset-corrected when offsets were estimated
// (x = the solution: 12 model parameters, then the offsets [deg]).
void known_axis_rms(const std::vector<StaticInterval>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
                    const std::vector<std::array<double, 2>>& angles, const Eigen::Matrix3d& M,
                    const TableOffsets& off, const std::vector<double>& x, CalibrationResult& r) {
  std::vector<Eigen::Vector3d> truth = truth_f, reading;
  if (off.count() > 0 && r.ok) {
    const double dh = off.tilt ? x[kFull] : 0.0, dd = off.rotation ? x[static_cast<std::size_t>(kFull + (off.tilt ? 1 : 0))] : 0.0;
    for (std::size_t k = 0; k < truth.size(); ++k)
      truth[k] = table_gravity(M, angles[k][0] + dh, angles[k][1] + dd, r.gravity_mps2);
  }
  for (const auto& iv : intervals) reading.push_back(iv.accel_mean);
  axis_rms_against(r, truth, reading, truth);
}

// Known orientations, shared by the truth-vector and the encoder-angle (offset) variants.
// `angles` (tilt, rotation deg per interval) and M are used only when offsets are estimated.
CalibrationResult known_impl(const std::vector<StaticInterval>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
                             const std::vector<std::array<double, 2>>& angles, const Eigen::Matrix3d& M,
                             const CalibrationOptions& o) {
  CalibrationResult r;
  r.method = "known_orientations";
  r.model = accelerometer_model();
  r.intervals = intervals;
  r.gravity_mps2 = known_gravity(truth_f, o);
  r.whitened = o.orientation_sigma_deg > 0.0;
  const TableOffsets off = table_offsets(o.table_offsets);
  const int p = kFull + off.count();
  std::vector<int> free_index(static_cast<std::size_t>(p));
  for (int i = 0; i < p; ++i) free_index[static_cast<std::size_t>(i)] = i;
  init_parameters(r, std::vector<int>(free_index.begin(), free_index.begin() + kFull));
  for (const char* ax : {"tilt", "rotation"}) {
    if ((std::string(ax) == "tilt" && !off.tilt) || (std::string(ax) == "rotation" && !off.rotation)) continue;
    Parameter prm;
    prm.name = std::string("table_offset_") + ax;
    prm.unit = "deg";
    r.parameters.push_back(prm);
  }
  gyro_bias(r, o);
  const int n = static_cast<int>(intervals.size());
  r.observations = 3 * n;
  r.estimated = p;
  r.dof = 3 * n - p;
  auto done = [&](const std::string& why) {
    fail_all(r, why);
    norm_rms(r);
    return r;
  };
  if (truth_f.size() != intervals.size() || (off.count() > 0 && angles.size() != intervals.size()))
    return done("known orientations: one truth vector (or encoder angle pair) per static interval is needed");
  if (!finite_intervals(intervals)) return done("non-finite (NaN) readings in a static interval");
  if (3 * n < p + 1)
    return done(fmt::format("too few static intervals: {} found, need at least {} (3 equations each) for {} "
                            "parameters plus noise",
                            n, (p + 1 + 2) / 3, p));
  std::vector<double> x(static_cast<std::size_t>(p), 0.0);
  ceres::Problem problem;
  add_known_residuals(intervals, truth_f, angles, M, off, free_index, o, r, problem, x);
  solve(problem, x, free_index, 3 * n, o, r);
  norm_rms(r);
  known_axis_rms(intervals, truth_f, angles, M, off, x, r);
  return r;
}

}  // namespace

CalibrationResult calibrate_accelerometer_known_orientations(const std::vector<StaticInterval>& intervals,
                                                             const std::vector<Eigen::Vector3d>& truth_f,
                                                             const CalibrationOptions& o) {
  if (!o.table_offsets.empty())
    throw std::invalid_argument("table_offsets need the encoder angles: use the recording overload");
  return known_impl(intervals, truth_f, {}, Eigen::Matrix3d::Identity(), o);
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
    r.method = "known_orientations";
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

// ============================================================================================
// Gyroscope

model::ErrorModel gyroscope_model(bool g_sensitivity) {
  model::ErrorModel m;
  m.instrument = model::Instrument::kGyroscope;
  m.terms = {{model::TermKind::kBias}, {model::TermKind::kScale}, {model::TermKind::kCrossAxis}};
  if (g_sensitivity) m.terms.push_back({model::TermKind::kGSensitivity});
  return m;
}

namespace {

// The solve() machinery reads its settings from CalibrationOptions.
CalibrationOptions as_calibration_options(const GyroOptions& g, double loss_scale) {
  CalibrationOptions o;
  o.loss = g.loss;
  o.loss_scale_mps2 = loss_scale;
  o.confidence = g.confidence;
  o.max_iterations = g.max_iterations;
  o.rank_tolerance = g.rank_tolerance;
  o.tolerances = g.tolerances;
  o.estimate_gyro_bias = false;
  return o;
}

// Rate-table residual ȳ − measure(θ, ω, f); p = the model's full parameter vector (12 or 21).
template <int N>
struct RateCost {
  const model::ErrorModel* m;
  Eigen::Vector3d y, w, f;
  template <typename T>
  bool operator()(const T* const p, T* residual) const {
    model::Stimulus<T> s;
    s.input = w.cast<T>();
    s.specific_force = f.cast<T>();
    const model::Vec3<T> d = m->measure<T>(p, s) - y.cast<T>();
    for (int i = 0; i < 3; ++i) residual[i] = d[i];
    return true;
  }
};

// Static-interval residual for stage 1 of the integration method: ȳ − measure(θ, 0, f) with only
// bias (and G) free; `base` holds the full vector (scale and cross at 0).
struct StaticGyroCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  int full;
  Eigen::Vector3d y, f;
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    std::vector<T> theta(static_cast<std::size_t>(full), T(0));
    for (std::size_t k = 0; k < free_index.size(); ++k) theta[static_cast<std::size_t>(free_index[k])] = p[0][k];
    model::Stimulus<T> s;
    s.specific_force = f.cast<T>();
    const model::Vec3<T> d = m->measure<T>(theta.data(), s) - y.cast<T>();
    for (int i = 0; i < 3; ++i) residual[i] = d[i];
    return true;
  }
};

// One step of the gravity direction v carried through a rotation vector θ [rad] of the sensor
// frame (passive, v̇ = −ω × v): exp(−[θ]×)·v = v − c1·(θ × v) + c2·θ × (θ × v) with c1, c2 the
// series of sin|θ|/|θ| and (1 − cos|θ|)/|θ|² to fifth order in θ (error θ⁶/720: < 1e-10 rad per
// step at 0.05 rad). With the derivatives the move's Jacobian needs.
struct RotationStep {
  Eigen::Vector3d th;
  double c1, c2, dc1, dc2;  // c(x), dc/dx at x = |θ|²
  explicit RotationStep(const Eigen::Vector3d& theta) : th(theta) {
    const double x = th.squaredNorm();
    c1 = 1.0 - x / 6.0 + x * x / 120.0;
    c2 = 0.5 - x / 24.0;
    dc1 = -1.0 / 6.0 + x / 60.0;
    dc2 = -1.0 / 24.0;
  }
  // R·v, R = I − c1·[θ]× + c2·[θ]×².
  Eigen::Vector3d apply(const Eigen::Vector3d& v) const {
    const Eigen::Vector3d a1 = th.cross(v);
    return v - c1 * a1 + c2 * th.cross(a1);
  }
  // Rᵀ·l (carries ∂r/∂v back one step).
  Eigen::Vector3d apply_transpose(const Eigen::Vector3d& l) const {
    const Eigen::Vector3d a1 = th.cross(l);
    return l + c1 * a1 + c2 * th.cross(a1);
  }
  // (∂(R·v)/∂θ)ᵀ·l.
  Eigen::Vector3d gradient(const Eigen::Vector3d& v, const Eigen::Vector3d& l) const {
    const Eigen::Vector3d a1 = th.cross(v), a2 = th.cross(a1);
    return -c1 * v.cross(l) + th * (2.0 * dc2 * a2.dot(l) - 2.0 * dc1 * a1.dot(l)) +
           c2 * (a1.cross(l) - v.cross(th.cross(l)));
  }
};

// Stage 2 of the integration method: p = scale(3) + cross(6), the rest of the gyro model's θ
// (`base`: bias and G from stage 1) held. `inc` are the move's rate increments
// Δ_i = ½(w_i + w_{i+1})·(t_{i+1} − t_i) of the bias-corrected readings w [rad]; the corrected rate
// is A⁻¹·w (the model's affine form, from measure() only), so step i turns by θ_i = A⁻¹·Δ_i. The
// gravity direction g0 (sensor frame at the start) is carried through the steps (RotationStep);
// residual = [e1·v, e2·v], e1 e2 ⊥ ĝ_end. The Jacobian is the exact derivative of that recursion,
// from one backward (adjoint) pass: λ ← Rᵢᵀ·λ, ∂r/∂A⁻¹ = Σ_i (∂(Rᵢv_i)/∂θ_i)ᵀλ·Δ_iᵀ, and
// ∂A⁻¹/∂p_k = −A⁻¹·(∂A/∂p_k)·A⁻¹ (every term is linear in its parameters: ∂A/∂p_k = A(e_k) − A(0)).
class MoveCost final : public ceres::SizedCostFunction<2, 9> {
 public:
  MoveCost(const model::ErrorModel& m, std::vector<double> base, std::vector<Eigen::Vector3d> inc,
           const Eigen::Vector3d& g0, const Eigen::Vector3d& e1, const Eigen::Vector3d& e2)
      : m_(m), base_(std::move(base)), inc_(std::move(inc)), g0_(g0), e1_(e1), e2_(e2) {}

  bool Evaluate(double const* const* p, double* residual, double** jacobian) const override {
    std::vector<double> theta = base_;
    for (std::size_t k = 0; k < 9; ++k) theta[3 + k] = p[0][k];
    const Eigen::Matrix3d ai = m_.affine<double>(theta.data()).a_inv;
    const std::size_t n = inc_.size();
    std::vector<Eigen::Vector3d> v(n + 1);  // v[i]: the direction before step i
    v[0] = g0_;
    for (std::size_t i = 0; i < n; ++i) v[i + 1] = RotationStep(ai * inc_[i]).apply(v[i]);
    residual[0] = e1_.dot(v[n]);
    residual[1] = e2_.dot(v[n]);
    if (jacobian && jacobian[0]) jacobian_by_adjoint(theta, ai, v, jacobian[0]);
    return true;
  }

 private:
  void jacobian_by_adjoint(std::vector<double>& theta, const Eigen::Matrix3d& ai, const std::vector<Eigen::Vector3d>& v,
                           double* jac) const {
    Eigen::Vector3d l1 = e1_, l2 = e2_;
    Eigen::Matrix3d d1 = Eigen::Matrix3d::Zero(), d2 = Eigen::Matrix3d::Zero();  // ∂r_m/∂A⁻¹
    for (std::size_t i = inc_.size(); i-- > 0;) {
      const RotationStep step(ai * inc_[i]);
      d1 += step.gradient(v[i], l1) * inc_[i].transpose();
      d2 += step.gradient(v[i], l2) * inc_[i].transpose();
      l1 = step.apply_transpose(l1);
      l2 = step.apply_transpose(l2);
    }
    for (std::size_t k = 0; k < 9; ++k) {
      const double keep = theta[3 + k];
      theta[3 + k] = 1.0;
      Eigen::Matrix3d da = m_.affine<double>(theta.data()).a;
      theta[3 + k] = 0.0;
      da -= m_.affine<double>(theta.data()).a;
      theta[3 + k] = keep;
      const Eigen::Matrix3d dai = -ai * da * ai;
      jac[k] = d1.cwiseProduct(dai).sum();
      jac[9 + k] = d2.cwiseProduct(dai).sum();
    }
  }

  const model::ErrorModel& m_;
  std::vector<double> base_;  // full θ with bias and G from stage 1
  std::vector<Eigen::Vector3d> inc_;
  Eigen::Vector3d g0_, e1_, e2_;
};

void gyro_parameters_init(CalibrationResult& r) {
  std::vector<int> all(static_cast<std::size_t>(r.model.size()));
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  init_parameters(r, all);
}

}  // namespace

CalibrationResult calibrate_gyro_rate_table(const std::vector<StaticInterval>& intervals,
                                            const std::vector<Eigen::Vector3d>& truth_w,
                                            const std::vector<Eigen::Vector3d>& truth_f, const GyroOptions& go) {
  CalibrationResult r;
  r.method = "rate_table";
  r.model = gyroscope_model(go.estimate_g_sensitivity);
  r.intervals = intervals;
  double g = 0.0;
  for (const auto& f : truth_f) g += f.norm();
  r.gravity_mps2 = truth_f.empty() ? 0.0 : g / static_cast<double>(truth_f.size());
  gyro_parameters_init(r);
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
  for (std::size_t k = 0; k < truth_w.size(); ++k)
    if (!truth_w[k].allFinite() || !truth_f[k].allFinite()) return done("non-finite truth in an interval");
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
          new RateCost<12>{&r.model, intervals[k].gyro_mean, truth_w[k], truth_f[k]});
    else
      cf = new ceres::AutoDiffCostFunction<RateCost<21>, 3, 21>(
          new RateCost<21>{&r.model, intervals[k].gyro_mean, truth_w[k], truth_f[k]});
    problem.AddResidualBlock(cf, make_loss(o), x.data());
  }
  std::vector<int> free_index(static_cast<std::size_t>(p));
  for (int i = 0; i < p; ++i) free_index[static_cast<std::size_t>(i)] = i;
  solve(problem, x, free_index, 3 * n, o, r);
  std::vector<Eigen::Vector3d> reading;
  double before = 0.0, after = 0.0;
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    reading.push_back(intervals[k].gyro_mean);
    before += (intervals[k].gyro_mean - truth_w[k]).squaredNorm();
    if (r.ok) {
      model::Stimulus<double> st;
      st.specific_force = truth_f[k];
      after += (r.model.correct(r.theta.data(), intervals[k].gyro_mean, st) - truth_w[k]).squaredNorm();
    }
  }
  r.rms_norm_before = std::sqrt(before / std::max(1, n));
  r.rms_norm_after = r.ok ? std::sqrt(after / std::max(1, n)) : kNaN;
  axis_rms_against(r, truth_w, reading, truth_f);
  return r;
}

CalibrationResult calibrate_gyro_rate_table(const Recording& rec, const GyroOptions& go) {
  const std::vector<std::string> columns = {"w_x_radps", "w_y_radps", "w_z_radps", "f_x_mps2", "f_y_mps2", "f_z_mps2"};
  const bool have = std::all_of(columns.begin(), columns.end(),
                                [&](const std::string& c) { return rec.truth_column(c) >= 0; });
  std::vector<StaticInterval> kept;
  std::vector<Eigen::Vector3d> w, f;
  if (have) {
    processing::Request request;
    request.truth_columns = columns;
    std::vector<processing::StaticPoint> points = processing::extract(rec, go.processing, request).points;
    std::stable_sort(points.begin(), points.end(), [](const processing::StaticPoint& a, const processing::StaticPoint& b) {
      return a.t_start_s < b.t_start_s;
    });
    for (const auto& p : points) {
      kept.push_back(to_interval(p));
      kept.back().label = std::string(to_string(p.segment.kind)) + ": " + p.segment.label;
      w.emplace_back(p.truth[0], p.truth[1], p.truth[2]);
      f.emplace_back(p.truth[3], p.truth[4], p.truth[5]);
    }
  }
  CalibrationResult r = calibrate_gyro_rate_table(kept, w, f, go);
  if (!have) {
    fail_all(r, "the rate-table gyro calibration needs the truth columns w_x_radps.. and f_x_mps2..; this "
                "recording has none (use the integration method)");
  } else if (std::none_of(kept.begin(), kept.end(), [](const StaticInterval& iv) { return iv.label.rfind("rate", 0) == 0; }) && !r.ok) {
    r.message = "no rate segments in the recording (add a `rates:` step): " + r.message;
  }
  return r;
}

namespace {

// Stage-2 parameters of the gyro model: scale (3) and cross-axis (6).
const std::vector<int> kScaleCrossIndex = {3, 4, 5, 6, 7, 8, 9, 10, 11};

// A move between consecutive static intervals k and k + 1: samples a (last of k) .. b (first of k + 1).
struct Move {
  std::size_t k, a, b;
};

// The samples a .. b between consecutive static intervals (the last of one, the first of the
// next), read from the recording, and their calibrated specific force [m/s²] (with G only).
struct Turn {
  std::size_t a = 0;
  std::vector<ImuSample> samples;
  std::vector<Eigen::Vector3d> f_cal;
  const ImuSample& at(std::size_t i) const { return samples[i - a]; }
};

// Inputs shared by the steps of the integration method; intervals sorted by time.
struct IntegrationData {
  const Recording& rec;
  const CalibrationResult& accel;
  const GyroOptions& go;
  std::vector<StaticInterval> ivs;
  std::vector<Eigen::Vector3d> fk;     // calibrated specific force of each interval [m/s²]
  std::vector<Eigen::Vector3d> gdir;   // its direction (unit, sensor frame)
  std::vector<Turn> turns;             // after interval k (empty when the next starts no later)
  std::vector<int> s1_index;           // stage-1 parameters: bias (+ G)
  std::vector<Move> moves;             // the moves that can be integrated
};

// Moves with at least one sample and no lost samples inside (a rotation cannot be integrated
// across a gap).
std::vector<Move> integrable_moves(const IntegrationData& d) {
  std::vector<Move> moves;
  for (std::size_t k = 0; k + 1 < d.ivs.size(); ++k) {
    const std::size_t a = d.ivs[k].last, b = d.ivs[k + 1].first;
    if (b <= a) continue;
    bool gap = false;
    for (std::size_t i = a + 1; i <= b; ++i) gap = gap || (d.turns[k].at(i).flags & kGapBefore);
    if (!gap) moves.push_back({k, a, b});
  }
  return moves;
}

// Sorted intervals, their calibrated specific force and direction, the stage-1 parameter list and
// the calibrated specific force of the samples between consecutive intervals (G·f during the
// turns; the accelerometer model is affine, so its inverse is applied as A⁻¹·(y − b)); the moves
// come later, once the intervals are known to index the recording.
IntegrationData integration_data(const Recording& rec, const CalibrationResult& accel, const GyroOptions& go) {
  IntegrationData d{rec, accel, go, accel.intervals, {}, {}, {}, {0, 1, 2}, {}};
  std::sort(d.ivs.begin(), d.ivs.end(), [](const StaticInterval& a, const StaticInterval& b) { return a.first < b.first; });
  if (!accel.ok) return d;
  for (const auto& iv : d.ivs) d.fk.push_back(accel.correct(iv.accel_mean));
  for (const auto& f : d.fk) d.gdir.push_back(f.normalized());
  if (go.estimate_g_sensitivity)
    for (int i = 12; i < 21; ++i) d.s1_index.push_back(i);
  const model::AffineForm<double> cal = accel.model.affine<double>(accel.theta.data());
  d.turns.resize(d.ivs.size());
  for (std::size_t k = 0; k + 1 < d.ivs.size(); ++k) {
    Turn& t = d.turns[k];
    t.a = d.ivs[k].last;
    const std::size_t b = d.ivs[k + 1].first;
    if (b <= t.a || b >= rec.sample_count()) continue;  // nothing between, or not this recording's
    t.samples.resize(b - t.a + 1);
    rec.sample_source().read(t.a, t.samples.size(), t.samples.data());
    if (go.estimate_g_sensitivity)
      for (const ImuSample& x : t.samples) t.f_cal.push_back(cal.correct(x.accel_mps2));
  }
  return d;
}

// Why the recording cannot be used for the integration method, or "" when it can.
std::string integration_precondition(const IntegrationData& d) {
  if (!d.accel.ok) return "the gyro integration needs the accelerometer calibration first, which failed: " + d.accel.message;
  if (!finite_intervals(d.ivs)) return "non-finite (NaN) readings in a static interval";
  if (d.ivs.size() < 7)
    return fmt::format("too few static intervals: {} found, need at least 7 (6 moves, 2 residuals each) for "
                       "9 gyro scale and cross-axis parameters plus noise",
                       d.ivs.size());
  for (const auto& iv : d.ivs)
    if (iv.last >= d.rec.sample_count()) return "the accelerometer calibration's intervals do not index this recording";
  return "";
}

// Stage 1: gyro bias [rad/s] (+ G [rad/s/(m/s²)]) from the static-interval means, with f the
// calibrated specific force; x1 holds the stage-1 parameters on return.
CalibrationResult solve_static_stage(const IntegrationData& d, const CalibrationResult& r, const CalibrationOptions& o1,
                                     std::vector<double>& x1) {
  const int p1 = static_cast<int>(d.s1_index.size());
  x1.assign(static_cast<std::size_t>(p1), 0.0);
  ceres::Problem prob1;
  for (std::size_t k = 0; k < d.ivs.size(); ++k) {
    auto* c = new ceres::DynamicAutoDiffCostFunction<StaticGyroCost, 4>(
        new StaticGyroCost{&r.model, d.s1_index, r.model.size(), d.ivs[k].gyro_mean, d.fk[k]});
    c->AddParameterBlock(p1);
    c->SetNumResiduals(3);
    prob1.AddResidualBlock(c, make_loss(o1), x1.data());
  }
  CalibrationResult r1 = r;
  solve(prob1, x1, d.s1_index, 3 * static_cast<int>(d.ivs.size()), o1, r1);
  return r1;
}

// Gyro reading of sample i of turn k minus the bias (+ G·f, f the calibrated specific force) of θ
// [rad/s].
Eigen::Vector3d bias_corrected_rate(const IntegrationData& d, const model::ErrorModel& m, const double* theta,
                                    std::size_t k, std::size_t i) {
  const Turn& t = d.turns[k];
  model::Stimulus<double> st;
  if (d.go.estimate_g_sensitivity) st.specific_force = t.f_cal[i - t.a];
  return t.at(i).gyro_radps - m.measure<double>(theta, st);
}

// Rate increments of a move's bias-corrected readings w (θ's bias and G removed), trapezoidal:
// Δ_i = ½(w_i + w_{i+1})·(t_{i+1} − t_i) [rad], i = a .. b − 1.
std::vector<Eigen::Vector3d> move_increments(const IntegrationData& d, const model::ErrorModel& m, const double* theta,
                                             const Move& mv) {
  const Turn& turn = d.turns[mv.k];
  std::vector<Eigen::Vector3d> inc(mv.b - mv.a);
  Eigen::Vector3d w_prev = bias_corrected_rate(d, m, theta, mv.k, mv.a);
  for (std::size_t i = mv.a; i < mv.b; ++i) {
    const Eigen::Vector3d w_next = bias_corrected_rate(d, m, theta, mv.k, i + 1);
    inc[i - mv.a] = (w_prev + w_next) * (0.5 * (turn.at(i + 1).t_s - turn.at(i).t_s));
    w_prev = w_next;
  }
  return inc;
}

// Stage 2: scale and cross-axis (9 parameters) from the gravity direction carried through each
// move by the bias-corrected rates of `base` (stage 1); x2 holds them on return.
CalibrationResult solve_move_stage(const IntegrationData& d, const CalibrationResult& r, const std::vector<double>& base,
                                   const CalibrationOptions& o2, std::vector<double>& x2) {
  x2.assign(9, 0.0);
  ceres::Problem prob2;
  for (const Move& mv : d.moves) {
    const Eigen::Vector3d& g1 = d.gdir[mv.k + 1];
    const Eigen::Vector3d e1 = g1.unitOrthogonal(), e2 = g1.cross(e1);
    auto* c = new MoveCost(r.model, base, move_increments(d, r.model, base.data(), mv), d.gdir[mv.k], e1, e2);
    prob2.AddResidualBlock(c, make_loss(o2), x2.data());
  }
  CalibrationResult r2 = r;
  solve(prob2, x2, kScaleCrossIndex, 2 * static_cast<int>(d.moves.size()), o2, r2);
  return r2;
}

// Counts, noise and solver reports of the two stages merged into r: bias (+ G) from stage 1,
// scale and cross-axis from stage 2.
void merge_stages(const IntegrationData& d, const CalibrationResult& r1, const CalibrationResult& r2,
                  CalibrationResult& r) {
  const int pairs = static_cast<int>(d.moves.size());
  r.parameters = r2.parameters;
  for (int i : d.s1_index) r.parameters[static_cast<std::size_t>(i)] = r1.parameters[static_cast<std::size_t>(i)];
  r.observations = 2 * pairs;
  r.estimated = 9;
  r.dof = 2 * pairs - 9;
  r.sigma = r2.sigma;
  r.quantile = r2.quantile;
  r.iterations = r1.iterations + r2.iterations;
  r.condition_number = r2.condition_number;
  r.not_identifiable = r2.not_identifiable;
  r.solver_report = "stage 1 (bias" + std::string(d.go.estimate_g_sensitivity ? ", g-sensitivity" : "") +
                    fmt::format(", {} static intervals, sigma {:.3g} rad/s): ", d.ivs.size(), r1.sigma) +
                    r1.solver_report + fmt::format("; stage 2 (scale, cross-axis, {} moves): ", pairs) +
                    r2.solver_report;
}

// Move residuals [rad] as a function of the upstream parameters z = [accelerometer free
// parameters, stage-1 parameters] and the stage-2 parameters x. The bias-corrected rates are
// recomputed only when a stage-1 parameter (or, with G, anything upstream) moved; otherwise the
// ones of the first evaluation are reused.
class MoveResiduals {
 public:
  MoveResiduals(const IntegrationData& d, const model::ErrorModel& gyro)
      : d_(d), gyro_(gyro), increment_cache_(d.moves.size()) {}

  Eigen::VectorXd operator()(const Eigen::VectorXd& z, const std::vector<double>& x, bool rates_moved) {
    const std::size_t na = d_.accel.free_index.size();
    std::vector<double> ta = d_.accel.theta, tb(static_cast<std::size_t>(gyro_.size()), 0.0);
    for (std::size_t j = 0; j < na; ++j) ta[static_cast<std::size_t>(d_.accel.free_index[j])] = z[static_cast<Eigen::Index>(j)];
    for (std::size_t j = 0; j < d_.s1_index.size(); ++j)
      tb[static_cast<std::size_t>(d_.s1_index[j])] = z[static_cast<Eigen::Index>(na + j)];
    auto cal = [&](const Eigen::Vector3d& y) { return d_.accel.model.correct(ta.data(), y, model::Stimulus<double>{}); };
    Eigen::VectorXd out(static_cast<Eigen::Index>(2 * d_.moves.size()));
    for (std::size_t q = 0; q < d_.moves.size(); ++q) {
      const Move& mv = d_.moves[q];
      // G·f during the turns with the baseline calibrated f (the accelerometer's uncertainty
      // reaches the rates through G·δf only at second order).
      const bool use_cache = !rates_moved && !increment_cache_[q].empty();
      std::vector<Eigen::Vector3d> inc = use_cache ? increment_cache_[q] : move_increments(d_, gyro_, tb.data(), mv);
      if (increment_cache_[q].empty()) increment_cache_[q] = inc;
      const Eigen::Vector3d g0 = cal(d_.ivs[mv.k].accel_mean).normalized(), g1 = cal(d_.ivs[mv.k + 1].accel_mean).normalized();
      const Eigen::Vector3d e1 = g1.unitOrthogonal(), e2 = g1.cross(e1);
      const MoveCost c(gyro_, tb, std::move(inc), g0, e1, e2);
      const double* p[] = {x.data()};
      double res[2];
      c.Evaluate(p, res, nullptr);
      out[static_cast<Eigen::Index>(2 * q)] = res[0];
      out[static_cast<Eigen::Index>(2 * q + 1)] = res[1];
    }
    return out;
  }

 private:
  const IntegrationData& d_;
  const model::ErrorModel& gyro_;
  std::vector<std::vector<Eigen::Vector3d>> increment_cache_;
};

// Covariance Cz of the upstream parameters z: the accelerometer's and stage 1's, uncorrelated.
// Returns false when either calibration has no covariance of the expected size.
bool upstream_covariance(const IntegrationData& d, const CalibrationResult& r1, Eigen::MatrixXd& Cz) {
  const auto na = static_cast<Eigen::Index>(d.accel.free_index.size());
  const auto n1 = static_cast<Eigen::Index>(d.s1_index.size());
  Cz = Eigen::MatrixXd::Zero(na + n1, na + n1);
  if (d.accel.covariance.rows() != na || r1.covariance.rows() != n1) return false;
  Cz.topLeftCorner(na, na) = d.accel.covariance;
  Cz.bottomRightCorner(r1.covariance.rows(), r1.covariance.cols()) = r1.covariance;
  return true;
}

// Stage-2 covariance with the uncertainty the accelerometer calibration and stage 1 pass on
// (delta method, forward differences of the move residuals): C = C2 + S·Cz·Sᵀ with
// S = −(J2ᵀJ2)⁻¹·J2ᵀ·Rz; fills the stage-2 standard errors and bounds in r.
void add_upstream_uncertainty(const IntegrationData& d, const CalibrationResult& r1, const CalibrationResult& r2,
                              const std::vector<double>& x1, const std::vector<double>& x2,
                              const estimation::PrecisionTolerances& tolerances, CalibrationResult& r) {
  Eigen::MatrixXd Cz;
  if (!upstream_covariance(d, r1, Cz)) return;
  const std::size_t na = d.accel.free_index.size();
  const auto nz = static_cast<Eigen::Index>(na + d.s1_index.size());
  Eigen::VectorXd z0(nz);
  for (std::size_t j = 0; j < na; ++j) z0[static_cast<Eigen::Index>(j)] = d.accel.theta[static_cast<std::size_t>(d.accel.free_index[j])];
  for (std::size_t j = 0; j < d.s1_index.size(); ++j) z0[static_cast<Eigen::Index>(na + j)] = x1[j];
  MoveResiduals residuals(d, r.model);
  const Eigen::VectorXd r0 = residuals(z0, x2, true);
  Eigen::MatrixXd Rz(r0.size(), nz), J2(r0.size(), 9);
  for (Eigen::Index j = 0; j < nz; ++j) {
    const double h = 1e-6 * std::max(1.0, std::abs(z0[j]));
    Eigen::VectorXd z = z0;
    z[j] += h;
    Rz.col(j) = (residuals(z, x2, j >= static_cast<Eigen::Index>(na)) - r0) / h;
  }
  for (int j = 0; j < 9; ++j) {
    std::vector<double> x = x2;
    x[static_cast<std::size_t>(j)] += 1e-7;
    J2.col(j) = (residuals(z0, x, false) - r0) / 1e-7;
  }
  const Eigen::MatrixXd S = -(J2.transpose() * J2).ldlt().solve(J2.transpose() * Rz);
  const Eigen::MatrixXd C = r2.covariance + S * Cz * S.transpose();
  r.covariance = C;
  r.free_index = kScaleCrossIndex;
  for (int k = 0; k < 9; ++k) {
    auto& prm = r.parameters[static_cast<std::size_t>(kScaleCrossIndex[static_cast<std::size_t>(k)])];
    prm.std_error = std::sqrt(std::max(0.0, C(k, k)));
    prm.lower = prm.value - r.quantile * prm.std_error;
    prm.upper = prm.value + r.quantile * prm.std_error;
    estimation::judge(prm, tolerances);
  }
}

// Gravity-direction mismatch after each move (RMS over the moves of |v − ĝ_end|, and per axis),
// raw (θ unused, readings as they are, directions of the raw means) or calibrated with θ.
std::pair<double, Eigen::Vector3d> gravity_mismatch(const IntegrationData& d, const model::ErrorModel& m,
                                                    const std::vector<double>& th, bool raw,
                                                    std::vector<MoveMismatch>* per_move = nullptr, bool after = false) {
  const auto& ivs = d.ivs;
  // Calibrated: A⁻¹·(y − b − G·f) (the gyro model is affine in the rate; G·f only moves its offset).
  const Eigen::Matrix3d ai = raw ? Eigen::Matrix3d::Identity() : m.affine<double>(th.data()).a_inv;
  std::size_t k = 0;  // the turn being integrated
  auto rate = [&](std::size_t i) {
    return raw ? Eigen::Vector3d(d.turns[k].at(i).gyro_radps)
               : Eigen::Vector3d(ai * bias_corrected_rate(d, m, th.data(), k, i));
  };
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();
  double sum = 0.0;
  int count = 0;
  for (; k + 1 < ivs.size(); ++k) {
    const std::size_t a = ivs[k].last, b = ivs[k + 1].first;
    if (b <= a) continue;
    const Turn& turn = d.turns[k];
    Eigen::Vector3d v = raw ? ivs[k].accel_mean.normalized() : d.gdir[k];
    Eigen::Vector3d wp = rate(a);
    for (std::size_t i = a; i < b; ++i) {
      const Eigen::Vector3d wn = rate(i + 1);
      const Eigen::Vector3d t = (wp + wn) * 0.5 * (turn.at(i + 1).t_s - turn.at(i).t_s);
      const double ang = t.norm();
      if (ang > 0.0) v = Eigen::AngleAxisd(-ang, t / ang).toRotationMatrix() * v;
      wp = wn;
    }
    const Eigen::Vector3d target = raw ? ivs[k + 1].accel_mean.normalized() : d.gdir[k + 1];
    acc += (v - target).cwiseAbs2();
    sum += (v - target).squaredNorm();
    ++count;
    if (per_move) {
      const auto j = static_cast<std::size_t>(count - 1);
      if (per_move->size() <= j) per_move->push_back({ivs[k + 1].t_start_s, kNaN, kNaN});
      (after ? (*per_move)[j].after_rad : (*per_move)[j].before_rad) = std::atan2(v.cross(target).norm(), v.dot(target));
    }
  }
  const double dm = std::max(1, count);
  return std::make_pair(std::sqrt(sum / dm), Eigen::Vector3d((acc / dm).cwiseSqrt()));
}

}  // namespace

CalibrationResult calibrate_gyro_integration(const Recording& rec, const CalibrationResult& accel, const GyroOptions& go) {
  CalibrationResult r;
  r.method = "integration";
  r.model = gyroscope_model(go.estimate_g_sensitivity);
  r.gravity_mps2 = accel.gravity_mps2;
  gyro_parameters_init(r);
  IntegrationData d = integration_data(rec, accel, go);
  r.intervals = d.ivs;
  auto done = [&](const std::string& why) {
    fail_all(r, why);
    return r;
  };
  if (const std::string why = integration_precondition(d); !why.empty()) return done(why);
  d.moves = integrable_moves(d);
  const int n = static_cast<int>(d.ivs.size());
  if (3 * n < static_cast<int>(d.s1_index.size()) + 1) return done("too few static intervals for the gyro bias and g-sensitivity");
  std::vector<double> x1;
  const CalibrationResult r1 = solve_static_stage(d, r, as_calibration_options(go, go.loss_scale_radps), x1);
  if (!r1.ok) {
    r.not_identifiable = r1.not_identifiable;
    return done("stage 1 (bias" + std::string(go.estimate_g_sensitivity ? " and g-sensitivity" : "") +
                " from the static intervals): " + r1.message);
  }
  const int pairs = static_cast<int>(d.moves.size());
  if (2 * pairs < 10)
    return done(fmt::format("too few moves between static intervals: {} usable, need at least 5 (2 residuals each) "
                            "for 9 gyro scale and cross-axis parameters plus noise",
                            pairs));
  std::vector<double> x2;
  const CalibrationResult r2 = solve_move_stage(d, r, r1.theta, as_calibration_options(go, go.loss_scale_rad), x2);
  merge_stages(d, r1, r2, r);
  if (!r2.ok) return done("stage 2 (scale and cross-axis from the integrated rotations): " + r2.message);
  r.ok = true;
  r.theta = r1.theta;
  for (int i : kScaleCrossIndex) r.theta[static_cast<std::size_t>(i)] = r2.theta[static_cast<std::size_t>(i)];
  add_upstream_uncertainty(d, r1, r2, x1, x2, go.tolerances, r);
  std::tie(r.rms_norm_before, r.rms_axis_before) = gravity_mismatch(
      d, r.model, std::vector<double>(static_cast<std::size_t>(r.model.size()), 0.0), true, &r.moves, false);
  std::tie(r.rms_norm_after, r.rms_axis_after) = gravity_mismatch(d, r.model, r.theta, false, &r.moves, true);
  return r;
}

}  // namespace stend::ceres_nonlinear
