// The covariance of the gap's segment means in time. See segment_covariance.hpp.
#include "segment_covariance.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "stend/stats/hypothesis_tests.hpp"

namespace stend::diagnosis {

namespace {

// Rows per axis (blocks) and the mid-times [s] of their segments.
struct AxisBlocks {
  std::vector<std::vector<Eigen::Index>> rows;
  std::vector<std::vector<double>> t_s;
};
AxisBlocks axis_blocks(const GapInput& in, const Rows& rows) {
  AxisBlocks b;
  std::map<int, std::size_t> slot_of_axis;
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const int a = rows.axis[static_cast<std::size_t>(r)];
    if (!slot_of_axis.count(a)) {
      slot_of_axis[a] = b.rows.size();
      b.rows.emplace_back();
      b.t_s.emplace_back();
    }
    const auto& p = in.segments[static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)])].point;
    b.rows[slot_of_axis[a]].push_back(r);
    b.t_s[slot_of_axis[a]].push_back(0.5 * (p.t_start_s + p.t_end_s));
  }
  return b;
}

// The blocks' correlations at (λ, τ [s]), factored; nullopt when one is not positive definite.
std::optional<stats::BlockWhitening> factor(const AxisBlocks& b, double lambda, double tau_s) {
  std::vector<MatrixXd> correlations;
  for (const auto& t : b.t_s) correlations.push_back(stats::exponential_correlation(t, lambda, tau_s));
  return stats::BlockWhitening::factor(b.rows, correlations);
}

// Longest time span [s] of one axis' segments, and its most segments.
double time_span(const AxisBlocks& b, std::size_t* most_rows) {
  double span = 0;
  *most_rows = 0;
  for (const auto& t : b.t_s) {
    *most_rows = std::max(*most_rows, t.size());
    if (!t.empty()) span = std::max(span, *std::max_element(t.begin(), t.end()) - *std::min_element(t.begin(), t.end()));
  }
  return span;
}

constexpr double kLambdas[] = {0.0, 0.05, 0.15, 0.4, 1.0};
constexpr double kTauShares[] = {0.03, 0.1, 0.3};  // × the time span
constexpr std::size_t kMaxRowsPerAxis = 600;       // dense factors beyond: the cost is not spent
constexpr double kRegion = 3.0;                    // χ²₂(95 %)/2: the profile likelihood region

}  // namespace

SegmentCovariance estimate_segment_covariance(const GapInput& in, const Rows& rows, const MatrixXd& all_columns) {
  SegmentCovariance cov;
  const Eigen::Index K = rows.y.size();
  const AxisBlocks blocks = axis_blocks(in, rows);
  std::size_t most_rows = 0;
  const double span = time_span(blocks, &most_rows);
  // Beyond kMaxRowsPerAxis segments the lag-1 and Newey–West tests stand alone.
  if (!(span > 0) || all_columns.cols() == 0 || most_rows > kMaxRowsPerAxis) return cov;
  // Orthonormal basis of the weighted fixed-effect column space (REML is basis invariant).
  Eigen::ColPivHouseholderQR<MatrixXd> qr(unit_columns(all_columns));
  qr.setThreshold(1e-9);
  const Eigen::Index p = qr.rank();
  if (p >= K - 5) return cov;
  const MatrixXd Q = MatrixXd(qr.householderQ()).leftCols(p);
  const VectorXd sw = rows.w.cwiseSqrt();
  const VectorXd y = sw.cwiseProduct(rows.y);
  const MatrixXd X = sw.asDiagonal() * Q;  // Q spans the unweighted columns; the rows weighted like y
  double best = -std::numeric_limits<double>::infinity();
  std::vector<std::array<double, 3>> tried;  // λ, τ [s], log-likelihood
  for (double lambda : kLambdas)
    for (double share : kTauShares) {
      if (lambda == 0.0 && share != kTauShares[0]) continue;
      const double tau = share * span;
      const std::optional<stats::BlockWhitening> w = factor(blocks, lambda, tau);
      if (!w) continue;
      const std::optional<double> ll = stats::reml_log_likelihood(*w, y, X);
      if (!ll) continue;
      tried.push_back({lambda, tau, *ll});
      if (*ll > best) {
        best = *ll;
        cov.lambda = lambda;
        cov.tau_s = tau;
      }
    }
  if (!std::isfinite(best)) return cov;
  for (const auto& [lambda, tau, ll] : tried) {
    if (ll < best - kRegion || lambda == 0.0) continue;
    cov.region.push_back({lambda, tau, *factor(blocks, lambda, tau)});
  }
  cov.found = !cov.region.empty();
  return cov;
}

MatrixXd whiten(const CovarianceCandidate& c, const Rows& rows, const MatrixXd& X) {
  return c.whitening.whiten(rows.w.cwiseSqrt().asDiagonal() * X);
}

GlsStep gls_prepare(const SegmentCovariance& cov, const Rows& rows, const MatrixXd& model_columns) {
  GlsStep st;
  for (const auto& c : cov.region) {
    VectorXd r0 = whiten(c, rows, rows.y);
    MatrixXd Q(rows.y.size(), 0);
    if (model_columns.cols() > 0) {
      Q = column_basis(whiten(c, rows, model_columns));
      r0 -= Q * (Q.transpose() * r0);
    }
    st.basis.push_back(std::move(Q));
    st.residual.push_back(std::move(r0));
  }
  return st;
}

double gls_p_value(const SegmentCovariance& cov, const GlsStep& st, const Rows& rows, const MatrixXd& C) {
  double pmax = 0.0;
  for (std::size_t k = 0; k < cov.region.size(); ++k)
    pmax = std::max(pmax, stats::projected_f_p_value(st.basis[k], st.residual[k], whiten(cov.region[k], rows, C),
                                                     rows.y.size()));
  return pmax;
}

}  // namespace stend::diagnosis
