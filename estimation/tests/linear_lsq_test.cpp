// Generic weighted linear least squares: recovery, interval coverage, identifiability, refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <numbers>
#include <random>
#include <regex>
#include <sstream>
#include <vector>

#include "stend/estimation/linear_lsq.hpp"
#include "stend/physics/geometry.hpp"
#include "stend/model/terms.hpp"

using namespace stend;
using namespace stend::estimation;
using model::ErrorModel;
using model::TermKind;
using model::TermSpec;

namespace {

ErrorModel accel_model(std::vector<TermSpec> terms) {
  ErrorModel m;
  m.instrument = model::Instrument::kAccelerometer;
  m.terms = std::move(terms);
  return m;
}

// Static orientations: the 6 faces, 12 edges (45°) of a cube — 18 gravity directions.
std::vector<Eigen::Vector3d> orientations(double g) {
  std::vector<Eigen::Vector3d> out;
  for (int a = 0; a < 3; ++a)
    for (double s : {1.0, -1.0}) {
      Eigen::Vector3d v = Eigen::Vector3d::Zero();
      v[a] = s * g;
      out.push_back(v);
    }
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      for (double s1 : {1.0, -1.0})
        for (double s2 : {1.0, -1.0}) {
          Eigen::Vector3d v = Eigen::Vector3d::Zero();
          v[a] = s1 * g / std::sqrt(2.0);
          v[b] = s2 * g / std::sqrt(2.0);
          out.push_back(v);
        }
  return out;
}

// Δ = measure(θ, f) + noise − f for every orientation and axis; design from the regressor.
LsqProblem synthetic(const ErrorModel& m, const Eigen::VectorXd& theta,
                     const std::vector<model::Stimulus<double>>& stimuli, double sigma,
                     std::mt19937& rng, std::vector<int> axes = {0, 1, 2},
                     const std::vector<double>& axis_sigma_scale = {1, 1, 1}) {
  std::normal_distribution<double> n(0.0, 1.0);
  LsqProblem pr;
  const int k = static_cast<int>(stimuli.size() * axes.size());
  pr.design.resize(k, m.size());
  pr.observations.resize(k);
  pr.weights.resize(k);
  int row = 0;
  for (const auto& s : stimuli) {
    const Eigen::Vector3d y = m.measure<double>(theta.data(), s);
    const auto phi = m.regressor(s);
    for (int a : axes) {
      const double sd = sigma * axis_sigma_scale[static_cast<std::size_t>(a)];
      pr.design.row(row) = phi.row(a);
      pr.observations[row] = y[a] + sd * n(rng) - s.input[a];
      pr.weights[row] = 1.0 / (sd * sd);
      ++row;
    }
  }
  for (const auto& p : m.params()) {
    pr.names.push_back(p.name);
    pr.units.push_back(p.unit);
  }
  return pr;
}

std::vector<model::Stimulus<double>> cube_stimuli(double g, double temperature = 25.0) {
  std::vector<model::Stimulus<double>> out;
  for (const auto& f : orientations(g)) {
    model::Stimulus<double> s;
    s.input = f;
    s.specific_force = f;
    s.temperature_c = temperature;
    out.push_back(s);
  }
  return out;
}

Eigen::VectorXd random_theta(const ErrorModel& m, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::VectorXd theta(m.size());
  const auto info = m.params();
  for (int i = 0; i < theta.size(); ++i)
    theta[i] = (info[static_cast<std::size_t>(i)].unit == "m/s^2" ? 0.05 : 0.005) * n(rng);
  return theta;
}

}  // namespace

TEST(StudentT, MatchesTables) {
  EXPECT_NEAR(student_t_quantile(0.975, 1), 12.7062047, 1e-6);
  EXPECT_NEAR(student_t_quantile(0.975, 2), 4.30265273, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 3), 3.18244631, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 10), 2.22813885, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 20), 2.08596345, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.995, 5), 4.03214298, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.025, 10), -2.22813885, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 1e7), 1.95996398, 1e-5);
  EXPECT_NEAR(normal_quantile(0.975), 1.95996398, 1e-8);
  EXPECT_NEAR(student_t_cdf(2.22813885, 10), 0.975, 1e-8);
  EXPECT_NEAR(student_t_cdf(0.0, 3), 0.5, 1e-15);
}

