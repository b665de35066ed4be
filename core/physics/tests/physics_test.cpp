// core/physics: rotations, the table chains and their kinematics, the lever arm, gravity through a
// tilted base, units — each checked against an independent form (products of elementary
// rotations, finite differences, closed forms from the paper).
#include <gtest/gtest.h>

#include <ceres/jet.h>

#include <Eigen/LU>

#include <array>
#include <cmath>

#include "stend/physics/geometry.hpp"

namespace {

using namespace stend::physics;
using Jet = ceres::Jet<double, 1>;

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

// Angles, rates and accelerations of one smooth three-axis motion q(t) = q0 + q̇0·t + ½·q̈·t².
struct Trajectory {
  Eigen::Vector3d q0{0.4, -0.7, 1.1}, qd0{0.9, -0.5, 1.3}, qdd{-2.0, 1.5, 0.7};
  Eigen::Vector3d q(double t) const { return q0 + qd0 * t + 0.5 * qdd * t * t; }
  Eigen::Vector3d qd(double t) const { return qd0 + qdd * t; }
  TableMotion<double> at(double t) const { return three_axis_table_motion<double>(q(t), qd(t), qdd); }
};

TEST(Rotations, PassiveElementaryRotations) {
  const double a = 0.3;
  // The frame turned by +a about x sees a fixed y axis turned by −a.
  EXPECT_LT((Rx(a) * Eigen::Vector3d::UnitY() - Eigen::Vector3d(0, std::cos(a), -std::sin(a))).norm(), 1e-15);
  EXPECT_LT((Ry(a) * Eigen::Vector3d::UnitZ() - Eigen::Vector3d(-std::sin(a), 0, std::cos(a))).norm(), 1e-15);
  EXPECT_LT((Rz(a) * Eigen::Vector3d::UnitX() - Eigen::Vector3d(std::cos(a), -std::sin(a), 0)).norm(), 1e-15);
  for (const Eigen::Matrix3d& R : {Rx(a), Ry(a), Rz(a)}) {
    EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-15);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-15);
  }
}

TEST(Rotations, JetsCarryTheDerivative) {
  // dRx/da = −[e_x]×·Rx(a), the same rotation differentiated by Ceres' dual numbers.
  const double a = 0.7;
  Jet ja(a, 0);
  const Mat3<Jet> R = Rx(ja);
  const Eigen::Matrix3d dR = -skew(Eigen::Vector3d::UnitX()) * Rx(a);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      EXPECT_DOUBLE_EQ(R(i, j).a, Rx(a)(i, j));
      EXPECT_NEAR(R(i, j).v[0], dR(i, j), 1e-15);
    }
}

TEST(TableChain, PaperTableIsRyOfDeltaTimesRxOfTilt) {
  for (double h : {-0.4, 0.0, 0.02, 1.0})
    for (double d : {-2.5, 0.0, 0.7, 3.0}) {
      EXPECT_LT((paper_table(h, d) - Ry(d) * Rx(h)).norm(), 1e-15);
      // The paper's eq. (3) as specific force.
      const double g = 9.8;
      const Eigen::Vector3d f = gravity_specific_force(paper_table(h, d), g);
      EXPECT_LT((f - g * Eigen::Vector3d(-std::sin(d) * std::cos(h), std::sin(h), std::cos(d) * std::cos(h))).norm(),
                1e-14);
      const auto [h2, d2] = paper_table_pointing(f / g);
      EXPECT_NEAR(h2, h, 1e-12);
      EXPECT_NEAR(std::remainder(d2 - d, 2 * std::numbers::pi), 0.0, 1e-12);
    }
}

TEST(TableChain, ThreeAxisTableAddsTheAzimuthOutside) {
  const double az = 0.8, h = -0.3, d = 2.0;
  EXPECT_LT((three_axis_table(az, h, d) - Ry(d) * Rx(h) * Rz(az)).norm(), 1e-15);
  EXPECT_LT((three_axis_table(0.0, h, d) - paper_table(h, d)).norm(), 1e-15);
  EXPECT_LT((three_axis_table_motion<double>({az, h, d}, {0, 0, 0}, {0, 0, 0}).R_top_from_base -
             three_axis_table(az, h, d))
                .norm(),
            1e-15);
}

