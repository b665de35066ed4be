// Tests of linear-model effects. See stend/stats/hypothesis_tests.hpp.
#include "stend/stats/hypothesis_tests.hpp"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "stend/stats/distributions.hpp"

namespace stend::stats {

TestResult nested_f_test(double rss_reduced, double rss_full, int added_rank, int dof_full, double effective_share) {
  TestResult t;
  t.statistic = ((rss_reduced - rss_full) / added_rank) / (rss_full / dof_full) * effective_share;
  t.p_value = f_sf(std::max(0.0, t.statistic), added_rank, std::max(1.0, dof_full * effective_share));
  return t;
}

TestResult wald_test(const Eigen::VectorXd& estimate, const Eigen::MatrixXd& covariance) {
  TestResult t;
  t.statistic = estimate.dot(covariance.ldlt().solve(estimate));
  t.p_value = std::isfinite(t.statistic) ? chi2_sf(t.statistic, static_cast<double>(estimate.size())) : 1.0;
  return t;
}

Eigen::MatrixXd long_run_covariance(const Eigen::MatrixXd& g) {
  const int T = static_cast<int>(g.cols());
  const int L = std::max(1, T / 4);
  Eigen::MatrixXd S = g * g.transpose();
  for (int l = 1; l <= L && l < T; ++l) {
    const Eigen::MatrixXd G = g.leftCols(T - l) * g.rightCols(T - l).transpose();
    S += (1.0 - l / (L + 1.0)) * (G + G.transpose());
  }
  return S;
}

int numerical_rank(const Eigen::VectorXd& sv, double relative) {
  int q = 0;
  while (q < sv.size() && sv[q] > relative * sv[0]) ++q;
  return q;
}

double projected_f_p_value(const Eigen::MatrixXd& Q, const Eigen::VectorXd& r, const Eigen::MatrixXd& C,
                           Eigen::Index rows) {
  Eigen::MatrixXd outside = C;
  if (Q.cols() > 0) outside -= Q * (Q.transpose() * outside);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(outside, Eigen::ComputeThinU);
  const int q = numerical_rank(svd.singularValues());
  const Eigen::Index dof = rows - Q.cols() - q;
  if (q == 0 || dof <= 0) return 1.0;
  const Eigen::VectorXd beta = svd.matrixU().leftCols(q).transpose() * r;
  const double rss = r.squaredNorm() - beta.squaredNorm();
  if (!(rss > 0)) return 1.0;
  const double F = (beta.squaredNorm() / q) / (rss / static_cast<double>(dof));
  return f_sf(F, q, static_cast<double>(dof));
}

std::vector<bool> benjamini_yekutieli(const std::vector<double>& p, double q) {
  const std::size_t m = p.size();
  std::vector<bool> reject(m, false);
  if (m == 0) return reject;
  double cm = 0;
  for (std::size_t i = 1; i <= m; ++i) cm += 1.0 / static_cast<double>(i);
  std::vector<double> sorted;
  for (double v : p)
    if (std::isfinite(v)) sorted.push_back(v);
  std::sort(sorted.begin(), sorted.end());
  double cut = -1;  // the largest p rejected
  for (std::size_t k = 1; k <= sorted.size(); ++k)
    if (sorted[k - 1] <= static_cast<double>(k) * q / (static_cast<double>(m) * cm)) cut = sorted[k - 1];
  for (std::size_t i = 0; i < m; ++i) reject[i] = std::isfinite(p[i]) && p[i] <= cut;
  return reject;
}

}  // namespace stend::stats
