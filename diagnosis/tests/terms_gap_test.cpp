// The vocabulary terms added for the gap diagnoser (thermal_hysteresis, gravity_error,
// table_angle_offset, table_axis_tilt, lever_arm): regressor = forward model, autodiff Jacobian =
// numerical derivative, and each term's first-order formula against the physics it stands for.
#include <gtest/gtest.h>

#include <ceres/jet.h>

#include <random>

#include "stend/diagnosis/gap.hpp"
#include "stend/physics/geometry.hpp"
#include "stend/model/terms.hpp"

using namespace stend::model;

namespace {

const TermKind kNew[] = {TermKind::kThermalHysteresis, TermKind::kGravityError, TermKind::kTableAngleOffset,
                         TermKind::kTableAxisTilt, TermKind::kLeverArm};

Stimulus<double> random_stimulus(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 3.0);
  Stimulus<double> s;
  s.input = {n(rng), n(rng), n(rng)};
  s.specific_force = s.input;
  s.temperature_c = 25 + n(rng);
  s.temperature_direction = n(rng) > 0 ? 1.0 : -1.0;
  s.gravity_up = Vec3<double>(n(rng), n(rng), n(rng)).normalized();
  s.angular_rate = {n(rng), n(rng), n(rng)};
  s.angular_accel = {n(rng), n(rng), n(rng)};
  for (auto& v : s.table_df_dangle) v = {n(rng), n(rng), n(rng)};
  for (auto& v : s.table_df_dtilt) v = {n(rng), n(rng), n(rng)};
  return s;
}

ErrorModel new_terms_model() {
  ErrorModel m;
  m.terms.push_back({TermKind::kBias, 1, 25.0});
  for (TermKind k : kNew) m.terms.push_back({k, 1, 25.0});
  return m;
}

}  // namespace

TEST(GapTerms, NamesCountsAndInfo) {
  for (TermKind k : kNew) {
    TermSpec t{k, 1, 25.0};
    EXPECT_EQ(term_from_name(term_name(k)), k);
    EXPECT_EQ(static_cast<int>(param_info(t, Instrument::kAccelerometer).size()), param_count(t)) << term_name(k);
  }
  EXPECT_EQ(param_count({TermKind::kGravityError, 1, 25.0}), 1);
  EXPECT_EQ(param_count({TermKind::kTableAxisTilt, 1, 25.0}), 2);
}

TEST(GapTerms, DefaultStimulusFieldsMakeThemSilent) {
  // A stimulus that does not set the new fields (every existing producer) sees no contribution.
  ErrorModel m = new_terms_model();
  Eigen::VectorXd theta = Eigen::VectorXd::Constant(m.size(), 0.37);
  theta.head(3).setZero();  // no bias
  Stimulus<double> s;
  s.input = {1, -2, 9.8};
  s.specific_force = s.input;
  EXPECT_LT((m.measure<double>(theta.data(), s) - s.input).norm(), 1e-15);
}

TEST(GapTerms, RegressorReproducesForwardModel) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1e-2);
  ErrorModel m = new_terms_model();
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::VectorXd theta(m.size());
    for (int i = 0; i < theta.size(); ++i) theta[i] = n(rng);
    const Stimulus<double> s = random_stimulus(rng);
    const Eigen::Vector3d y = m.measure<double>(theta.data(), s);
    EXPECT_LT((y - (s.input + m.regressor(s) * theta)).norm(), 1e-12 * (1 + y.norm()));
  }
}

