// The error-model vocabulary: regressor agrees with the forward model, inverse undoes forward,
// autodiff Jacobians agree with numerical derivatives.
#include <gtest/gtest.h>

#include <ceres/jet.h>

#include <sstream>

#include <random>

#include "stend/model/terms.hpp"

using namespace stend::model;

namespace {
ErrorModel full_model(Instrument inst) {
  ErrorModel m;
  m.instrument = inst;
  for (TermKind k : kAllTermKinds) {
    if (k == TermKind::kGSensitivity && inst != Instrument::kGyroscope) continue;
    TermSpec t{k, 1, 25.0};
    if (k == TermKind::kBiasTemperature || k == TermKind::kScaleTemperature) t.order = 2;
    m.terms.push_back(t);
  }
  return m;
}

Stimulus<double> random_stimulus(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 5.0);
  Stimulus<double> s;
  s.input = {n(rng), n(rng), n(rng)};
  s.specific_force = {n(rng), n(rng), n(rng)};
  s.temperature_c = 25.0 + 3.0 * n(rng);
  s.temperature_rate_cps = 0.01 * n(rng);
  s.time_s = 100.0 + 10.0 * n(rng);
  return s;
}
}  // namespace

TEST(Terms, RegressorReproducesForwardModel) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1e-3);
  for (Instrument inst : {Instrument::kAccelerometer, Instrument::kGyroscope}) {
    ErrorModel m = full_model(inst);
    Eigen::VectorXd theta(m.size());
    for (int i = 0; i < theta.size(); ++i) theta[i] = n(rng);
    for (int trial = 0; trial < 20; ++trial) {
      Stimulus<double> s = random_stimulus(rng);
      Eigen::Vector3d y = m.measure<double>(theta.data(), s);
      Eigen::Vector3d lin = s.input + m.regressor(s) * theta;
      EXPECT_LT((y - lin).norm(), 1e-12 * (1 + y.norm()));
    }
  }
}

TEST(Terms, ParamInfoMatchesParamCount) {
  for (TermKind k : kAllTermKinds) {
    for (int order : {1, 2, 3}) {
      TermSpec t{k, order, 25.0};
      EXPECT_EQ(static_cast<int>(param_info(t, Instrument::kAccelerometer).size()), param_count(t))
          << term_name(k);
    }
    EXPECT_EQ(term_from_name(term_name(k)), k);
  }
  EXPECT_FALSE(term_from_name("no_such_term").has_value());
}

TEST(Terms, CorrectInvertsMeasure) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1e-3);
  ErrorModel m = full_model(Instrument::kAccelerometer);
  Eigen::VectorXd theta(m.size());
  for (int i = 0; i < theta.size(); ++i) theta[i] = n(rng);
  for (int trial = 0; trial < 20; ++trial) {
    Stimulus<double> s = random_stimulus(rng);
    s.specific_force = s.input;  // accelerometer: the input is the specific force
    Eigen::Vector3d y = m.measure<double>(theta.data(), s);
    Eigen::Vector3d u = m.correct(theta.data(), y, s);
    EXPECT_LT((u - s.input).norm(), 1e-9);
  }
}

// The affine form of every input-affine term (temperature, G, drift... included) at a stimulus
// inverts measure() exactly and agrees with correct(); a model with u² has none.
TEST(Terms, AffineFormInvertsMeasure) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1e-3);
  for (Instrument inst : {Instrument::kAccelerometer, Instrument::kGyroscope}) {
    ErrorModel full = full_model(inst), m;
    m.instrument = inst;
    for (const auto& t : full.terms)
      if (input_affine(t.kind)) m.terms.push_back(t);
    ASSERT_TRUE(m.input_affine());
    Eigen::VectorXd theta(m.size());
    for (int i = 0; i < theta.size(); ++i) theta[i] = n(rng);
    for (int trial = 0; trial < 20; ++trial) {
      Stimulus<double> s = random_stimulus(rng);
      if (inst == Instrument::kAccelerometer) s.specific_force = s.input;
      const Eigen::Vector3d y = m.measure<double>(theta.data(), s);
      const AffineForm<double> f = m.affine<double>(theta.data(), s);
      EXPECT_LT((f.correct(y) - s.input).norm(), 1e-12 * (1 + s.input.norm()));
      EXPECT_LT((f.correct(y) - m.correct(theta.data(), y, s)).norm(), 1e-9);
      EXPECT_LT((f.a * f.a_inv - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    }
  }
  const ErrorModel nonlinear = full_model(Instrument::kAccelerometer);
  EXPECT_FALSE(nonlinear.input_affine());
  const std::vector<double> zero(static_cast<std::size_t>(nonlinear.size()), 0.0);
  EXPECT_THROW(nonlinear.affine<double>(zero.data()), std::logic_error);
}

TEST(Terms, AutodiffJacobianMatchesNumericalDerivative) {
  using Jet = ceres::Jet<double, 3>;
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1e-3);
  ErrorModel m = full_model(Instrument::kGyroscope);
  Eigen::VectorXd theta(m.size());
  for (int i = 0; i < theta.size(); ++i) theta[i] = n(rng);
  Stimulus<double> s = random_stimulus(rng);
  // d y / d input by autodiff
  std::vector<Jet> theta_j(static_cast<std::size_t>(m.size()));
  for (int i = 0; i < m.size(); ++i) theta_j[static_cast<std::size_t>(i)] = Jet(theta[i]);
  Stimulus<Jet> sj;
  for (int i = 0; i < 3; ++i) {
    sj.input[i] = Jet(s.input[i], i);
    sj.specific_force[i] = Jet(s.specific_force[i]);
  }
  sj.temperature_c = Jet(s.temperature_c);
  sj.temperature_rate_cps = Jet(s.temperature_rate_cps);
  sj.time_s = Jet(s.time_s);
  Vec3<Jet> yj = m.measure<Jet>(theta_j.data(), sj);
  for (int i = 0; i < 3; ++i) {
    const double h = 1e-6;
    Stimulus<double> sp = s, sm = s;
    sp.input[i] += h;
    sm.input[i] -= h;
    Eigen::Vector3d num = (m.measure<double>(theta.data(), sp) - m.measure<double>(theta.data(), sm)) / (2 * h);
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(yj[r].v[i], num[r], 1e-7);
  }
}

TEST(ErrorModel, PrintsItsTermsAndEqualsComparesThem) {
  ErrorModel a;
  a.terms = {TermSpec{TermKind::kBias}, TermSpec{TermKind::kBiasTemperature, 2, 25.0}};
  std::ostringstream os;
  a.print(os);
  EXPECT_EQ(os.str(), "accelerometer: bias, bias_temperature(order 2, T0 25 degC)");
  ErrorModel b = a;
  EXPECT_TRUE(a.equals(b));
  b.terms[1].order = 3;
  EXPECT_FALSE(a.equals(b));
  b = a;
  b.instrument = Instrument::kGyroscope;
  EXPECT_FALSE(a.equals(b));
}
