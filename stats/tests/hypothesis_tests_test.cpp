// Tests of linear-model effects against their definitions and textbook equivalences.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <random>

#include "stend/stats/distributions.hpp"
#include "stend/stats/hypothesis_tests.hpp"

using namespace stend::stats;

namespace {

Eigen::MatrixXd random_matrix(int rows, int cols, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) m(i, j) = n(rng);
  return m;
}

// Residual sum of squares of y on the columns of A (least squares).
double rss(const Eigen::MatrixXd& A, const Eigen::VectorXd& y) {
  const Eigen::VectorXd beta = A.colPivHouseholderQr().solve(y);
  return (y - A * beta).squaredNorm();
}

}  // namespace

TEST(NestedFTest, OneColumnIsTheTwoSidedTTest) {
  // F(1, d) = t(d)²: the p value of an added column is the two-sided t test's.
  const TestResult t = nested_f_test(12.0, 9.0, 1, 20);
  EXPECT_NEAR(t.statistic, (3.0 / 1.0) / (9.0 / 20.0), 1e-12);
  EXPECT_NEAR(t.p_value, 2.0 * (1.0 - student_t_cdf(std::sqrt(t.statistic), 20.0)), 1e-12);
}

TEST(NestedFTest, EffectiveShareShrinksTheEvidence) {
  const TestResult full = nested_f_test(12.0, 9.0, 2, 30), half = nested_f_test(12.0, 9.0, 2, 30, 0.5);
  EXPECT_NEAR(half.statistic, 0.5 * full.statistic, 1e-12);
  EXPECT_NEAR(half.p_value, f_sf(half.statistic, 2, 15), 1e-15);
  EXPECT_GT(half.p_value, full.p_value);
}

TEST(WaldTest, IdentityCovarianceIsTheSquaredNorm) {
  Eigen::Vector2d beta(1.5, -2.0);
  const TestResult t = wald_test(beta, Eigen::Matrix2d::Identity());
  EXPECT_NEAR(t.statistic, beta.squaredNorm(), 1e-15);
  EXPECT_NEAR(t.p_value, std::exp(-0.5 * t.statistic), 1e-15);  // χ²₂
  EXPECT_NEAR(wald_test(beta, 4.0 * Eigen::Matrix2d::Identity()).statistic, beta.squaredNorm() / 4.0, 1e-15);
}

TEST(LongRunCovariance, BartlettWeights) {
  // T = 8, L = 2: S = Γ0 + (2/3)(Γ1 + Γ1ᵀ) + (1/3)(Γ2 + Γ2ᵀ), Γl = Σ_t g_t g_{t+l}ᵀ.
  std::mt19937 rng(3);
  const Eigen::MatrixXd g = random_matrix(2, 8, rng);
  Eigen::MatrixXd expect = g * g.transpose();
  for (int l = 1; l <= 2; ++l) {
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(2, 2);
    for (int t = 0; t + l < 8; ++t) G += g.col(t) * g.col(t + l).transpose();
    expect += (1.0 - l / 3.0) * (G + G.transpose());
  }
  EXPECT_LT((long_run_covariance(g) - expect).norm(), 1e-12);
  const Eigen::MatrixXd one = random_matrix(3, 1, rng);
  EXPECT_LT((long_run_covariance(one) - one * one.transpose()).norm(), 1e-15);
}

TEST(NumericalRank, RelativeThreshold) {
  EXPECT_EQ(numerical_rank(Eigen::Vector3d(10.0, 1e-3, 1e-9)), 2);
  EXPECT_EQ(numerical_rank(Eigen::Vector3d(10.0, 1e-3, 1e-9), 1e-2), 1);
  EXPECT_EQ(numerical_rank(Eigen::VectorXd()), 0);
}

TEST(ProjectedFTest, EqualsTheNestedFTestOfOrdinaryFits) {
  std::mt19937 rng(7);
  const int n = 40;
  const Eigen::MatrixXd X = random_matrix(n, 3, rng), C = random_matrix(n, 2, rng);
  Eigen::VectorXd y = X * Eigen::Vector3d(1.0, -2.0, 0.5) + 0.3 * C.col(0) + random_matrix(n, 1, rng);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(X);
  const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(n, 3);
  const Eigen::VectorXd r = y - Q * (Q.transpose() * y);
  Eigen::MatrixXd XC(n, 5);
  XC << X, C;
  const double rss0 = rss(X, y), rss1 = rss(XC, y);
  EXPECT_NEAR(projected_f_p_value(Q, r, C, n), nested_f_test(rss0, rss1, 2, n - 5).p_value, 1e-10);
  // No degree of freedom left: p = 1.
  EXPECT_EQ(projected_f_p_value(Q, r, C, 5), 1.0);
  // Without a model: the test of C alone.
  const double rss_c = rss(C, y);
  EXPECT_NEAR(projected_f_p_value(Eigen::MatrixXd(n, 0), y, C, n),
              nested_f_test(y.squaredNorm(), rss_c, 2, n - 2).p_value, 1e-10);
}

// Benjamini–Yekutieli: m = 4, c(4) = 25/12; the step-up thresholds k·q/(m·c) at q = 0.05 are
// 0.006, 0.012, 0.018, 0.024. The largest k under its threshold sets the cut (step-up: p_(1)
// rides along), NaN is never rejected but counts in m.
TEST(BenjaminiYekutieli, StepUpWithTheDependenceFactor) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(stend::stats::benjamini_yekutieli({0.007, 0.011, 0.5, nan}, 0.05),
            (std::vector<bool>{true, true, false, false}));
  EXPECT_EQ(stend::stats::benjamini_yekutieli({0.007, 0.5, 0.9, 0.9}, 0.05),
            (std::vector<bool>{false, false, false, false}));
  EXPECT_EQ(stend::stats::benjamini_yekutieli({0.0059}, 0.05), (std::vector<bool>{true}));
  EXPECT_TRUE(stend::stats::benjamini_yekutieli({}, 0.05).empty());
}
