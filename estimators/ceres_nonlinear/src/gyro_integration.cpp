// Gyroscope calibration by integration between static intervals (IMU-TK style; orientations
// unknown): stage 1 the bias (and g-sensitivity) from the static intervals, stage 2 scale and
// cross-axis from the gravity direction carried through each move by the integrated rates, with
// the uncertainty the accelerometer calibration and stage 1 pass on. See
// stend/ceres_nonlinear/calibration.hpp.
#include "gyro.hpp"

#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <span>
#include <tuple>

namespace stend::ceres_nonlinear {

using namespace detail;

namespace {

// Static-interval residual for stage 1 of the integration method: ȳ − measure(θ, w, f) with only
// bias (and G) free (scale and cross at 0); w the Earth rate's vertical part along the interval's
// gravity direction (0 when the recording states no latitude).
struct StaticGyroCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  int full;
  Eigen::Vector3d y, f, w;
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    std::vector<T> theta(static_cast<std::size_t>(full), T(0));
    for (std::size_t k = 0; k < free_index.size(); ++k) theta[static_cast<std::size_t>(free_index[k])] = p[0][k];
    model::Stimulus<T> s;
    s.input = w.cast<T>();
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
  // (∂(R·v)/∂θ)ᵀ·l for the two l of a move's residuals:
  //   −c1·(v × l) + θ·(2·dc2·(a2·l) − 2·dc1·(a1·l)) + c2·((a1 × l) − v × (θ × l)),
  // a1 = θ × v, a2 = θ × a1, and by a × (b × c) = b(a·c) − c(a·b) the last bracket is
  // v(θ·l) + l(v·θ) − 2θ(v·l).
  void gradients(const Eigen::Vector3d& v, const Eigen::Vector3d& l1, const Eigen::Vector3d& l2,
                 Eigen::Vector3d& g1, Eigen::Vector3d& g2) const {
    const Eigen::Vector3d a1 = th.cross(v), a2 = th.cross(a1);
    const double vth = v.dot(th);
    auto one = [&](const Eigen::Vector3d& l) {
      return Eigen::Vector3d(-c1 * v.cross(l) + (2.0 * (dc2 * a2.dot(l) - dc1 * a1.dot(l) - c2 * v.dot(l))) * th +
                             (c2 * th.dot(l)) * v + (c2 * vth) * l);
    };
    g1 = one(l1);
    g2 = one(l2);
  }
};

// What the stage-1 parameters move in a move's increments: Δ_i = ½(w_i + w_{i+1})·dt_i with
// w = y − c − G·f, so ∂Δ_i/∂c = −dt_i·I and ∂Δ_i/∂G = −φ_iᵀ ⊗ I, φ_i = ½dt_i·(f_i + f_{i+1}) [m/s·s]
// (f the calibrated specific force; φ empty without g-sensitivity).
struct IncrementWeights {
  std::vector<double> dt;           // t_{i+1} − t_i [s]
  std::vector<Eigen::Vector3d> phi;
};

// Sums of a move's adjoint over the steps against IncrementWeights, for residual m:
// s_m = Σ_i dt_i·h_mi and M_m = Σ_i h_mi·φ_iᵀ with h_mi = ∂r_m/∂Δ_i = A⁻ᵀ·∂r_m/∂θ_i; then
// ∂r_m/∂z = −(s_m·∂c/∂z + ⟨M_m, ∂G/∂z⟩) for a stage-1 parameter z.
struct UpstreamSums {
  Eigen::Vector3d s[2];
  Eigen::Matrix3d m[2];
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
    std::vector<double> theta = theta_at(p[0]);
    const Eigen::Matrix3d ai = m_.affine<double>(theta.data()).a_inv;
    if (!jacobian || !jacobian[0]) {  // the end direction only: nothing kept for a backward pass
      Eigen::Vector3d v = g0_;
      for (const Eigen::Vector3d& inc : inc_) v = RotationStep(ai * inc).apply(v);
      residual[0] = e1_.dot(v);
      residual[1] = e2_.dot(v);
      return true;
    }
    const Path path = carry(ai);
    residual[0] = e1_.dot(path.v.back());
    residual[1] = e2_.dot(path.v.back());
    const Adjoint a = adjoint(path, ai, nullptr);
    jacobian_in_p(theta, ai, a.d[0], a.d[1], jacobian[0]);
    return true;
  }

