#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/estimation/linear_lsq.hpp>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>

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

// The input u that the (affine) model maps to y: b = measure(θ, 0), A e_j = measure(θ, e_j) − b,
// u = A⁻¹ (y − b). Only measure<T> is used, so the terms are not re-derived here.
template <typename T>
model::Vec3<T> invert_affine(const model::ErrorModel& m, const T* theta, const Eigen::Vector3d& y) {
  model::Stimulus<T> s;
  const model::Vec3<T> b = m.measure<T>(theta, s);
  Eigen::Matrix<T, 3, 3> A;
  for (int j = 0; j < 3; ++j) {
    s.input = model::Vec3<T>::Zero();
    s.input[j] = T(1);
    s.specific_force = s.input;
    A.col(j) = m.measure<T>(theta, s) - b;
  }
  const model::Vec3<T> r = y.cast<T>() - b;
  // Cramer's rule (works for ceres::Jet).
  const model::Vec3<T> c0 = A.col(0), c1 = A.col(1), c2 = A.col(2);
  const T det = c0.dot(c1.cross(c2));
  model::Vec3<T> u;
  u[0] = r.dot(c1.cross(c2)) / det;
  u[1] = c0.dot(r.cross(c2)) / det;
  u[2] = c0.dot(c1.cross(r)) / det;
  return u;
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

ceres::LossFunction* make_loss(const CalibrationOptions& o) {
  switch (o.loss) {
    case Loss::kHuber: return new ceres::HuberLoss(o.loss_scale_mps2);
    case Loss::kCauchy: return new ceres::CauchyLoss(o.loss_scale_mps2);
    case Loss::kNone: break;
  }
  return nullptr;
}

double nominal_size(const std::string& name, double g) {
  return name.rfind("bias", 0) == 0 ? g : 1.0;
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
    p.reason = "mean over static intervals (includes Earth rotation projected on the axis)";
    r.gyro_parameters.push_back(p);
  }
}

