// The error-model vocabulary: every deterministic sensor error term Stend knows, defined once.
//
// The simulator runs a model forward (measure), estimators run it backward (regressor, Ceres
// autodiff through measure<T>), the gap diagnoser adds and removes terms. Nothing else writes a
// term's formula: the linear regressor is obtained by evaluating the same contribution<T> with unit
// parameter vectors, so the two can never disagree.
//
// Measurement of one triad (accelerometer or gyroscope), sensor frame, SI units:
//     y = u + Σ_terms contribution(term, θ_term, stimulus)        (+ noise, quantization, saturation
//                                                                  in the output stage, not here)
// u is the true input on the sensor axes: specific force [m/s^2] for an accelerometer, angular
// rate [rad/s] for a gyroscope. This is the paper's eq. (2): Δa_i = a_w + k·a + (k_t t + k_tt t²) A_i.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "stend/physics/kinematics.hpp"

namespace stend::model {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

enum class Instrument { kAccelerometer, kGyroscope };

// Everything a term may depend on at one sample (sensor frame, SI).
template <typename T>
struct Stimulus {
  Vec3<T> input = Vec3<T>::Zero();           // true specific force (accel) or rate (gyro)
  Vec3<T> specific_force = Vec3<T>::Zero();  // true specific force; for an accel equals input
  T temperature_c = T(25);                   // die temperature [degC]
  T temperature_rate_cps = T(0);             // d(die temperature)/dt [degC/s]
  T time_s = T(0);                           // since the start of the run [s]
  // Appended for the gap diagnoser's candidates (stend gap). Every default makes the terms that
  // read them contribute nothing, so a stimulus that does not set them behaves as before.
  // +1 when the current temperature was approached from below (heating), −1 from above
  // (cooling), 0 unknown / first temperature [1].
  T temperature_direction = T(0);
  // Unit vector opposite to local gravity, sensor frame ("up"); zero when unknown [1].
  Vec3<T> gravity_up = Vec3<T>::Zero();
  // Angular rate and angular acceleration of the sensor frame, sensor axes [rad/s], [rad/s^2].
  Vec3<T> angular_rate = Vec3<T>::Zero();
  Vec3<T> angular_accel = Vec3<T>::Zero();
  // ∂f/∂(angle of table axis k) for up to three table axes, sensor frame [(m/s^2)/rad]: how the
  // specific force would change if that axis's angle read zero δ_k too high. Zero when unknown.
  std::array<Vec3<T>, 3> table_df_dangle = {Vec3<T>::Zero(), Vec3<T>::Zero(), Vec3<T>::Zero()};
  // ∂f/∂(tilt of the table base about base x, base y), sensor frame [(m/s^2)/rad]. Zero when
  // unknown.
  std::array<Vec3<T>, 2> table_df_dtilt = {Vec3<T>::Zero(), Vec3<T>::Zero()};
};

enum class TermKind {
  kBias,              // b_i                                  [unit]
  kScale,             // s_i · u_i                            [1]
  kCrossAxis,         // Σ_{j≠i} m_ij · u_j  (non-orthogonality, the paper's μ_xy, μ_xz …) [1]
  kNonlinearK2,       // k2_i · u_i²                          [1/unit]
  kNonlinearK3,       // k3_i · u_i³                          [1/unit²]
  kOddQuadratic,      // q_i · u_i·|u_i|                      [1/unit]
  kBiasTemperature,   // Σ_k c_ik (T − T0)^k                  [unit/degC^k], k = 1..order
  kScaleTemperature,  // Σ_k d_ik (T − T0)^k · u_i            [1/degC^k],    k = 1..order
  kThermalLag,        // l_i · dT/dt  (die lag / hysteresis)  [unit/(degC/s)]
  kTimeDrift,         // r_i · t                              [unit/s]
  kGSensitivity,      // Σ_j G_ij · f_j  (gyro only)          [(rad/s)/(m/s^2)]
  // Appended (gap diagnosis candidates). Bench-side effects are written as what they do to the
  // sensor's reading, to first order, through the stimulus fields above.
  kThermalHysteresis, // h_i · temperature_direction          [unit]
  kGravityError,      // δg · gravity_up (the local g assumed wrong by δg) [m/s^2], 1 parameter
  kTableAngleOffset,  // Σ_k δ_k · table_df_dangle_k  (zero offsets of the table axes) [rad], 3
  kTableAxisTilt,     // Σ_k ε_k · table_df_dtilt_k   (base tilted about base x, y)    [rad], 2
  kLeverArm,          // centripetal + tangential acceleration at offset r (physics::point_acceleration) [m], 3
};

inline constexpr std::array<TermKind, 11> kAllTermKinds = {
    TermKind::kBias,        TermKind::kScale,           TermKind::kCrossAxis,
    TermKind::kNonlinearK2, TermKind::kNonlinearK3,     TermKind::kOddQuadratic,
    TermKind::kBiasTemperature, TermKind::kScaleTemperature, TermKind::kThermalLag,
    TermKind::kTimeDrift,   TermKind::kGSensitivity};

// The terms appended for the gap diagnoser (bench-side effects and hysteresis). Kept out of
// kAllTermKinds so that code iterating the sensor terms (model files, existing tests) is unchanged;
// term_from_name knows them.
inline constexpr std::array<TermKind, 5> kGapTermKinds = {
    TermKind::kThermalHysteresis, TermKind::kGravityError, TermKind::kTableAngleOffset,
    TermKind::kTableAxisTilt, TermKind::kLeverArm};

// One term as used in a model: its kind plus the structural settings that are not estimated.
struct TermSpec {
  TermKind kind = TermKind::kBias;
  int order = 1;             // polynomial order of the temperature terms (k = 1..order)
  double reference_c = 25.0; // T0 of the temperature terms [degC]
};

// The temperature polynomials: the terms whose TermSpec order and reference_c apply.
inline bool is_temperature_polynomial(TermKind k) {
  return k == TermKind::kBiasTemperature || k == TermKind::kScaleTemperature;
}

// The terms that read the die temperature (its value, its rate or the direction it was approached
// from): none of them can be assessed on a recording without temperature.
inline bool reads_temperature(TermKind k) {
  return is_temperature_polynomial(k) || k == TermKind::kThermalLag || k == TermKind::kThermalHysteresis;
}

struct ParamInfo {
  std::string name;  // "bias_x", "cross_xz", "bias_tc1_y" …
  std::string unit;  // "m/s^2", "1", "rad/s/degC" …
};

inline const char* term_name(TermKind k) {
  switch (k) {
    case TermKind::kBias: return "bias";
    case TermKind::kScale: return "scale";
    case TermKind::kCrossAxis: return "cross_axis";
    case TermKind::kNonlinearK2: return "nonlinear_k2";
    case TermKind::kNonlinearK3: return "nonlinear_k3";
    case TermKind::kOddQuadratic: return "odd_quadratic";
    case TermKind::kBiasTemperature: return "bias_temperature";
    case TermKind::kScaleTemperature: return "scale_temperature";
    case TermKind::kThermalLag: return "thermal_lag";
    case TermKind::kTimeDrift: return "time_drift";
    case TermKind::kGSensitivity: return "g_sensitivity";
    case TermKind::kThermalHysteresis: return "thermal_hysteresis";
    case TermKind::kGravityError: return "gravity_error";
    case TermKind::kTableAngleOffset: return "table_angle_offset";
    case TermKind::kTableAxisTilt: return "table_axis_tilt";
    case TermKind::kLeverArm: return "lever_arm";
  }
  return "?";
}

inline std::optional<TermKind> term_from_name(std::string_view name) {
  for (TermKind k : kAllTermKinds)
    if (name == term_name(k)) return k;
  for (TermKind k : kGapTermKinds)
    if (name == term_name(k)) return k;
  return std::nullopt;
}

inline int param_count(const TermSpec& t) {
  switch (t.kind) {
    case TermKind::kCrossAxis: return 6;
    case TermKind::kGSensitivity: return 9;
    case TermKind::kBiasTemperature:
    case TermKind::kScaleTemperature: return 3 * t.order;
    case TermKind::kGravityError: return 1;
    case TermKind::kTableAxisTilt: return 2;
    default: return 3;
  }
}

// Names and units of a term's parameters, in the order of its slice of the flat vector.
inline std::vector<ParamInfo> param_info(const TermSpec& t, Instrument inst) {
  const std::string u = inst == Instrument::kAccelerometer ? "m/s^2" : "rad/s";
  const char* ax = "xyz";
  auto per_axis = [&](const std::string& stem, const std::string& unit) {
    std::vector<ParamInfo> out;
    for (int i = 0; i < 3; ++i) out.push_back({stem + "_" + ax[i], unit});
    return out;
  };
  auto pow_unit = [](const std::string& base, int k) {
    return k == 1 ? base + "/degC" : base + "/degC^" + std::to_string(k);
  };
  switch (t.kind) {
    case TermKind::kBias: return per_axis("bias", u);
    case TermKind::kScale: return per_axis("scale", "1");
    case TermKind::kCrossAxis:
      return {{"cross_xy", "1"}, {"cross_xz", "1"}, {"cross_yx", "1"},
              {"cross_yz", "1"}, {"cross_zx", "1"}, {"cross_zy", "1"}};
    case TermKind::kNonlinearK2: return per_axis("k2", "1/(" + u + ")");
    case TermKind::kNonlinearK3: return per_axis("k3", "1/(" + u + ")^2");
    case TermKind::kOddQuadratic: return per_axis("odd_quadratic", "1/(" + u + ")");
    case TermKind::kBiasTemperature:
    case TermKind::kScaleTemperature: {
      const bool bias = t.kind == TermKind::kBiasTemperature;
      std::vector<ParamInfo> out;
      for (int i = 0; i < 3; ++i)
        for (int k = 1; k <= t.order; ++k)
          out.push_back({std::string(bias ? "bias_tc" : "scale_tc") + std::to_string(k) + "_" +
                             ax[i],
                         pow_unit(bias ? u : "1", k)});
      return out;
    }
    case TermKind::kThermalLag: return per_axis("thermal_lag", u + "/(degC/s)");
    case TermKind::kTimeDrift: return per_axis("drift", u + "/s");
    case TermKind::kGSensitivity: {
      std::vector<ParamInfo> out;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          out.push_back({std::string("gsens_") + ax[i] + ax[j], "rad/s/(m/s^2)"});
      return out;
    }
    case TermKind::kThermalHysteresis: return per_axis("hysteresis", u);
    case TermKind::kGravityError: return {{"gravity_error", "m/s^2"}};
    case TermKind::kTableAngleOffset:
      return {{"table_offset_1", "rad"}, {"table_offset_2", "rad"}, {"table_offset_3", "rad"}};
    case TermKind::kTableAxisTilt: return {{"table_tilt_x", "rad"}, {"table_tilt_y", "rad"}};
    case TermKind::kLeverArm: return per_axis("lever_arm", "m");
  }
  return {};
}

namespace detail {
template <typename T>
T abs_value(const T& x) {
  using std::abs;
  return abs(x);  // ceres::Jet provides abs through ADL
}
}  // namespace detail

// Forward contribution of one term. `p` points to the term's param_count(t) parameters.
template <typename T>
Vec3<T> contribution(const TermSpec& t, const T* p, const Stimulus<T>& s) {
  const Vec3<T>& u = s.input;
  Vec3<T> d;
  switch (t.kind) {
    case TermKind::kBias: return Vec3<T>(p[0], p[1], p[2]);
    case TermKind::kScale: return Vec3<T>(p[0] * u[0], p[1] * u[1], p[2] * u[2]);
    case TermKind::kCrossAxis:
      return Vec3<T>(p[0] * u[1] + p[1] * u[2], p[2] * u[0] + p[3] * u[2],
                     p[4] * u[0] + p[5] * u[1]);
    case TermKind::kNonlinearK2:
      return Vec3<T>(p[0] * u[0] * u[0], p[1] * u[1] * u[1], p[2] * u[2] * u[2]);
    case TermKind::kNonlinearK3:
      return Vec3<T>(p[0] * u[0] * u[0] * u[0], p[1] * u[1] * u[1] * u[1],
                     p[2] * u[2] * u[2] * u[2]);
    case TermKind::kOddQuadratic:
      for (int i = 0; i < 3; ++i) d[i] = p[i] * u[i] * detail::abs_value(u[i]);
      return d;
    case TermKind::kBiasTemperature:
    case TermKind::kScaleTemperature: {
      const T dt = s.temperature_c - T(t.reference_c);
      for (int i = 0; i < 3; ++i) {
        T acc = T(0), power = T(1);
        for (int k = 0; k < t.order; ++k) {
          power = power * dt;
          acc = acc + p[i * t.order + k] * power;
        }
        d[i] = t.kind == TermKind::kBiasTemperature ? acc : acc * u[i];
      }
      return d;
    }
    case TermKind::kThermalLag:
      return Vec3<T>(p[0], p[1], p[2]) * s.temperature_rate_cps;
    case TermKind::kTimeDrift: return Vec3<T>(p[0], p[1], p[2]) * s.time_s;
    case TermKind::kGSensitivity: {
      const Vec3<T>& f = s.specific_force;
      for (int i = 0; i < 3; ++i) d[i] = p[3 * i] * f[0] + p[3 * i + 1] * f[1] + p[3 * i + 2] * f[2];
      return d;
    }
    case TermKind::kThermalHysteresis: return Vec3<T>(p[0], p[1], p[2]) * s.temperature_direction;
    case TermKind::kGravityError: return s.gravity_up * p[0];
    case TermKind::kTableAngleOffset:
      return s.table_df_dangle[0] * p[0] + s.table_df_dangle[1] * p[1] + s.table_df_dangle[2] * p[2];
    case TermKind::kTableAxisTilt: return s.table_df_dtilt[0] * p[0] + s.table_df_dtilt[1] * p[1];
    case TermKind::kLeverArm:
      return physics::point_acceleration<T>(s.angular_rate, s.angular_accel, Vec3<T>(p[0], p[1], p[2]));
  }
  return Vec3<T>::Zero();
}

// Whether a term's contribution is affine in the input u (the rest of the stimulus held): all but
// the input's square, cube and |u|·u.
inline bool input_affine(TermKind k) {
  return k != TermKind::kNonlinearK2 && k != TermKind::kNonlinearK3 && k != TermKind::kOddQuadratic;
}

// An input-affine model at one stimulus: y = offset + A·u, and its inverse (the calibration)
// u = A⁻¹·(y − offset). A⁻¹ by cofactors, so it works for ceres::Jet.
template <typename T>
struct AffineForm {
  Eigen::Matrix<T, 3, 3> a, a_inv;
  Vec3<T> offset;
  Vec3<T> correct(const Vec3<T>& y) const { return a_inv * (y - offset); }
};

// A model: an ordered set of terms over one flat parameter vector (Basalt style).
struct ErrorModel {
  Instrument instrument = Instrument::kAccelerometer;
  std::vector<TermSpec> terms;

