// Gyroscope calibration from the Earth rate in up/down positions at a known latitude: the vertical
// projection of each still's mean reading against the vertical Earth rate. See
// stend/ceres_nonlinear/calibration.hpp, (d).
#include "gyro.hpp"

#include <stend/physics/units.hpp>

#include <Eigen/Cholesky>
#include <stend/recording/truth_columns.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace stend::ceres_nonlinear {

using namespace detail;

namespace {

// An axis within 45° of the vertical in a still is excited by it: u·ȳ sees its bias and scale.
constexpr double kNearVertical = std::numbers::sqrt2 / 2.0;
constexpr std::array<char, 3> kAxisNames = {'x', 'y', 'z'};

// The stills usable here: finite f and w truth, |f| > 0.
struct VerticalStills {
  std::vector<processing::StaticPoint> stills;
  std::vector<Eigen::Vector3d> up;     // u_k = f_k/|f_k|
  std::vector<double> omega_v_radps;   // Ω_v,k = u_k·w_k
  std::size_t left_out = 0;
};

VerticalStills vertical_stills(const std::vector<processing::StaticPoint>& stills,
                               const std::vector<Eigen::Vector3d>& truth_f, const std::vector<Eigen::Vector3d>& truth_w) {
  VerticalStills v;
  for (std::size_t k = 0; k < stills.size(); ++k) {
    if (!truth_f[k].allFinite() || !truth_w[k].allFinite() || !(truth_f[k].norm() > 0.0)) {
      ++v.left_out;
      continue;
    }
    v.stills.push_back(stills[k]);
    v.up.push_back(truth_f[k].normalized());
    v.omega_v_radps.push_back(v.up.back().dot(truth_w[k]));
  }
  return v;
}

std::array<bool, 3> excited_axes(const std::vector<Eigen::Vector3d>& up) {
  std::array<bool, 3> excited{};
  for (const auto& u : up)
    for (std::size_t a = 0; a < 3; ++a) excited[a] = excited[a] || std::abs(u[static_cast<Eigen::Index>(a)]) >= kNearVertical;
  return excited;
}

// The places of bias_<axis> and scale_<axis> of each excited axis in the model's vector.
std::vector<int> excited_parameters(const model::ErrorModel& m, const std::array<bool, 3>& excited) {
  const auto info = m.params();
  std::vector<int> free_index;
  for (std::size_t i = 0; i < info.size(); ++i)
    for (std::size_t a = 0; a < 3; ++a)
      if (excited[a] && (info[i].name == fmt::format("bias_{}", kAxisNames[a]) ||
                         info[i].name == fmt::format("scale_{}", kAxisNames[a])))
        free_index.push_back(static_cast<int>(i));
  return free_index;
}

// Why each held parameter is held (init_parameters marks them; the reasons are this method's).
void explain_held(CalibrationResult& r, const std::array<bool, 3>& excited) {
  for (auto& p : r.parameters) {
    if (!p.held) continue;
    p.zero_is_exact = false;  // not a convention: 0 stands for what the Earth rate does not show
    if (p.name.rfind("cross", 0) == 0) {
      p.reason = "held at 0: not estimated by earth_rate (the vertical projection sees a cross-axis term only as "
                 "m_ij + m_ji, and only in tilted positions)";
      continue;
    }
    p.reason = fmt::format("held at 0: axis {} is never within 45 deg of the vertical in these positions, so u·ȳ does "
                           "not see its bias or scale (not identifiable, not invented)",
                           p.name.back());
  }
  std::string held;
  for (std::size_t a = 0; a < 3; ++a)
    if (!excited[a]) held += (held.empty() ? "" : ", ") + std::string(1, kAxisNames[a]);
  if (!held.empty())
    r.notes.push_back("axes never near the vertical (bias and scale held at 0, not identifiable): " + held);
  r.notes.push_back("cross-axis terms held at 0: the vertical Earth rate does not separate them");
}

// The stills' projections z_k = u_k·ȳ_k against u_k·measure(θ, Ω_v,k·u_k), in one residual block
// whitened by their joint a-priori covariance (vertical_covariance).
struct JointVerticalCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  std::vector<Eigen::Vector3d> up, reading;
  std::vector<double> omega_v;
  Eigen::MatrixXd W;  // n × n
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    std::vector<T> theta(static_cast<std::size_t>(m->size()), T(0));
    for (std::size_t k = 0; k < free_index.size(); ++k) theta[static_cast<std::size_t>(free_index[k])] = p[0][k];
    const auto n = static_cast<Eigen::Index>(up.size());
    std::vector<T> d(up.size());
    for (std::size_t k = 0; k < up.size(); ++k) {
      model::Stimulus<T> s;
      s.input = (omega_v[k] * up[k]).cast<T>();
      d[k] = up[k].cast<T>().dot(m->measure<T>(theta.data(), s) - reading[k].cast<T>());
    }
    for (Eigen::Index row = 0; row < n; ++row) {
      residual[row] = T(0);
      for (Eigen::Index k = 0; k < n; ++k) residual[row] += W(row, k) * d[static_cast<std::size_t>(k)];
    }
    return true;
  }
};