TEST(LinearLsq, ExactDataRecoveredExactly) {
  std::mt19937 rng(1);
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}, {TermKind::kCrossAxis}});
  const Eigen::VectorXd theta = random_theta(m, rng);
  LsqProblem pr = synthetic(m, theta, cube_stimuli(9.81), 0.0, rng);
  pr.weights.resize(0);
  const LsqResult r = solve_lsq(pr);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.rank, 12);
  EXPECT_EQ(r.dof, 54 - 12);
  for (int i = 0; i < 12; ++i) EXPECT_NEAR(r.estimate[i], theta[i], 1e-12);
  EXPECT_LT(r.rss, 1e-20);
  EXPECT_TRUE(r.warnings.empty());
}

TEST(LinearLsq, RecoversParametersFromNoisyMeasurements) {
  std::mt19937 rng(11);
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}, {TermKind::kCrossAxis}});
  const Eigen::VectorXd theta = random_theta(m, rng);
  // 10 repetitions of the 18 orientations: k = 540, σ = 2 mg.
  std::vector<model::Stimulus<double>> st;
  for (int rep = 0; rep < 10; ++rep)
    for (const auto& s : cube_stimuli(9.81)) st.push_back(s);
  const double sigma = 0.02;
  LsqProblem pr = synthetic(m, theta, st, sigma, rng);
  pr.weights.resize(0);
  const LsqResult r = solve_lsq(pr);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(std::sqrt(r.sigma2), sigma, 0.1 * sigma);
  for (int i = 0; i < 12; ++i) {
    const auto& e = r.parameters[static_cast<std::size_t>(i)];
    EXPECT_TRUE(e.identifiable);
    EXPECT_LT(std::abs(e.value - theta[i]), 4.0 * e.std_error) << e.name;
    EXPECT_GT(e.std_error, 0.0);
  }
  // Bias standard error: σ/√(rows per axis) since the other regressors are balanced (mean zero).
  EXPECT_NEAR(r.parameter("bias_x").std_error, std::sqrt(r.sigma2 / 180.0), 1e-12);
  // QR gives the same answer.
  LsqOptions qr;
  qr.method = LsqMethod::kQr;
  const LsqResult rq = solve_lsq(pr, qr);
  EXPECT_EQ(rq.method, LsqMethod::kQr);
  EXPECT_TRUE(approx_equal(r, rq, 1e-8, 1e-14));
}

// Coverage of the reported 95% intervals: over 1000 synthetic experiments with known truth the
// true value must lie inside in 90–98% of the fits, for every parameter.
TEST(LinearLsq, IntervalCoverageFullModel) {
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}, {TermKind::kCrossAxis}});
  const auto st = cube_stimuli(9.80665);
  std::vector<int> inside(static_cast<std::size_t>(m.size()), 0);
  const int seeds = 1000;
  for (int seed = 0; seed < seeds; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(1000 + seed));
    const Eigen::VectorXd theta = random_theta(m, rng);
    LsqProblem pr = synthetic(m, theta, st, 0.01, rng);
    pr.weights.resize(0);
    const LsqResult r = solve_lsq(pr);
    ASSERT_TRUE(r.ok());
    for (int i = 0; i < m.size(); ++i) {
      const auto& e = r.parameters[static_cast<std::size_t>(i)];
      if (theta[i] >= e.lower && theta[i] <= e.upper) ++inside[static_cast<std::size_t>(i)];
    }
  }
  for (int i = 0; i < m.size(); ++i) {
    const double c = inside[static_cast<std::size_t>(i)] / static_cast<double>(seeds);
    std::printf("coverage %-10s %.3f\n", m.params()[static_cast<std::size_t>(i)].name.c_str(), c);
    EXPECT_GE(c, 0.90) << m.params()[static_cast<std::size_t>(i)].name;
    EXPECT_LE(c, 0.98) << m.params()[static_cast<std::size_t>(i)].name;
  }
}

