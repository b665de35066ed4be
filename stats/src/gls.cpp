// Correlation matrices, whitening and the REML log-likelihood. See stend/stats/gls.hpp.
#include "stend/stats/gls.hpp"

#include <cmath>
#include <utility>

namespace stend::stats {

Eigen::MatrixXd exponential_correlation(const std::vector<double>& t, double lambda, double tau) {
  const auto n = static_cast<Eigen::Index>(t.size());
  Eigen::MatrixXd V = Eigen::MatrixXd::Identity(n, n);
  if (lambda > 0)
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j)
        V(i, j) += lambda * std::exp(-std::abs(t[static_cast<std::size_t>(i)] - t[static_cast<std::size_t>(j)]) / tau);
  return V;
}

Eigen::MatrixXd shrunk_cholesky(Eigen::MatrixXd R) {
  const Eigen::Index n = R.rows();
  for (;;) {
    Eigen::LLT<Eigen::MatrixXd> llt(R);
    if (llt.info() == Eigen::Success) return llt.matrixL();
    R = 0.9 * R + 0.1 * Eigen::MatrixXd::Identity(n, n);
  }
}

std::optional<BlockWhitening> BlockWhitening::factor(std::vector<std::vector<Eigen::Index>> blocks,
                                                     const std::vector<Eigen::MatrixXd>& correlations) {
  BlockWhitening w;
  w.factors_.reserve(correlations.size());  // no copies of factored matrices as the vector grows
  for (const auto& R : correlations) {
    w.factors_.emplace_back(R);
    if (w.factors_.back().info() != Eigen::Success) return std::nullopt;
  }
  w.blocks_ = std::move(blocks);
  return w;
}

Eigen::MatrixXd BlockWhitening::whiten(const Eigen::MatrixXd& X) const {
  Eigen::MatrixXd out(X.rows(), X.cols());
  for (std::size_t b = 0; b < blocks_.size(); ++b) {
    const auto& rows = blocks_[b];
    Eigen::MatrixXd B(static_cast<Eigen::Index>(rows.size()), X.cols());
    for (std::size_t i = 0; i < rows.size(); ++i) B.row(static_cast<Eigen::Index>(i)) = X.row(rows[i]);
    B = factors_[b].matrixL().solve(B);
    for (std::size_t i = 0; i < rows.size(); ++i) out.row(rows[i]) = B.row(static_cast<Eigen::Index>(i));
  }
  return out;
}

double BlockWhitening::log_determinant() const {
  double logdet = 0.0;
  for (const auto& f : factors_) logdet += 2.0 * f.matrixL().toDenseMatrix().diagonal().array().log().sum();
  return logdet;
}

std::optional<double> reml_log_likelihood(const BlockWhitening& R, const Eigen::VectorXd& y, const Eigen::MatrixXd& X) {
  const Eigen::MatrixXd Xw = R.whiten(X);
  const Eigen::VectorXd yw = R.whiten(y);
  const Eigen::MatrixXd M = Xw.transpose() * Xw;
  const Eigen::VectorXd b = Xw.transpose() * yw;
  Eigen::LLT<Eigen::MatrixXd> lm(M);
  if (lm.info() != Eigen::Success) return std::nullopt;
  const double q = yw.squaredNorm() - b.dot(lm.solve(b));
  if (!(q > 0)) return std::nullopt;
  return -0.5 * (static_cast<double>(y.size() - X.cols()) * std::log(q) + R.log_determinant() +
                 2.0 * lm.matrixL().toDenseMatrix().diagonal().array().log().sum());
}

}  // namespace stend::stats
