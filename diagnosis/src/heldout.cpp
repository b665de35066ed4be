// Held-out prediction of the gap's rows. See heldout.hpp.
#include "heldout.hpp"

#include <algorithm>
#include <cmath>

#include "stend/stats/distributions.hpp"

namespace stend::diagnosis {

Heldout cross_validate(const MatrixXd& A, const Rows& rows) {
  const Eigen::Index n = rows.y.size();
  Heldout h;
  h.err = VectorXd::Constant(n, kNaN);
  h.var0 = VectorXd::Constant(n, kNaN);
  std::vector<char> out(static_cast<std::size_t>(n));
  for (const auto& fold : rows.folds) {
    std::fill(out.begin(), out.end(), 0);
    for (int r : fold) out[static_cast<std::size_t>(r)] = 1;
    const Eigen::Index k = n - static_cast<Eigen::Index>(fold.size());
    MatrixXd At(k, A.cols());
    VectorXd yt(k), wt(k);
    Eigen::Index j = 0;
    for (Eigen::Index r = 0; r < n; ++r)
      if (!out[static_cast<std::size_t>(r)]) {
        At.row(j) = A.row(r);
        yt[j] = rows.y[r];
        wt[j] = rows.w[r];
        ++j;
      }
    const Fit f = solve(At, yt, wt, {}, {}, /*known_variance=*/true);  // covariance (AᵀWA)⁺ [unit²]
    if (!f.lsq.ok()) {
      ++h.failed_folds;
      continue;
    }
    for (int r : fold) {
      const VectorXd a = A.row(r).transpose();
      if (a.norm() > 0 && f.lsq.null_space.cols() > 0 &&
          (f.lsq.null_space.transpose() * a).norm() > 1e-7 * a.norm()) {
        ++h.not_estimable;
        continue;
      }
      // pinv_covariance = (AᵀWA)⁺ with the weights 1/floor² as known variances.
      const double prediction_var = a.dot(f.lsq.pinv_covariance * a);
      if (prediction_var * rows.w[r] > kMaxPredictionVariance) {
        ++h.extrapolated;
        continue;
      }
      h.err[r] = rows.y[r] - a.dot(f.lsq.min_norm_solution);
      h.var0[r] = 1.0 / rows.w[r] + prediction_var;
    }
  }
  return h;
}

CvCompare compare(const Heldout& a, const Heldout& b) {
  double sa = 0, sb = 0, sf = 0;
  int n = 0;
  for (Eigen::Index r = 0; r < a.err.size(); ++r)
    if (std::isfinite(a.err[r]) && std::isfinite(b.err[r])) {
      sa += a.err[r] * a.err[r];
      sb += b.err[r] * b.err[r];
      sf += b.var0[r];
      ++n;
    }
  CvCompare c;
  c.n = n;
  if (n > 0) {
    c.before = std::sqrt(sa / n);
    c.after = std::sqrt(sb / n);
    c.floor = std::sqrt(sf / n);
  }
  return c;
}

double rms_finite(const Heldout& h, double* floor_rms) {
  double s = 0, sf = 0;
  int n = 0;
  for (Eigen::Index r = 0; r < h.err.size(); ++r)
    if (std::isfinite(h.err[r])) {
      s += h.err[r] * h.err[r];
      sf += h.var0[r];
      ++n;
    }
  if (floor_rms) *floor_rms = n ? std::sqrt(sf / n) : kNaN;
  return n ? std::sqrt(s / n) : kNaN;
}

bool at_noise_floor(const Heldout& h) {
  double chi = 0;
  int n = 0;
  for (Eigen::Index r = 0; r < h.err.size(); ++r)
    if (std::isfinite(h.err[r]) && h.var0[r] > 0) {
      chi += h.err[r] * h.err[r] / h.var0[r];
      ++n;
    }
  return n > 0 && stats::chi2_sf(chi, n) > 0.05;
}

}  // namespace stend::diagnosis
