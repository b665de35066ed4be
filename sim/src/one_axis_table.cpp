#include <stend/sim/one_axis_table.hpp>

#include <stend/physics/kinematics.hpp>
#include <stend/physics/rotations.hpp>

#include <cmath>
#include <bit>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace stend::sim {

namespace {
using physics::kDegToRad;
constexpr std::uint64_t kFallbackSeed = 0x7AB1EULL;
}  // namespace

const fields::Table<OneAxisTableConfig>& OneAxisTableConfig::fields() {
  using F = stend::fields::Field<OneAxisTableConfig>;
  static const stend::fields::Table<OneAxisTableConfig> table("sim_one_axis_table", {
      F("axis_tilt_deg", &OneAxisTableConfig::axis_tilt_deg, "deg",
        "tilt h of the rotation axis, set beforehand (the paper's h): R = Ry(δ)·Rx(h)")
          .range(-90.0, 90.0),
      F("min_deg", &OneAxisTableConfig::min_deg, "deg", "lowest position command").range(-3600.0, 3600.0),
      F("max_deg", &OneAxisTableConfig::max_deg, "deg",
        "highest position command; a travel of a full turn or more makes the axis continuous in rate mode")
          .range(-3600.0, 3600.0),
      F("max_rate_dps", &OneAxisTableConfig::max_rate_dps, "deg/s", "speed limit (rate commands beyond it are refused)")
          .range(1e-6, 1e5),
      F("max_accel_dps2", &OneAxisTableConfig::max_accel_dps2, "deg/s^2", "acceleration limit").range(1e-6, 1e6),
      F("initial_deg", &OneAxisTableConfig::initial_deg, "deg", "angle at power-on").range(-3600.0, 3600.0),
      F("lever_arm_m", &OneAxisTableConfig::lever_arm_m, "m",
        "mounting point from the rotation axis, top frame (centripetal and tangential acceleration)")
          .range(-10.0, 10.0),
      F("settle_tolerance_deg", &OneAxisTableConfig::settle_tolerance_deg, "deg",
        "position mode: settled when |measured − commanded| stays within this")
          .range(1e-9, 10.0),
      F("settle_rate_tolerance_dps", &OneAxisTableConfig::settle_rate_tolerance_dps, "deg/s",
        "settled only when the rate is within this of the commanded rate (0 in position mode)")
          .range(1e-9, 100.0),
      F("settle_time_s", &OneAxisTableConfig::settle_time_s, "s", "how long the settle condition must hold").range(0.0, 3600.0),
      F("encoder_resolution_deg", &OneAxisTableConfig::encoder_resolution_deg, "deg", "reading quantum; 0 = none").range(0.0, 1.0),
      F("encoder_noise_deg", &OneAxisTableConfig::encoder_noise_deg, "deg", "standard deviation of the reading noise")
          .range(0.0, 1.0),
      F("angle_offset_deg", &OneAxisTableConfig::angle_offset_deg, "deg",
        "unmodelled encoder zero error: true angle = encoder angle + offset")
          .range(-360.0, 360.0),
      F("axis_misalignment_x_deg", &OneAxisTableConfig::axis_misalignment_x_deg, "deg",
        "unmodelled tilt of the rotation axis about the tilted frame's x axis")
          .range(-10.0, 10.0),
      F("axis_misalignment_z_deg", &OneAxisTableConfig::axis_misalignment_z_deg, "deg",
        "unmodelled tilt of the rotation axis about the tilted frame's z axis")
          .range(-10.0, 10.0),
      F("seed", &OneAxisTableConfig::seed, "", "encoder-noise seed; 0 = chosen by the host").at_least(0.0),
  });
  return table;
}

AxisConfig OneAxisTableConfig::axis() const {
  AxisConfig a;
  a.name = "angle";
  a.unit = "deg";
  a.min = min_deg;
  a.max = max_deg;
  a.max_rate = max_rate_dps;
  a.max_accel = max_accel_dps2;
  a.initial = initial_deg;
  a.settle_tolerance = settle_tolerance_deg;
  a.settle_rate_tolerance = settle_rate_tolerance_dps;
  a.settle_time_s = settle_time_s;
  a.encoder_resolution = encoder_resolution_deg;
  a.encoder_noise = encoder_noise_deg;
  return a;
}