  int size() const {
    int n = 0;
    for (const auto& t : terms) n += param_count(t);
    return n;
  }
  // Offset of term `index`'s slice in the flat vector.
  int offset(std::size_t index) const {
    int n = 0;
    for (std::size_t i = 0; i < index; ++i) n += param_count(terms[i]);
    return n;
  }
  std::vector<ParamInfo> params() const {
    std::vector<ParamInfo> out;
    for (const auto& t : terms) {
      auto p = param_info(t, instrument);
      out.insert(out.end(), p.begin(), p.end());
    }
    return out;
  }
  int find(TermKind k) const {
    for (std::size_t i = 0; i < terms.size(); ++i)
      if (terms[i].kind == k) return static_cast<int>(i);
    return -1;
  }

  // y = u + Σ contributions. `theta` has size() entries.
  template <typename T>
  Vec3<T> measure(const T* theta, const Stimulus<T>& s) const {
    Vec3<T> y = s.input;
    const T* p = theta;
    for (const auto& t : terms) {
      y += contribution<T>(t, p, s);
      p += param_count(t);
    }
    return y;
  }

  // "accelerometer: bias, scale, bias_temperature(order 2, T0 25 degC)".
  void print(std::ostream& os) const {
    os << (instrument == Instrument::kAccelerometer ? "accelerometer" : "gyroscope") << ":";
    for (std::size_t i = 0; i < terms.size(); ++i) {
      os << (i ? ", " : " ") << term_name(terms[i].kind);
      if (terms[i].kind == TermKind::kBiasTemperature || terms[i].kind == TermKind::kScaleTemperature)
        os << "(order " << terms[i].order << ", T0 " << terms[i].reference_c << " degC)";
    }
  }
  // Same instrument and the same terms in the same order (kind, order, reference temperature).
  bool equals(const ErrorModel& other) const {
    if (instrument != other.instrument || terms.size() != other.terms.size()) return false;
    for (std::size_t i = 0; i < terms.size(); ++i) {
      const TermSpec &a = terms[i], &b = other.terms[i];
      if (a.kind != b.kind || a.order != b.order || a.reference_c != b.reference_c) return false;
    }
    return true;
  }

