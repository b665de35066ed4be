// The procedure player: a person's (or a rate table's) motion as a timeline of pieces, sampled by
// the simulated sensor. See stend/sim/procedure_player.hpp.
#include <stend/sim/procedure_player.hpp>

#include <stend/errors.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>

#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

namespace stend::sim {

namespace {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;
constexpr double kDeg = physics::kDegToRad;

Mat3 rot(const Vec3& v) {
  const double a = v.norm();
  return a > 0.0 ? Mat3(Eigen::AngleAxisd(a, v / a)) : Mat3::Identity();
}

Vec3 log_rot(const Mat3& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

double clamp01(double s) { return std::clamp(s, 0.0, 1.0); }

// Minimum-jerk progress 0 → 1 with zero rate and acceleration at both ends: a hand's reach.
double min_jerk(double s) {
  s = clamp01(s);
  return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
}

// A hand turn's progress 0 → 1: the rate rises as sin² and falls back (accelerate, brake).
double turn_progress(double s) {
  s = clamp01(s);
  return s - std::sin(2.0 * kPi * s) / (2.0 * kPi);
}

// A piece of the motion: the sensor's orientation R_sensor_from_local over [t0, t0 + duration]
// (τ = t − t0; the function is called with τ clamped to the piece).
struct Piece {
  double t0 = 0.0, duration = 0.0;
  std::function<Mat3(double)> orientation;
};

// The motion as the sensor sees it: orientation, angular rate (the orientation's derivative plus
// the Earth rate) and specific force at any time.
class Timeline final : public TruthSource {
 public:
  Timeline(double g, const Vec3& earth_local) : g_(g), earth_local_(earth_local) {}

  void add(double duration, std::function<Mat3(double)> orientation) {
    pieces_.push_back({end_s(), duration, std::move(orientation)});
  }
  double end_s() const { return pieces_.empty() ? 0.0 : pieces_.back().t0 + pieces_.back().duration; }

  Mat3 orientation(double t) const {
    auto it = std::upper_bound(pieces_.begin(), pieces_.end(), t, [](double v, const Piece& p) { return v < p.t0; });
    const Piece& p = it == pieces_.begin() ? pieces_.front() : *std::prev(it);
    return p.orientation(std::clamp(t - p.t0, 0.0, p.duration));
  }

  // dR/dt = −[ω]× R for R = R_sensor_from_local and ω in the sensor frame: a central difference.
  BenchTruth at(double t) const override {
    constexpr double h = 1e-4;
    BenchTruth b;
    b.t_s = t;
    b.R_sensor_from_local = orientation(t);
    const Vec3 body = -log_rot(orientation(t + h) * orientation(t - h).transpose()) / (2.0 * h);
    b.angular_rate_radps = body + b.R_sensor_from_local * earth_local_;
    b.specific_force_mps2 = b.R_sensor_from_local * Vec3(0.0, 0.0, g_);
    return b;
  }

 private:
  double g_;
  Vec3 earth_local_;
  std::vector<Piece> pieces_;
};

// The player's state: where the sensor is, what it has played, the randomness.
class Player {
 public:
  Player(const Experiment& exp, const PlayerOptions& o)
      : h_(o.hand), rng_(o.seed ^ 0x7E11A5EDULL),
        timeline_(exp.gravity.resolved_mps2, exp.gravity.latitude_known() ? physics::earth_rate_local(exp.gravity.latitude_deg)
                                                                          : Vec3::Zero()) {
    R_ = rot(Vec3(0.0, 0.0, uniform(0.0, 2.0 * kPi)));  // z up at a random heading
  }

  void play(const Step& s) {
    switch (s.kind) {
      case Step::Kind::kFaces: faces(s); break;
      case Step::Kind::kStill: stills(s); break;
      case Step::Kind::kTurns: turns(s); break;
      case Step::Kind::kRateLegs: rate_legs(s); break;
      case Step::Kind::kRecord:
      case Step::Kind::kWait: hold(s.record_s > 0.0 ? s.record_s : h_.hold_s); break;
      case Step::Kind::kSetTemperature:
      case Step::Kind::kSetVibration: break;  // nothing a person does to the sensor
      case Step::Kind::kOrientations:
      case Step::Kind::kRates:
        throw InputError(std::string("procedure player: a '") + step_kind_name(s.kind) + "' step ('" + s.label +
                         "') needs its table: turn the experiment into observed steps first (as_observed_procedure)");
    }
  }

  const Timeline& timeline() const { return timeline_; }
  std::vector<PlayedStep> take_steps() { return std::move(steps_); }

 private:
  // --- randomness ---
  double uniform(double a, double b) { return a + (b - a) * rng_.uniform(); }
  double normal(double sigma) { return sigma * rng_.normal(); }
  // A small random rotation about the two axes perpendicular to `axis` [rad, 1σ each].
  Vec3 across(const Vec3& axis, double sigma_rad) {
    const Vec3 e1 = axis.unitOrthogonal(), e2 = axis.cross(e1).normalized();
    return normal(sigma_rad) * e1 + normal(sigma_rad) * e2;
  }

  Vec3 up_now() const { return R_ * Vec3::UnitZ(); }  // local up in the sensor frame

  // --- pieces ---
  void hold(double seconds) {
    const Mat3 R = R_;
    if (h_.tremor_deg > 0.0) {
      const double a = h_.tremor_deg * kDeg;
      const Vec3 phase(uniform(0, 2 * kPi), uniform(0, 2 * kPi), uniform(0, 2 * kPi));
      timeline_.add(seconds, [R, a, phase, seconds](double tau) {
        const double envelope = std::min({1.0, tau / 0.2, (seconds - tau) / 0.2});
        const Vec3 w(std::sin(2 * kPi * 8.3 * tau + phase[0]), std::sin(2 * kPi * 9.7 * tau + phase[1]),
                     std::sin(2 * kPi * 11.1 * tau + phase[2]));
        return Mat3(rot(a * envelope * w) * R);
      });
    } else {
      timeline_.add(seconds, [R](double) { return R; });
    }
    last_was_hold_ = true;
  }

  double hold_time(double record_s) {
    return (record_s > 0.0 ? record_s * h_.hold_factor : h_.hold_s) * uniform(0.9, 1.1);
  }

  // A hand move to `target` along the shortest rotation, minimum jerk; its time grows with the angle.
  void move_to(const Mat3& target) {
    const Mat3 R0 = R_;
    const Vec3 delta = log_rot(target * R0.transpose());
    const double seconds = h_.move_min_s + delta.norm() / kPi * (h_.move_max_s - h_.move_min_s);
    timeline_.add(seconds, [R0, delta, seconds](double tau) { return Mat3(rot(min_jerk(tau / seconds) * delta) * R0); });
    R_ = target;
    last_was_hold_ = false;
  }

  // The orientation with sensor direction `up` (stated) up: the shortest rotation from where the
  // sensor is (a quarter turn about the vertical when it is up already), tilted by the placement
  // and turned about the vertical by the heading scatter.
  Mat3 placed(const Vec3& stated_up) {
    const Vec3 up = (rot(across(stated_up, h_.placement_sigma_deg * kDeg)) * stated_up).normalized();
    const Vec3 now = up_now();
    Mat3 q;
    if (std::acos(std::clamp(now.dot(up), -1.0, 1.0)) < 10.0 * kDeg)
      q = rot(0.5 * kPi * up) * Mat3(Eigen::Quaterniond::FromTwoVectors(now, up));
    else if (now.dot(up) < -0.999)
      q = Mat3(Eigen::Quaterniond::FromTwoVectors(-now, up)) * rot(kPi * now.unitOrthogonal());
    else
      q = Mat3(Eigen::Quaterniond::FromTwoVectors(now, up));
    return rot(normal(h_.heading_sigma_deg * kDeg) * up) * q * R_;
  }

  // Moves to `target` (the recording's first placement is where the sensor starts).
  void go(const Mat3& target) {
    if (timeline_.end_s() == 0.0 && !started_) {
      R_ = target;
    } else {
      move_to(target);
    }
    started_ = true;
  }

  void record(const std::string& label, double t0) {
    PlayedStep p;
    p.label = label;
    p.t_start_s = t0;
    p.t_end_s = timeline_.end_s();
    p.up = up_now();
    steps_.push_back(p);
  }

  // --- steps ---
  void faces(const Step& s) {
    for (std::size_t k = 0; k < s.faces_up.size(); ++k) {
      go(placed(s.faces_up[k].normalized()));
      const double t0 = timeline_.end_s();
      hold(hold_time(s.record_s));
      record(s.label + " face " + std::to_string(k + 1), t0);
    }
  }

  // A uniformly random orientation whose up differs from the present one by at least 20°.
  Mat3 random_orientation() {
    for (;;) {
      Eigen::Quaterniond q(rng_.normal(), rng_.normal(), rng_.normal(), rng_.normal());
      q.normalize();
      const Mat3 r(q);
      if (!started_ || std::acos(std::clamp((r * Vec3::UnitZ()).dot(up_now()), -1.0, 1.0)) > 20.0 * kDeg) return r;
    }
  }

  void stills(const Step& s) {
    const int n = s.count > 0 ? s.count : h_.stills_for_all;
    for (int k = 0; k < n; ++k) {
      if (started_) go(random_orientation());
      started_ = true;
      const double t0 = timeline_.end_s();
      hold(hold_time(s.record_s));
      record(s.label + " still " + std::to_string(k + 1), t0);
    }
  }

  void turns(const Step& s) {
    started_ = true;
    for (int k = 0; k < s.count; ++k) {
      if (!last_was_hold_) hold(hold_time(0.0));
      const double sign = s.direction != 0 ? s.direction : (rng_.uniform() < 0.5 ? -1.0 : 1.0);
      const double t0 = timeline_.end_s();
      const Vec3 turned = turn(s.sensor_axis.normalized(), sign * s.angle_deg * kDeg);
      PlayedStep p;
      p.label = s.label + " turn " + std::to_string(k + 1);
      p.t_start_s = t0;
      p.t_end_s = timeline_.end_s();
      p.rotation_deg = turned / kDeg;
      steps_.push_back(p);
      hold(hold_time(0.0));
    }
  }

  // One hand turn by `angle` [rad] about `axis` (sensor frame), off in angle and axis, with a wobble
  // off the axis that starts and ends at zero. Returns the rotation vector actually turned [rad].
  Vec3 turn(const Vec3& axis, double angle) {
    const Vec3 a = (rot(across(axis, h_.turn_axis_sigma_deg * kDeg)) * axis).normalized();
    const double phi = angle + normal(h_.turn_angle_sigma_deg * kDeg);
    const double seconds = uniform(h_.turn_min_s, h_.turn_max_s);
    const Vec3 e1 = a.unitOrthogonal(), e2 = a.cross(e1).normalized();
    const double c = uniform(0.0, 2.0 * kPi);
    const Vec3 w1 = h_.wobble_deg * kDeg * (std::cos(c) * e1 + std::sin(c) * e2);
    const Vec3 w2 = 0.5 * h_.wobble_deg * kDeg * (-std::sin(c) * e1 + std::cos(c) * e2);
    const Mat3 R0 = R_;
    timeline_.add(seconds, [=](double tau) {
      const double s = tau / seconds;
      const Vec3 wobble = std::sin(kPi * s) * w1 + std::sin(2.0 * kPi * s) * w2;
      return Mat3(rot(wobble) * rot(-turn_progress(s) * phi * a) * R0);
    });
    R_ = rot(-phi * a) * R0;
    last_was_hold_ = false;
    return phi * a;
  }

  // The sensor on a level table with `up` up; each leg a still, a ramp up to the rate about the
  // table's (vertical) axis, the rate held, a ramp down; a still after the last.
  void rate_legs(const Step& s) {
    const Vec3 axis = s.sensor_axis.normalized();
    const Vec3 up = s.up ? s.up->normalized() : axis;
    if (std::abs(up.dot(axis)) < 0.999)
      throw InputError("procedure player: step '" + s.label +
                       "' (rate_legs): the table's axis is vertical, so `up` must lie along the rate axis");
    go(placed(up));
    for (std::size_t k = 0; k < s.rates.size(); ++k) {
      hold(hold_time(0.0));
      const double t0 = timeline_.end_s();
      leg(s.rates[k] * kDeg * (up.dot(axis) > 0 ? 1.0 : -1.0), hold_time(s.record_s));
      PlayedStep p;
      p.label = s.label + " leg " + std::to_string(k + 1);
      p.t_start_s = t0;
      p.t_end_s = timeline_.end_s();
      p.rate_dps = s.rates[k];
      steps_.push_back(p);
    }
    hold(hold_time(0.0));
  }

  // The table turning at `rate` [rad/s] about the local vertical for `seconds` between cosine ramps.
  void leg(double rate, double seconds) {
    const double ramp = std::max(0.5, std::abs(rate) / (h_.table_accel_dps2 * kDeg));
    const double total = 2.0 * ramp + seconds;
    const auto angle = [=](double tau) {  // ψ(τ): the table angle [rad]
      const auto ramp_angle = [&](double x) { return rate * (0.5 * x - ramp / (2.0 * kPi) * std::sin(kPi * x / ramp)); };
      if (tau <= ramp) return ramp_angle(tau);
      if (tau <= ramp + seconds) return ramp_angle(ramp) + rate * (tau - ramp);
      return 2.0 * ramp_angle(ramp) + rate * seconds - ramp_angle(total - tau);
    };
    const Mat3 R0 = R_;
    timeline_.add(total, [=](double tau) { return Mat3(R0 * rot(Vec3(0.0, 0.0, -angle(tau)))); });
    R_ = R0 * rot(Vec3(0.0, 0.0, -angle(total)));
    last_was_hold_ = false;
  }

  const HandOptions& h_;
  model::Rng rng_;
  Timeline timeline_;
  Mat3 R_ = Mat3::Identity();  // R_sensor_from_local now
  bool started_ = false, last_was_hold_ = false;
  std::vector<PlayedStep> steps_;
};

// (i, j) of a triad's cross-axis matrix from the vocabulary's name "cross_ij".
Mat3 cross_matrix(const std::map<std::string, double>& p, const std::string& prefix) {
  Mat3 m = Mat3::Zero();
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (i != j) m(i, j) = p.at(prefix + "cross_" + ax[i] + ax[j]);
  return m;
}

Mat3 affine_matrix(const std::map<std::string, double>& p, const std::string& prefix) {
  Mat3 a = Mat3::Identity() + cross_matrix(p, prefix);
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) a(i, i) += p.at(prefix + "scale_" + ax[i]);
  return a;
}

void set_affine(std::map<std::string, double>& p, const std::string& prefix, const Mat3& a) {
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      p[prefix + (i == j ? std::string("scale_") + ax[i] : std::string("cross_") + ax[i] + ax[j])] = a(i, j) - (i == j ? 1.0 : 0.0);
}

// A triad's terms in the vocabulary's order and names, with their values from TriadErrors.
void add_triad(std::map<std::string, double>& out, const std::string& prefix, const TriadErrors& e, bool gyro) {
  using model::TermKind;
  const model::Instrument inst = gyro ? model::Instrument::kGyroscope : model::Instrument::kAccelerometer;
  const Mat3& M = e.cross_axis;
  const Mat3& G = e.g_sensitivity;
  const std::vector<std::pair<TermKind, std::vector<double>>> terms = {
      {TermKind::kBias, {e.bias[0], e.bias[1], e.bias[2]}},
      {TermKind::kScale, {e.scale[0], e.scale[1], e.scale[2]}},
      {TermKind::kCrossAxis, {M(0, 1), M(0, 2), M(1, 0), M(1, 2), M(2, 0), M(2, 1)}},
      {TermKind::kGSensitivity, {G(0, 0), G(0, 1), G(0, 2), G(1, 0), G(1, 1), G(1, 2), G(2, 0), G(2, 1), G(2, 2)}}};
  for (const auto& [kind, values] : terms) {
    if (kind == TermKind::kGSensitivity && !gyro) continue;
    const auto info = model::param_info({kind}, inst);
    for (std::size_t i = 0; i < info.size(); ++i) out[prefix + info[i].name] = values[i];
  }
}

}  // namespace

bool HandOptions::IsValid(std::string* error) const {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  const auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!(positive(hold_s) && positive(hold_factor))) return invalid(error, "hold_s and hold_factor must be > 0");
  if (!(positive(move_min_s) && move_max_s >= move_min_s)) return invalid(error, "hand moves need 0 < move_min_s <= move_max_s");
  if (!(positive(turn_min_s) && turn_max_s >= turn_min_s)) return invalid(error, "hand turns need 0 < turn_min_s <= turn_max_s");
  for (double v : {placement_sigma_deg, heading_sigma_deg, tremor_deg, turn_angle_sigma_deg, turn_axis_sigma_deg, wobble_deg})
    if (!non_negative(v)) return invalid(error, "the hand's sigmas and amplitudes must be >= 0");
  if (!positive(table_accel_dps2)) return invalid(error, "table_accel_dps2 must be > 0");
  if (stills_for_all < 1) return invalid(error, "stills_for_all must be >= 1");
  return true;
}

