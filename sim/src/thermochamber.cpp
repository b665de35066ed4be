#include <stend/sim/thermochamber.hpp>


#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace stend::sim {

namespace {
constexpr std::uint64_t kFallbackSeed = 0xC4A3BE5ULL;
constexpr double kRangeMargin_c = 0.5;  // setpoints must lie this far inside what the plant can hold

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}
}  // namespace

const fields::Table<ThermochamberConfig>& ThermochamberConfig::fields() {
  using F = stend::fields::Field<ThermochamberConfig>;
  static const stend::fields::Table<ThermochamberConfig> table("sim_thermochamber", {
      F("control_period_s", &ThermochamberConfig::control_period_s, "s",
        "controller cycle (≈ one DS18B20 12-bit conversion, 750 ms, plus the loop)")
          .range(0.01, 60.0),
      F("ambient_c", &ThermochamberConfig::ambient_c, "degC", "room temperature around the chamber").range(-40.0, 60.0),
      F("initial_c", &ThermochamberConfig::initial_c, "degC",
        "air temperature at power-on (the die starts self_heating_c above it); default = the default ambient")
          .range(-40.0, 100.0),
      F("heat_capacity_j_per_c", &ThermochamberConfig::heat_capacity_j_per_c, "J/degC",
        "heat capacity of the air node (air, walls, module)")
          .range(1e-3, 1e7),
      F("conductance_w_per_c", &ThermochamberConfig::conductance_w_per_c, "W/degC", "thermal conductance to ambient")
          .range(1e-6, 1e4),
      F("internal_load_w", &ThermochamberConfig::internal_load_w, "W",
        "constant heat released inside (fan, electronics, Peltier hot-side back-leak)")
          .range(0.0, 1e4),
      F("heater_power_w", &ThermochamberConfig::heater_power_w, "W",
        "heater power at PWM 255 (the published loop never exceeds PWM 15 = 255/16)")
          .range(0.0, 1e5),
      F("peltier_cooling_w", &ThermochamberConfig::peltier_cooling_w, "W", "net heat the Peltier removes from the air at PWM 255")
          .range(0.0, 1e5),
      F("die_lag_s", &ThermochamberConfig::die_lag_s, "s", "first-order time constant of the module/die temperature behind the air")
          .range(0.0, 1e5),
      F("self_heating_c", &ThermochamberConfig::self_heating_c, "degC", "die above air at equilibrium").range(-10.0, 50.0),
      F("sensor_noise_c", &ThermochamberConfig::sensor_noise_c, "degC",
        "noise of the DS18B20 reading before its 1/16 degC quantization")
          .range(0.0, 5.0),
      F("min_c", &ThermochamberConfig::min_c, "degC", "lowest setpoint accepted (further narrowed to what the plant can hold)")
          .range(-100.0, 200.0),
      F("max_c", &ThermochamberConfig::max_c, "degC", "highest setpoint accepted (further narrowed to what the plant can hold)")
          .range(-100.0, 200.0),
      F("settle_tolerance_c", &ThermochamberConfig::settle_tolerance_c, "degC", "settled when |reading − setpoint| stays within this …")
          .range(1e-3, 50.0),
      F("settle_time_s", &ThermochamberConfig::settle_time_s, "s", "… for this long").range(0.0, 1e5),
      F("max_step_s", &ThermochamberConfig::max_step_s, "s",
        "largest plant step inside advance() (thermal() interpolates between the exact states)")
          .range(1e-3, 0.1),
      F("seed", &ThermochamberConfig::seed, "", "sensor-noise seed; 0 = chosen by the host").at_least(0.0),
  });
  return table;
}

SimThermochamber::SimThermochamber(const Params& p) : SimThermochamber(ThermochamberConfig::from(p)) {}

double ThermochamberConfig::coldest_c() const { return plant_equilibrium_c(*this, 0, 255); }
double ThermochamberConfig::hottest_c() const { return plant_equilibrium_c(*this, 15, 0); }
double ThermochamberConfig::lowest_setpoint_c() const { return std::max(min_c, coldest_c() + kRangeMargin_c); }
double ThermochamberConfig::highest_setpoint_c() const { return std::min(max_c, hottest_c() - kRangeMargin_c); }

