// Generalized least squares: whitening makes correlated rows independent, REML's value in the
// independent case and its preference for the true correlation.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "stend/stats/gls.hpp"

using namespace stend::stats;

TEST(ExponentialCorrelation, Shape) {
  const Eigen::MatrixXd V = exponential_correlation({0.0, 1.0, 3.0}, 0.5, 2.0);
  EXPECT_DOUBLE_EQ(V(0, 0), 1.5);
  EXPECT_DOUBLE_EQ(V(0, 1), 0.5 * std::exp(-0.5));
  EXPECT_DOUBLE_EQ(V(2, 0), 0.5 * std::exp(-1.5));
  EXPECT_TRUE(exponential_correlation({0.0, 1.0}, 0.0, 2.0).isIdentity());
}

TEST(ShrunkCholesky, ExactWhenPositiveDefiniteShrunkOtherwise) {
  const Eigen::MatrixXd R = exponential_correlation({0.0, 0.5, 2.0, 2.5}, 0.8, 1.0);
  const Eigen::MatrixXd L = shrunk_cholesky(R);
  EXPECT_LT((L * L.transpose() - R).norm(), 1e-14);
  Eigen::Matrix3d bad;
  bad << 1, 0.99, -0.99, 0.99, 1, 0.99, -0.99, 0.99, 1;  // not positive definite
  const Eigen::MatrixXd Lb = shrunk_cholesky(bad);
  const Eigen::MatrixXd S = Lb * Lb.transpose();
  EXPECT_LT((S.diagonal() - Eigen::Vector3d::Ones()).norm(), 1e-14);  // still a correlation
  EXPECT_LT(std::abs(S(0, 1)), 0.99);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(S).eigenvalues().minCoeff(), 0.0);
}

TEST(BlockWhitening, WhitenedRowsAreIndependent) {
  const Eigen::MatrixXd R0 = exponential_correlation({0, 1, 2}, 0.7, 1.5), R1 = exponential_correlation({0, 4}, 0.3, 1.0);
  // Rows 0, 2, 4 in block 0 and 1, 3 in block 1: the full correlation is R0 ⊕ R1 permuted.
  const auto w = BlockWhitening::factor({{0, 2, 4}, {1, 3}}, {R0, R1});
  ASSERT_TRUE(w);
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(5, 5);
  const int b0[3] = {0, 2, 4}, b1[2] = {1, 3};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(b0[i], b0[j]) = R0(i, j);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) R(b1[i], b1[j]) = R1(i, j);
  // L⁻¹ R L⁻ᵀ = I
  const Eigen::MatrixXd half = w->whiten(R);
  const Eigen::MatrixXd I = w->whiten(Eigen::MatrixXd(half.transpose()));
  EXPECT_LT((I - Eigen::MatrixXd::Identity(5, 5)).norm(), 1e-13);
  EXPECT_NEAR(w->log_determinant(), std::log(R.determinant()), 1e-12);
  Eigen::Matrix2d bad;
  bad << 1, 2, 2, 1;
  EXPECT_FALSE(BlockWhitening::factor({{0, 1}}, {bad}));
}

TEST(Reml, IndependentRowsAndTheTrueCorrelationWins) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  const int rows = 200;
  std::vector<double> t(rows);
  for (int i = 0; i < rows; ++i) t[static_cast<std::size_t>(i)] = i;
  Eigen::MatrixXd X(rows, 1);
  X.setOnes();
  X /= std::sqrt(static_cast<double>(rows));  // orthonormal
  // Independent rows: −½ (n − p) ln q with q the residual sum of squares about the mean.
  Eigen::VectorXd y(rows);
  for (int i = 0; i < rows; ++i) y[i] = 3.0 + n(rng);
  std::vector<Eigen::Index> all(rows);
  for (int i = 0; i < rows; ++i) all[static_cast<std::size_t>(i)] = i;
  const auto id = BlockWhitening::factor({all}, {Eigen::MatrixXd::Identity(rows, rows)});
  ASSERT_TRUE(id);
  const double q = (y.array() - y.mean()).matrix().squaredNorm();
  EXPECT_NEAR(*reml_log_likelihood(*id, y, X), -0.5 * (rows - 1) * std::log(q), 1e-9);
  // Rows with a strong slow component: REML prefers the correlation they were drawn from.
  const Eigen::MatrixXd R = exponential_correlation(t, 1.0, 20.0);
  const Eigen::MatrixXd L = R.llt().matrixL();
  Eigen::VectorXd e(rows);
  for (int i = 0; i < rows; ++i) e[i] = n(rng);
  const Eigen::VectorXd yc = Eigen::VectorXd::Constant(rows, 3.0) + L * e;
  const auto truth = BlockWhitening::factor({all}, {R});
  ASSERT_TRUE(truth);
  EXPECT_GT(*reml_log_likelihood(*truth, yc, X), *reml_log_likelihood(*id, yc, X));
}