bool PlayerOptions::IsValid(std::string* error) const {
  if (!(std::isfinite(rate_hz) && rate_hz > 0.0)) return invalid(error, "rate_hz must be > 0");
  return hand.IsValid(error);
}

PlantedTruth PlantedTruth::in_accel_frame_convention() const {
  PlantedTruth out = *this;
  // A = L·R  ⇔  Aᵀ = Rᵀ·Lᵀ: the QR decomposition of Aᵀ, signs so that L's diagonal is positive.
  const Mat3 a = affine_matrix(parameters, "accel_");
  const Eigen::HouseholderQR<Mat3> qr(a.transpose());
  Mat3 q = qr.householderQ();
  Mat3 u = qr.matrixQR().triangularView<Eigen::Upper>();
  const Vec3 sign = u.diagonal().cwiseSign();
  q = q * sign.asDiagonal();
  u = sign.asDiagonal() * u;
  const Mat3 r = q.transpose();
  set_affine(out.parameters, "accel_", u.transpose());
  set_affine(out.parameters, "gyro_", affine_matrix(parameters, "gyro_") * r.transpose());
  if (parameters.count("gyro_gsens_xx")) {
    Mat3 g;
    const char* ax = "xyz";
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) g(i, j) = parameters.at(std::string("gyro_gsens_") + ax[i] + ax[j]);
    g = g * r.transpose();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) out.parameters[std::string("gyro_gsens_") + ax[i] + ax[j]] = g(i, j);
  }
  return out;
}

