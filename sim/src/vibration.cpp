#include <stend/sim/vibration.hpp>

#include <stend/physics/units.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace stend::sim {

namespace {
std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}
}  // namespace

const fields::Table<VibrationConfig>& VibrationConfig::fields() {
  using F = stend::fields::Field<VibrationConfig>;
  static const stend::fields::Table<VibrationConfig> table("sim_vibration", {
      F("direction", &VibrationConfig::direction, "1",
        "direction of the vibration in the shaker's top frame (normalized; must not be zero)")
          .range(-1e6, 1e6),
      F("max_amplitude_g", &VibrationConfig::max_amplitude_g, "g",
        "largest peak amplitude accepted (the paper: 0.5 g), g = standard gravity")
          .range(1e-6, 100.0),
      F("min_frequency_hz", &VibrationConfig::min_frequency_hz, "Hz", "lowest frequency accepted (the paper: 20 Hz)")
          .range(1e-3, 1e5),
      F("max_frequency_hz", &VibrationConfig::max_frequency_hz, "Hz", "highest frequency accepted (the paper: 800 Hz)")
          .range(1e-3, 1e5),
      F("initial_frequency_hz", &VibrationConfig::initial_frequency_hz, "Hz",
        "frequency before the first command (amplitude starts at 0)")
          .range(1e-3, 1e5),
  });
  return table;
}

SimVibration::SimVibration(const Params& p) : SimVibration(VibrationConfig::from(p)) {}

bool VibrationConfig::IsValid(std::string* error) const {
  if (!(direction.allFinite() && direction.norm() > 1e-12)) return invalid(error, "direction must be a non-zero vector");
  if (!(max_amplitude_g > 0.0)) return invalid(error, "max_amplitude_g must be > 0");
  if (!(min_frequency_hz > 0.0 && min_frequency_hz < max_frequency_hz))
    return invalid(error, "need 0 < min_frequency_hz < max_frequency_hz");
  if (!(initial_frequency_hz >= min_frequency_hz && initial_frequency_hz <= max_frequency_hz))
    return invalid(error, "initial_frequency_hz outside [min_frequency_hz, max_frequency_hz]");
  return true;
}

SimVibration::SimVibration(const VibrationConfig& c) : c_(require_valid(c, "sim_vibration")) {
  dir_ = c.direction.normalized();
  cur_.frequency_hz = c.initial_frequency_hz;
  prev_ = cur_;
}

std::vector<AxisSpec> SimVibration::axes() const {
  AxisSpec a;
  a.name = "amplitude";
  a.unit = "g";
  a.min = 0.0;
  a.max = c_.max_amplitude_g;
  AxisSpec f;
  f.name = "frequency";
  f.unit = "Hz";
  f.min = c_.min_frequency_hz;
  f.max = c_.max_frequency_hz;
  return {a, f};
}

double SimVibration::phase(double t_s) const {
  const Segment& s = segment_at(t_s);
  return s.phase0 + 2.0 * std::numbers::pi * s.frequency_hz * (t_s - s.t0);
}

void SimVibration::install(const Segment& s) {
  if (cur_.t0 < s.t0) prev_ = cur_;  // keep the history for times before the command
  cur_ = s;
}

void SimVibration::command(std::size_t axis, CommandMode mode, double value) {
  if (axis > kFrequency)
    throw std::invalid_argument("sim_vibration: no axis " + std::to_string(axis) + " (0 amplitude, 1 frequency)");
  if (mode == CommandMode::kRate)
    throw std::invalid_argument("sim_vibration: amplitude and frequency take values, not rates");
  const AxisSpec a = axes()[axis];
  if (!(value >= a.min && value <= a.max))
    throw std::invalid_argument("sim_vibration: " + a.name + " " + num(value) + " " + a.unit + " outside [" +
                                num(a.min) + ", " + num(a.max) + "] " + a.unit);
  Segment s = cur_;
  s.phase0 = std::fmod(phase(now_), 2.0 * std::numbers::pi);
  s.t0 = now_;
  if (axis == kAmplitude)
    s.amplitude_g = value;
  else
    s.frequency_hz = value;
  install(s);
}

void SimVibration::advance(double t_s) {
  if (!started_) {  // commands before the first advance take effect there
    started_ = true;
    cur_.t0 = prev_.t0 = t_s;
  } else if (t_s < now_) {
    return;
  }
  now_ = t_s;
}

double SimVibration::measured(std::size_t axis) const { return commanded(axis); }

double SimVibration::commanded(std::size_t axis) const {
  if (axis > kFrequency) throw std::invalid_argument("sim_vibration: no axis " + std::to_string(axis));
  return axis == kAmplitude ? cur_.amplitude_g : cur_.frequency_hz;
}

Pose SimVibration::pose(double t_s) const {
  const Segment& s = segment_at(t_s);
  Pose p;
  if (s.amplitude_g != 0.0) {
    const double ph = s.phase0 + 2.0 * std::numbers::pi * s.frequency_hz * (t_s - s.t0);
    p.accel_top_mps2 = (s.amplitude_g * physics::kStandardGravity * std::sin(ph)) * dir_;
  }
  return p;
}

std::string SimVibration::safe_state() noexcept {
  Segment s = cur_;
  s.phase0 = std::fmod(phase(now_), 2.0 * std::numbers::pi);
  s.t0 = now_;
  s.amplitude_g = 0.0;
  install(s);
  return "";
}

}  // namespace stend::sim
