// The covariance of the gap's segment means in time (internal to stend_diagnosis). A slowly
// wandering bias (Gauss–Markov, correlation time of minutes) correlates segment means over many
// segments: lag-1 and HAC corrections underestimate what a slow regressor sees. Per axis the rows'
// covariance is floor²·(δ_ij + λ·exp(−|t_i − t_j|/τ)) at the segment mid-times t [s]; λ, τ by
// restricted likelihood (REML, stend/stats/gls.hpp) on a grid, with the fixed effects of the most
// general model (the model plus every candidate), so a planted effect cannot inflate it. The
// estimate is weak (a wander of a fraction of the floor), so candidates are tested under every
// covariance the data do not reject and the largest p value is kept.
#pragma once

#include <vector>

#include "linear_problem.hpp"
#include "stend/stats/gls.hpp"

namespace stend::diagnosis {

// One covariance of the likelihood region, its per-axis blocks factored.
struct CovarianceCandidate {
  double lambda = 0.0, tau_s = 0.0;
  stats::BlockWhitening whitening;
};

struct SegmentCovariance {
  bool found = false;                        // a correlated covariance in the region
  double lambda = 0.0, tau_s = 0.0;          // the REML estimate
  std::vector<CovarianceCandidate> region;   // profile log-likelihood within χ²₂(95 %)/2 of the best, λ > 0
};

// REML over λ ∈ {0, 0.05, 0.15, 0.4, 1} × τ ∈ {0.03, 0.1, 0.3}·(time span of the segments), fixed
// effects `all_columns`. Not found (no GLS test) when the segments span no time, there are no
// columns, more than 600 segments on an axis (n³ per grid point is not spent) or fewer than 5 rows
// beyond the fixed effects' rank.
SegmentCovariance estimate_segment_covariance(const GapInput& input, const Rows& rows, const MatrixXd& all_columns);

// The rows of X weighted by √w, then whitened by the candidate's per-axis factors.
MatrixXd whiten(const CovarianceCandidate& covariance, const Rows& rows, const MatrixXd& X);

// Per model step: for each covariance of the region the whitened model basis and the whitened
// residual of the rows on it.
struct GlsStep {
  std::vector<MatrixXd> basis;
  std::vector<VectorXd> residual;
};
GlsStep gls_prepare(const SegmentCovariance& covariance, const Rows& rows, const MatrixXd& model_columns);

// GLS partial F test of the candidate columns C against the step's model: the largest p over the
// region.
double gls_p_value(const SegmentCovariance& covariance, const GlsStep& step, const Rows& rows, const MatrixXd& C);

}  // namespace stend::diagnosis