PlantedTruth planted_truth(const SimImuConfig& sensor) {
  PlantedTruth t;
  add_triad(t.parameters, "accel_", sensor.accel, false);
  add_triad(t.parameters, "gyro_", sensor.gyro, true);
  t.accel_noise_density = sensor.accel_noise_density;
  t.gyro_noise_density = sensor.gyro_noise_density;
  return t;
}

SimImuConfig twin_sensor(std::uint64_t seed) {
  model::Rng rng(seed ^ 0x5E1150A5ULL);
  SimImuConfig c;
  const auto draw = [&](double sigma) { return sigma * rng.normal(); };
  const auto triad = [&](TriadErrors& e, double bias, double scale, double cross) {
    for (int i = 0; i < 3; ++i) {
      e.bias[i] = draw(bias);
      e.scale[i] = draw(scale);
      for (int j = 0; j < 3; ++j)
        if (i != j) e.cross_axis(i, j) = draw(cross);
    }
  };
  triad(c.accel, 30.0 * physics::kMilliG, 0.01, 0.005);
  triad(c.gyro, 1.0 * physics::kDegPerSecond, 0.01, 0.005);
  const double gsens = 0.05 * physics::kDegPerSecond / physics::kStandardGravity;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.gyro.g_sensitivity(i, j) = draw(gsens);
  c.accel_range_g = 2.0;
  c.gyro_range_dps = 500.0;
  // White noise only: the bias instability and random walk move the bias during a session, which a
  // short procedure cannot tell from the bias (a fit's bias is the session's).
  c.accel_bias_instability_mps2 = c.accel_random_walk = 0.0;
  c.gyro_bias_instability_radps = c.gyro_random_walk = 0.0;
  return c;
}

Played play_procedure(const Experiment& exp, const SimImuConfig& sensor, const PlayerOptions& options) {
  require_valid(options, "procedure player options");
  if (!(exp.gravity.resolved_mps2 > 0.0)) throw InputError("procedure player: the experiment states no gravity (bench.gravity)");
  Player player(exp, options);
  for (const Step& s : exp.procedure) player.play(s);

  SimImuConfig c = sensor;
  c.output_rate_hz = options.rate_hz;
  c.seed = static_cast<std::int64_t>((options.seed * 0x9E3779B97F4A7C15ULL) >> 17) + 1;
  SimImu imu(c);
  Played out;
  imu.acquire(player.timeline().end_s(), player.timeline(), out.samples);
  out.info = imu.info();
  out.truth = planted_truth(sensor);
  out.steps = player.take_steps();
  out.gravity_mps2 = exp.gravity.resolved_mps2;
  return out;
}

}  // namespace stend::sim