// The a-priori covariance of the projections z_k [(rad/s)²]: the per-sample noise projected on u_k
// over N; the tilt of each placement (σ_tilt, 1σ per component), which lets the horizontal reading
// ȳ_⊥ (the other axes' biases) into the projection, σ_tilt²·|ȳ_⊥|² (placements independent); the
// g-sensitivity the method cannot estimate, g·uᵀGu with each G_ij ~ N(0, σ_G²): g_k·g_l·σ_G²·(u_k·u_l)²
// between any two stills (it flips with the Earth rate between up and down: it widens the scales).
Eigen::MatrixXd vertical_covariance(const VerticalStills& v, const std::vector<double>& g_mps2,
                                    const Eigen::Vector3d& noise_radps, const GyroOptions& go) {
  const auto n = static_cast<Eigen::Index>(v.stills.size());
  const double tilt = go.orientation_sigma_deg * physics::kDegToRad;
  const double sigma_g = go.g_sensitivity_sigma_dps_per_g * physics::kDegPerSecond / physics::kStandardGravity;
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    const Eigen::Vector3d& u = v.up[i];
    const Eigen::Vector3d y = v.stills[i].gyro.mean;
    c(k, k) = u.cwiseAbs2().dot(noise_radps.cwiseAbs2()) / static_cast<double>(v.stills[i].samples_used) +
              tilt * tilt * (y - u.dot(y) * u).squaredNorm();
    for (Eigen::Index l = 0; l < n; ++l) {
      const auto j = static_cast<std::size_t>(l);
      c(k, l) += g_mps2[i] * g_mps2[j] * sigma_g * sigma_g * std::pow(u.dot(v.up[j]), 2);
    }
  }
  return c;
}

// RMS of u·ȳ − Ω_v (raw) and u·correct(ȳ) − Ω_v (calibrated) over the stills [rad/s].
void vertical_checks(const VerticalStills& v, CalibrationResult& r) {
  double before = 0.0, after = 0.0;
  for (std::size_t k = 0; k < v.stills.size(); ++k) {
    before += std::pow(v.up[k].dot(v.stills[k].gyro.mean) - v.omega_v_radps[k], 2);
    if (r.ok())
      after += std::pow(v.up[k].dot(r.correct(v.stills[k].gyro.mean)) - v.omega_v_radps[k], 2);
  }
  const double n = static_cast<double>(std::max<std::size_t>(1, v.stills.size()));
  r.rate_error_radps.before = std::sqrt(before / n);
  r.rate_error_radps.after = r.ok() ? std::sqrt(after / n) : kNaN;
}

std::string vertical_sigmas_text(const Eigen::Vector3d& noise_radps, const GyroOptions& go) {
  const Eigen::Vector3d dps = noise_radps / physics::kDegPerSecond;
  return fmt::format("a-priori sigmas: gyro noise {:.3g} {:.3g} {:.3g} deg/s per sample (pooled over the stills), "
                     "projected on the vertical u_k, over √N; each position placed to {} deg (the horizontal reading "
                     "seen through its tilt); an unmodelled g-sensitivity of {} (deg/s)/g per term (it flips with the "
                     "Earth rate: it widens the scales by g·σ/Ω_v)",
                     dps[0], dps[1], dps[2], go.orientation_sigma_deg, go.g_sensitivity_sigma_dps_per_g);
}

// The result before the solve: the usable stills, the free parameters (bias and scale of the
// excited axes) and why the others are held, the counts.
CalibrationResult earth_rate_setup(const VerticalStills& v, const std::vector<Eigen::Vector3d>& truth_f,
                                   std::vector<int>& free_index) {
  CalibrationResult r;
  r.method = Method::kEarthRate;
  r.model = gyroscope_model(false);
  r.whitened = true;
  r.intervals = v.stills;
  if (v.left_out > 0)
    r.notes.push_back(fmt::format("{} still(s) left out: no finite specific force or rate truth (orientation or "
                                  "latitude unknown)", v.left_out));
  const std::array<bool, 3> excited = excited_axes(v.up);
  free_index = excited_parameters(r.model, excited);
  init_parameters(r, free_index);
  explain_held(r, excited);
  r.observations = static_cast<int>(v.stills.size());
  r.estimated = static_cast<int>(free_index.size());
  r.dof = r.observations - r.estimated;
  for (const auto& f : truth_f)
    if (f.allFinite()) r.gravity_mps2 = std::max(r.gravity_mps2, f.norm());
  return r;
}

