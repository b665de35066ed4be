#include <stend/sim/one_axis_table.hpp>

#include <stend/physics/kinematics.hpp>
#include <stend/physics/rotations.hpp>
#include <stend/sim/param_reader.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace stend::sim {

namespace {
using physics::kDegToRad;
constexpr std::uint64_t kFallbackSeed = 0x7AB1EULL;
}  // namespace

OneAxisTableConfig OneAxisTableConfig::from(const Params& p) {
  OneAxisTableConfig c;
  ParamReader r(p, "sim_one_axis_table");
  c.axis_tilt_deg = r.number("axis_tilt_deg", c.axis_tilt_deg);
  c.min_deg = r.number("min_deg", c.min_deg);
  c.max_deg = r.number("max_deg", c.max_deg);
  c.max_rate_dps = r.number("max_rate_dps", c.max_rate_dps);
  c.max_accel_dps2 = r.number("max_accel_dps2", c.max_accel_dps2);
  c.initial_deg = r.number("initial_deg", c.initial_deg);
  c.lever_arm_m = r.vec3("lever_arm_m", c.lever_arm_m);
  c.settle_tolerance_deg = r.number("settle_tolerance_deg", c.settle_tolerance_deg);
  c.settle_rate_tolerance_dps = r.number("settle_rate_tolerance_dps", c.settle_rate_tolerance_dps);
  c.settle_time_s = r.number("settle_time_s", c.settle_time_s);
  c.encoder_resolution_deg = r.number("encoder_resolution_deg", c.encoder_resolution_deg);
  c.encoder_noise_deg = r.number("encoder_noise_deg", c.encoder_noise_deg);
  c.angle_offset_deg = r.number("angle_offset_deg", c.angle_offset_deg);
  c.axis_misalignment_x_deg = r.number("axis_misalignment_x_deg", c.axis_misalignment_x_deg);
  c.axis_misalignment_z_deg = r.number("axis_misalignment_z_deg", c.axis_misalignment_z_deg);
  c.seed = r.integer("seed", c.seed);
  r.finish();
  return c;
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

SimOneAxisTable::SimOneAxisTable(const OneAxisTableConfig& c) : c_(c) {
  try {
    axis_ = SimAxis(c.axis(), c.seed == 0 ? kFallbackSeed : static_cast<std::uint64_t>(c.seed));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("sim_one_axis_table: ") + e.what());
  }
  if (!(std::abs(c.axis_tilt_deg) <= 90.0))
    throw std::invalid_argument("sim_one_axis_table: axis_tilt_deg must be within ±90 deg");
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
  const double delta = (s.position + c_.angle_offset_deg) * kDegToRad;
  Pose p;
  if (misaligned_)
    p.R_top_from_base = M_.transpose() * physics::Ry(delta) * M_ * Rh_;
  else  // the paper's chain with cos h, sin h cached: this runs at every sensor sample
    p.R_top_from_base = chain_.at(delta);
  const Eigen::Vector3d w = (s.velocity * kDegToRad) * n_;
  p.omega_top_radps = w;
  p.accel_top_mps2 = physics::point_acceleration<double>(w, (s.acceleration * kDegToRad) * n_, c_.lever_arm_m);
  return p;
}

void SimOneAxisTable::telemetry(std::vector<std::pair<std::string, double>>& out) const {
  const AxisState s = axis_.at(now_);
  // Whole turns removed as in the encoder reading.
  const double truth = axis_.continuous() ? axis_.wrap(s.position) : s.position;
  out.emplace_back("true_angle_deg", truth + c_.angle_offset_deg);
  out.emplace_back("rate_dps", s.velocity);
}

void SimOneAxisTable::safe_state() noexcept { axis_.safe_state(now_); }

}  // namespace stend::sim