// Solve, check identifiability, fill the covariance. `free_index` lists the estimated parameters.
void solve(ceres::Problem& problem, std::vector<double>& x, const std::vector<int>& free_index,
           int residual_count, const CalibrationOptions& o, CalibrationResult& r) {
  const int p = static_cast<int>(free_index.size());
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

  // Identifiability from the Jacobian at the solution (before judging convergence: a flat
  // direction is the more useful explanation of a failure).
  ceres::CRSMatrix crs;
  double cost = 0.0;
  std::vector<double> residuals;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, &residuals, nullptr, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int row = 0; row < crs.num_rows; ++row)
    for (int k = crs.rows[static_cast<std::size_t>(row)]; k < crs.rows[static_cast<std::size_t>(row) + 1]; ++k)
      J(row, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
  Eigen::VectorXd scale(p);
  for (int k = 0; k < p; ++k)
    scale[k] = nominal_size(r.parameters[static_cast<std::size_t>(free_index[static_cast<std::size_t>(k)])].name,
                            r.gravity_mps2);
  const Eigen::MatrixXd Js = J * scale.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Js, Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  const double rss = 2.0 * cost;
  r.sigma = r.dof > 0 ? std::sqrt(rss / r.dof) : kNaN;
  std::vector<std::string> weak;
  std::string why;
  // Weak directions: rank-deficient, or determined worse than max_std_error (relative).
  std::vector<int> weak_dirs;
  for (int k = 0; k < sv.size(); ++k) {
    const bool rank = !(sv[k] > o.rank_tolerance * sv[0]);
    const double se_dir = r.sigma / sv[k];
    const bool poor = !rank && std::isfinite(se_dir) && se_dir > o.max_std_error;
    if (!rank && !poor) continue;
    weak_dirs.push_back(k);
    if (why.empty() || rank)
      why = rank ? fmt::format("rank-deficient Jacobian (singular value ratio {:.2e})", sv[k] / sv[0])
                 : fmt::format("the weakest direction is determined only to {:.3g} (relative; limit {:.3g})",
                               se_dir, o.max_std_error);
  }
  if (!weak_dirs.empty()) {
    // Share of each parameter's unit vector inside the weak subspace: ≥ 0.5 → not identifiable
    // (if none reaches it, the most affected ones).
    std::vector<double> share(static_cast<std::size_t>(p), 0.0);
    for (int j = 0; j < p; ++j)
      for (int k : weak_dirs) share[static_cast<std::size_t>(j)] += std::pow(svd.matrixV()(j, k), 2);
    const double top = *std::max_element(share.begin(), share.end());
    const double cut = std::min(0.5, 0.5 * top);
    for (int j = 0; j < p; ++j)
      if (share[static_cast<std::size_t>(j)] >= cut)
        weak.push_back(r.parameters[static_cast<std::size_t>(free_index[static_cast<std::size_t>(j)])].name);
    why = fmt::format("{} unobservable or poorly observed direction(s); {}", weak_dirs.size(), why);
  }
  if (!weak.empty()) {
    r.not_identifiable = weak;
    std::string names;
    for (const auto& w : weak) names += (names.empty() ? "" : ", ") + w;
    fail_all(r, "not identifiable from this experiment: " + names + " — " + why +
                    ". The other parameters are coupled to them, so no numbers are reported; add "
                    "orientations that excite these parameters.");
    for (auto& prm : r.parameters)
      if (std::find(weak.begin(), weak.end(), prm.name) != weak.end())
        prm.reason = "not identifiable: " + why;
    return;
  }
  if (summary.termination_type != ceres::CONVERGENCE) {
    fail_all(r, "the solver did not converge: " + summary.BriefReport() +
                    " (raise max_iterations, check the static intervals and gravity)");
    return;
  }
  if (r.dof <= 0) {
    fail_all(r, fmt::format("no degree of freedom left for the noise ({} residuals, {} parameters): "
                            "add static intervals", residual_count, p));
    return;
  }

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
  r.quantile = estimation::student_t_quantile(0.5 + 0.5 * o.confidence, r.dof);
  r.theta.assign(kFull, 0.0);
  for (int k = 0; k < p; ++k) {
    const auto idx = static_cast<std::size_t>(free_index[static_cast<std::size_t>(k)]);
    auto& prm = r.parameters[idx];
    r.theta[idx] = x[static_cast<std::size_t>(k)];
    prm.value = x[static_cast<std::size_t>(k)];
    prm.std_error = std::sqrt(std::max(0.0, C(k, k)));
    prm.lower = prm.value - r.quantile * prm.std_error;
    prm.upper = prm.value + r.quantile * prm.std_error;
    prm.identifiable = true;
  }
  r.ok = true;
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
  if (last < first || last >= rec.samples.size())
    throw std::out_of_range("make_interval: bad sample range");
  StaticInterval iv;
  iv.first = first;
  iv.last = last;
  iv.t_start_s = rec.samples[first].t_s;
  iv.t_end_s = rec.samples[last].t_s;
  iv.count = last - first + 1;
  iv.label = std::move(label);
  Eigen::Vector3d s2 = Eigen::Vector3d::Zero();
  for (std::size_t i = first; i <= last; ++i) {
    iv.accel_mean += rec.samples[i].accel_mps2;
    iv.gyro_mean += rec.samples[i].gyro_radps;
  }
  const double n = static_cast<double>(iv.count);
  iv.accel_mean /= n;
  iv.gyro_mean /= n;
  for (std::size_t i = first; i <= last; ++i)
    s2 += (rec.samples[i].accel_mps2 - iv.accel_mean).cwiseAbs2();
  if (iv.count > 1) iv.accel_std = (s2 / (n - 1.0)).cwiseSqrt();
  return iv;
}

std::vector<StaticInterval> detect_static_intervals(const Recording& rec, const StaticDetectorOptions& o) {
  const std::size_t n = rec.samples.size();
  std::vector<StaticInterval> out;
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
      if (rec.samples[b].t_s - rec.samples[a].t_s >= o.min_duration_s)
        out.push_back(make_interval(rec, a, b, fmt::format("static_{}", out.size())));
    }
    i = j + 1;
  }
  return out;
}