SimOneAxisTable::SimOneAxisTable(const Params& p) : SimOneAxisTable(OneAxisTableConfig::from(p)) {}

bool OneAxisTableConfig::IsValid(std::string* error) const {
  const AxisConfig a = axis();
  std::string why;
  if (!a.IsValid(&why)) return invalid(error, "axis '" + a.name + "': " + why);
  if (!(std::abs(axis_tilt_deg) <= 90.0)) return invalid(error, "axis_tilt_deg must be within ±90 deg");
  return true;
}

SimOneAxisTable::SimOneAxisTable(const OneAxisTableConfig& c) : c_(require_valid(c, "sim_one_axis_table")) {
  axis_ = SimAxis(c.axis(), c.seed == 0 ? kFallbackSeed : static_cast<std::uint64_t>(c.seed));
  chain_ = physics::PaperTable<double>(c.axis_tilt_deg * kDegToRad);
  Rh_ = physics::Rx(c.axis_tilt_deg * kDegToRad);
  misaligned_ = c.axis_misalignment_x_deg != 0.0 || c.axis_misalignment_z_deg != 0.0;
  M_ = physics::Rz(c.axis_misalignment_z_deg * kDegToRad) * physics::Rx(c.axis_misalignment_x_deg * kDegToRad);
  n_ = M_.transpose() * Eigen::Vector3d::UnitY();
}

void SimOneAxisTable::check_axis(std::size_t axis) const {
  if (axis != 0)
    throw std::invalid_argument("sim_one_axis_table: no axis " + std::to_string(axis) + " (it has one axis, 'angle')");
}

void SimOneAxisTable::command(std::size_t axis, CommandMode mode, double value) {
  check_axis(axis);
  axis_.command(mode, value, now_);
}

void SimOneAxisTable::advance(double t_s) {
  if (!started_) {
    started_ = true;
    axis_.start_at(t_s);
  } else if (t_s < now_) {
    return;  // time never runs backwards
  }
  now_ = t_s;
  axis_.advance(t_s);
}

double SimOneAxisTable::measured(std::size_t axis) const {
  check_axis(axis);
  return axis_.measured();
}

double SimOneAxisTable::commanded(std::size_t axis) const {
  check_axis(axis);
  return axis_.commanded();
}

Pose SimOneAxisTable::pose(double t_s) const {
  const AxisState s = axis_.at(t_s);
  using Bits = std::uint64_t;  // compared bit for bit: −0 ≠ +0
  if (std::bit_cast<Bits>(s.position) == std::bit_cast<Bits>(last_state_.position) &&
      std::bit_cast<Bits>(s.velocity) == std::bit_cast<Bits>(last_state_.velocity) &&
      std::bit_cast<Bits>(s.acceleration) == std::bit_cast<Bits>(last_state_.acceleration))
    return last_pose_;
  last_state_ = s;
  const double delta = (s.position + c_.angle_offset_deg) * kDegToRad;
  Pose p;
  if (misaligned_)
    p.R_top_from_base = M_.transpose() * physics::Ry(delta) * M_ * Rh_;
  else  // the paper's chain with cos h, sin h cached: this runs at every sensor sample
    p.R_top_from_base = chain_.at(delta);
  const Eigen::Vector3d w = (s.velocity * kDegToRad) * n_;
  p.omega_top_radps = w;
  p.accel_top_mps2 = physics::point_acceleration<double>(w, (s.acceleration * kDegToRad) * n_, c_.lever_arm_m);
  last_pose_ = p;
  return p;
}

void SimOneAxisTable::telemetry(std::vector<std::pair<std::string, double>>& out) const {
  const AxisState s = axis_.at(now_);
  // Whole turns removed as in the encoder reading.
  const double truth = axis_.continuous() ? axis_.wrap(s.position) : s.position;
  out.emplace_back("true_angle_deg", truth + c_.angle_offset_deg);
  out.emplace_back("rate_dps", s.velocity);
}

std::string SimOneAxisTable::safe_state() noexcept {
  axis_.safe_state(now_);
  return "";
}

}  // namespace stend::sim