TEST(TableChain, AngularVelocityIsTheRateOfTheChain) {
  // Passive R_top_from_base: dR/dt = −[ω_top]×·R, so [ω]× = −Ṙ·Rᵀ (central differences).
  const Trajectory tr;
  const double e = 1e-6;
  for (double t : {0.0, 0.37, 1.2}) {
    const TableMotion<double> m = tr.at(t);
    const Eigen::Matrix3d Rdot = (tr.at(t + e).R_top_from_base - tr.at(t - e).R_top_from_base) / (2 * e);
    const Eigen::Matrix3d W = -Rdot * m.R_top_from_base.transpose();
    EXPECT_LT((Eigen::Vector3d(W(2, 1), W(0, 2), W(1, 0)) - m.omega_top_radps).norm(), 1e-8);
    // The written-out ω: Ry(δ)·Rx(h)·[0,0,ȧz] + Ry(δ)·[ḣ,0,0] + [0,δ̇,0].
    const Eigen::Vector3d q = tr.q(t), qd = tr.qd(t);
    const Eigen::Vector3d w = Ry(q[2]) * Rx(q[1]) * Eigen::Vector3d(0, 0, qd[0]) +
                              Ry(q[2]) * Eigen::Vector3d(qd[1], 0, 0) + Eigen::Vector3d(0, qd[2], 0);
    EXPECT_LT((w - m.omega_top_radps).norm(), 1e-14);
    // α = dω/dt (components in the top frame).
    const Eigen::Vector3d alpha = (tr.at(t + e).omega_top_radps - tr.at(t - e).omega_top_radps) / (2 * e);
    EXPECT_LT((alpha - m.alpha_top_radps2).norm(), 1e-8);
  }
}

TEST(TableChain, PaperTableMotionTurnsAboutTheTopYAxis) {
  const TableMotion<double> m = paper_table_motion(0.2, 1.0, 0.5, -0.25);
  EXPECT_LT((m.R_top_from_base - paper_table(0.2, 1.0)).norm(), 1e-15);
  EXPECT_LT((m.omega_top_radps - Eigen::Vector3d(0, 0.5, 0)).norm(), 1e-15);
  EXPECT_LT((m.alpha_top_radps2 - Eigen::Vector3d(0, -0.25, 0)).norm(), 1e-15);
}

TEST(Kinematics, PointAccelerationIsTheSecondDerivativeOfAFixedPoint) {
  // A point fixed at r on the table top: in the base frame p(t) = R(t)ᵀ·r; its acceleration seen
  // in the top frame, R·p̈, is the lever-arm formula with the chain's ω and α.
  const Trajectory tr;
  const Eigen::Vector3d r(0.05, -0.12, 0.3);
  const double t = 0.6, e = 1e-4;
  auto p = [&](double s) { return Eigen::Vector3d(tr.at(s).R_top_from_base.transpose() * r); };
  const Eigen::Vector3d pdd = (p(t + e) - 2 * p(t) + p(t - e)) / (e * e);
  const TableMotion<double> m = tr.at(t);
  const Eigen::Vector3d a = point_acceleration<double>(m.omega_top_radps, m.alpha_top_radps2, r);
  EXPECT_LT((m.R_top_from_base * pdd - a).norm(), 1e-6);
  // Pure spin about z at ω: centripetal ω²·r towards the axis.
  const Eigen::Vector3d c = point_acceleration<double>({0, 0, 2.0}, Eigen::Vector3d::Zero(), {0.1, 0, 0});
  EXPECT_LT((c - Eigen::Vector3d(-0.4, 0, 0)).norm(), 1e-15);
}

TEST(Gravity, TiltedBaseDerivativesByJets) {
  // ∂f/∂ε at ε = 0 for f = R·Rx(ε_x)·Ry(ε_y)·[0,0,g]: R·(−e_x × g·e_z) = g·R·e_y and
  // R·(−e_y × g·e_z) = −g·R·e_x.
  using J2 = ceres::Jet<double, 2>;
  const Eigen::Matrix3d R = three_axis_table(0.3, 0.5, -1.2);
  const double g = 9.81;
  const Vec3<J2> f =
      gravity_specific_force<J2>(R.cast<J2>() * tilted_base(J2(0.0, 0), J2(0.0, 1)), J2(g));
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(f[i].a, g * R(i, 2), 1e-15);
    EXPECT_NEAR(f[i].v[0], g * R(i, 1), 1e-15);
    EXPECT_NEAR(f[i].v[1], -g * R(i, 0), 1e-15);
  }
}

TEST(Gravity, NormalGravity) {
  // Somigliana at the equator and the pole, and the free-air gradient ≈ −3.086e-6 s⁻².
  EXPECT_NEAR(normal_gravity(0.0, 0.0), 9.7803253359, 1e-10);
  EXPECT_NEAR(normal_gravity(90.0, 0.0), 9.8321849378, 1e-9);
  EXPECT_NEAR(normal_gravity(45.0, 100.0) - normal_gravity(45.0, 0.0), -3.086e-4, 2e-6);
  EXPECT_NEAR(earth_rate_local(90.0).z(), kEarthRateRadps, 1e-18);
}

TEST(Units, OneDefinitionEach) {
  EXPECT_EQ(kStandardGravity, 9.80665);
  EXPECT_NEAR(1000.0 * kMilliG, kStandardGravity, 1e-15);
  EXPECT_NEAR(1e6 * kMicroG, kStandardGravity, 1e-14);
  EXPECT_NEAR(180.0 * kDegToRad, std::numbers::pi, 1e-15);
  EXPECT_NEAR(kDegToRad * kRadToDeg, 1.0, 1e-15);
  EXPECT_EQ(kDegPerSecond, kDegToRad);
  EXPECT_NEAR(3600.0 * kDegPerHour, kDegToRad, 1e-18);
}

}  // namespace