  // The map that carries a start direction through the move at the stage-2 parameters p (the
  // steps applied to the unit vectors): v_end = carried(p)·v_start.
  Eigen::Matrix3d carried(const double* p) const {
    const Eigen::Matrix3d ai = m_.affine<double>(theta_at(p).data()).a_inv;
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    for (const Eigen::Vector3d& inc : inc_) {
      const RotationStep step(ai * inc);
      for (int c = 0; c < 3; ++c) m.col(c) = step.apply(m.col(c));
    }
    return m;
  }

  // Evaluate's Jacobian in p (jac, 2 × 9 row-major) and the UpstreamSums for the increments'
  // weights w, from the same backward pass.
  UpstreamSums jacobians(const double* p, const IncrementWeights& w, double* jac) const {
    std::vector<double> theta = theta_at(p);
    const Eigen::Matrix3d ai = m_.affine<double>(theta.data()).a_inv;
    const Adjoint a = adjoint(carry(ai), ai, &w);
    jacobian_in_p(theta, ai, a.d[0], a.d[1], jac);
    return a.u;
  }

 private:
  // The steps at A⁻¹ and the direction before each (v[n]: at the end).
  struct Path {
    std::vector<RotationStep> steps;
    std::vector<Eigen::Vector3d> v;
  };
  Path carry(const Eigen::Matrix3d& ai) const {
    Path path;
    path.steps.reserve(inc_.size());
    path.v.reserve(inc_.size() + 1);
    path.v.push_back(g0_);
    for (const Eigen::Vector3d& inc : inc_) {
      path.steps.emplace_back(ai * inc);
      path.v.push_back(path.steps.back().apply(path.v.back()));
    }
    return path;
  }

  // The backward pass: at_step(i, ∂r_1/∂θ_i, ∂r_2/∂θ_i) from the last step to the first.
  template <class StepFn>
  void backward(const Path& path, const StepFn& at_step) const {
    Eigen::Vector3d l1 = e1_, l2 = e2_;
    for (std::size_t i = path.steps.size(); i-- > 0;) {
      const RotationStep& step = path.steps[i];
      Eigen::Vector3d g1, g2;
      step.gradients(path.v[i], l1, l2, g1, g2);
      at_step(i, g1, g2);
      l1 = step.apply_transpose(l1);
      l2 = step.apply_transpose(l2);
    }
  }

  // What the backward pass sums: ∂r_m/∂A⁻¹ = Σ_i ∂r_m/∂θ_i·Δ_iᵀ and, with weights, the
  // UpstreamSums.
  struct Adjoint {
    Eigen::Matrix3d d[2] = {Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()};
    UpstreamSums u{{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}, {Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()}};
  };
  Adjoint adjoint(const Path& path, const Eigen::Matrix3d& ai, const IncrementWeights* w) const {
    Adjoint a;
    backward(path, [&](std::size_t i, const Eigen::Vector3d& g1, const Eigen::Vector3d& g2) {
      a.d[0].noalias() += g1 * inc_[i].transpose();
      a.d[1].noalias() += g2 * inc_[i].transpose();
      if (w == nullptr) return;
      const Eigen::Vector3d h[2] = {ai.transpose() * g1, ai.transpose() * g2};
      for (int m = 0; m < 2; ++m) {
        a.u.s[m] += w->dt[i] * h[m];
        if (!w->phi.empty()) a.u.m[m].noalias() += h[m] * w->phi[i].transpose();
      }
    });
    return a;
  }

  // The full θ: `base` with the stage-2 parameters p.
  std::vector<double> theta_at(const double* p) const {
    std::vector<double> theta = base_;
    for (std::size_t k = 0; k < 9; ++k) theta[3 + k] = p[k];
    return theta;
  }

