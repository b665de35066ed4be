#include <stend/sim/imu.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace stend::sim {

namespace {

bool all_zero(const double* p, int n) {
  for (int i = 0; i < n; ++i)
    if (p[i] != 0.0) return false;
  return true;
}

// Builds the model with only the terms that have a non-zero parameter (a zero term adds exactly
// 0.0, so the output is the same; leaving it out is faster).
model::ErrorModel build_model(model::Instrument inst, const TriadErrors& e, double t0_c,
                              std::vector<double>& theta) {
  using model::TermKind;
  model::ErrorModel m;
  m.instrument = inst;
  theta.clear();
  auto add = [&](TermKind k, std::vector<double> p, int order = 1) {
    if (all_zero(p.data(), static_cast<int>(p.size()))) return;
    m.terms.push_back({k, order, t0_c});
    theta.insert(theta.end(), p.begin(), p.end());
  };
  auto v3 = [](const Eigen::Vector3d& v) { return std::vector<double>{v[0], v[1], v[2]}; };
  auto tc = [](const std::vector<std::vector<double>>& rows) {
    std::vector<double> p;  // layout of the temperature terms: [i * order + k]
    for (const auto& row : rows) p.insert(p.end(), row.begin(), row.end());
    return p;
  };
  const Eigen::Matrix3d& M = e.cross_axis;
  add(TermKind::kBias, v3(e.bias));
  add(TermKind::kScale, v3(e.scale));
  add(TermKind::kCrossAxis, {M(0, 1), M(0, 2), M(1, 0), M(1, 2), M(2, 0), M(2, 1)});
  add(TermKind::kNonlinearK2, v3(e.nonlinear_k2));
  add(TermKind::kNonlinearK3, v3(e.nonlinear_k3));
  add(TermKind::kOddQuadratic, v3(e.odd_quadratic));
  const int bias_order = static_cast<int>(e.bias_tc[0].size());
  const int scale_order = static_cast<int>(e.scale_tc[0].size());
  if (bias_order > 0) add(TermKind::kBiasTemperature, tc(e.bias_tc), bias_order);
  if (scale_order > 0) add(TermKind::kScaleTemperature, tc(e.scale_tc), scale_order);
  add(TermKind::kThermalLag, v3(e.thermal_lag));
  add(TermKind::kTimeDrift, v3(e.time_drift));
  if (inst == model::Instrument::kGyroscope) {
    const Eigen::Matrix3d& G = e.g_sensitivity;
    add(TermKind::kGSensitivity,
        {G(0, 0), G(0, 1), G(0, 2), G(1, 0), G(1, 1), G(1, 2), G(2, 0), G(2, 1), G(2, 2)});
  }
  if (static_cast<int>(theta.size()) != m.size())
    throw std::logic_error("sim_imu: parameter vector does not match the model");
  return m;
}

using F = fields::Field<SimImuConfig>;
constexpr auto kAccel = &SimImuConfig::accel;
constexpr auto kGyro = &SimImuConfig::gyro;

}  // namespace

