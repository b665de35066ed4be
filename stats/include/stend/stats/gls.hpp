// Generalized least squares on correlated rows: correlation matrices, their Cholesky whitening
// (rows with correlation R = L·Lᵀ become independent after L⁻¹), and the restricted (REML)
// log-likelihood by which a covariance is estimated with the fixed effects profiled out. The gap
// diagnosis models slowly correlated segment means with these; the Allan noise fit whitens its
// overlapping AVAR points.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <optional>
#include <vector>

namespace stend::stats {

// δ_ij + λ·exp(−|t_i − t_j|/τ): the correlation of rows at times t [s] that share an exponentially
// correlated component of relative variance λ ≥ 0 and correlation time τ > 0 [s].
Eigen::MatrixXd exponential_correlation(const std::vector<double>& t_s, double lambda, double tau_s);

// The lower Cholesky factor of the correlation R; when R is not positive definite, of R shrunk
// towards the identity (R ← 0.9·R + 0.1·I, repeated) until it is.
Eigen::MatrixXd shrunk_cholesky(Eigen::MatrixXd R);

// Rows correlated within blocks and independent between them, each block's correlation factored.
class BlockWhitening {
 public:
  // blocks[b]: the row indices of block b (every row in one block); correlations[b]: its
  // correlation matrix. nullopt when one is not positive definite.
  static std::optional<BlockWhitening> factor(std::vector<std::vector<Eigen::Index>> blocks,
                                              const std::vector<Eigen::MatrixXd>& correlations);
  // L⁻¹X, block by block (rows in X's order).
  Eigen::MatrixXd whiten(const Eigen::MatrixXd& X) const;
  // ln det R of the whole (block-diagonal) correlation.
  double log_determinant() const;

 private:
  std::vector<std::vector<Eigen::Index>> blocks_;
  std::vector<Eigen::LLT<Eigen::MatrixXd>> factors_;
};

// Restricted log-likelihood, up to a constant, of y = Xβ + e with e ~ N(0, σ²·R), β and σ²
// profiled out: −½[(n − p)·ln q + ln det R + ln det(XᵀR⁻¹X)], q the GLS residual sum of squares,
// X an n × p basis of the fixed effects with orthonormal columns (REML does not depend on the
// basis; the same basis for every R compared). nullopt when XᵀR⁻¹X is singular or q ≤ 0.
std::optional<double> reml_log_likelihood(const BlockWhitening& R, const Eigen::VectorXd& y, const Eigen::MatrixXd& X);

}  // namespace stend::stats