bool ThermochamberConfig::IsValid(std::string* error) const {
  if (!(control_period_s > 0.0)) return invalid(error, "control_period_s must be > 0");
  if (!(heat_capacity_j_per_c > 0.0 && conductance_w_per_c > 0.0))
    return invalid(error, "heat_capacity_j_per_c and conductance_w_per_c must be > 0");
  if (!(heater_power_w >= 0.0 && peltier_cooling_w >= 0.0 && internal_load_w >= 0.0))
    return invalid(error, "heater, Peltier and internal powers must be >= 0");
  if (!(die_lag_s >= 0.0)) return invalid(error, "die_lag_s must be >= 0");
  if (!(sensor_noise_c >= 0.0)) return invalid(error, "sensor_noise_c must be >= 0");
  if (!(min_c < max_c)) return invalid(error, "min_c must be < max_c");
  if (!(settle_tolerance_c > 0.0 && settle_time_s >= 0.0)) return invalid(error, "settle tolerance must be > 0, time >= 0");
  if (!(max_step_s > 0.0 && max_step_s <= 0.1)) return invalid(error, "max_step_s must be in (0, 0.1] s");
  if (!(lowest_setpoint_c() < highest_setpoint_c()))
    return invalid(error, "the plant cannot hold any setpoint within [min_c, max_c]: it holds " + fmt(coldest_c()) +
                              " … " + fmt(hottest_c()) +
                              " degC (change peltier_cooling_w, heater_power_w, internal_load_w or ambient_c)");
  return true;
}

SimThermochamber::SimThermochamber(const ThermochamberConfig& c)
    : c_(require_valid(c, "sim_thermochamber")), rng_(c.seed == 0 ? kFallbackSeed : static_cast<std::uint64_t>(c.seed)) {
  air_ = c.initial_c;
  die_ = c.initial_c + c.self_heating_c;
  measured_ = std::round(air_ * 16.0) / 16.0;
  knots_.reserve(64);
  knots_.push_back({0.0, air_, die_});
}

double SimThermochamber::equilibrium_c(int heater_pwm, int peltier_pwm) const {
  return plant_equilibrium_c(c_, heater_pwm, peltier_pwm);
}

std::vector<AxisSpec> SimThermochamber::axes() const {
  AxisSpec a;
  a.name = "temperature";
  a.unit = "degC";
  // The configured limits, narrowed to what this plant can actually hold.
  a.min = c_.lowest_setpoint_c();
  a.max = c_.highest_setpoint_c();
  a.supports_rate = false;
  return {a};
}

void SimThermochamber::command(std::size_t axis, CommandMode mode, double value) {
  if (axis != 0)
    throw std::invalid_argument("sim_thermochamber: no axis " + std::to_string(axis) +
                                " (it has one axis, 'temperature')");
  if (mode == CommandMode::kRate)
    throw std::invalid_argument("sim_thermochamber: the temperature axis takes setpoints, not rates");
  const AxisSpec a = axes()[0];
  if (!(value >= a.min && value <= a.max)) {
    std::string why = "sim_thermochamber: setpoint " + fmt(value) + " degC outside " + fmt(a.min) + " … " +
                      fmt(a.max) + " degC";
    if (value < c_.min_c || value > c_.max_c)
      why += " (min_c/max_c)";
    else
      why += " (the plant holds " + fmt(coldest_c()) + " … " + fmt(hottest_c()) + " degC at ambient " +
             fmt(c_.ambient_c) + " degC; raise peltier_cooling_w or heater_power_w)";
    throw std::invalid_argument(why);
  }
  if (!active_) {  // the controller starts from a fresh state
    integral_ = 0.0;
    err_prev_ = 0.0;
  }
  active_ = true;
  setpoint_ = value;
  in_band_ = false;
}