const fields::Table<SimImuConfig>& SimImuConfig::fields() {
  static const stend::fields::Table<SimImuConfig> table("sim_imu", {
      // --- deterministic accelerometer errors (the error-model vocabulary, SI) ---
      F("accel_bias_mps2", kAccel, &TriadErrors::bias, "m/s^2", "bias b_i (term 'bias')").range(-100.0, 100.0),
      F("accel_scale", kAccel, &TriadErrors::scale, "1", "scale-factor error s_i: y_i = (1 + s_i)·u_i (term 'scale')")
          .range(-0.5, 0.5),
      F("accel_cross_axis", kAccel, &TriadErrors::cross_axis, "1",
        "cross-axis m_ij (row i = output axis, column j = input axis), zero diagonal (term 'cross_axis')")
          .range(-0.5, 0.5),
      F("accel_nonlinear_k2", kAccel, &TriadErrors::nonlinear_k2, "1/(m/s^2)", "k2_i·u_i² (term 'nonlinear_k2')")
          .range(-1.0, 1.0),
      F("accel_nonlinear_k3", kAccel, &TriadErrors::nonlinear_k3, "1/(m/s^2)^2", "k3_i·u_i³ (term 'nonlinear_k3')")
          .range(-1.0, 1.0),
      F("accel_odd_quadratic", kAccel, &TriadErrors::odd_quadratic, "1/(m/s^2)", "q_i·u_i·|u_i| (term 'odd_quadratic')")
          .range(-1.0, 1.0),
      F("accel_bias_tc", kAccel, &TriadErrors::bias_tc, "m/s^2/degC^k",
        "bias temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1) (term 'bias_temperature', "
        "order = columns)"),
      F("accel_scale_tc", kAccel, &TriadErrors::scale_tc, "1/degC^k",
        "scale temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1)·u_i (term "
        "'scale_temperature')"),
      F("accel_thermal_lag", kAccel, &TriadErrors::thermal_lag, "(m/s^2)/(degC/s)",
        "l_i·dT/dt, T = die temperature (term 'thermal_lag')"),
      F("accel_time_drift", kAccel, &TriadErrors::time_drift, "m/s^2/s", "r_i·t since start (term 'time_drift')"),
      // --- deterministic gyroscope errors (rad/s) ---
      F("gyro_bias_radps", kGyro, &TriadErrors::bias, "rad/s", "bias b_i (term 'bias')").range(-10.0, 10.0),
      F("gyro_scale", kGyro, &TriadErrors::scale, "1", "scale-factor error s_i (term 'scale')").range(-0.5, 0.5),
      F("gyro_cross_axis", kGyro, &TriadErrors::cross_axis, "1", "cross-axis m_ij, zero diagonal (term 'cross_axis')")
          .range(-0.5, 0.5),
      F("gyro_nonlinear_k2", kGyro, &TriadErrors::nonlinear_k2, "1/(rad/s)", "k2_i·u_i² (term 'nonlinear_k2')")
          .range(-1.0, 1.0),
      F("gyro_nonlinear_k3", kGyro, &TriadErrors::nonlinear_k3, "1/(rad/s)^2", "k3_i·u_i³ (term 'nonlinear_k3')")
          .range(-1.0, 1.0),
      F("gyro_odd_quadratic", kGyro, &TriadErrors::odd_quadratic, "1/(rad/s)", "q_i·u_i·|u_i| (term 'odd_quadratic')")
          .range(-1.0, 1.0),
      F("gyro_bias_tc", kGyro, &TriadErrors::bias_tc, "rad/s/degC^k",
        "bias temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1)"),
      F("gyro_scale_tc", kGyro, &TriadErrors::scale_tc, "1/degC^k",
        "scale temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1)·u_i"),
      F("gyro_thermal_lag", kGyro, &TriadErrors::thermal_lag, "(rad/s)/(degC/s)", "l_i·dT/dt (term 'thermal_lag')"),
      F("gyro_time_drift", kGyro, &TriadErrors::time_drift, "rad/s/s", "r_i·t since start (term 'time_drift')"),
      F("gyro_g_sensitivity", kGyro, &TriadErrors::g_sensitivity, "(rad/s)/(m/s^2)",
        "G_ij: gyro axis i responds to specific force f_j (term 'g_sensitivity')")
          .range(-1.0, 1.0),
      F("temperature_reference_c", &SimImuConfig::temperature_reference_c, "degC", "T0 of the temperature terms")
          .range(-100.0, 200.0),
      // --- noise (stend/model/noise.hpp) ---
      F("accel_noise_density", &SimImuConfig::accel_noise_density, "m/s^2/sqrt(Hz)",
        "white noise, one-sided density (datasheet convention; 400 µg/√Hz); σ = density·√(rate/2) before the "
        "low-pass")
          .range(0.0, 1.0),
      F("accel_bias_instability_mps2", &SimImuConfig::accel_bias_instability_mps2, "m/s^2",
        "bias instability: stationary σ of a first-order Gauss–Markov process (Allan deviation peak ≈ 0.617·σ)")
          .range(0.0, 10.0),
      F("accel_bias_correlation_s", &SimImuConfig::accel_bias_correlation_s, "s",
        "correlation time of the bias instability")
          .range(1e-3, 1e7),
      F("accel_random_walk", &SimImuConfig::accel_random_walk, "m/s^2/sqrt(s)",
        "bias random walk K: Var[b(t) − b(0)] = K²·t (m/s^2.5)")
          .range(0.0, 1.0),
      F("gyro_noise_density", &SimImuConfig::gyro_noise_density, "rad/s/sqrt(Hz)",
        "white noise, one-sided density (0.005 °/s/√Hz)")
          .range(0.0, 0.1),
      F("gyro_bias_instability_radps", &SimImuConfig::gyro_bias_instability_radps, "rad/s",
        "bias instability: stationary σ of a first-order Gauss–Markov process")
          .range(0.0, 1.0),
      F("gyro_bias_correlation_s", &SimImuConfig::gyro_bias_correlation_s, "s",
        "correlation time of the gyro bias instability")
          .range(1e-3, 1e7),
      F("gyro_random_walk", &SimImuConfig::gyro_random_walk, "rad/s/sqrt(s)",
        "gyro bias random walk K: Var[b(t) − b(0)] = K²·t (rad/s^1.5)")
          .range(0.0, 0.1),
      // --- output stage ---
      F("accel_range_g", &SimImuConfig::accel_range_g, "g",
        "full scale ±range (g = standard gravity); beyond it the output saturates and is flagged")
          .range(1e-3, 1000.0),
      F("gyro_range_dps", &SimImuConfig::gyro_range_dps, "deg/s", "full scale ±range").range(1e-3, 1e5),
      F("accel_lsb_mps2", &SimImuConfig::accel_lsb_mps2, "m/s^2",
        "one count; 0 = full scale / 2^(output_bits−1) (16384 LSB/g at ±2 g)")
          .range(0.0, 100.0),
      F("gyro_lsb_radps", &SimImuConfig::gyro_lsb_radps, "rad/s",
        "one count; 0 = full scale / 2^(output_bits−1) (131.072 LSB/(°/s) at ±250 °/s)")
          .range(0.0, 10.0),
      F("output_bits", &SimImuConfig::output_bits, "", "signed output word length").range(2.0, 32.0),
      F("output_rate_hz", &SimImuConfig::output_rate_hz, "Hz", "output data rate").range(1e-3, 1e6),
      F("lowpass_hz", &SimImuConfig::lowpass_hz, "Hz",
        "2nd-order Butterworth low-pass cutoff at the output rate; 0 = off; must be below rate/2")
          .range(0.0, 5e5),
      F("temperature_offset_c", &SimImuConfig::temperature_offset_c, "degC",
        "temperature reading = counts / temperature_counts_per_c + offset")
          .range(-100.0, 200.0),
      F("temperature_counts_per_c", &SimImuConfig::temperature_counts_per_c, "1/degC", "temperature sensitivity")
          .range(1e-6, 1e6),
      F("temperature_noise_c", &SimImuConfig::temperature_noise_c, "degC", "white noise on the temperature reading")
          .range(0.0, 10.0),
      // --- identity and reproducibility ---
      F("seed", &SimImuConfig::seed, "", "noise seed; 0 = chosen by the host from the experiment seed").at_least(0.0),
      F("vendor", &SimImuConfig::vendor, "", "reported vendor"),
      F("model", &SimImuConfig::model, "", "reported model"),
      F("serial", &SimImuConfig::serial, "", "reported serial number"),
      F("who_am_i", &SimImuConfig::who_am_i, "", "reported identity register"),
  });
  return table;
}