TEST(GapTerms, AutodiffJacobianInParametersMatchesNumerical) {
  constexpr int kP = 1 + 3 + 1 + 3 + 2 + 3 + 3;  // bias(3) hysteresis(3) g(1) offset(3) tilt(2) lever(3)
  using Jet = ceres::Jet<double, kP - 1>;
  ErrorModel m = new_terms_model();
  ASSERT_EQ(m.size(), kP - 1);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1e-2);
  Eigen::VectorXd theta(m.size());
  for (int i = 0; i < theta.size(); ++i) theta[i] = n(rng);
  const Stimulus<double> s = random_stimulus(rng);
  std::vector<Jet> tj(static_cast<std::size_t>(m.size()));
  for (int i = 0; i < m.size(); ++i) tj[static_cast<std::size_t>(i)] = Jet(theta[i], i);
  Stimulus<Jet> sj;
  for (int i = 0; i < 3; ++i) {
    sj.input[i] = Jet(s.input[i]);
    sj.specific_force[i] = Jet(s.specific_force[i]);
    sj.gravity_up[i] = Jet(s.gravity_up[i]);
    sj.angular_rate[i] = Jet(s.angular_rate[i]);
    sj.angular_accel[i] = Jet(s.angular_accel[i]);
    for (std::size_t k = 0; k < 3; ++k) sj.table_df_dangle[k][i] = Jet(s.table_df_dangle[k][i]);
    for (std::size_t k = 0; k < 2; ++k) sj.table_df_dtilt[k][i] = Jet(s.table_df_dtilt[k][i]);
  }
  sj.temperature_c = Jet(s.temperature_c);
  sj.temperature_direction = Jet(s.temperature_direction);
  const Vec3<Jet> yj = m.measure<Jet>(tj.data(), sj);
  for (int j = 0; j < m.size(); ++j) {
    const double h = 1e-6;
    Eigen::VectorXd tp = theta, tm = theta;
    tp[j] += h;
    tm[j] -= h;
    const Eigen::Vector3d num = (m.measure<double>(tp.data(), s) - m.measure<double>(tm.data(), s)) / (2 * h);
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(yj[r].v[j], num[r], 1e-7) << "param " << j << " row " << r;
  }
}

TEST(GapTerms, LeverArmIsCentripetalPlusTangential) {
  // ω about z at 2 rad/s, r = 0.1 m along x: centripetal −ω²r along x; ω̇ = 3 rad/s² about z
  // gives tangential ω̇·r along y.
  ErrorModel m;
  m.terms = {{TermKind::kLeverArm, 1, 25.0}};
  const double r[3] = {0.1, 0, 0};
  Stimulus<double> s;
  s.angular_rate = {0, 0, 2};
  s.angular_accel = {0, 0, 3};
  const Eigen::Vector3d d = m.measure<double>(r, s) - s.input;
  EXPECT_NEAR(d[0], -0.4, 1e-12);
  EXPECT_NEAR(d[1], 0.3, 1e-12);
  EXPECT_NEAR(d[2], 0.0, 1e-12);
}

TEST(GapTerms, TableOffsetAndTiltAreFirstOrderGeometry) {
  // The table derivatives from stend::diagnosis::table_stimulus, times a small offset, equal the change
  // of the specific force when the table really stands δ further / the base really is tilted.
  const double g = 9.81, deg = stend::physics::kDegToRad;
  ErrorModel m;
  m.terms = {{TermKind::kTableAngleOffset, 1, 25.0}, {TermKind::kTableAxisTilt, 1, 25.0}};
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (auto [h, d] : {std::pair{0.0, 0.0}, {30.0, 45.0}, {-60.0, 120.0}, {90.0, 10.0}}) {
    Stimulus<double> s;
    const Eigen::Vector3d f0 = stend::diagnosis::table_stimulus(s, 0.0, h * deg, d * deg, I, g);
    s.input = f0;
    const double delta = 1e-4;  // rad
    // rotation-axis zero offset
    double th[5] = {0, 0, delta, 0, 0};
    Stimulus<double> moved;
    const Eigen::Vector3d f1 = stend::diagnosis::table_stimulus(moved, 0.0, h * deg, d * deg + delta, I, g);
    EXPECT_LT(((m.measure<double>(th, s) - f0) - (f1 - f0)).norm(), 1e-6 * g);
    // tilt offset
    th[1] = delta;
    th[2] = 0;
    const Eigen::Vector3d f2 = stend::diagnosis::table_stimulus(moved, 0.0, h * deg + delta, d * deg, I, g);
    EXPECT_LT(((m.measure<double>(th, s) - f0) - (f2 - f0)).norm(), 1e-6 * g);
    // base tilt about x: the same as gravity rotated by Rx(ε) in the base frame
    double tt[5] = {0, 0, 0, delta, 0};
    const Eigen::Vector3d f3 = stend::physics::Ry(d * deg) * stend::physics::Rx(h * deg) *
                               stend::physics::Rx(delta) * Eigen::Vector3d(0, 0, g);
    EXPECT_LT(((m.measure<double>(tt, s) - f0) - (f3 - f0)).norm(), 1e-6 * g);
  }
}

TEST(GapTerms, GravityErrorActsAlongUp) {
  ErrorModel m;
  m.terms = {{TermKind::kGravityError, 1, 25.0}};
  Stimulus<double> s;
  s.input = {0, 0, 9.81};
  s.gravity_up = {0, 0, 1};
  const double dg = 0.002;
  EXPECT_NEAR((m.measure<double>(&dg, s) - s.input)[2], 0.002, 1e-15);
}