// Few degrees of freedom (k = 8, p = 4, dof = 4): the Student t quantile (2.776) is what keeps the
// coverage at 95%; the normal quantile (1.96) would cover only ≈ 88%.
TEST(LinearLsq, IntervalCoverageFewDegreesOfFreedomAndWeights) {
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}, {TermKind::kCrossAxis}});
  std::vector<model::Stimulus<double>> st;
  int idx = 0;
  for (double deg : {0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0}) {
    const double h = (idx++ % 3 - 1) * 0.4;  // tilts −0.4, 0, 0.4 rad: f_y varies
    const Eigen::Vector3d f = physics::paper_table(h, deg * physics::kDegToRad) *
                              Eigen::Vector3d(0, 0, 9.81);
    model::Stimulus<double> s;
    s.input = s.specific_force = f;
    st.push_back(s);
  }
  std::vector<int> inside(4, 0);
  const int seeds = 2000;
  for (int seed = 0; seed < seeds; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    const Eigen::VectorXd theta = random_theta(m, rng);
    // Only the z row: bias_z, scale_z, cross_zx, cross_zy. Heteroscedastic noise (odd rows twice
    // as noisy) with weights known up to an arbitrary factor.
    const std::vector<int> cols = {2, 5, 10, 11};
    std::normal_distribution<double> n(0.0, 1.0);
    LsqProblem z;
    z.design.resize(8, 4);
    z.observations.resize(8);
    z.weights.resize(8);
    for (int i = 0; i < 8; ++i) {
      const double sd = (i % 2 ? 2.0 : 1.0) * 0.01;
      const auto phi = m.regressor(st[static_cast<std::size_t>(i)]);
      for (int j = 0; j < 4; ++j) z.design(i, j) = phi(2, cols[static_cast<std::size_t>(j)]);
      z.observations[i] = phi.row(2).dot(theta) + sd * n(rng);
      z.weights[i] = 7.0 / (sd * sd);
    }
    const LsqResult r = solve_lsq(z);
    ASSERT_TRUE(r.ok()) << r.message;
    ASSERT_EQ(r.dof, 4);
    for (int j = 0; j < 4; ++j) {
      const double truth = theta[cols[static_cast<std::size_t>(j)]];
      const auto& e = r.parameters[static_cast<std::size_t>(j)];
      if (truth >= e.lower && truth <= e.upper) ++inside[static_cast<std::size_t>(j)];
    }
  }
  for (int j = 0; j < 4; ++j) {
    const double c = inside[static_cast<std::size_t>(j)] / static_cast<double>(seeds);
    std::printf("coverage (dof 4, weighted) param %d %.3f\n", j, c);
    EXPECT_GE(c, 0.90);
    EXPECT_LE(c, 0.98);
  }
}

