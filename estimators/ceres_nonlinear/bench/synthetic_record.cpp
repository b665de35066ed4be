#include "synthetic_record.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace stend::ceres_nonlinear::synthetic {

Record make(const Spec& spec) {
  Record out;
  Recording& rec = out.recording;
  rec.header.gravity_mps2 = spec.gravity_mps2;
  rec.header.info.output_rate_hz = spec.rate_hz;
  rec.header.status = RunStatus::kComplete;
  rec.samples.resize(spec.samples);
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> angle(60.0, 150.0);
  const model::ErrorModel ma = accelerometer_model();
  const model::ErrorModel mg = gyroscope_model(spec.gyro_theta.size() == 21);
  auto random_unit = [&] {
    Eigen::Vector3d v(n01(rng), n01(rng), n01(rng));
    return Eigen::Vector3d(v.normalized());
  };
  Eigen::Matrix3d R = Eigen::AngleAxisd(std::uniform_real_distribution<double>(0, std::numbers::pi)(rng), random_unit())
                          .toRotationMatrix();  // R_sensor_from_local
  const double dt = 1.0 / spec.rate_hz;
  const std::size_t per = spec.samples / static_cast<std::size_t>(spec.positions);
  const auto n_static = static_cast<std::size_t>(std::round(spec.static_fraction * static_cast<double>(per)));
  const Eigen::Vector3d up(0.0, 0.0, spec.gravity_mps2);
  std::size_t i = 0;
  auto emit = [&](const Eigen::Matrix3d& Rs, const Eigen::Vector3d& w) {
    ImuSample& s = rec.samples[i];
    s.t_s = static_cast<double>(i) * dt;
    model::Stimulus<double> sa;
    sa.input = Rs * up;
    sa.specific_force = sa.input;
    model::Stimulus<double> sg;
    sg.input = w;
    sg.specific_force = sa.input;
    s.accel_mps2 = ma.measure<double>(spec.accel_theta.data(), sa) +
                   spec.accel_noise_mps2 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    s.gyro_radps = mg.measure<double>(spec.gyro_theta.data(), sg) +
                   spec.gyro_noise_radps * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    s.temperature_c = 25.0;
    ++i;
  };
  for (int k = 0; k < spec.positions && i < spec.samples; ++k) {
    const bool last = k + 1 == spec.positions;
    const std::size_t first = i;
    const std::size_t stat = last ? spec.samples - i : n_static;
    for (std::size_t j = 0; j < stat && i < spec.samples; ++j) emit(R, Eigen::Vector3d::Zero());
    out.statics.emplace_back(first, i - 1);
    if (last) break;
    const std::size_t move = per - n_static;
    const double T = static_cast<double>(move) * dt, phi = angle(rng) * physics::kDegToRad;
    const Eigen::Vector3d axis = random_unit();
    // The static pose ends at the last static sample; the turn runs over the next `move` samples and
    // ends exactly one sample before the next pose's first sample (φ(T) = φ).
    for (std::size_t j = 1; j <= move && i < spec.samples; ++j) {
      const double t = static_cast<double>(j) * dt;
      const double ang = phi * (t / T - std::sin(2.0 * std::numbers::pi * t / T) / (2.0 * std::numbers::pi));
      const double rate = 2.0 * phi / T * std::pow(std::sin(std::numbers::pi * t / T), 2);
      emit(Eigen::AngleAxisd(-ang, axis).toRotationMatrix() * R, axis * rate);
    }
    R = Eigen::AngleAxisd(-phi, axis).toRotationMatrix() * R;
  }
  rec.samples.resize(i);
  return out;
}

}  // namespace stend::ceres_nonlinear::synthetic