SimImu::SimImu(const Params& p) : SimImu(SimImuConfig::from(p)) {}

bool SimImuConfig::IsValid(std::string* error) const {
  if (!(output_rate_hz > 0.0 && std::isfinite(output_rate_hz))) return invalid(error, "output_rate_hz must be > 0");
  if (!(output_bits >= 2 && output_bits <= 32)) return invalid(error, "output_bits must be 2..32");
  if (!(accel_range_g > 0.0 && gyro_range_dps > 0.0)) return invalid(error, "ranges must be > 0");
  if (!(accel_lsb_mps2 >= 0.0 && gyro_lsb_radps >= 0.0)) return invalid(error, "LSBs must be >= 0 (0 = derived)");
  if (!(lowpass_hz >= 0.0 && lowpass_hz < 0.5 * output_rate_hz))
    return invalid(error, "lowpass_hz must be 0 (off) or below half the output rate (" +
                              std::to_string(0.5 * output_rate_hz) + " Hz)");
  if (!(temperature_counts_per_c > 0.0)) return invalid(error, "temperature_counts_per_c must be > 0");
  if (!(seed >= 0)) return invalid(error, "seed must be >= 0");
  for (const auto* e : {&accel, &gyro})
    for (const auto* m : {&e->bias_tc, &e->scale_tc}) {
      if (m->size() != 3) return invalid(error, "temperature coefficient matrices need 3 rows");
      for (const auto& row : *m)
        if (row.size() != (*m)[0].size()) return invalid(error, "temperature coefficient rows differ in length");
    }
  for (const auto& [e, name] : {std::pair{&accel, "accel"}, std::pair{&gyro, "gyro"}})
    for (int i = 0; i < 3; ++i)
      if (e->cross_axis(i, i) != 0.0)
        return invalid(error, std::string(name) + "_cross_axis must have a zero diagonal (the diagonal is " + name +
                                  "_scale); row " + std::to_string(i + 1) + " has " +
                                  std::to_string(e->cross_axis(i, i)));
  return true;
}

