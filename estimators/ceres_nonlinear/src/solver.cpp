// The solve every ceres_nonlinear procedure shares (see solver.hpp).
#include "solver.hpp"

#include <stend/estimation/linear_lsq.hpp>
#include <stend/physics/units.hpp>

#include <fmt/format.h>

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>

namespace stend::ceres_nonlinear::detail {

ceres::LossFunction* make_loss(const CalibrationOptions& o) {
  switch (o.loss) {
    case Loss::kHuber: return new ceres::HuberLoss(o.loss_scale_mps2);
    case Loss::kCauchy: return new ceres::CauchyLoss(o.loss_scale_mps2);
    case Loss::kNone: break;
  }
  return nullptr;
}

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

namespace {

// Nominal size of a parameter for the identifiability scaling: a bias in units of g (accel) or
// 1 rad/s (gyro), g-sensitivity in 1/g, an angle offset in 1 rad = 57.3 deg, the rest 1.
double nominal_size(const std::string& name, const CalibrationResult& r) {
  const double g = r.gravity_mps2 > 0.0 ? r.gravity_mps2 : physics::kStandardGravity;
  if (name.rfind("bias", 0) == 0) return r.model.instrument == model::Instrument::kAccelerometer ? g : 1.0;
  if (name.rfind("gsens", 0) == 0) return 1.0 / g;
  if (name.rfind("table_offset", 0) == 0) return physics::kRadToDeg;
  return 1.0;
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

// Covariance variance_factor·(JᵀJ)⁻¹ of the free parameters, their values, standard errors and
// confidence bounds (r.quantile); fails the fit when Ceres cannot invert JᵀJ.
void fill_parameters(ceres::Problem& problem, std::vector<double>& x, const std::vector<int>& free_index,
                     const CalibrationOptions& o, double variance_factor, CalibrationResult& r) {
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
  C *= variance_factor;
  r.covariance = C;
  r.free_index = free_index;
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
    estimation::judge(prm, o.tolerances, {o.confidence, r.quantile});
  }
  r.status = estimation::FitStatus::kOk;
}

// Where the covariance's scale comes from, in words, with the degrees of freedom.
std::string covariance_source(Weighting weighting, double variance_factor, int dof) {
  if (weighting == Weighting::kRelative)
    return fmt::format("covariance (JᵀJ)⁻¹ scaled by σ² = RSS/(n − p), {} dof; Student t intervals", dof);
  if (weighting == Weighting::kAPrioriAtLeast && dof > 0 && variance_factor <= 1.0)
    return fmt::format("covariance from the a-priori sigmas (the reduced χ² = {:.4g}, {} dof, is at most 1: the "
                       "stated sigmas are not narrowed); normal-quantile intervals",
                       variance_factor, dof);
  if (dof > 0)
    return fmt::format("covariance from the a-priori sigmas scaled by the reduced χ² = {:.4g} ({} dof); Student t "
                       "intervals",
                       variance_factor, dof);
  return "covariance from the a-priori sigmas alone: 0 dof (as many equations as parameters), so no residual to "
         "scale it by; normal-quantile intervals";
}

}  // namespace

void fail_all(CalibrationResult& r, const std::string& message) {
  r.status = estimation::FitStatus::kFailed;
  r.message = message;
  r.theta.assign(static_cast<std::size_t>(r.model.size()), kNaN);
  for (auto& p : r.parameters) {
    if (p.held) continue;
    p.value = p.std_error = p.lower = p.upper = kNaN;
    p.identifiable = false;
    if (p.reason.empty()) p.reason = "fit failed";
  }
}

void init_parameters(CalibrationResult& r, const std::vector<int>& free_index) {
  const auto info = r.model.params();
  r.parameters.clear();
  for (std::size_t i = 0; i < info.size(); ++i) {
    estimation::ParameterEstimate p;
    p.name = info[i].name;
    p.unit = info[i].unit;
    p.held = std::find(free_index.begin(), free_index.end(), static_cast<int>(i)) == free_index.end();
    if (p.held) {
      p.value = p.std_error = p.lower = p.upper = 0.0;
      p.identifiable = false;
      p.reason = "held at 0 (frame convention: a rotation is unobservable with unknown orientations)";
      p.zero_is_exact = true;  // the calibrated output is the same in any frame of the convention
    }
    r.parameters.push_back(p);
  }
}

// Solve, check identifiability, fill the covariance. `free_index` lists the estimated parameters.
void solve(ceres::Problem& problem, std::vector<double>& x, const std::vector<int>& free_index,
           int residual_count, const CalibrationOptions& o, CalibrationResult& r, Weighting weighting) {
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
  if (r.dof <= 0 && weighting == Weighting::kRelative) {
    fail_all(r, fmt::format("no degree of freedom left for the noise ({} residuals, {} parameters): "
                            "add static intervals", residual_count, p));
    return;
  }
  const double chi2 = r.dof > 0 ? rss / r.dof : 1.0;
  const bool scaled = r.dof > 0 && (weighting != Weighting::kAPrioriAtLeast || chi2 > 1.0);
  const double variance_factor = scaled ? chi2 : 1.0;
  r.quantile = estimation::interval_quantile(o.confidence, scaled ? r.dof : estimation::kAPrioriDof);
  r.uncertainty += (r.uncertainty.empty() ? "" : "; ") + covariance_source(weighting, chi2, r.dof);
  fill_parameters(problem, x, free_index, o, variance_factor, r);
}

double noise_correlation_factor(const std::vector<processing::StaticPoint>& points, bool gyro) {
  double white = 0.0, correlated = 0.0;
  for (const auto& p : points) {
    const processing::AxesValue& v = gyro ? p.gyro : p.accel;
    if (!v.std_error.allFinite() || !v.correlated_std_error.allFinite()) continue;
    white += v.std_error.squaredNorm();
    correlated += v.correlated_std_error.squaredNorm();
  }
  return white > 0.0 ? std::max(1.0, std::sqrt(correlated / white)) : 1.0;
}

bool mean_noise_unknown(const std::vector<processing::StaticPoint>& ivs, bool gyro) {
  for (const auto& iv : ivs) {
    const processing::AxesValue& v = gyro ? iv.gyro : iv.accel;
    if (v.std_error.allFinite() && (v.std_error.array() > 1e-12 * v.mean.array().abs()).any()) return false;
  }
  return !ivs.empty();
}

HeldWeights held_weights(const std::vector<processing::StaticPoint>& ivs) {
  HeldWeights w;
  const bool weighted = !ivs.empty() && std::all_of(ivs.begin(), ivs.end(), [](const processing::StaticPoint& p) {
    return p.held && p.held->weighted();
  });
  if (!weighted) return w;
  const bool absolute = std::all_of(ivs.begin(), ivs.end(), [](const processing::StaticPoint& p) { return p.held->absolute(); });
  w.kind = absolute ? HeldWeighting::kAbsolute : HeldWeighting::kRelative;
  double ss = 0.0;
  for (const auto& p : ivs) {
    w.std_error.push_back(p.held->std_error());
    ss += w.std_error.back().squaredNorm();
  }
  if (!absolute)
    for (auto& se : w.std_error) se /= std::sqrt(ss / (3.0 * static_cast<double>(ivs.size())));
  return w;
}

std::string HeldWeights::text() const {
  switch (kind) {
    case HeldWeighting::kAbsolute:
      return "a-priori sigmas: each row's stated standard error sigma/√n (a table of means), scaled by the reduced "
             "χ² only when it exceeds 1";
    case HeldWeighting::kRelative:
      return "relative weights: each row's stated n or sigma alone (a table of means; sigma/√n with the factor "
             "not stated taken as 1), their scale from the residuals";
    case HeldWeighting::kNone: break;
  }
  return {};
}

bool finite_accel_means(const std::vector<processing::StaticPoint>& ivs) {
  return std::all_of(ivs.begin(), ivs.end(), [](const processing::StaticPoint& iv) { return iv.accel.mean.allFinite(); });
}

bool finite_gyro_means(const std::vector<processing::StaticPoint>& ivs) {
  return std::all_of(ivs.begin(), ivs.end(), [](const processing::StaticPoint& iv) { return iv.gyro.mean.allFinite(); });
}

bool finite_intervals(const std::vector<processing::StaticPoint>& ivs) {
  return finite_accel_means(ivs) && finite_gyro_means(ivs);
}

// Per-axis RMS of reading − truth, raw and calibrated (known orientations, rate table).
void axis_rms_against(CalibrationResult& r, const std::vector<Eigen::Vector3d>& truth,
                      const std::vector<Eigen::Vector3d>& reading, const std::vector<Eigen::Vector3d>& f) {
  Eigen::Vector3d pb = Eigen::Vector3d::Zero(), pa = Eigen::Vector3d::Zero();
  const std::size_t n = std::min(truth.size(), reading.size());
  for (std::size_t k = 0; k < n; ++k) {
    pb += (reading[k] - truth[k]).cwiseAbs2();
    if (r.ok()) {
      model::Stimulus<double> st;
      st.specific_force = k < f.size() ? f[k] : truth[k];
      pa += (r.model.correct(r.theta.data(), reading[k], st) - truth[k]).cwiseAbs2();
    }
  }
  const double d = static_cast<double>(std::max<std::size_t>(1, n));
  r.truth_error_axis.before = (pb / d).cwiseSqrt();
  r.truth_error_axis.after = r.ok() ? Eigen::Vector3d((pa / d).cwiseSqrt()) : Eigen::Vector3d::Constant(kNaN);
}

}  // namespace stend::ceres_nonlinear::detail