double SimThermochamber::read_sensor() {
  double t = air_;
  if (c_.sensor_noise_c > 0.0) t += c_.sensor_noise_c * rng_.normal();
  // DS18B20 12-bit: a signed count of 1/16 °C, −55 … +125 °C.
  const double raw = std::clamp(std::round(t * 16.0), -55.0 * 16.0, 125.0 * 16.0);
  return raw / 16.0;
}

void SimThermochamber::control(double t) {
  measured_ = read_sensor();
  if (!active_) {
    heater_pwm_ = peltier_pwm_ = 0;
    return;
  }
  // The published loop.
  const double err = measured_ - setpoint_;
  integral_ = std::clamp(integral_ + 0.05 * err, -20.0, 20.0);
  double u = 100.0 * err + 24.0 * integral_ - 20.0 * (err - err_prev_);
  err_prev_ = err;
  u = std::clamp(u, -255.0, 255.0);
  if (u > 0.0) {
    peltier_pwm_ = static_cast<int>(std::min(u + 20.0, 255.0));
    heater_pwm_ = 0;
  } else {
    peltier_pwm_ = 0;
    heater_pwm_ = static_cast<int>(-u / 16.0);
  }
  const bool in = std::abs(measured_ - setpoint_) <= c_.settle_tolerance_c;
  if (in && !in_band_) in_band_since_ = t;
  in_band_ = in;
}

void SimThermochamber::integrate(double dt) { plant_step(c_, heater_pwm_, peltier_pwm_, dt, air_, die_); }

void SimThermochamber::advance(double t_s) {
  if (!started_) {
    started_ = true;
    now_ = t_s;
    next_control_ = t_s;
    knots_.assign(1, {t_s, air_, die_});
  } else {
    if (!(t_s > now_)) return;
    knots_.clear();
    knots_.push_back({now_, air_, die_});
  }
  for (;;) {
    if (now_ >= next_control_ - 1e-9) {
      control(now_);
      next_control_ += c_.control_period_s;
    }
    if (now_ >= t_s) break;
    const double end = std::min({t_s, next_control_, now_ + c_.max_step_s});
    integrate(end - now_);
    now_ = end;
    knots_.push_back({now_, air_, die_});
  }
}

bool SimThermochamber::thermal(double t_s, double& air_c, double& die_c) const {
  const Knot& first = knots_.front();
  const Knot& last = knots_.back();
  if (t_s <= first.t) {
    air_c = first.air;
    die_c = first.die;
    return true;
  }
  if (t_s >= last.t) {
    air_c = last.air;
    die_c = last.die;
    return true;
  }
  const auto it = std::upper_bound(knots_.begin(), knots_.end(), t_s,
                                   [](double t, const Knot& k) { return t < k.t; });
  const Knot& b = *it;
  const Knot& a = *(it - 1);
  const double w = (t_s - a.t) / (b.t - a.t);
  air_c = a.air + w * (b.air - a.air);
  die_c = a.die + w * (b.die - a.die);
  return true;
}

double SimThermochamber::measured(std::size_t axis) const {
  if (axis != 0) throw std::invalid_argument("sim_thermochamber: no axis " + std::to_string(axis));
  return measured_;
}

double SimThermochamber::commanded(std::size_t axis) const {
  if (axis != 0) throw std::invalid_argument("sim_thermochamber: no axis " + std::to_string(axis));
  return active_ ? setpoint_ : std::numeric_limits<double>::quiet_NaN();
}

bool SimThermochamber::settled() const {
  return active_ && in_band_ && now_ - in_band_since_ >= c_.settle_time_s - 1e-9;
}

void SimThermochamber::telemetry(std::vector<std::pair<std::string, double>>& out) const {
  out.emplace_back("air_measured_c", measured_);
  out.emplace_back("heater_pwm", heater_pwm_);
  out.emplace_back("peltier_pwm", peltier_pwm_);
  out.emplace_back("pid_integral", integral_);
}

std::string SimThermochamber::safe_state() noexcept {
  active_ = false;
  heater_pwm_ = peltier_pwm_ = 0;
  in_band_ = false;
  return "";
}

}  // namespace stend::sim