SimImu::SimImu(const SimImuConfig& c) : c_(require_valid(c, "sim_imu")) {
  dt_ = 1.0 / c.output_rate_hz;
  seed_ = c.seed == 0 ? kFallbackSeed : static_cast<std::uint64_t>(c.seed);
  accel_model_ = build_model(model::Instrument::kAccelerometer, c.accel, c.temperature_reference_c, accel_theta_);
  gyro_model_ = build_model(model::Instrument::kGyroscope, c.gyro, c.temperature_reference_c, gyro_theta_);

  const model::NoiseSpec an = accel_noise(), gn = gyro_noise();
  for (int i = 0; i < 3; ++i) {
    noise_[static_cast<std::size_t>(i)] = model::NoiseChannel(an, dt_);
    noise_[static_cast<std::size_t>(i + 3)] = model::NoiseChannel(gn, dt_);
  }
  draws_ = 0;
  for (const auto& n : noise_) draws_ += n.draws();
  if (draws_ > static_cast<int>(z_.size())) throw std::logic_error("sim_imu: too many noise processes");
  lowpass_on_ = c.lowpass_hz > 0.0;
  if (lowpass_on_)
    for (auto& f : lowpass_) f = model::Biquad::butterworth_lowpass(c.lowpass_hz, c.output_rate_hz);

  const int bits = static_cast<int>(c.output_bits);
  const double half_words = std::ldexp(1.0, bits - 1);
  const double accel_fs = c.accel_range_g * physics::kStandardGravity;
  const double gyro_fs = c.gyro_range_dps * physics::kDegPerSecond;
  accel_sat_ = model::Saturation(accel_fs);
  gyro_sat_ = model::Saturation(gyro_fs);
  accel_q_ = model::Quantizer(c.accel_lsb_mps2 > 0.0 ? c.accel_lsb_mps2 : accel_fs / half_words, bits);
  gyro_q_ = model::Quantizer(c.gyro_lsb_radps > 0.0 ? c.gyro_lsb_radps : gyro_fs / half_words, bits);
  temp_q_ = model::Quantizer(1.0 / c.temperature_counts_per_c, 16);
  start(0.0);
}

model::NoiseSpec SimImu::accel_noise() const {
  model::NoiseSpec s;
  s.white_density = c_.accel_noise_density;
  if (c_.accel_bias_instability_mps2 > 0.0)
    s.bias_instability.push_back({c_.accel_bias_instability_mps2, c_.accel_bias_correlation_s});
  s.random_walk = c_.accel_random_walk;
  return s;
}

model::NoiseSpec SimImu::gyro_noise() const {
  model::NoiseSpec s;
  s.white_density = c_.gyro_noise_density;
  if (c_.gyro_bias_instability_radps > 0.0)
    s.bias_instability.push_back({c_.gyro_bias_instability_radps, c_.gyro_bias_correlation_s});
  s.random_walk = c_.gyro_random_walk;
  return s;
}

