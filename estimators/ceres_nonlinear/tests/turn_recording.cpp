#include "turn_recording.hpp"

#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/truth_columns.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>

namespace stend::ceres_nonlinear::turn_record {

namespace {

using Kind = Step::Kind;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Step still(double s = 10.0) { return {Kind::kStill, 0, 0.0, s}; }
Step turn(int axis, double deg) { return {Kind::kTurn, axis, deg, 5.0}; }
Step move(int axis, double deg) { return {Kind::kMove, axis, deg, 3.0}; }

// The recording under construction: samples, segments and held truth rows.
class Builder {
 public:
  Builder(const Spec& spec) : spec_(spec), rng_(spec.seed), mg_(gyroscope_model(spec.gyro_theta.size() == 21)) {
    Recording& r = rec_;
    r.header.gravity_mps2 = spec.gravity_mps2;
    r.header.latitude_deg = std::isfinite(spec.latitude_deg) ? spec.latitude_deg : 0.0;
    r.header.info.output_rate_hz = spec.rate_hz;
    r.header.status = RunStatus::kComplete;
    r.header.truth_columns = truth_column_names({kSpecificForceColumns, kRateColumns, kTurnColumns});
    if (std::isfinite(spec.latitude_deg)) {
      const double phi = spec.latitude_deg * physics::kDegToRad;
      earth_local_ = Eigen::Vector3d(0.0, std::cos(phi), std::sin(phi)) * physics::kEarthRateRadps;  // ENU
    }
  }

  void add(const Step& s) {
    switch (s.kind) {
      case Kind::kStill:
      case Kind::kDetectedStill: add_still(s); break;
      case Kind::kTurn:
      case Kind::kMove: add_rotation(s); break;
    }
  }

  Recording take() { return std::move(rec_); }

 private:
  Eigen::Vector3d up_sensor() const { return R_ * Eigen::Vector3d::UnitZ(); }

  // One sample at the current orientation R_ turning at `rate` (sensor frame) [rad/s].
  void emit(const Eigen::Vector3d& rate) {
    std::normal_distribution<double> n(0.0, 1.0);
    ImuSample s;
    s.t_s = static_cast<double>(rec_.samples.size()) / spec_.rate_hz;
    model::Stimulus<double> st;
    st.specific_force = up_sensor() * spec_.gravity_mps2;
    st.input = rate + R_ * earth_local_;
    s.gyro_radps = mg_.measure<double>(spec_.gyro_theta.data(), st) +
                   spec_.gyro_noise_radps * Eigen::Vector3d(n(rng_), n(rng_), n(rng_));
    s.accel_mps2 = st.specific_force + spec_.accel_noise_mps2 * Eigen::Vector3d(n(rng_), n(rng_), n(rng_));
    s.temperature_c = 25.0;
    rec_.samples.push_back(s);
  }

  double now() const { return rec_.samples.empty() ? 0.0 : rec_.samples.back().t_s; }

  void segment(SegmentKind kind, const std::string& label, double t0, double t1, const std::vector<double>& truth) {
    Segment seg;
    seg.id = static_cast<int>(rec_.segments.size());
    seg.kind = kind;
    seg.label = label;
    seg.t_start_s = t0;
    seg.t_end_s = t1;
    rec_.segments.push_back(seg);
    for (const double t : {t0, 0.5 * (t0 + t1), t1}) {  // held truth, as io's add_held_truth
      if (!rec_.truth_t.empty() && !(t > rec_.truth_t.back())) continue;
      rec_.truth_t.push_back(t);
      rec_.truth.push_back(truth);
    }
  }

  void add_still(const Step& s) {
    const auto n = static_cast<std::size_t>(std::lround(s.seconds * spec_.rate_hz));
    const double t0 = static_cast<double>(rec_.samples.size()) / spec_.rate_hz;
    for (std::size_t i = 0; i < n; ++i) emit(Eigen::Vector3d::Zero());
    const bool known = s.kind == Kind::kStill;
    const Eigen::Vector3d f = up_sensor() * spec_.gravity_mps2;
    const Eigen::Vector3d w = up_sensor() * up_sensor().dot(R_ * earth_local_);  // the vertical part
    std::vector<double> truth(9, kNaN);
    if (known)
      for (int a = 0; a < 3; ++a) {
        truth[static_cast<std::size_t>(a)] = f[a];
        truth[static_cast<std::size_t>(3 + a)] = w[a];
      }
    ++stills_;
    segment(known ? SegmentKind::kOrientation : SegmentKind::kDetected, "still " + std::to_string(stills_), t0, now(),
            truth);
  }