// Why the fit cannot run on these stills ("" when it can).
std::string earth_rate_refusal(const VerticalStills& v, const CalibrationResult& r, const Eigen::Vector3d& noise) {
  if (r.estimated == 0) return "no axis is ever near the vertical (or no still has a known orientation and rate)";
  if (!finite_intervals(v.stills)) return "non-finite (NaN) readings in a still";
  if (r.observations < r.estimated)
    return fmt::format("too few stills: {} with a known orientation and rate for {} parameters (bias and scale of "
                       "each near-vertical axis: an up and a down position each)",
                       r.observations, r.estimated);
  if (!(noise.minCoeff() > 0.0))
    return "the stills show no gyro noise and the quantization step is unknown: the a-priori sigmas need one";
  return {};
}

}  // namespace

CalibrationResult calibrate_gyro_earth_rate(const std::vector<processing::StaticPoint>& stills,
                                            const std::vector<Eigen::Vector3d>& truth_f,
                                            const std::vector<Eigen::Vector3d>& truth_w, const GyroOptions& go,
                                            double quantization_radps) {
  auto refused = [](const std::string& why) {
    CalibrationResult r;
    r.method = Method::kEarthRate;
    r.model = gyroscope_model(false);
    init_gyro_parameters(r);
    fail_all(r, why);
    return r;
  };
  if (go.estimate_g_sensitivity)
    return refused("earth_rate cannot estimate g-sensitivity: the vertical Earth rate and gravity flip together "
                   "between up and down, so G_ii is the same combination as scale_i");
  if (truth_f.size() != stills.size() || truth_w.size() != stills.size())
    return refused("earth_rate: one truth specific force and rate per still is needed");
  const VerticalStills v = vertical_stills(stills, truth_f, truth_w);
  std::vector<int> free_index;
  CalibrationResult r = earth_rate_setup(v, truth_f, free_index);
  const Eigen::Vector3d noise = pooled_gyro_noise(v.stills, quantization_radps);
  if (const std::string why = earth_rate_refusal(v, r, noise); !why.empty()) {
    fail_all(r, why);
    return r;
  }
  std::vector<double> g_mps2;
  for (const auto& f : truth_f)
    if (f.allFinite() && f.norm() > 0.0) g_mps2.push_back(f.norm());
  const Eigen::MatrixXd c = vertical_covariance(v, g_mps2, noise, go);
  auto* cost = new JointVerticalCost{&r.model, free_index, v.up, {}, v.omega_v_radps, {}};
  for (const auto& st : v.stills) cost->reading.push_back(st.gyro.mean);
  const Eigen::MatrixXd L = c.llt().matrixL();
  cost->W = L.inverse();
  r.uncertainty = vertical_sigmas_text(noise, go);
  std::vector<double> x(free_index.size(), 0.0);
  ceres::Problem problem;
  const CalibrationOptions o = as_calibration_options(go, go.loss_scale_radps);
  auto* fn = new ceres::DynamicAutoDiffCostFunction<JointVerticalCost, 8>(cost);
  fn->AddParameterBlock(static_cast<int>(free_index.size()));
  fn->SetNumResiduals(static_cast<int>(v.stills.size()));
  problem.AddResidualBlock(fn, make_loss(o), x.data());
  solve(problem, x, free_index, static_cast<int>(v.stills.size()), o, r, Weighting::kAPriori);
  vertical_checks(v, r);
  return r;
}

CalibrationResult calibrate_gyro_earth_rate(const Recording& rec, const GyroOptions& go) {
  const bool have = truth_columns(rec, kSpecificForceColumns) && truth_columns(rec, kRateColumns);
  std::vector<processing::StaticPoint> stills;
  std::vector<Eigen::Vector3d> f, w;
  std::vector<std::string> notes;
  if (have) {
    const Extracted ex = extract_intervals(rec, still_segment_options(go),
                                           truth_column_names({kSpecificForceColumns, kRateColumns}));
    for (std::size_t k = 0; k < ex.intervals.size(); ++k) {
      const std::vector<double>& t = ex.truth[k];
      f.emplace_back(t[0], t[1], t[2]);
      w.emplace_back(t[3], t[4], t[5]);
    }
    stills = ex.intervals;
  }
  CalibrationResult r = calibrate_gyro_earth_rate(stills, f, w, go, rec.header.info.gyro_lsb_radps);
  if (!have)
    fail_all(r, "the earth_rate gyro calibration needs the truth columns f_x_mps2.. and w_x_radps.. (the "
                "orientation and the Earth rate of each still); this recording has none");
  return r;
}

}  // namespace stend::ceres_nonlinear