SensorIdentity SimImu::identity() const { return {c_.vendor, c_.model, c_.serial, c_.who_am_i}; }

SensorInfo SimImu::info() const {
  SensorInfo i;
  i.output_rate_hz = c_.output_rate_hz;
  i.accel_range_mps2 = accel_sat_.full_scale();
  i.gyro_range_radps = gyro_sat_.full_scale();
  i.accel_lsb_mps2 = accel_q_.lsb();
  i.gyro_lsb_radps = gyro_q_.lsb();
  i.temperature_lsb_c = temp_q_.lsb();
  i.has_gyro = true;
  i.has_temperature = true;
  return i;
}

void SimImu::start(double t0_s) {
  t0_ = t0_s;
  next_k_ = 1;
  first_ = true;
  rng_.reseed(seed_);
  for (auto& n : noise_) n.reset(rng_);
}

void SimImu::acquire(double t_s, const TruthSource& truth, std::vector<ImuSample>& out) {
  // Sample k is due at t0 + k·dt; a sample exactly at t_s (within 1 ns) belongs to this call.
  const double last = std::floor((t_s - t0_ + 1e-9) * c_.output_rate_hz);
  if (last < static_cast<double>(next_k_)) return;
  const auto k_end = static_cast<std::int64_t>(last);
  const std::size_t need = out.size() + static_cast<std::size_t>(k_end - next_k_ + 1);
  if (out.capacity() < need) out.reserve(std::max(need, 2 * out.capacity()));  // keep growth geometric
  for (; next_k_ <= k_end; ++next_k_) {
    const double t = t0_ + static_cast<double>(next_k_) / c_.output_rate_hz;
    out.emplace_back();
    sample(t, truth.at(t), out.back());
  }
}

void SimImu::sample(double t, const BenchTruth& truth, ImuSample& s) {
  s.t_s = t;
  const double die = truth.die_temperature_c;
  const double rate = first_ ? 0.0 : (die - prev_die_c_) / dt_;
  prev_die_c_ = die;

  model::Stimulus<double> st;
  st.input = truth.specific_force_mps2;
  st.specific_force = truth.specific_force_mps2;
  st.temperature_c = die;
  st.temperature_rate_cps = rate;
  st.time_s = t - t0_;
  const Eigen::Vector3d ya = accel_model_.measure<double>(accel_theta_.data(), st);
  st.input = truth.angular_rate_radps;
  const Eigen::Vector3d yg = gyro_model_.measure<double>(gyro_theta_.data(), st);

  double y[6] = {ya[0], ya[1], ya[2], yg[0], yg[1], yg[2]};
  if (draws_ > 0) {
    rng_.fill_normal(z_.data(), draws_);
    const double* z = z_.data();
    for (std::size_t i = 0; i < 6; ++i) y[i] += noise_[i].step(z);
  }
  if (lowpass_on_) {
    if (first_)
      for (std::size_t i = 0; i < 6; ++i) lowpass_[i].reset(y[i]);
    for (std::size_t i = 0; i < 6; ++i) y[i] = lowpass_[i](y[i]);
  }
  first_ = false;

  bool accel_sat = false, gyro_sat = false;
  for (int i = 0; i < 3; ++i) {
    const auto a = static_cast<std::size_t>(i), g = static_cast<std::size_t>(i + 3);
    const std::int32_t ca = accel_q_.counts(accel_sat_.apply(y[a], accel_sat), &accel_sat);
    const std::int32_t cg = gyro_q_.counts(gyro_sat_.apply(y[g], gyro_sat), &gyro_sat);
    s.accel_counts[i] = ca;
    s.gyro_counts[i] = cg;
    s.accel_mps2[i] = accel_q_.value(ca);
    s.gyro_radps[i] = gyro_q_.value(cg);
  }
  double temp = die - c_.temperature_offset_c;
  if (c_.temperature_noise_c > 0.0) temp += c_.temperature_noise_c * rng_.normal();
  s.temperature_counts = temp_q_.counts(temp);
  s.temperature_c = temp_q_.value(s.temperature_counts) + c_.temperature_offset_c;
  s.flags = (accel_sat ? kAccelSaturated : 0u) | (gyro_sat ? kGyroSaturated : 0u);
}

}  // namespace stend::sim