std::vector<StaticInterval> intervals_from_segments(const Recording& rec, const std::string& kind,
                                                    double trim_s) {
  std::vector<StaticInterval> out;
  for (const auto& seg : rec.segments) {
    if (seg.kind != kind) continue;
    std::size_t a = rec.samples.size(), b = 0;
    for (std::size_t i = 0; i < rec.samples.size(); ++i) {
      const double t = rec.samples[i].t_s;
      if (t >= seg.t_start_s + trim_s && t <= seg.t_end_s - trim_s) {
        a = std::min(a, i);
        b = std::max(b, i);
      }
    }
    if (a < rec.samples.size() && b > a) out.push_back(make_interval(rec, a, b, seg.label));
  }
  return out;
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
  std::string s = fmt::format("Ceres accelerometer calibration ({})\n", method);
  s += fmt::format("status: {}\n", ok ? "ok" : "FAILED — " + message);
  s += fmt::format("static intervals: {}, residuals: {}, estimated parameters: {}, dof: {}, g = {} m/s^2\n",
                   intervals.size(), observations, estimated, dof, gravity_mps2);
  s += fmt::format("residual sigma: {} {}, solver: {}\n", fmt_num(sigma),
                   whitened ? "(whitened residuals; 1 = as expected)" : "m/s^2", solver_report);
  s += fmt::format("RMS of |a| - g over the intervals: raw {} m/s^2, calibrated {} m/s^2\n",
                   fmt_num(rms_norm_before), fmt_num(rms_norm_after));
  s += fmt::format("{:<14} {:>14} {:>12} {:>14} {:>14}  {:<8} {}\n", "parameter", "value",
                   "std error", "95% lower", "95% upper", "unit", "note");
  auto row = [&](const Parameter& p) {
    s += fmt::format("{:<14} {:>14} {:>12} {:>14} {:>14}  {:<8} {}\n", p.name, fmt_num(p.value),
                     fmt_num(p.std_error), fmt_num(p.lower), fmt_num(p.upper), p.unit,
                     p.fixed ? "fixed" : (p.identifiable ? "" : p.reason));
  };
  for (const auto& p : parameters) row(p);
  for (const auto& p : gyro_parameters) row(p);
  return s;
}