TEST(LinearLsq, ZeroColumnIsNotIdentifiableAndPrintsNoValue) {
  // Rotation about y only (h = 0): f_y ≡ 0, so cross_zy has a zero column.
  std::mt19937 rng(5);
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}, {TermKind::kCrossAxis}});
  Eigen::VectorXd theta = random_theta(m, rng);
  std::vector<model::Stimulus<double>> st;
  for (double deg = 0; deg < 360; deg += 15) {
    model::Stimulus<double> s;
    s.input = s.specific_force =
        physics::paper_table(0.0, deg * physics::kDegToRad) * Eigen::Vector3d(0, 0, 9.81);
    st.push_back(s);
  }
  LsqProblem full = synthetic(m, theta, st, 0.005, rng, {2});
  LsqProblem z;
  const std::vector<int> cols = {2, 5, 10, 11};
  z.design.resize(full.design.rows(), 4);
  for (int j = 0; j < 4; ++j) {
    z.design.col(j) = full.design.col(cols[static_cast<std::size_t>(j)]);
    z.names.push_back(full.names[static_cast<std::size_t>(cols[static_cast<std::size_t>(j)])]);
    z.units.push_back(full.units[static_cast<std::size_t>(cols[static_cast<std::size_t>(j)])]);
  }
  z.observations = full.observations;
  const LsqResult r = solve_lsq(z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.rank, 3);
  EXPECT_TRUE(std::isinf(r.condition_number));
  const auto& zy = r.parameter("cross_zy");
  EXPECT_FALSE(zy.identifiable);
  EXPECT_TRUE(std::isnan(zy.value));
  EXPECT_TRUE(std::isnan(zy.std_error));
  EXPECT_NE(zy.reason.find("not excited"), std::string::npos) << zy.reason;
  EXPECT_TRUE(r.aliases.empty());
  for (const char* name : {"bias_z", "scale_z", "cross_zx"}) {
    const auto& e = r.parameter(name);
    EXPECT_TRUE(e.identifiable) << name;
    EXPECT_LT(std::abs(e.value - theta[cols[static_cast<std::size_t>(r.index(name))]]), 5 * e.std_error);
  }
  std::ostringstream os;
  os << r;
  const std::string text = os.str();
  const auto line_start = text.find("cross_zy");
  ASSERT_NE(line_start, std::string::npos);
  const std::string line = text.substr(line_start, text.find('\n', line_start) - line_start);
  EXPECT_NE(line.find("not estimated"), std::string::npos) << line;
  EXPECT_NE(line.find("NO"), std::string::npos) << line;
  EXPECT_FALSE(std::regex_search(line, std::regex("[0-9]\\.[0-9]|[0-9]e[-+]")))
      << "a number is printed for a non-identifiable parameter: " << line;
  EXPECT_NE(text.find("rank-deficient"), std::string::npos);
  // Non-estimable combinations are refused.
  Eigen::VectorXd c = Eigen::VectorXd::Zero(4);
  c[3] = 1.0;
  EXPECT_FALSE(r.estimable(c));
  EXPECT_THROW(r.combination(c), std::domain_error);
}

TEST(LinearLsq, CollinearTermsReportedAsAliasedPairWithIdentifiedCombination) {
  // bias and bias_temperature (order 1, T0 = 25) at one constant temperature of 35 degC: the
  // columns 1 and (35 − 25) = 10 are proportional; only bias + 10·bias_tc1 is identified.
  std::mt19937 rng(8);
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale},
                                    {TermKind::kBiasTemperature, 1, 25.0}});
  const Eigen::VectorXd theta = random_theta(m, rng);
  const LsqProblem pr = synthetic(m, theta, cube_stimuli(9.81, 35.0), 0.003, rng);
  const LsqResult r = solve_lsq(pr);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.rank, 6);
  ASSERT_EQ(r.aliases.size(), 3u);  // one pair per axis
  for (int a = 0; a < 3; ++a) {
    const std::string ax(1, "xyz"[a]);
    const auto& g = r.aliases[static_cast<std::size_t>(a)];
    ASSERT_EQ(g.parameters.size(), 2u);
    EXPECT_EQ(r.parameters[static_cast<std::size_t>(g.parameters[0])].name, "bias_" + ax);
    EXPECT_EQ(r.parameters[static_cast<std::size_t>(g.parameters[1])].name, "bias_tc1_" + ax);
    EXPECT_EQ(g.null_dimension, 1);
    ASSERT_EQ(g.identified.size(), 1u);
    const Combination& c = g.identified[0];
    EXPECT_EQ(c.text, "bias_" + ax + " + 10*bias_tc1_" + ax);
    const double truth = theta[a] + 10.0 * theta[6 + a];
    EXPECT_LT(std::abs(c.value - truth), 5 * c.std_error) << c.text;
    EXPECT_GT(c.std_error, 0.0);
    for (int j : g.parameters) {
      const auto& e = r.parameters[static_cast<std::size_t>(j)];
      EXPECT_FALSE(e.identifiable);
      EXPECT_TRUE(std::isnan(e.value));
      EXPECT_NE(e.reason.find("aliased with"), std::string::npos);
      EXPECT_NE(e.reason.find("bias_" + ax + " + 10*bias_tc1_" + ax), std::string::npos);
      // The direction the design cannot see, named: δbias = −10·δbias_tc1.
      EXPECT_NE(e.reason.find("do not see bias_" + ax + " - 0.1*bias_tc1_" + ax), std::string::npos) << e.reason;
      EXPECT_EQ(e.judged(), Verdict::kNotIdentifiable);
    }
    EXPECT_NE(std::find(r.warnings.begin(), r.warnings.end(),
                        "unidentified combination: bias_" + ax + " - 0.1*bias_tc1_" + ax +
                            " (a singular direction of the design; add orientations or inputs that separate these "
                            "parameters)"),
              r.warnings.end());
    EXPECT_TRUE(r.parameter("scale_" + ax).identifiable);
  }
  std::ostringstream os;
  os << r;
  EXPECT_NE(os.str().find("identified: bias_x + 10*bias_tc1_x = "), std::string::npos) << os.str();
}

