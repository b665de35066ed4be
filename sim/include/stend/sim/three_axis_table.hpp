// Simulated three-axis table (the paper's three-axis iXblue table): azimuth (outer, about the base
// z axis), tilt h (middle, about x) and rotation δ (inner, about y):
//
//   R_top_from_base = Ry(δ) · Rx(h) · Rz(az)
//
// so azimuth 0 is the paper's Table 1 exactly (stend::physics::paper_table(h, δ)). The chain, the
// top's angular velocity and acceleration (physics::three_axis_table_motion) and the lever arm
// (physics::point_acceleration) are stend/physics'. Each axis moves under its own trapezoidal
// profile (stend/sim/motion_profile.hpp). See README.md.
#pragma once

#include <stend/fields.hpp>
#include <stend/sdk.hpp>
#include <stend/sim/motion_profile.hpp>

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace stend::sim {

struct ThreeAxisTableConfig {
  // Per axis, in the order [azimuth, tilt, rotation].
  Eigen::Vector3d min_deg{-360.0, -360.0, -360.0};
  Eigen::Vector3d max_deg{360.0, 360.0, 360.0};
  Eigen::Vector3d max_rate_dps{500.0, 500.0, 500.0};
  Eigen::Vector3d max_accel_dps2{200.0, 200.0, 200.0};
  Eigen::Vector3d initial_deg{0.0, 0.0, 0.0};
  Eigen::Vector3d angle_offset_deg{0.0, 0.0, 0.0};  // true angle = encoder angle + offset
  Eigen::Vector3d lever_arm_m{0.0, 0.0, 0.0};       // mounting point, top frame
  double settle_tolerance_deg = 0.01;
  double settle_rate_tolerance_dps = 0.01;
  double settle_time_s = 0.5;
  double encoder_resolution_deg = 1e-4;
  double encoder_noise_deg = 0.0;
  std::int64_t seed = 0;

  // Every parameter of the sim_three_axis_table plugin: its schema and the reader of its Params.
  static const stend::fields::Table<ThreeAxisTableConfig>& fields();
  static ThreeAxisTableConfig from(const Params& p) { return fields().read(p); }  // throws std::invalid_argument
  // Axis i (0 azimuth, 1 tilt, 2 rotation) as the table moves it.
  AxisConfig axis(int i) const;
  // Every axis (AxisConfig::IsValid).
  bool IsValid(std::string* error = nullptr) const;
};

class SimThreeAxisTable final : public Fixture {
 public:
  static constexpr std::size_t kAzimuth = 0, kTilt = 1, kRotation = 2;

  explicit SimThreeAxisTable(const Params& p);
  explicit SimThreeAxisTable(const ThreeAxisTableConfig& c);

  FixtureRole role() const override { return FixtureRole::kTable; }
  std::vector<AxisSpec> axes() const override;
  void command(std::size_t axis, CommandMode mode, double value) override;
  void advance(double t_s) override;
  double measured(std::size_t axis) const override;
  double commanded(std::size_t axis) const override;
  bool settled() const override;
  Pose pose(double t_s) const override;
  void telemetry(std::vector<std::pair<std::string, double>>& out) const override;
  std::string safe_state() noexcept override;  // always reached: ""

  const SimAxis& axis(std::size_t i) const { return axes_.at(i); }

 private:
  const SimAxis& checked(std::size_t axis) const;

  ThreeAxisTableConfig c_;
  std::array<SimAxis, 3> axes_;
  double now_ = 0.0;
  bool started_ = false;
};

}  // namespace stend::sim