std::string CalibrationResult::to_json() const {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  auto prm = [&](const Parameter& p) {
    return json{{"name", p.name}, {"unit", p.unit}, {"value", num(p.value)},
                {"std_error", num(p.std_error)}, {"ci95", {num(p.lower), num(p.upper)}},
                {"identifiable", p.identifiable}, {"fixed", p.fixed}, {"reason", p.reason}};
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
  j["rms_norm_before_mps2"] = num(rms_norm_before);
  j["rms_norm_after_mps2"] = num(rms_norm_after);
  j["solver"] = solver_report;
  j["not_identifiable"] = not_identifiable;
  j["parameters"] = json::array();
  for (const auto& p : parameters) j["parameters"].push_back(prm(p));
  j["gyro_parameters"] = json::array();
  for (const auto& p : gyro_parameters) j["gyro_parameters"].push_back(prm(p));
  j["intervals"] = json::array();
  for (const auto& iv : intervals)
    j["intervals"].push_back({{"label", iv.label}, {"t_start_s", iv.t_start_s}, {"t_end_s", iv.t_end_s},
                              {"samples", iv.count}});
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
  const double g = o.gravity_mps2 > 0.0 ? o.gravity_mps2 : rec.header.gravity_mps2;
  const auto ivs = o.use_segments ? intervals_from_segments(rec, "orientation", o.detector.trim_s)
                                  : detect_static_intervals(rec, o.detector);
  return calibrate_accelerometer_unknown_orientations(ivs, g, o);
}

CalibrationResult calibrate_accelerometer_known_orientations(const std::vector<StaticInterval>& intervals,
                                                             const std::vector<Eigen::Vector3d>& truth_f,
                                                             const CalibrationOptions& o) {
  CalibrationResult r;
  r.method = "known_orientations";
  r.model = accelerometer_model();
  r.intervals = intervals;
  double g = o.gravity_mps2;
  if (!(g > 0.0)) {
    g = 0.0;
    for (const auto& f : truth_f) g += f.norm();
    g /= static_cast<double>(std::max<std::size_t>(1, truth_f.size()));
  }
  r.gravity_mps2 = g;
  r.whitened = o.orientation_sigma_deg > 0.0;
  std::vector<int> free_index(kFull);
  for (int i = 0; i < kFull; ++i) free_index[static_cast<std::size_t>(i)] = i;
  init_parameters(r, free_index);
  gyro_bias(r, o);
  const int n = static_cast<int>(intervals.size());
  r.observations = 3 * n;
  r.estimated = kFull;
  r.dof = 3 * n - kFull;
  if (truth_f.size() != intervals.size()) {
    fail_all(r, "known orientations: one truth vector per static interval is needed");
    norm_rms(r);
    return r;
  }
  if (3 * n < kFull + 1) {
    fail_all(r, fmt::format("too few static intervals: {} found, need at least 5 (3 equations each) for "
                            "12 accelerometer parameters plus noise",
                            n));
    norm_rms(r);
    return r;
  }
  std::vector<double> x(kFull, 0.0);
  ceres::Problem problem;
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    Eigen::Matrix3d W = Eigen::Matrix3d::Identity();
    if (o.orientation_sigma_deg > 0.0 && truth_f[k].norm() > 0.0) {
      // Tilt of the true orientation ~ N(0, σ_tilt²): the residual across gravity gets the extra
      // variance (g·σ_tilt)², the one along gravity only the noise of the mean.
      const Eigen::Vector3d e0 = truth_f[k].normalized();
      const Eigen::Vector3d e1 = e0.unitOrthogonal(), e2 = e0.cross(e1);
      const double n_sd = std::max(1e-6, intervals[k].accel_std.mean() /
                                             std::sqrt(static_cast<double>(std::max<std::size_t>(1, intervals[k].count))));
      const double t_sd = std::hypot(n_sd, g * o.orientation_sigma_deg * std::numbers::pi / 180.0);
      W.row(0) = e0.transpose() / n_sd;
      W.row(1) = e1.transpose() / t_sd;
      W.row(2) = e2.transpose() / t_sd;
    }
    auto* f = new KnownCost{&r.model, free_index, intervals[k].accel_mean, truth_f[k], W};
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<KnownCost, 3, kFull>(f), make_loss(o), x.data());
  }
  solve(problem, x, free_index, 3 * n, o, r);
  norm_rms(r);
  return r;
}

CalibrationResult calibrate_accelerometer_known_orientations(const Recording& rec, const CalibrationOptions& o) {
  const int cx = rec.truth_column("f_x_mps2"), cy = rec.truth_column("f_y_mps2"),
            cz = rec.truth_column("f_z_mps2");
  auto ivs = o.use_segments ? intervals_from_segments(rec, "orientation", o.detector.trim_s)
                            : detect_static_intervals(rec, o.detector);
  if (cx < 0 || cy < 0 || cz < 0) {
    CalibrationResult r;
    r.method = "known_orientations";
    r.model = accelerometer_model();
    r.intervals = ivs;
    init_parameters(r, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
    fail_all(r, "known orientations need the truth columns f_x_mps2, f_y_mps2, f_z_mps2; this recording "
                "has none (use calibrate_accelerometer_unknown_orientations)");
    return r;
  }
  std::vector<StaticInterval> kept;
  std::vector<Eigen::Vector3d> truth;
  for (const auto& iv : ivs) {
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    int m = 0;
    for (std::size_t i = 0; i < rec.truth_t.size(); ++i) {
      if (rec.truth_t[i] < iv.t_start_s || rec.truth_t[i] > iv.t_end_s) continue;
      const auto& row = rec.truth[i];
      f += Eigen::Vector3d(row[static_cast<std::size_t>(cx)], row[static_cast<std::size_t>(cy)],
                           row[static_cast<std::size_t>(cz)]);
      ++m;
    }
    if (m == 0) continue;
    kept.push_back(iv);
    truth.push_back(f / static_cast<double>(m));
  }
  CalibrationOptions o2 = o;
  if (!(o2.gravity_mps2 > 0.0)) o2.gravity_mps2 = rec.header.gravity_mps2;
  return calibrate_accelerometer_known_orientations(kept, truth, o2);
}

}  // namespace stend::ceres_nonlinear