TEST(LinearLsq, VerdictsJudgeTheStandardErrorAgainstAUnitAwareTolerance) {
  std::mt19937 rng(12);
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}});
  const Eigen::VectorXd theta = random_theta(m, rng);
  const LsqProblem pr = synthetic(m, theta, cube_stimuli(9.81), 0.003, rng);
  const LsqResult r = solve_lsq(pr);
  ASSERT_TRUE(r.ok()) << r.message;
  for (const auto& e : r.parameters) {
    EXPECT_EQ(e.judged(), Verdict::kDetermined) << e.name;
    // bias: 1 mg in m/s^2; scale: 1000 ppm.
    EXPECT_DOUBLE_EQ(e.tolerance, e.unit == "m/s^2" ? 1e-3 * 9.80665 : 1e-3) << e.name;
  }
  // Tolerances tighter than the standard errors: every parameter is still reported, with its value,
  // and flagged imprecise.
  LsqOptions tight;
  tight.tolerances.accel_bias_mg = 1e-6;
  tight.tolerances.scale_cross_ppm = 1e-3;
  const LsqResult t = solve_lsq(pr, tight);
  ASSERT_TRUE(t.ok());
  for (const auto& e : t.parameters) {
    EXPECT_TRUE(e.identifiable);
    EXPECT_TRUE(std::isfinite(e.value));
    EXPECT_EQ(e.judged(), Verdict::kImprecise) << e.name;
    EXPECT_NE(e.reason.find("interval's half-width"), std::string::npos) << e.reason;
    EXPECT_NE(e.reason.find("exceeds 1.96 × the tolerance"), std::string::npos) << e.reason;
  }
  std::ostringstream os;
  os << t;
  EXPECT_NE(os.str().find("imprecise: the 95 % interval"), std::string::npos) << os.str();
  // Units the tolerances do not cover are judged by identifiability alone.
  EXPECT_TRUE(std::isnan(tolerance_for("m", PrecisionTolerances{})));
  EXPECT_DOUBLE_EQ(tolerance_for("m/s^2/degC^2", PrecisionTolerances{}), 1e-3 * 9.80665 / 100.0);
  EXPECT_DOUBLE_EQ(tolerance_for("rad/s", PrecisionTolerances{}), 0.05 * std::numbers::pi / 180.0);
  EXPECT_EQ(tolerance_text("1/degC", PrecisionTolerances{}), "1000 ppm over 10 degC");
}

