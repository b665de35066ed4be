// Simulated one-axis turntable in the role of the paper's iXblue EVO-10-L: a rotation axis tilted
// beforehand by h (fixed configuration), turned by δ under a trapezoidal speed profile.
//
// Frames: base = the bench (or the fixture below), z up. Top = the table plate:
//   R_top_from_base = A(δ_true) · Rx(h),   A(δ) = Mᵀ·Ry(δ)·M  (= Ry(δ) without misalignment)
// which is the paper's Table 1 (stend::physics::paper_table(h, δ)). With h = 0 the specific force
// of gravity on the plate is g·[−sin δ, 0, cos δ]. The plate turns about its own y axis (n = Mᵀ·e_y
// when the axis is misaligned): ω_top = δ̇·n, and a sensor at lever_arm_m from the axis feels
// physics::point_acceleration(ω, δ̈·n, lever_arm_m). See README.md.
#pragma once

#include <stend/fields.hpp>
#include <stend/physics/table_chain.hpp>
#include <stend/sdk.hpp>
#include <stend/sim/motion_profile.hpp>

#include <Eigen/Core>
#include <cstdint>
#include <limits>

namespace stend::sim {

struct OneAxisTableConfig {
  double axis_tilt_deg = 0.0;  // the paper's h, set beforehand
  double min_deg = -360.0, max_deg = 360.0;
  double max_rate_dps = 500.0, max_accel_dps2 = 200.0;
  double initial_deg = 0.0;
  Eigen::Vector3d lever_arm_m = Eigen::Vector3d::Zero();  // mounting point, top frame
  double settle_tolerance_deg = 0.01;
  double settle_rate_tolerance_dps = 0.01;
  double settle_time_s = 0.5;
  double encoder_resolution_deg = 1e-4;
  double encoder_noise_deg = 0.0;
  // Unmodelled imperfections (for gap diagnosis): true angle = encoder angle + angle_offset_deg;
  // the rotation axis is tilted from nominal by small rotations about the tilted frame's x and z.
  double angle_offset_deg = 0.0;
  double axis_misalignment_x_deg = 0.0;
  double axis_misalignment_z_deg = 0.0;
  std::int64_t seed = 0;

  // Every parameter of the sim_one_axis_table plugin: its schema and the reader of its Params.
  static const stend::fields::Table<OneAxisTableConfig>& fields();
  static OneAxisTableConfig from(const Params& p) { return fields().read(p); }  // throws std::invalid_argument
  // The motion of the one axis "angle" (deg): limits, profile, settling, encoder — as
  // SimOneAxisTable moves it and as emulators/bench_world serves it.
  AxisConfig axis() const;
  // The axis (AxisConfig::IsValid) and the tilt h within ±90 deg.
  bool IsValid(std::string* error = nullptr) const;
};

class SimOneAxisTable final : public Fixture {
 public:
  explicit SimOneAxisTable(const Params& p);
  explicit SimOneAxisTable(const OneAxisTableConfig& c);

  FixtureRole role() const override { return FixtureRole::kTable; }
  std::vector<AxisSpec> axes() const override { return {axis_.spec()}; }
  void command(std::size_t axis, CommandMode mode, double value) override;
  void advance(double t_s) override;
  double measured(std::size_t axis) const override;
  double commanded(std::size_t axis) const override;
  bool settled() const override { return axis_.settled(); }
  Pose pose(double t_s) const override;
  void telemetry(std::vector<std::pair<std::string, double>>& out) const override;
  std::string safe_state() noexcept override;  // always reached: ""

  const SimAxis& axis() const { return axis_; }
  const OneAxisTableConfig& config() const { return c_; }

 private:
  void check_axis(std::size_t axis) const;

  OneAxisTableConfig c_;
  SimAxis axis_;
  physics::PaperTable<double> chain_{0.0};           // Ry(δ)·Rx(h), h fixed
  Eigen::Matrix3d Rh_ = Eigen::Matrix3d::Identity();  // Rx(h), for the misaligned axis
  Eigen::Matrix3d M_ = Eigen::Matrix3d::Identity();   // axis misalignment
  Eigen::Vector3d n_ = Eigen::Vector3d::UnitY();      // rotation axis in the top frame
  bool misaligned_ = false;
  // pose() for the last axis state asked (one thread at a time): the sensor asks at every sample,
  // and a table holding a position repeats the same state.
  mutable AxisState last_state_{std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  mutable Pose last_pose_;
  double now_ = 0.0;
  bool started_ = false;
};

}  // namespace stend::sim