  // The actual rotation of a known turn: its stated angle and axis, off by turn_error_deg (1σ).
  std::pair<Eigen::Vector3d, double> actual(const Eigen::Vector3d& axis, double angle_rad) {
    std::normal_distribution<double> n(0.0, spec_.turn_error_deg * physics::kDegToRad);
    const Eigen::Vector3d e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
    return {(axis + n(rng_) * e1 + n(rng_) * e2).normalized(), angle_rad + n(rng_)};
  }

  void add_rotation(const Step& s) {
    const Eigen::Vector3d stated_axis = Eigen::Vector3d::Unit(s.axis);
    const double stated = s.angle_deg * physics::kDegToRad;
    const auto [axis, phi] = s.kind == Kind::kTurn ? actual(stated_axis, stated) : std::pair{stated_axis, stated};
    const double t_before = now();
    const auto m = static_cast<std::size_t>(std::lround(s.seconds * spec_.rate_hz));
    const double T = static_cast<double>(m) / spec_.rate_hz;
    const Eigen::Matrix3d R0 = R_;
    for (std::size_t j = 1; j <= m; ++j) {
      const double t = static_cast<double>(j) / spec_.rate_hz;
      const double ang = phi * (t / T - std::sin(2.0 * std::numbers::pi * t / T) / (2.0 * std::numbers::pi));
      const double rate = 2.0 * phi / T * std::pow(std::sin(std::numbers::pi * t / T), 2);
      R_ = Eigen::AngleAxisd(-ang, axis).toRotationMatrix() * R0;
      emit(axis * rate);
    }
    R_ = Eigen::AngleAxisd(-phi, axis).toRotationMatrix() * R0;
    if (s.kind != Kind::kTurn) return;
    // The turn's segment spans the motion: from the last sample of the still before it to the first
    // of the still after it.
    std::vector<double> truth(9, kNaN);
    for (int a = 0; a < 3; ++a) truth[static_cast<std::size_t>(6 + a)] = stated_axis[a] * s.angle_deg;
    segment(SegmentKind::kRotation, std::string("turn ") + "xyz"[s.axis], t_before, now() + 1.0 / spec_.rate_hz, truth);
  }

  const Spec& spec_;
  std::mt19937_64 rng_;
  model::ErrorModel mg_;
  Recording rec_;
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();  // R_sensor_from_local (ENU): z up at the start
  Eigen::Vector3d earth_local_ = Eigen::Vector3d::Zero();
  int stills_ = 0;
};

}  // namespace

std::vector<Step> ferraris_steps(bool turn_x) {
  std::vector<Step> s = {still(), turn(2, 360.0), {Kind::kDetectedStill, 0, 0.0, 10.0},  // z up
                         move(0, 180.0), still(),                                         // z down
                         move(0, 90.0),  still(), turn(1, -360.0), still(),               // y down
                         move(0, 180.0), still(),                                         // y up
                         move(2, 90.0),  still()};                                        // x up
  if (turn_x) s.insert(s.end(), {turn(0, 360.0), still()});
  s.insert(s.end(), {move(1, 180.0), still()});  // x down
  return s;
}

std::vector<Step> six_face_steps(double seconds) {
  return {still(seconds), move(0, 180.0), still(seconds),   // z up, z down
          move(0, 90.0),  still(seconds), move(0, 180.0),   // y down
          still(seconds), move(2, 90.0),  still(seconds),   // y up, x up
          move(1, 180.0), still(seconds)};                  // x down
}

std::vector<Step> up_down_steps(int axis, double seconds) {
  std::vector<Step> s;
  if (axis == 0) s.push_back(move(1, -90.0));  // x up
  if (axis == 1) s.push_back(move(0, 90.0));   // y up
  s.push_back(still(seconds));
  s.push_back(move(axis == 0 ? 2 : 0, 180.0));
  s.push_back(still(seconds));
  return s;
}

Recording make(const Spec& spec, const std::vector<Step>& steps) {
  Builder b(spec);
  for (const Step& s : steps) b.add(s);
  return b.take();
}

}  // namespace stend::ceres_nonlinear::turn_record