TEST(LinearLsq, RefusesWhenUnderdetermined) {
  LsqProblem pr;
  pr.design = Eigen::MatrixXd::Random(3, 5);
  pr.observations = Eigen::VectorXd::Random(3);
  const LsqResult r = solve_lsq(pr);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.message.find("underdetermined"), std::string::npos) << r.message;
  EXPECT_EQ(r.estimate.size(), 0);
  for (const auto& e : r.parameters) {
    EXPECT_FALSE(e.identifiable);
    EXPECT_TRUE(std::isnan(e.value));
  }
  std::ostringstream os;
  os << r;
  EXPECT_EQ(os.str().rfind("FIT FAILED: underdetermined", 0), 0u) << os.str();
  EXPECT_EQ(os.str().find("e-"), std::string::npos);
  EXPECT_THROW(r.combination(Eigen::VectorXd::Ones(5)), std::domain_error);

  // k = p: an exact fit leaves no degree of freedom for the noise; refused too …
  pr.design = Eigen::MatrixXd::Random(5, 5);
  pr.observations = Eigen::VectorXd::Random(5);
  EXPECT_FALSE(solve_lsq(pr).ok());
  // … unless the variances are known.
  LsqOptions known;
  known.known_variance = true;
  const LsqResult rk = solve_lsq(pr, known);
  EXPECT_TRUE(rk.ok()) << rk.message;
  EXPECT_NEAR(rk.quantile, 1.959964, 1e-5);
}

TEST(LinearLsq, WarnsWhenFewObservationsAndIllConditioned) {
  LsqProblem pr;
  pr.design.resize(6, 3);
  pr.observations.resize(6);
  for (int i = 0; i < 6; ++i) {
    const double x = 1.0 + 1e-7 * i;
    pr.design.row(i) << 1.0, x, std::sin(static_cast<double>(i));
    pr.observations[i] = 0.1 * i;
  }
  pr.names = {"a", "b", "c"};
  const LsqResult r = solve_lsq(pr);
  ASSERT_TRUE(r.ok());
  bool few = false, ill = false;
  for (const auto& w : r.warnings) {
    few = few || w.find("few observations") != std::string::npos;
    ill = ill || (w.find("ill-conditioned") != std::string::npos && w.find("a") != std::string::npos);
  }
  EXPECT_TRUE(few);
  EXPECT_TRUE(ill);
  EXPECT_GT(r.condition_number, 1e6);
}

TEST(LinearLsq, ColumnScalingMakesUnitsIrrelevant) {
  std::mt19937 rng(2);
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}});
  const Eigen::VectorXd theta = random_theta(m, rng);
  LsqProblem pr = synthetic(m, theta, cube_stimuli(9.81), 0.01, rng);
  const LsqResult a = solve_lsq(pr);
  pr.design.col(4) *= 1e6;  // scale_y in ppm instead of 1
  const LsqResult b = solve_lsq(pr);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NEAR(a.condition_number, b.condition_number, 1e-9 * a.condition_number);
  EXPECT_NEAR(b.estimate[4] * 1e6, a.estimate[4], 1e-9 * std::abs(a.estimate[4]));
  EXPECT_NEAR(b.parameters[4].std_error * 1e6, a.parameters[4].std_error, 1e-9 * a.parameters[4].std_error);
  EXPECT_FALSE(approx_equal(a, b, 1e-6));
}

TEST(LinearLsq, ApproxEqualHonoursTolerance) {
  std::mt19937 rng(4);
  const ErrorModel m = accel_model({{TermKind::kBias}, {TermKind::kScale}});
  const Eigen::VectorXd theta = random_theta(m, rng);
  LsqProblem pr = synthetic(m, theta, cube_stimuli(9.81), 0.01, rng);
  const LsqResult a = solve_lsq(pr);
  pr.observations[0] += 1e-9;
  const LsqResult b = solve_lsq(pr);
  EXPECT_TRUE(approx_equal(a, a));
  EXPECT_FALSE(approx_equal(a, b, 1e-14));
  EXPECT_TRUE(approx_equal(a, b, 1e-5));
  std::ostringstream os;
  os << a;
  EXPECT_NE(os.str().find("bias_x"), std::string::npos);
  EXPECT_NE(os.str().find("95% interval"), std::string::npos);
}