  // 3 × size() regressor Φ with y − u = Φ·θ. Every term is linear in its own parameters, so the
  // columns are the contributions of unit parameter vectors — the same formula as measure().
  Eigen::Matrix<double, 3, Eigen::Dynamic> regressor(const Stimulus<double>& s) const {
    Eigen::Matrix<double, 3, Eigen::Dynamic> phi(3, size());
    int col = 0;
    std::vector<double> unit;
    for (const auto& t : terms) {
      const int n = param_count(t);
      unit.assign(static_cast<std::size_t>(n), 0.0);
      for (int k = 0; k < n; ++k) {
        unit[static_cast<std::size_t>(k)] = 1.0;
        phi.col(col++) = contribution<double>(t, unit.data(), s);
        unit[static_cast<std::size_t>(k)] = 0.0;
      }
    }
    return phi;
  }

  bool input_affine() const {
    for (const auto& t : terms)
      if (!model::input_affine(t.kind)) return false;
    return true;
  }

  // The affine form of an input_affine() model at the stimulus s (its input ignored; for an
  // accelerometer the specific force follows the input, as in correct()): offset = measure(θ, 0),
  // A·e_j = measure(θ, e_j) − offset. Its correct() is the exact inverse of measure(); a model
  // with the input's square or cube has no such form (std::logic_error).
  template <typename T>
  AffineForm<T> affine(const T* theta, Stimulus<T> s = {}) const {
    if (!input_affine()) throw std::logic_error("ErrorModel::affine: the model is not affine in its input");
    const bool accel = instrument == Instrument::kAccelerometer;
    auto at = [&](const Vec3<T>& u) {
      s.input = u;
      if (accel) s.specific_force = u;
      return measure<T>(theta, s);
    };
    AffineForm<T> f;
    f.offset = at(Vec3<T>::Zero());
    for (int j = 0; j < 3; ++j) f.a.col(j) = at(Vec3<T>::Unit(j)) - f.offset;
    const Vec3<T> c0 = f.a.col(0), c1 = f.a.col(1), c2 = f.a.col(2);
    const T det = c0.dot(c1.cross(c2));
    f.a_inv.row(0) = c1.cross(c2).transpose() / det;
    f.a_inv.row(1) = c2.cross(c0).transpose() / det;
    f.a_inv.row(2) = c0.cross(c1).transpose() / det;
    return f;
  }

  // Inverse (calibration): the input u that makes measure(θ, u) = y, with the rest of the
  // stimulus as given. Newton's method on the input with a central-difference Jacobian; for an
  // accelerometer the specific force follows the input.
  Vec3<double> correct(const double* theta, const Vec3<double>& y, Stimulus<double> s,
                       int max_iterations = 20) const {
    const bool accel = instrument == Instrument::kAccelerometer;
    auto eval = [&](const Vec3<double>& u) {
      Stimulus<double> t = s;
      t.input = u;
      if (accel) t.specific_force = u;
      return measure<double>(theta, t);
    };
    Vec3<double> u = y;
    for (int it = 0; it < max_iterations; ++it) {
      const Vec3<double> r = eval(u) - y;
      if (r.norm() <= 1e-13 * (1.0 + y.norm())) break;
      Eigen::Matrix3d J;
      for (int j = 0; j < 3; ++j) {
        const double h = 1e-6 * (1.0 + std::abs(u[j]));
        Vec3<double> up = u, um = u;
        up[j] += h;
        um[j] -= h;
        J.col(j) = (eval(up) - eval(um)) / (2.0 * h);
      }
      u -= J.partialPivLu().solve(r);
    }
    return u;
  }
};

}  // namespace stend::model
