#include <stend/sim/imu.hpp>

#include <stend/sim/param_reader.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace stend::sim {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("sim_imu: " + what);
}

TriadErrors read_triad(ParamReader& r, const std::string& p, const std::string& bias_key, bool gyro) {
  TriadErrors e;
  e.bias = r.vec3(bias_key, e.bias);
  e.scale = r.vec3(p + "_scale", e.scale);
  e.cross_axis = r.mat3(p + "_cross_axis", e.cross_axis);
  e.nonlinear_k2 = r.vec3(p + "_nonlinear_k2", e.nonlinear_k2);
  e.nonlinear_k3 = r.vec3(p + "_nonlinear_k3", e.nonlinear_k3);
  e.odd_quadratic = r.vec3(p + "_odd_quadratic", e.odd_quadratic);
  e.bias_tc = r.matrix(p + "_bias_tc", e.bias_tc);
  e.scale_tc = r.matrix(p + "_scale_tc", e.scale_tc);
  e.thermal_lag = r.vec3(p + "_thermal_lag", e.thermal_lag);
  e.time_drift = r.vec3(p + "_time_drift", e.time_drift);
  if (gyro) e.g_sensitivity = r.mat3(p + "_g_sensitivity", e.g_sensitivity);
  for (int i = 0; i < 3; ++i)
    require(e.cross_axis(i, i) == 0.0, p + "_cross_axis must have a zero diagonal (the diagonal is " + p +
                                           "_scale); row " + std::to_string(i + 1) + " has " +
                                           std::to_string(e.cross_axis(i, i)));
  return e;
}

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

}  // namespace

SimImuConfig SimImuConfig::from(const Params& p) {
  SimImuConfig c;
  ParamReader r(p, "sim_imu");
  c.accel = read_triad(r, "accel", "accel_bias_mps2", false);
  c.gyro = read_triad(r, "gyro", "gyro_bias_radps", true);
  c.temperature_reference_c = r.number("temperature_reference_c", c.temperature_reference_c);
  c.accel_noise_density = r.number("accel_noise_density", c.accel_noise_density);
  c.accel_bias_instability_mps2 = r.number("accel_bias_instability_mps2", c.accel_bias_instability_mps2);
  c.accel_bias_correlation_s = r.number("accel_bias_correlation_s", c.accel_bias_correlation_s);
  c.accel_random_walk = r.number("accel_random_walk", c.accel_random_walk);
  c.gyro_noise_density = r.number("gyro_noise_density", c.gyro_noise_density);
  c.gyro_bias_instability_radps = r.number("gyro_bias_instability_radps", c.gyro_bias_instability_radps);
  c.gyro_bias_correlation_s = r.number("gyro_bias_correlation_s", c.gyro_bias_correlation_s);
  c.gyro_random_walk = r.number("gyro_random_walk", c.gyro_random_walk);
  c.accel_range_g = r.number("accel_range_g", c.accel_range_g);
  c.gyro_range_dps = r.number("gyro_range_dps", c.gyro_range_dps);
  c.accel_lsb_mps2 = r.number("accel_lsb_mps2", c.accel_lsb_mps2);
  c.gyro_lsb_radps = r.number("gyro_lsb_radps", c.gyro_lsb_radps);
  c.output_bits = r.integer("output_bits", c.output_bits);
  c.output_rate_hz = r.number("output_rate_hz", c.output_rate_hz);
  c.lowpass_hz = r.number("lowpass_hz", c.lowpass_hz);
  c.temperature_offset_c = r.number("temperature_offset_c", c.temperature_offset_c);
  c.temperature_counts_per_c = r.number("temperature_counts_per_c", c.temperature_counts_per_c);
  c.temperature_noise_c = r.number("temperature_noise_c", c.temperature_noise_c);
  c.seed = r.integer("seed", c.seed);
  c.vendor = r.string("vendor", c.vendor);
  c.model = r.string("model", c.model);
  c.serial = r.string("serial", c.serial);
  c.who_am_i = r.string("who_am_i", c.who_am_i);
  r.finish();
  return c;
}

SimImu::SimImu(const Params& p) : SimImu(SimImuConfig::from(p)) {}

SimImu::SimImu(const SimImuConfig& c) : c_(c) {
  require(c.output_rate_hz > 0.0 && std::isfinite(c.output_rate_hz), "output_rate_hz must be > 0");
  require(c.output_bits >= 2 && c.output_bits <= 32, "output_bits must be 2..32");
  require(c.accel_range_g > 0.0 && c.gyro_range_dps > 0.0, "ranges must be > 0");
  require(c.accel_lsb_mps2 >= 0.0 && c.gyro_lsb_radps >= 0.0, "LSBs must be >= 0 (0 = derived)");
  require(c.lowpass_hz >= 0.0 && c.lowpass_hz < 0.5 * c.output_rate_hz,
          "lowpass_hz must be 0 (off) or below half the output rate (" + std::to_string(0.5 * c.output_rate_hz) +
              " Hz)");
  require(c.temperature_counts_per_c > 0.0, "temperature_counts_per_c must be > 0");
  require(c.seed >= 0, "seed must be >= 0");
  for (const auto* e : {&c.accel, &c.gyro})
    for (const auto* m : {&e->bias_tc, &e->scale_tc}) {
      require(m->size() == 3, "temperature coefficient matrices need 3 rows");
      for (const auto& row : *m) require(row.size() == (*m)[0].size(), "temperature coefficient rows differ in length");
    }

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