// ------------------------------------------------------------------------------------------------
// The verdict from the interval (identifiability.hpp): the same standard error, 1 or 100 degrees of
// freedom.

TEST(Verdict, TheSameStandardErrorIsImpreciseWithOneDegreeOfFreedomAndDeterminedWithAHundred) {
  const PrecisionTolerances t;
  const double tol = tolerance_for("1", t);  // 1000 ppm
  const double se = 0.8 * tol;               // within the tolerance at 1 σ
  const IntervalBasis one{0.95, interval_quantile(0.95, 1)};
  const IntervalBasis hundred{0.95, interval_quantile(0.95, 100)};
  const IntervalBasis a_priori{0.95, interval_quantile(0.95, kAPrioriDof)};
  EXPECT_NEAR(one.quantile, 12.706, 1e-3);
  EXPECT_NEAR(hundred.quantile, 1.984, 1e-3);
  EXPECT_NEAR(a_priori.quantile, 1.95996, 1e-5);
  EXPECT_TRUE(std::isnan(interval_quantile(0.95, 0)));  // no residual: no t
  EXPECT_EQ(precision_verdict(se, one, "1", t), Verdict::kImprecise);
  EXPECT_EQ(precision_verdict(se, hundred, "1", t), Verdict::kDetermined);
  EXPECT_EQ(precision_verdict(se, a_priori, "1", t), Verdict::kDetermined);
  // A standard error just inside the tolerance stays determined with many dof, and is imprecise
  // once t · se passes z · tolerance.
  EXPECT_EQ(precision_verdict(0.98 * tol, hundred, "1", t), Verdict::kDetermined);
  EXPECT_EQ(precision_verdict(1.01 * tol, hundred, "1", t), Verdict::kImprecise);
  EXPECT_EQ(precision_verdict(std::nan(""), hundred, "1", t), Verdict::kImprecise);
  EXPECT_EQ(precision_verdict(1.0, one, "deg", t), Verdict::kDetermined);  // no tolerance applies
}

// A bias fitted from k readings of a constant, their scatter giving a standard error of 0.8 mg:
// with two readings (1 dof) it is imprecise, the reason naming the interval; with 101 it is
// determined.
TEST(Verdict, ABiasFromTwoReadingsIsImpreciseAndFromManyDetermined) {
  auto fit = [](int k) {
    LsqProblem pr;
    pr.design = Eigen::MatrixXd::Ones(k, 1);
    pr.observations.resize(k);
    // Alternating ±d about 0 (k even) or with one 0 (k odd): standard error 0.8 mg for both sizes.
    const double se = 0.8e-3 * 9.80665;
    const double d = k == 2 ? se : se * std::sqrt(static_cast<double>(k));
    for (int i = 0; i < k; ++i) pr.observations[i] = (i == k - 1 && k % 2 == 1) ? 0.0 : (i % 2 ? d : -d);
    pr.names = {"bias_z"};
    pr.units = {"m/s^2"};
    return solve_lsq(pr);
  };
  const LsqResult two = fit(2), many = fit(101);
  ASSERT_TRUE(two.ok() && many.ok());
  EXPECT_EQ(two.dof, 1);
  EXPECT_EQ(many.dof, 100);
  EXPECT_NEAR(two.parameters[0].std_error, 0.8e-3 * 9.80665, 1e-9);
  EXPECT_NEAR(many.parameters[0].std_error, 0.8e-3 * 9.80665, 1e-4 * 9.80665);
  EXPECT_EQ(two.parameters[0].judged(), Verdict::kImprecise);
  EXPECT_NE(two.parameters[0].reason.find("half-width"), std::string::npos) << two.parameters[0].reason;
  EXPECT_EQ(many.parameters[0].judged(), Verdict::kDetermined);
}
