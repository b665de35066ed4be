#include <stend/sim/three_axis_table.hpp>

#include <stend/physics/kinematics.hpp>
#include <stend/physics/table_chain.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace stend::sim {

namespace {
constexpr std::uint64_t kFallbackSeed = 0x3A7AB1EULL;
const char* const kNames[3] = {"azimuth", "tilt", "rotation"};
}  // namespace

const fields::Table<ThreeAxisTableConfig>& ThreeAxisTableConfig::fields() {
  using F = stend::fields::Field<ThreeAxisTableConfig>;
  static const stend::fields::Table<ThreeAxisTableConfig> table("sim_three_axis_table", {
      F("min_deg", &ThreeAxisTableConfig::min_deg, "deg", "lowest position command per axis [azimuth, tilt, rotation]")
          .range(-3600.0, 3600.0),
      F("max_deg", &ThreeAxisTableConfig::max_deg, "deg",
        "highest position command per axis; a travel of a full turn or more makes that axis continuous in rate mode")
          .range(-3600.0, 3600.0),
      F("max_rate_dps", &ThreeAxisTableConfig::max_rate_dps, "deg/s", "speed limit per axis").range(1e-6, 1e5),
      F("max_accel_dps2", &ThreeAxisTableConfig::max_accel_dps2, "deg/s^2", "acceleration limit per axis").range(1e-6, 1e6),
      F("initial_deg", &ThreeAxisTableConfig::initial_deg, "deg", "angles at power-on").range(-3600.0, 3600.0),
      F("angle_offset_deg", &ThreeAxisTableConfig::angle_offset_deg, "deg",
        "unmodelled encoder zero errors: true angle = encoder angle + offset")
          .range(-360.0, 360.0),
      F("lever_arm_m", &ThreeAxisTableConfig::lever_arm_m, "m", "mounting point from the axes' intersection, top frame")
          .range(-10.0, 10.0),
      F("settle_tolerance_deg", &ThreeAxisTableConfig::settle_tolerance_deg, "deg",
        "position mode: settled when |measured − commanded| stays within this on every axis")
          .range(1e-9, 10.0),
      F("settle_rate_tolerance_dps", &ThreeAxisTableConfig::settle_rate_tolerance_dps, "deg/s",
        "settled only when each rate is within this of its commanded rate (0 in position mode)")
          .range(1e-9, 100.0),
      F("settle_time_s", &ThreeAxisTableConfig::settle_time_s, "s", "how long the settle condition must hold").range(0.0, 3600.0),
      F("encoder_resolution_deg", &ThreeAxisTableConfig::encoder_resolution_deg, "deg", "reading quantum; 0 = none").range(0.0, 1.0),
      F("encoder_noise_deg", &ThreeAxisTableConfig::encoder_noise_deg, "deg", "standard deviation of the reading noise")
          .range(0.0, 1.0),
      F("seed", &ThreeAxisTableConfig::seed, "", "encoder-noise seed; 0 = chosen by the host").at_least(0.0),
  });
  return table;
}

SimThreeAxisTable::SimThreeAxisTable(const Params& p) : SimThreeAxisTable(ThreeAxisTableConfig::from(p)) {}

AxisConfig ThreeAxisTableConfig::axis(int i) const {
  AxisConfig a;
  a.name = kNames[i];
  a.unit = "deg";
  a.min = min_deg[i];
  a.max = max_deg[i];
  a.max_rate = max_rate_dps[i];
  a.max_accel = max_accel_dps2[i];
  a.initial = initial_deg[i];
  a.settle_tolerance = settle_tolerance_deg;
  a.settle_rate_tolerance = settle_rate_tolerance_dps;
  a.settle_time_s = settle_time_s;
  a.encoder_resolution = encoder_resolution_deg;
  a.encoder_noise = encoder_noise_deg;
  return a;
}

bool ThreeAxisTableConfig::IsValid(std::string* error) const {
  for (int i = 0; i < 3; ++i) {
    const AxisConfig a = axis(i);
    std::string why;
    if (!a.IsValid(&why)) return invalid(error, "axis '" + a.name + "': " + why);
  }
  return true;
}

SimThreeAxisTable::SimThreeAxisTable(const ThreeAxisTableConfig& c) : c_(require_valid(c, "sim_three_axis_table")) {
  const std::uint64_t seed = c.seed == 0 ? kFallbackSeed : static_cast<std::uint64_t>(c.seed);
  for (int i = 0; i < 3; ++i) axes_[static_cast<std::size_t>(i)] = SimAxis(c.axis(i), seed + static_cast<std::uint64_t>(i));
}

std::vector<AxisSpec> SimThreeAxisTable::axes() const {
  return {axes_[0].spec(), axes_[1].spec(), axes_[2].spec()};
}

const SimAxis& SimThreeAxisTable::checked(std::size_t axis) const {
  if (axis >= 3)
    throw std::invalid_argument("sim_three_axis_table: no axis " + std::to_string(axis) +
                                " (axes: 0 azimuth, 1 tilt, 2 rotation)");
  return axes_[axis];
}

void SimThreeAxisTable::command(std::size_t axis, CommandMode mode, double value) {
  checked(axis);
  axes_[axis].command(mode, value, now_);
}

void SimThreeAxisTable::advance(double t_s) {
  if (!started_) {
    started_ = true;
    for (auto& a : axes_) a.start_at(t_s);
  } else if (t_s < now_) {
    return;
  }
  now_ = t_s;
  for (auto& a : axes_) a.advance(t_s);
}

double SimThreeAxisTable::measured(std::size_t axis) const { return checked(axis).measured(); }
double SimThreeAxisTable::commanded(std::size_t axis) const { return checked(axis).commanded(); }

bool SimThreeAxisTable::settled() const {
  return axes_[0].settled() && axes_[1].settled() && axes_[2].settled();
}

Pose SimThreeAxisTable::pose(double t_s) const {
  const AxisState az = axes_[kAzimuth].at(t_s), h = axes_[kTilt].at(t_s), d = axes_[kRotation].at(t_s);
  const Eigen::Vector3d q_deg = Eigen::Vector3d(az.position, h.position, d.position) + c_.angle_offset_deg;
  const physics::TableMotion<double> m = physics::three_axis_table_motion<double>(
      q_deg * physics::kDegToRad, Eigen::Vector3d(az.velocity, h.velocity, d.velocity) * physics::kDegToRad,
      Eigen::Vector3d(az.acceleration, h.acceleration, d.acceleration) * physics::kDegToRad);
  Pose p;
  p.R_top_from_base = m.R_top_from_base;
  p.omega_top_radps = m.omega_top_radps;
  p.accel_top_mps2 = physics::point_acceleration<double>(m.omega_top_radps, m.alpha_top_radps2, c_.lever_arm_m);
  return p;
}

void SimThreeAxisTable::telemetry(std::vector<std::pair<std::string, double>>& out) const {
  for (std::size_t i = 0; i < 3; ++i) {
    const AxisState s = axes_[i].at(now_);
    const double truth = axes_[i].continuous() ? axes_[i].wrap(s.position) : s.position;
    out.emplace_back(std::string(kNames[i]) + "_true_deg", truth + c_.angle_offset_deg[static_cast<int>(i)]);
  }
}

std::string SimThreeAxisTable::safe_state() noexcept {
  for (auto& a : axes_) a.safe_state(now_);
  return "";
}

}  // namespace stend::sim
