// A seeded hand-held multi-position log from SimImu. See stend/sim/stress_log.hpp.
#include <stend/sim/imu.hpp>
#include <stend/sim/stress_log.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

namespace stend::sim {

namespace {

constexpr double kTremorHz = 8.0;            // physiological tremor band
constexpr double kMaxMoveRateDps = 150.0;    // peak turn rate, well inside the gyro's ±250 deg/s

// One stretch of the log: still in R0, or turning from R0 by phi about `axis` (sensor frame) with
// ω(t) = (2φ/T)·sin²(πt/T) — zero rate at both ends, so the poses either side are truly still.
struct Piece {
  double t0 = 0.0, t1 = 0.0;
  Eigen::Matrix3d R0 = Eigen::Matrix3d::Identity();  // R_sensor_from_local at t0
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  double phi = 0.0;  // 0: still
  Eigen::Vector3d tremor_phase = Eigen::Vector3d::Zero();
};

class Timeline final : public TruthSource {
 public:
  Timeline(std::vector<Piece> pieces, double g, double tremor) : pieces_(std::move(pieces)), g_(g), tremor_(tremor) {}
  BenchTruth at(double t) const override {
    const auto it = std::lower_bound(pieces_.begin(), pieces_.end(), t,
                                     [](const Piece& p, double x) { return p.t1 < x; });
    const Piece& p = it == pieces_.end() ? pieces_.back() : *it;
    BenchTruth b;
    b.t_s = t;
    b.R_sensor_from_local = p.R0;
    if (p.phi != 0.0) {
      const double T = p.t1 - p.t0, u = std::clamp((t - p.t0) / T, 0.0, 1.0);
      const double ang = p.phi * (u - std::sin(2.0 * std::numbers::pi * u) / (2.0 * std::numbers::pi));
      const double envelope = std::pow(std::sin(std::numbers::pi * u), 2);
      b.R_sensor_from_local = Eigen::AngleAxisd(-ang, p.axis).toRotationMatrix() * p.R0;
      b.angular_rate_radps = p.axis * (2.0 * p.phi / T * envelope);
      for (int a = 0; a < 3; ++a)
        b.specific_force_mps2[a] = tremor_ * envelope * std::sin(2.0 * std::numbers::pi * kTremorHz * t + p.tremor_phase[a]);
    }
    b.specific_force_mps2 += b.R_sensor_from_local * Eigen::Vector3d(0.0, 0.0, g_);
    return b;
  }

 private:
  std::vector<Piece> pieces_;
  double g_, tremor_;
};

}  // namespace

StressLog make_stress_log(const StressSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  auto unit = [&] {
    std::normal_distribution<double> n(0.0, 1.0);
    return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized().eval();
  };
  StressLog log;
  log.rate_hz = spec.rates_hz[std::uniform_int_distribution<std::size_t>(0, spec.rates_hz.size() - 1)(rng)];
  log.gravity_mps2 = physics::kStandardGravity;

  SimImuConfig c;
  c.output_rate_hz = log.rate_hz;
  c.seed = static_cast<std::int64_t>(rng() >> 1) | 1;
  for (int a = 0; a < 3; ++a) {
    c.accel.bias[a] = uniform(-spec.accel_bias_max_mps2, spec.accel_bias_max_mps2);
    c.accel.scale[a] = uniform(-spec.accel_scale_max, spec.accel_scale_max);
    c.gyro.bias[a] = uniform(-spec.gyro_offset_dps_max, spec.gyro_offset_dps_max) * physics::kDegPerSecond;
  }
  c.accel.cross_axis(1, 0) = uniform(-spec.accel_cross_max, spec.accel_cross_max);
  c.accel.cross_axis(2, 0) = uniform(-spec.accel_cross_max, spec.accel_cross_max);
  c.accel.cross_axis(2, 1) = uniform(-spec.accel_cross_max, spec.accel_cross_max);
  // The timeline: still start, then move → pose, `poses` times.
  std::vector<Piece> pieces;
  Eigen::Matrix3d R = Eigen::AngleAxisd(uniform(0.0, std::numbers::pi), unit()).toRotationMatrix();
  double t = 0.0;
  pieces.push_back({t, t + spec.init_still_s, R, Eigen::Vector3d::UnitX(), 0.0, Eigen::Vector3d::Zero()});
  t += spec.init_still_s;
  for (int k = 0; k < spec.poses; ++k) {
    const double phi = uniform(spec.move_angle_deg_min, spec.move_angle_deg_max) * physics::kDegToRad;
    const double T = std::max(uniform(spec.move_s_min, spec.move_s_max), 2.0 * phi / (kMaxMoveRateDps * physics::kDegToRad));
    const Eigen::Vector3d axis = unit();
    const Eigen::Vector3d phase(uniform(0, 6.3), uniform(0, 6.3), uniform(0, 6.3));
    pieces.push_back({t, t + T, R, axis, phi, phase});
    R = Eigen::AngleAxisd(-phi, axis).toRotationMatrix() * R;
    t += T;
    const double hold = uniform(spec.pose_s_min, spec.pose_s_max);
    pieces.push_back({t, t + hold, R, Eigen::Vector3d::UnitX(), 0.0, Eigen::Vector3d::Zero()});
    t += hold;
  }
  const Timeline timeline(pieces, log.gravity_mps2, spec.tremor_mps2);

  SimImu imu(c);
  // The truth by the vocabulary's names; terms the sensor leaves out (all zero) read as zero.
  for (const char* name : {"cross_xy", "cross_xz", "cross_yz"}) log.accel_truth[name] = 0.0;
  for (std::size_t i = 0; i < imu.accel_theta().size(); ++i)
    log.accel_truth[imu.accel_model().params()[i].name] = imu.accel_theta()[i];
  for (std::size_t i = 0; i < imu.gyro_theta().size(); ++i)
    log.gyro_truth[imu.gyro_model().params()[i].name] = imu.gyro_theta()[i];
  imu.start(0.0);
  imu.acquire(t, timeline, log.samples);
  // Still ranges: samples strictly inside a still piece.
  for (const Piece& p : pieces) {
    if (p.phi != 0.0) continue;
    const auto first = static_cast<std::size_t>(std::ceil(p.t0 * log.rate_hz + 1e-9));
    const auto last = static_cast<std::size_t>(std::floor(p.t1 * log.rate_hz - 1e-9));
    // Sample k (1-based in SimImu) is at k / rate: index k − 1.
    if (last > first && last <= log.samples.size()) log.statics.emplace_back(std::max<std::size_t>(first, 1) - 1, last - 1);
  }
  for (ImuSample& s : log.samples) {
    for (int a = 0; a < 3; ++a) {
      s.accel_counts[a] += spec.count_offset;  // an importer given LSB and offset converts them back
      s.gyro_counts[a] += spec.count_offset;
    }
    if (spec.timestamps == StressTimestamps::kRounded)
      s.t_s = std::round(s.t_s / spec.timestamp_resolution_s) * spec.timestamp_resolution_s;
  }
  return log;
}

}  // namespace stend::sim
