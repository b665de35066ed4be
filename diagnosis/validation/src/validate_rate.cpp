// `stend gap validate`, rate-table experiment: the segment-level generator for a sensor spun on the
// sim three-axis table (gyro: scale, cross-axis, nonlinearity, g-sensitivity; accelerometer off the
// axis: lever arm, local gravity). See validate.hpp (RateDesign).
#include <cmath>
#include <cstdio>

#include "stend/diagnosis/validate.hpp"
#include "stend/physics/kinematics.hpp"
#include "segment_mean_noise.hpp"
#include "stend/model/noise.hpp"

namespace stend::diagnosis {

RateDesign default_rate_design() {
  RateDesign d;
  const double r2 = 1.0 / std::sqrt(2.0), r3 = 1.0 / std::sqrt(3.0);
  d.axes = {Eigen::Vector3d::UnitX(),    -Eigen::Vector3d::UnitX(),  Eigen::Vector3d::UnitY(),
            -Eigen::Vector3d::UnitY(),   Eigen::Vector3d::UnitZ(),   -Eigen::Vector3d::UnitZ(),
            Eigen::Vector3d(r2, r2, 0),  Eigen::Vector3d(r2, 0, -r2), Eigen::Vector3d(0, -r2, r2),
            Eigen::Vector3d(-r3, r3, r3)};
  return d;
}

RateDesign two_mount_rate_design() {
  RateDesign d = default_rate_design();
  d.remount_offsets_m = {Eigen::Vector3d(-0.05, 0.04, 0.02)};
  return d;
}

estimation::ModelSpec rate_model(model::Instrument instrument) {
  estimation::ModelSpec s;
  s.model.instrument = instrument;
  s.model.terms = {model::TermSpec{model::TermKind::kBias, 1, 25.0}, model::TermSpec{model::TermKind::kScale, 1, 25.0}};
  s.source = instrument == model::Instrument::kGyroscope ? "bias + scale, gyroscope (rate-table validation model)"
                                                         : "bias + scale, accelerometer (rate-table validation model)";
  return s;
}

double rate_white_floor(const RateDesign& d, model::Instrument instrument) {
  const double density = instrument == model::Instrument::kGyroscope ? d.gyro_noise_density : d.accel_noise_density;
  const double sigma = model::WhiteNoise::sigma_from_density(density, 1.0 / d.rate_hz);
  return sigma / std::sqrt(d.record_s * d.rate_hz);
}

namespace {

// Constant rate [deg/s] about the vertical `up` (sensor frame): ω, gravity and the centripetal
// term are constant in the sensor frame, ω̇ = 0. Specific force at the sensor = the known mount's
// lever-arm acceleration (offset [m]) + g·up; the input is ω for a gyroscope, f otherwise.
model::Stimulus<double> rate_stimulus(const RateDesign& d, const Eigen::Vector3d& up, const Eigen::Vector3d& offset,
                                      double rate_dps, bool gyro, double mid_s) {
  model::Stimulus<double> st;
  const Eigen::Vector3d w = rate_dps * physics::kDegToRad * up;
  st.angular_rate = w;
  st.angular_accel = Eigen::Vector3d::Zero();
  const Eigen::Vector3d f = physics::point_acceleration<double>(w, st.angular_accel, offset) + d.gravity * up;
  st.specific_force = f;
  st.input = gyro ? w : f;
  st.gravity_up = up;
  st.temperature_c = d.temperature_c;
  st.temperature_rate_cps = 0.0;
  st.temperature_direction = 0.0;
  st.time_s = mid_s;
  return st;
}

}  // namespace

GapInput generate_rate(const RateDesign& d, const estimation::ModelSpec& fit_model, const Planted& truth,
                       std::uint64_t seed) {
  const model::Instrument inst = fit_model.model.instrument;
  const bool gyro = inst == model::Instrument::kGyroscope;
  GapInput in = generated_input(fit_model, "validation generator (rate table, segment level)");
  model::Rng rng(seed);
  const double dt = 1.0 / d.rate_hz;
  const double sigma =
      model::WhiteNoise::sigma_from_density(gyro ? d.gyro_noise_density : d.accel_noise_density, dt);
  const double se = rate_white_floor(d, inst);
  const double bi = d.bias_instability > 0 ? d.bias_instability : 0.3 * se;
  SegmentMeanNoise mean_noise(rng, se, sigma, bi, d.bias_correlation_s);
  double t = 0.0;
  int seg_id = 0;
  std::vector<Eigen::Vector3d> mounts = {d.offset_m};
  mounts.insert(mounts.end(), d.remount_offsets_m.begin(), d.remount_offsets_m.end());
  for (std::size_t mo = 0; mo < mounts.size() * d.axes.size(); ++mo) {
    const std::size_t mount = mo / d.axes.size(), o = mo % d.axes.size();
    const Eigen::Vector3d& offset = mounts[mount];
    const Eigen::Vector3d up = d.axes[o].normalized();  // rate axis = local vertical, sensor frame
    char oname[64];
    std::snprintf(oname, sizeof oname, "rate axis (%.2f,%.2f,%.2f)", up[0], up[1], up[2]);
    for (double rate_dps : d.rates_dps) {
      t += d.move_s;
      SegmentData s;
      auto& p = s.point;
      const double mid = time_segment(s, seg_id++, t, d.record_s, d.rate_hz);
      p.stimulus = rate_stimulus(d, up, offset, rate_dps, gyro, mid);
      measure_segment(truth, mean_noise, rng, mid, s);
      char label[160];
      std::snprintf(label, sizeof label, "mount %zu, %s %g deg/s", mount + 1, oname, rate_dps);
      p.segment.label = label;
      s.orientation = static_cast<int>(o);
      s.orientation_name = oname;
      s.setpoint_c = d.temperature_c;
      s.temperature_group = 0;
      s.ramp_direction = 0;
      s.time_since_change_s = d.move_s;  // since the last rate or orientation change
      s.averaging_s = d.record_s;
      in.segments.push_back(s);
      t += d.record_s;
    }
  }
  in.twin_sample_std = Eigen::Vector3d::Constant(sigma);
  return in;
}

}  // namespace stend::diagnosis