  // ∂r_m/∂p_k = ⟨∂r_m/∂A⁻¹, ∂A⁻¹/∂p_k⟩.
  void jacobian_in_p(std::vector<double>& theta, const Eigen::Matrix3d& ai, const Eigen::Matrix3d& d1,
                     const Eigen::Matrix3d& d2, double* jac) const {
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

}  // namespace

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
  std::span<const ImuSample> samples;  // the recording's own where it holds them, else `read`
  std::vector<ImuSample> read;
  std::vector<Eigen::Vector3d> f_cal;
  const ImuSample& at(std::size_t i) const { return samples[i - a]; }
};

// Inputs shared by the steps of the integration method; intervals sorted by time.
struct IntegrationData {
  const Recording& rec;
  const CalibrationResult& accel;
  const GyroOptions& go;
  std::vector<processing::StaticPoint> ivs;
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
  std::sort(d.ivs.begin(), d.ivs.end(), [](const processing::StaticPoint& a, const processing::StaticPoint& b) { return a.first < b.first; });
  if (!accel.ok()) return d;
  for (const auto& iv : d.ivs) d.fk.push_back(accel.correct(iv.accel.mean));
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
    t.samples = samples_view(rec.sample_source(), t.a, b - t.a + 1, t.read);
    if (go.estimate_g_sensitivity)
      for (const ImuSample& x : t.samples) t.f_cal.push_back(cal.correct(x.accel_mps2));
  }
  return d;
}

// Why the recording cannot be used for the integration method, or "" when it can.
std::string integration_precondition(const IntegrationData& d) {
  if (!d.accel.ok()) return "the gyro integration needs the accelerometer calibration first, which failed: " + d.accel.message;
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
  // The Earth rate's vertical part (the site's latitude from the recording, 0 when it states none):
  // else it aliases into the G diagonal (Ω_e·sin φ / g ≈ 5e-6 (rad/s)/(m/s²) at 47°).
  const double omega_v = physics::kEarthRateRadps * std::sin(d.rec.header.latitude_deg * physics::kDegToRad);
  for (std::size_t k = 0; k < d.ivs.size(); ++k) {
    auto* c = new ceres::DynamicAutoDiffCostFunction<StaticGyroCost, 4>(new StaticGyroCost{
        &r.model, d.s1_index, r.model.size(), d.ivs[k].gyro.mean, d.fk[k], omega_v * d.gdir[k]});
    c->AddParameterBlock(p1);
    c->SetNumResiduals(3);
    prob1.AddResidualBlock(c, make_loss(o1), x1.data());
  }
  CalibrationResult r1 = r;
  solve(prob1, x1, d.s1_index, 3 * static_cast<int>(d.ivs.size()), o1, r1);
  return r1;
}

// What θ adds to the gyro reading whatever the rate: the bias, plus G·f with f the calibrated
// specific force when g-sensitivity is estimated. The gyro model's only term that reads f is
// g-sensitivity, linear in f, so this is offset(f) = c + G·f: built from four evaluations of the
// model per θ, it costs each sample one 3×3 product instead of the model's terms.
struct RateOffset {
  Eigen::Vector3d c;
  Eigen::Matrix3d g;
  RateOffset(const model::ErrorModel& m, const double* theta) {
    model::Stimulus<double> st;
    c = m.measure<double>(theta, st);
    for (int j = 0; j < 3; ++j) {
      st.specific_force = Eigen::Vector3d::Unit(j);
      g.col(j) = m.measure<double>(theta, st) - c;
    }
  }
};

// Gyro reading of sample i of turn k minus the bias (+ G·f) of θ [rad/s].
Eigen::Vector3d bias_corrected_rate(const IntegrationData& d, const RateOffset& off, std::size_t k, std::size_t i) {
  const Turn& t = d.turns[k];
  if (!d.go.estimate_g_sensitivity) return t.at(i).gyro_radps - off.c;
  return t.at(i).gyro_radps - off.c - off.g * t.f_cal[i - t.a];
}

// Rate increments of a move's bias-corrected readings w (θ's bias and G removed), trapezoidal:
// Δ_i = ½(w_i + w_{i+1})·(t_{i+1} − t_i) [rad], i = a .. b − 1.
std::vector<Eigen::Vector3d> move_increments(const IntegrationData& d, const model::ErrorModel& m, const double* theta,
                                             const Move& mv) {
  const Turn& turn = d.turns[mv.k];
  const RateOffset off(m, theta);
  std::vector<Eigen::Vector3d> inc(mv.b - mv.a);
  Eigen::Vector3d w_prev = bias_corrected_rate(d, off, mv.k, mv.a);
  for (std::size_t i = mv.a; i < mv.b; ++i) {
    const Eigen::Vector3d w_next = bias_corrected_rate(d, off, mv.k, i + 1);
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
  r.uncertainty = "stage 2: " + r2.uncertainty + ", plus the stage-1 bias and the accelerometer passed on (delta method)";
  r.iterations = r1.iterations + r2.iterations;
  r.condition_number = r2.condition_number;
  r.not_identifiable = r2.not_identifiable;
  r.solver_report = "stage 1 (bias" + std::string(d.go.estimate_g_sensitivity ? ", g-sensitivity" : "") +
                    fmt::format(", {} static intervals, sigma {:.3g} rad/s): ", d.ivs.size(), r1.sigma) +
                    r1.solver_report + fmt::format("; stage 2 (scale, cross-axis, {} moves): ", pairs) +
                    r2.solver_report;
}

// The weights of a move's increments (IncrementWeights): dt_i and, with g-sensitivity, φ_i.
IncrementWeights increment_weights(const IntegrationData& d, const Move& mv) {
  const Turn& turn = d.turns[mv.k];
  IncrementWeights w;
  for (std::size_t i = mv.a; i < mv.b; ++i) {
    w.dt.push_back(turn.at(i + 1).t_s - turn.at(i).t_s);
    if (d.go.estimate_g_sensitivity) w.phi.push_back(0.5 * w.dt.back() * (turn.f_cal[i - turn.a] + turn.f_cal[i + 1 - turn.a]));
  }
  return w;
}

// Move residuals [rad] at the stage-2 parameters x with the rates bias-corrected by stage 1's θ
// `tb`: as a function of the accelerometer's free parameters (which move only each move's start
// and end directions: each move's map is carried once, and a change costs no integration), and
// with their exact derivatives in x and in the stage-1 parameters (the moves' adjoint pass).
// G·f during the turns uses the baseline calibrated f: the accelerometer's uncertainty reaches the
// rates through G·δf only at second order.
class MoveResiduals {
 public:
  MoveResiduals(const IntegrationData& d, const model::ErrorModel& gyro, std::vector<double> tb, std::vector<double> x)
      : d_(d), gyro_(gyro), tb_(std::move(tb)), x_(std::move(x)) {
    for (const Move& mv : d_.moves) {
      increments_.push_back(move_increments(d_, gyro_, tb_.data(), mv));
      const Eigen::Vector3d unused = Eigen::Vector3d::Zero();  // carried() reads no direction
      carried_.push_back(cost(increments_.size() - 1, unused, unused, unused).carried(x_.data()));
    }
  }

  // The residuals with the accelerometer's free parameters at za.
  Eigen::VectorXd at(const Eigen::VectorXd& za) const {
    const std::vector<Eigen::Vector3d> up = interval_directions(za);
    Eigen::VectorXd out(static_cast<Eigen::Index>(2 * d_.moves.size()));
    for (std::size_t q = 0; q < d_.moves.size(); ++q) {
      const auto [e1, e2] = across(up[d_.moves[q].k + 1]);
      const Eigen::Vector3d v = carried_[q] * up[d_.moves[q].k];
      out[static_cast<Eigen::Index>(2 * q)] = e1.dot(v);
      out[static_cast<Eigen::Index>(2 * q + 1)] = e2.dot(v);
    }
    return out;
  }

  // ∂r/∂x (2·moves × 9) and ∂r/∂z1 (2·moves × stage-1 parameters) with the accelerometer's
  // parameters at za.
  void jacobians(const Eigen::VectorXd& za, Eigen::MatrixXd& jx, Eigen::MatrixXd& jz1) const {
    const std::vector<Eigen::Vector3d> up = interval_directions(za);
    const auto rows = static_cast<Eigen::Index>(2 * d_.moves.size());
    const auto n1 = static_cast<Eigen::Index>(d_.s1_index.size());
    jx.resize(rows, 9);
    jz1.resize(rows, n1);
    const auto [dc, dg] = offset_derivatives();
    for (std::size_t q = 0; q < d_.moves.size(); ++q) {
      const Move& mv = d_.moves[q];
      const auto [e1, e2] = across(up[mv.k + 1]);
      double jac[18];
      const UpstreamSums u = cost(q, up[mv.k], e1, e2).jacobians(x_.data(), increment_weights(d_, mv), jac);
      for (Eigen::Index m = 0; m < 2; ++m) {
        const Eigen::Index row = static_cast<Eigen::Index>(2 * q) + m;
        for (Eigen::Index k = 0; k < 9; ++k) jx(row, k) = jac[9 * m + k];
        for (Eigen::Index j = 0; j < n1; ++j)
          jz1(row, j) = -(u.s[m].dot(dc[static_cast<std::size_t>(j)]) + u.m[m].cwiseProduct(dg[static_cast<std::size_t>(j)]).sum());
      }
    }
  }

 private:
  // Move q's cost from start direction g0 with the residuals' axes e1, e2.
  MoveCost cost(std::size_t q, const Eigen::Vector3d& g0, const Eigen::Vector3d& e1, const Eigen::Vector3d& e2) const {
    return MoveCost(gyro_, tb_, increments_[q], g0, e1, e2);
  }

  // e1, e2 ⊥ the end direction g1 (the residuals' axes).
  static std::pair<Eigen::Vector3d, Eigen::Vector3d> across(const Eigen::Vector3d& g1) {
    const Eigen::Vector3d e1 = g1.unitOrthogonal();
    return {e1, g1.cross(e1)};
  }

  // The direction of each interval's specific force calibrated with the accelerometer's free
  // parameters at za.
  std::vector<Eigen::Vector3d> interval_directions(const Eigen::VectorXd& za) const {
    std::vector<double> ta = d_.accel.theta;
    for (std::size_t j = 0; j < d_.accel.free_index.size(); ++j)
      ta[static_cast<std::size_t>(d_.accel.free_index[j])] = za[static_cast<Eigen::Index>(j)];
    std::vector<Eigen::Vector3d> up;
    for (const auto& iv : d_.ivs)
      up.push_back(d_.accel.model.correct(ta.data(), iv.accel.mean, model::Stimulus<double>{}).normalized());
    return up;
  }

  // ∂c/∂z_j and ∂G/∂z_j of the rate offset c + G·f for each stage-1 parameter z_j: exact as
  // differences at a unit step, the offset being linear in them.
  std::pair<std::vector<Eigen::Vector3d>, std::vector<Eigen::Matrix3d>> offset_derivatives() const {
    const RateOffset at(gyro_, tb_.data());
    std::vector<Eigen::Vector3d> dc;
    std::vector<Eigen::Matrix3d> dg;
    for (int i : d_.s1_index) {
      std::vector<double> t = tb_;
      t[static_cast<std::size_t>(i)] += 1.0;
      const RateOffset moved(gyro_, t.data());
      dc.push_back(moved.c - at.c);
      dg.push_back(moved.g - at.g);
    }
    return {dc, dg};
  }

  const IntegrationData& d_;
  const model::ErrorModel& gyro_;
  std::vector<double> tb_, x_;
  std::vector<std::vector<Eigen::Vector3d>> increments_;  // each move's, at tb
  std::vector<Eigen::Matrix3d> carried_;                  // each move's map at x
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
// (delta method: Rz = ∂r/∂z, by forward differences in the accelerometer's parameters and exact in
// stage 1's; J2 = ∂r/∂x exact): C = C2 + S·Cz·Sᵀ with S = −(J2ᵀJ2)⁻¹·J2ᵀ·Rz; fills the stage-2
// standard errors and bounds in r.
void add_upstream_uncertainty(const IntegrationData& d, const CalibrationResult& r1, const CalibrationResult& r2,
                              const std::vector<double>& x1, const std::vector<double>& x2,
                              const GyroOptions& go, CalibrationResult& r) {
  Eigen::MatrixXd Cz;
  if (!upstream_covariance(d, r1, Cz)) return;
  const auto na = static_cast<Eigen::Index>(d.accel.free_index.size());
  Eigen::VectorXd za(na);
  for (Eigen::Index j = 0; j < na; ++j) za[j] = d.accel.theta[static_cast<std::size_t>(d.accel.free_index[static_cast<std::size_t>(j)])];
  std::vector<double> tb(static_cast<std::size_t>(r.model.size()), 0.0);
  for (std::size_t j = 0; j < d.s1_index.size(); ++j) tb[static_cast<std::size_t>(d.s1_index[j])] = x1[j];
  const MoveResiduals residuals(d, r.model, tb, x2);
  Eigen::MatrixXd J2, J1;
  residuals.jacobians(za, J2, J1);
  const Eigen::VectorXd r0 = residuals.at(za);
  Eigen::MatrixXd Rz(r0.size(), Cz.rows());
  for (Eigen::Index j = 0; j < na; ++j) {
    const double h = 1e-6 * std::max(1.0, std::abs(za[j]));
    Eigen::VectorXd z = za;
    z[j] += h;
    Rz.col(j) = (residuals.at(z) - r0) / h;
  }
  Rz.rightCols(J1.cols()) = J1;
  const Eigen::MatrixXd S = -(J2.transpose() * J2).ldlt().solve(J2.transpose() * Rz);
  const Eigen::MatrixXd C = r2.covariance + S * Cz * S.transpose();
  r.covariance = C;
  r.free_index = kScaleCrossIndex;
  for (int k = 0; k < 9; ++k) {
    auto& prm = r.parameters[static_cast<std::size_t>(kScaleCrossIndex[static_cast<std::size_t>(k)])];
    prm.std_error = std::sqrt(std::max(0.0, C(k, k)));
    prm.lower = prm.value - r.quantile * prm.std_error;
    prm.upper = prm.value + r.quantile * prm.std_error;
    estimation::judge(prm, go.tolerances, {go.confidence, r.quantile});
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
  const RateOffset off(m, th.data());
  std::size_t k = 0;  // the turn being integrated
  auto rate = [&](std::size_t i) {
    return raw ? Eigen::Vector3d(d.turns[k].at(i).gyro_radps) : Eigen::Vector3d(ai * bias_corrected_rate(d, off, k, i));
  };
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();
  double sum = 0.0;
  int count = 0;
  for (; k + 1 < ivs.size(); ++k) {
    const std::size_t a = ivs[k].last, b = ivs[k + 1].first;
    if (b <= a) continue;
    const Turn& turn = d.turns[k];
    Eigen::Vector3d v = raw ? ivs[k].accel.mean.normalized() : d.gdir[k];
    Eigen::Vector3d wp = rate(a);
    for (std::size_t i = a; i < b; ++i) {
      const Eigen::Vector3d wn = rate(i + 1);
      v = RotationStep((wp + wn) * 0.5 * (turn.at(i + 1).t_s - turn.at(i).t_s)).apply(v);  // the fit's own step
      wp = wn;
    }
    const Eigen::Vector3d target = raw ? ivs[k + 1].accel.mean.normalized() : d.gdir[k + 1];
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
  r.method = Method::kIntegration;
  r.model = gyroscope_model(go.estimate_g_sensitivity);
  r.gravity_mps2 = accel.gravity_mps2;
  init_gyro_parameters(r);
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
  if (!r1.ok()) {
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
  if (!r2.ok()) return done("stage 2 (scale and cross-axis from the integrated rotations): " + r2.message);
  r.status = estimation::FitStatus::kOk;
  r.theta = r1.theta;
  for (int i : kScaleCrossIndex) r.theta[static_cast<std::size_t>(i)] = r2.theta[static_cast<std::size_t>(i)];
  add_upstream_uncertainty(d, r1, r2, x1, x2, go, r);
  std::tie(r.direction_error_rad.before, r.direction_error_axis_rad.before) = gravity_mismatch(
      d, r.model, std::vector<double>(static_cast<std::size_t>(r.model.size()), 0.0), true, &r.moves, false);
  std::tie(r.direction_error_rad.after, r.direction_error_axis_rad.after) =
      gravity_mismatch(d, r.model, r.theta, false, &r.moves, true);
  return r;
}

}  // namespace stend::ceres_nonlinear
