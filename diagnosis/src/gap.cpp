// stend gap, steps 2–6: the twin, where, which, how far. See stend/diagnosis/gap.hpp.
#include "stend/diagnosis/gap.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>

#include "stend/estimation/linear_lsq.hpp"
#include "stend/physics/units.hpp"
#include "magnitude.hpp"
#include "noise_stage.hpp"
#include "stats.hpp"
#include "text.hpp"

namespace stend::diagnosis {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using model::TermKind;
using model::TermSpec;

std::string term_label(const TermSpec& t) {
  std::string s = model::term_name(t.kind);
  if (t.kind == TermKind::kBiasTemperature || t.kind == TermKind::kScaleTemperature)
    s += "(order " + std::to_string(t.order) + ")";
  return s;
}

// Rows of the problem: one per (segment, fitted axis).
struct Rows {
  std::vector<int> seg, axis;
  VectorXd y, w;  // Δ = measured − true input; weights 1/floor²
  // Magnitude form only: the direction each row projects the segment's three axes on (û);
  // empty otherwise (row = one sensor axis).
  std::vector<Eigen::Vector3d> dir;
  std::vector<std::vector<int>> folds;  // row indices held out together
  std::vector<std::string> fold_names;
};

// Design columns of one term over all rows, from the vocabulary's regressor.
MatrixXd term_block(const GapInput& in, const Rows& rows, const TermSpec& t) {
  model::ErrorModel m;
  m.instrument = in.spec.model.instrument;
  m.terms = {t};
  MatrixXd B(rows.y.size(), m.size());
  std::vector<Eigen::Matrix<double, 3, Eigen::Dynamic>> per_seg(in.segments.size());
  for (std::size_t s = 0; s < in.segments.size(); ++s) per_seg[s] = m.regressor(in.segments[s].point.stimulus);
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const auto& R = per_seg[static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)])];
    if (rows.dir.empty())
      B.row(r) = R.row(rows.axis[static_cast<std::size_t>(r)]);
    else
      B.row(r) = rows.dir[static_cast<std::size_t>(r)].transpose() * R;
  }
  return B;
}

struct Fit {
  estimation::LsqResult lsq;
  double rss = kNaN;  // weighted
  int rank = 0;
};

Fit solve(const MatrixXd& A, const VectorXd& y, const VectorXd& w, const std::vector<std::string>& names = {},
          const std::vector<std::string>& units = {}) {
  estimation::LsqProblem pr;
  pr.design = A;
  pr.observations = y;
  pr.weights = w;
  pr.names = names;
  pr.units = units;
  estimation::LsqOptions o;
  o.observations_per_parameter_warning = 0.0;
  Fit f;
  f.lsq = estimation::solve_lsq(pr, o);
  if (f.lsq.ok()) {
    f.rss = f.lsq.rss;
    f.rank = f.lsq.rank;
  }
  return f;
}

struct Heldout {
  VectorXd err;    // NaN where the row is not predictable from its training fold
  VectorXd var0;   // variance of the prediction error if the model were right [unit²]
};

// Leave-one-group-out: fit on the other folds, predict the held-out rows (only where the row is
// estimable from the training design: no guessing across aliases).
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
    const Fit f = solve(At, yt, wt);
    if (!f.lsq.ok()) continue;
    const double s2 = f.lsq.sigma2 > 0 ? f.lsq.sigma2 : 1.0;
    for (int r : fold) {
      const VectorXd a = A.row(r).transpose();
      if (a.norm() > 0 && f.lsq.null_space.cols() > 0 &&
          (f.lsq.null_space.transpose() * a).norm() > 1e-7 * a.norm())
        continue;
      h.err[r] = rows.y[r] - a.dot(f.lsq.min_norm_solution);
      // pinv_covariance = σ²·(AᵀWA)⁺ with relative weights 1/floor²: divide σ² out.
      h.var0[r] = 1.0 / rows.w[r] + a.dot(f.lsq.pinv_covariance * a) / s2;
    }
  }
  return h;
}

// RMS over the rows finite in both, and the floor RMS over the same rows.
struct CvCompare {
  double before = kNaN, after = kNaN, floor = kNaN;
  int n = 0;
};
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

double rms_finite(const VectorXd& e, double* floor_rms = nullptr, const VectorXd* var0 = nullptr) {
  double s = 0, sf = 0;
  int n = 0;
  for (Eigen::Index r = 0; r < e.size(); ++r)
    if (std::isfinite(e[r])) {
      s += e[r] * e[r];
      if (var0) sf += (*var0)[r];
      ++n;
    }
  if (floor_rms) *floor_rms = n ? std::sqrt(sf / n) : kNaN;
  return n ? std::sqrt(s / n) : kNaN;
}

// Held-out errors consistent with the floor? χ² of Σ e²/var0 at the 95 % level.
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

// A with every non-zero column scaled to unit norm.
MatrixXd unit_columns(const MatrixXd& A) {
  MatrixXd S = A;
  for (Eigen::Index j = 0; j < S.cols(); ++j) {
    const double nj = S.col(j).norm();
    if (nj > 0) S.col(j) /= nj;
  }
  return S;
}

// Column-scaled numerical rank.
int rank_of(const MatrixXd& A) {
  if (A.cols() == 0) return 0;
  Eigen::ColPivHouseholderQR<MatrixXd> qr(unit_columns(A));
  qr.setThreshold(1e-9);
  return static_cast<int>(qr.rank());
}

MatrixXd hstack(const MatrixXd& a, const MatrixXd& b) {
  MatrixXd m(std::max(a.rows(), b.rows()), a.cols() + b.cols());
  if (a.cols()) m.leftCols(a.cols()) = a;
  if (b.cols()) m.rightCols(b.cols()) = b;
  return m;
}

MatrixXd scale_rows(const MatrixXd& A, const VectorXd& w) {
  return w.cwiseSqrt().asDiagonal() * A;
}

// Orthonormal basis of the column space of A (pivoted QR, relative rank threshold 1e-10).
MatrixXd column_basis(const MatrixXd& A) {
  Eigen::ColPivHouseholderQR<MatrixXd> qr(A);
  qr.setThreshold(1e-10);
  return MatrixXd(qr.householderQ()).leftCols(qr.rank());
}

// Number of singular values (sorted, largest first) above 1e-8 of the largest.
int svd_rank(const VectorXd& sv) {
  int q = 0;
  while (q < sv.size() && sv[q] > 1e-8 * sv[0]) ++q;
  return q;
}

// Slowly wandering bias (Gauss–Markov, correlation time of minutes) correlates segment means over
// many segments: lag-1 and HAC corrections underestimate what a slow regressor sees. Covariance of
// the segment-mean rows of one axis: floor²·(δ_ij + λ·exp(−|t_i − t_j|/τ)), times the segment
// mid-times [s]; λ, τ by restricted likelihood (REML) on a grid with the fixed effects of the most
// general model (the model plus every candidate), so a planted effect cannot inflate it.
struct GlsPoint {
  double lambda = 0.0, tau_s = 0.0;
  std::vector<Eigen::LLT<MatrixXd>> chol;  // of the per-axis correlation (floor² divided out)
};
struct Gls {
  bool ok = false;
  double lambda = 0.0, tau_s = 0.0;            // REML estimate
  std::vector<std::vector<Eigen::Index>> idx;  // rows per axis
  std::vector<GlsPoint> region;                // covariances in the 95 % likelihood region
};
// Per step: whitened model basis and whitened residual for every covariance of the region.
struct GlsStep {
  std::vector<MatrixXd> Q;
  std::vector<VectorXd> r0;
  Eigen::Index p0 = 0;
};

MatrixXd gls_corr(const std::vector<double>& t, double lambda, double tau) {
  const auto n = static_cast<Eigen::Index>(t.size());
  MatrixXd V = MatrixXd::Identity(n, n);
  if (lambda > 0)
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j)
        V(i, j) += lambda * std::exp(-std::abs(t[static_cast<std::size_t>(i)] - t[static_cast<std::size_t>(j)]) / tau);
  return V;
}

// Whiten the rows of X (all rows, per-axis blocks) with the stored factors; weights sqrt(w) first.
MatrixXd gls_whiten(const Gls& g, const GlsPoint& pt, const Rows& rows, const MatrixXd& X) {
  MatrixXd out(X.rows(), X.cols());
  for (std::size_t a = 0; a < g.idx.size(); ++a) {
    const auto& id = g.idx[a];
    MatrixXd B(static_cast<Eigen::Index>(id.size()), X.cols());
    for (std::size_t i = 0; i < id.size(); ++i) B.row(static_cast<Eigen::Index>(i)) = X.row(id[i]) * std::sqrt(rows.w[id[i]]);
    B = pt.chol[a].matrixL().solve(B);
    for (std::size_t i = 0; i < id.size(); ++i) out.row(id[i]) = B.row(static_cast<Eigen::Index>(i));
  }
  return out;
}

// Rows per axis into g.idx, and their segment mid-times [s] per axis.
std::vector<std::vector<double>> axis_times(const GapInput& in, const Rows& rows, Gls& g) {
  std::vector<std::vector<double>> t;
  std::map<int, std::size_t> axis_slot;
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const int a = rows.axis[static_cast<std::size_t>(r)];
    if (!axis_slot.count(a)) {
      axis_slot[a] = g.idx.size();
      g.idx.emplace_back();
      t.emplace_back();
    }
    const auto& p = in.segments[static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)])].point;
    g.idx[axis_slot[a]].push_back(r);
    t[axis_slot[a]].push_back(0.5 * (p.t_start_s + p.t_end_s));
  }
  return t;
}

// Restricted log-likelihood of the rows under covariance floor²·(δ_ij + λ·exp(−|t_i − t_j|/τ))
// per axis (τ [s]), fixed effects spanned by the orthonormal Q; nullopt when a factor fails.
std::optional<double> reml_loglik(const Gls& g, const std::vector<std::vector<double>>& t, const Rows& rows,
                                  const MatrixXd& Q, double lam, double tau) {
  const Eigen::Index p = Q.cols();
  const VectorXd sw = rows.w.cwiseSqrt();
  MatrixXd M = MatrixXd::Zero(p, p);
  VectorXd b = VectorXd::Zero(p);
  double yy = 0, logdet = 0;
  for (std::size_t a = 0; a < g.idx.size(); ++a) {
    const auto& id = g.idx[a];
    Eigen::LLT<MatrixXd> llt(gls_corr(t[a], lam, tau));
    if (llt.info() != Eigen::Success) return std::nullopt;
    MatrixXd Qa(static_cast<Eigen::Index>(id.size()), p);
    VectorXd ya(static_cast<Eigen::Index>(id.size()));
    for (std::size_t i = 0; i < id.size(); ++i) {
      Qa.row(static_cast<Eigen::Index>(i)) = Q.row(id[i]);
      ya[static_cast<Eigen::Index>(i)] = rows.y[id[i]] * sw[id[i]];
    }
    // Q spans the unweighted columns; rows are scaled by sqrt(w) like y (w is constant per axis).
    Qa *= sw[id[0]];
    Qa = llt.matrixL().solve(Qa);
    ya = llt.matrixL().solve(ya);
    M += Qa.transpose() * Qa;
    b += Qa.transpose() * ya;
    yy += ya.squaredNorm();
    logdet += 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  }
  Eigen::LLT<MatrixXd> lm(M);
  if (lm.info() != Eigen::Success) return std::nullopt;
  const double q = yy - b.dot(lm.solve(b));
  if (!(q > 0)) return std::nullopt;
  return -0.5 * (static_cast<double>(rows.y.size() - p) * std::log(q) + logdet +
                 2.0 * lm.matrixL().toDenseMatrix().diagonal().array().log().sum());
}

Gls estimate_gls(const GapInput& in, const Rows& rows, const MatrixXd& Xfull) {
  Gls g;
  const Eigen::Index K = rows.y.size();
  const std::vector<std::vector<double>> t = axis_times(in, rows, g);
  double span = 0;
  for (const auto& ta : t)
    if (!ta.empty()) span = std::max(span, *std::max_element(ta.begin(), ta.end()) - *std::min_element(ta.begin(), ta.end()));
  // Dense per-axis factors: beyond 600 segments the cost (n³ per grid point) is not spent and
  // the lag-1 and Newey–West tests stand alone.
  std::size_t nmax = 0;
  for (const auto& ta : t) nmax = std::max(nmax, ta.size());
  if (!(span > 0) || Xfull.cols() == 0 || nmax > 600) return g;
  // Orthonormal basis of the weighted fixed-effect column space (REML is basis invariant).
  Eigen::ColPivHouseholderQR<MatrixXd> qr(unit_columns(Xfull));
  qr.setThreshold(1e-9);
  const Eigen::Index p = qr.rank();
  if (p >= K - 5) return g;
  const MatrixXd Q = MatrixXd(qr.householderQ()).leftCols(p);
  double best = -std::numeric_limits<double>::infinity();
  std::vector<std::array<double, 3>> tried;  // λ, τ [s], log-likelihood
  const double lambdas[] = {0.0, 0.05, 0.15, 0.4, 1.0};
  const double taus[] = {0.03, 0.1, 0.3};  // × span
  for (double lam : lambdas)
    for (double tf : taus) {
      if (lam == 0.0 && tf != taus[0]) continue;
      const double tau = tf * span;
      const std::optional<double> ll = reml_loglik(g, t, rows, Q, lam, tau);
      if (!ll) continue;
      tried.push_back({lam, tau, *ll});
      if (*ll > best) {
        best = *ll;
        g.lambda = lam;
        g.tau_s = tau;
      }
    }
  if (!std::isfinite(best)) return g;
  // The estimate is weak (a wander of a fraction of the floor): test under every covariance the
  // data do not reject (profile log-likelihood within χ²₂(95 %)/2 of the best) and keep the largest p.
  for (const auto& tr : tried) {
    if (tr[2] < best - 3.0 || tr[0] == 0.0) continue;
    GlsPoint pt;
    pt.lambda = tr[0];
    pt.tau_s = tr[1];
    for (std::size_t a = 0; a < g.idx.size(); ++a) pt.chol.emplace_back(gls_corr(t[a], pt.lambda, pt.tau_s));
    g.region.push_back(std::move(pt));
  }
  g.ok = !g.region.empty();
  return g;
}

GlsStep gls_prepare(const Gls& g, const Rows& rows, const MatrixXd& A0) {
  GlsStep st;
  for (const auto& pt : g.region) {
    VectorXd r0 = gls_whiten(g, pt, rows, rows.y);
    MatrixXd Q(rows.y.size(), 0);
    if (A0.cols() > 0) {
      Q = column_basis(gls_whiten(g, pt, rows, A0));
      st.p0 = Q.cols();
      r0 -= Q * (Q.transpose() * r0);
    }
    st.Q.push_back(std::move(Q));
    st.r0.push_back(std::move(r0));
  }
  return st;
}

// GLS partial F test of candidate columns C against the model, the largest p over the region.
double gls_p_value(const Gls& g, const GlsStep& st, const Rows& rows, const MatrixXd& C) {
  double pmax = 0.0;
  for (std::size_t k = 0; k < g.region.size(); ++k) {
    MatrixXd Cw = gls_whiten(g, g.region[k], rows, C);
    if (st.Q[k].cols() > 0) Cw -= st.Q[k] * (st.Q[k].transpose() * Cw);
    Eigen::JacobiSVD<MatrixXd> svd(Cw, Eigen::ComputeThinU);
    const int q = svd_rank(svd.singularValues());
    const Eigen::Index dof = rows.y.size() - st.p0 - q;
    if (q == 0 || dof <= 0) return 1.0;
    const VectorXd beta = svd.matrixU().leftCols(q).transpose() * st.r0[k];
    const double rss1 = st.r0[k].squaredNorm() - beta.squaredNorm();
    if (!(rss1 > 0)) return 1.0;
    const double F = (beta.squaredNorm() / q) / (rss1 / static_cast<double>(dof));
    pmax = std::max(pmax, stats::f_sf(F, q, static_cast<double>(dof)));
  }
  return pmax;
}

struct Eval {
  CandidateResult res;
  Heldout cv;
};

// Parameter names and units of a term list, in design-column order.
struct ParamLabels {
  std::vector<std::string> names, units;
};
ParamLabels param_labels(const GapInput& in, const std::vector<TermSpec>& terms) {
  model::ErrorModel m;
  m.instrument = in.spec.model.instrument;
  m.terms = terms;
  ParamLabels l;
  for (const auto& p : m.params()) {
    l.names.push_back(p.name);
    l.units.push_back(p.unit);
  }
  return l;
}

// Model terms the candidate aliases with (null-space groups of the joint fit that hold a candidate
// parameter, p0 = model columns), and the experiment that would separate each from it.
void add_model_aliases(const Fit& f1, const std::vector<TermSpec>& current, int p0, TermKind kind,
                       CandidateResult& r) {
  std::set<std::string> al;
  for (const auto& g : f1.lsq.aliases) {
    bool mine = false;
    for (int idx : g.parameters) mine = mine || idx >= p0;
    if (!mine) continue;
    for (int idx : g.parameters)
      if (idx < p0) {
        int off = 0;
        for (const auto& t : current) {
          const int np = model::param_count(t);
          if (idx >= off && idx < off + np) al.insert(term_label(t));
          off += np;
        }
      }
  }
  for (const auto& a : al) r.aliases.push_back(a + " (in the model)");
  for (const auto& a : al) {
    for (const auto& t : current)
      if (term_label(t) == a) r.separate.push_back(separating_experiment(kind, t.kind));
  }
}

// Lag-1 autocorrelation ρ of the weighted residuals between consecutive segments on the same
// axis, clamped to [0, 0.9].
double lag1_correlation(const Rows& rows, const VectorXd& res) {
  double num = 0, den = 0;
  for (Eigen::Index i = 0; i < res.size(); ++i) {
    den += rows.w[i] * res[i] * res[i];
    for (Eigen::Index j = i + 1; j < res.size() && rows.seg[static_cast<std::size_t>(j)] <= rows.seg[static_cast<std::size_t>(i)] + 1; ++j)
      if (rows.seg[static_cast<std::size_t>(j)] == rows.seg[static_cast<std::size_t>(i)] + 1 &&
          rows.axis[static_cast<std::size_t>(j)] == rows.axis[static_cast<std::size_t>(i)])
        num += std::sqrt(rows.w[i] * rows.w[j]) * res[i] * res[j];
  }
  return den > 0 ? std::clamp(num / den, 0.0, 0.9) : 0.0;
}

// Partial F test and ΔBIC of the candidate. Segment means are not independent when the bias
// wanders slowly (instability, random walk): the lag-1 autocorrelation ρ of the residuals WITH the
// candidate shrinks the evidence to an effective (1 − ρ)/(1 + ρ) share of the segments.
void f_test(const Rows& rows, const Fit& f0, const Fit& f1, CandidateResult& r) {
  const int k = static_cast<int>(rows.y.size());
  const int dof1 = k - f1.rank;
  const double rho = lag1_correlation(rows, f1.lsq.residuals);
  const double eff = (1 - rho) / (1 + rho);
  r.f_stat = ((f0.rss - f1.rss) / r.added_rank) / (f1.rss / dof1) * eff;
  r.p_value = stats::f_sf(std::max(0.0, r.f_stat), r.added_rank, std::max(1.0, dof1 * eff));
  r.delta_bic = k * std::log(f1.rss / f0.rss) + r.added_rank * std::log(static_cast<double>(k));
}

// Newey–West (Bartlett, L = T/4) long-run covariance of the q per-segment scores g (q × T), scaled
// by T/(T − rank per segment) for small samples like the residual variance.
MatrixXd newey_west_covariance(const MatrixXd& g, int fit_rank, int rows_total) {
  const int T = static_cast<int>(g.cols());
  const int L = std::max(1, T / 4);
  MatrixXd S = g * g.transpose();
  for (int l = 1; l <= L && l < T; ++l) {
    const MatrixXd G = g.leftCols(T - l) * g.rightCols(T - l).transpose();
    S += (1.0 - l / (L + 1.0)) * (G + G.transpose());
  }
  S *= static_cast<double>(T) / std::max(1, T - fit_rank / std::max(1, rows_total / std::max(1, T)));
  return S;
}

// Second test, robust to slowly correlated segment means: the candidate's component orthogonal
// to the model, with a Newey–West long-run variance of its per-segment scores (residuals with the
// candidate); χ²_q. The candidate must pass both: p is the larger.
void newey_west_test(const Rows& rows, const MatrixXd& A0, const MatrixXd& C, const Fit& f1, CandidateResult& r) {
  const VectorXd sw = rows.w.cwiseSqrt();
  MatrixXd Ct = sw.asDiagonal() * C;
  if (A0.cols() > 0) {
    const MatrixXd Q = column_basis(sw.asDiagonal() * A0);
    Ct -= Q * (Q.transpose() * Ct);
  }
  Eigen::JacobiSVD<MatrixXd> svd(Ct, Eigen::ComputeThinU);
  const int q = svd_rank(svd.singularValues());
  // The long-run variance of q scores needs many more segments than q: the scores sum to zero
  // (residuals are orthogonal to the candidate), so with few segments S is singular or noise.
  // Below 5q segments the test is skipped and said so (the F test stands alone there).
  const int T = rows.seg.empty() ? 0 : rows.seg.back() + 1;
  if (q > 0 && T < 5 * q)
    r.reason = "Newey-West test skipped: " + std::to_string(T) + " segments for " + std::to_string(q) +
               " parameters (needs >= " + std::to_string(5 * q) + ")";
  if (q == 0 || T < 5 * q) return;
  const MatrixXd Z = svd.matrixU().leftCols(q);
  const VectorXd beta = Z.transpose() * (sw.asDiagonal() * rows.y);
  const VectorXd e1 = sw.asDiagonal() * f1.lsq.residuals;
  MatrixXd g = MatrixXd::Zero(q, T);
  for (Eigen::Index i = 0; i < e1.size(); ++i) g.col(rows.seg[static_cast<std::size_t>(i)]) += Z.row(i).transpose() * e1[i];
  const MatrixXd S = newey_west_covariance(g, f1.rank, static_cast<int>(rows.y.size()));
  const double wald = beta.dot(S.ldlt().solve(beta));
  const double p_hac = std::isfinite(wald) ? stats::chi2_sf(wald, q) : 1.0;
  r.p_value = std::max(r.p_value, p_hac);
}

// Held-out RMS without and with the candidate on the rows both predict, and the relative gain.
void heldout_gain(const Heldout& cv0, const Heldout& cv1, CandidateResult& r) {
  const CvCompare cc = compare(cv0, cv1);
  r.heldout_rms_before = cc.before;
  r.heldout_rms = cc.after;
  if (cc.n > 0 && cc.before > 0) r.heldout_improvement = 1.0 - cc.after / cc.before;
}

// Effect size: the candidate parameter (columns from p0 on) with the largest |value|/se.
void effect_size(const Fit& f1, int p0, Eigen::Index columns, CandidateResult& r) {
  double best = -1;
  for (int j = p0; j < static_cast<int>(columns); ++j) {
    const auto& pe = f1.lsq.parameters[static_cast<std::size_t>(j)];
    if (!pe.identifiable || !(pe.std_error > 0)) continue;
    const double z = std::abs(pe.value) / pe.std_error;
    if (z > best) {
      best = z;
      r.size = pe.value;
      r.size_param = pe.name;
      r.size_unit = pe.unit;
      r.ci_lo = pe.lower;
      r.ci_hi = pe.upper;
    }
  }
}

// Under a time-correlated covariance of the segment means (GLS region found) the interval of the
// effect-size parameter comes from the whitened fit; the widest over the likelihood region is
// kept, as for the p value (independent-mean intervals under-cover when the bias wanders).
void widen_by_gls(const Gls& gls, const Rows& rows, const MatrixXd& A1, const ParamLabels& labels,
                  CandidateResult& r) {
  const VectorXd ones = VectorXd::Ones(rows.y.size());
  double widest = r.ci_hi - r.ci_lo;
  for (const auto& pt : gls.region) {
    const Fit fg = solve(gls_whiten(gls, pt, rows, A1), gls_whiten(gls, pt, rows, rows.y), ones, labels.names,
                         labels.units);
    if (!fg.lsq.ok()) continue;
    const int j = fg.lsq.index(r.size_param);
    if (j < 0) continue;
    const auto& pe = fg.lsq.parameters[static_cast<std::size_t>(j)];
    if (!pe.identifiable || !(pe.upper - pe.lower > widest)) continue;
    widest = pe.upper - pe.lower;
    r.size = pe.value;
    r.ci_lo = pe.lower;
    r.ci_hi = pe.upper;
  }
}

// Axis on which the candidate's fitted contribution is largest ("|f|" in the magnitude form).
std::string dominant_axis(const GapInput& in, const Rows& rows, const MatrixXd& C, const Fit& f1) {
  const VectorXd th = f1.lsq.min_norm_solution.tail(C.cols());
  const VectorXd contrib = C * th;
  double ax[3] = {0, 0, 0};
  for (Eigen::Index i = 0; i < contrib.size(); ++i) ax[rows.axis[static_cast<std::size_t>(i)]] += contrib[i] * contrib[i];
  const int amax = static_cast<int>(std::max_element(ax, ax + 3) - ax);
  return in.magnitude ? "|f|" : std::string(1, "xyz"[amax]);
}

// One candidate (columns C) against the current set of terms (design A0, fit f0, held-out cv0).
Eval evaluate(const GapInput& in, const Rows& rows, const std::vector<TermSpec>& current, const MatrixXd& A0,
              const Fit& f0, const Heldout& cv0, const Candidate& c, const MatrixXd& C,
              const Gls* gls = nullptr, const GlsStep* gst = nullptr) {
  Eval e;
  CandidateResult& r = e.res;
  r.term = c.name;
  r.spec = c.term;
  if (C.cols() == 0 || C.norm() == 0.0) {
    r.reason = "not excited by this experiment (its regressor is zero in every segment)";
    return e;
  }
  const MatrixXd A1 = hstack(A0, C);
  std::vector<TermSpec> terms = current;
  terms.push_back(c.term);
  const ParamLabels labels = param_labels(in, terms);
  const Fit f1 = solve(A1, rows.y, rows.w, labels.names, labels.units);
  if (!f1.lsq.ok()) {
    r.reason = "fit with it failed: " + f1.lsq.message;
    return e;
  }
  r.added_rank = f1.rank - f0.rank;
  const int p0 = static_cast<int>(A0.cols());
  add_model_aliases(f1, current, p0, c.term.kind, r);
  if (r.added_rank <= 0) {
    r.reason = "aliased with the model's own terms: this experiment cannot see it beyond them";
    return e;
  }
  r.evaluated = true;
  if (static_cast<int>(rows.y.size()) - f1.rank > 0 && f1.rss > 0) {
    f_test(rows, f0, f1, r);
    newey_west_test(rows, A0, C, f1, r);
    // Third: GLS F test under the long-memory covariance of the segment means (when found).
    if (gls && gst && gls->ok) r.p_value = std::max(r.p_value, gls_p_value(*gls, *gst, rows, C));
  }
  e.cv = cross_validate(A1, rows);
  heldout_gain(cv0, e.cv, r);
  effect_size(f1, p0, A1.cols(), r);
  if (gls && gls->ok && !r.size_param.empty()) widen_by_gls(*gls, rows, A1, labels, r);
  r.axis = dominant_axis(in, rows, C, f1);
  return e;
}


}  // namespace

std::vector<Candidate> default_candidates(const model::ErrorModel& m) {
  std::vector<Candidate> out;
  const bool gyro = m.instrument == model::Instrument::kGyroscope;
  std::vector<TermKind> kinds(model::kAllTermKinds.begin(), model::kAllTermKinds.end());
  kinds.insert(kinds.end(), model::kGapTermKinds.begin(), model::kGapTermKinds.end());
  for (TermKind k : kinds) {
    if (k == TermKind::kBias) continue;  // every model has it (a model without bias is checked too)
    if (k == TermKind::kGSensitivity && !gyro) continue;
    if ((k == TermKind::kGravityError || k == TermKind::kTableAngleOffset || k == TermKind::kTableAxisTilt ||
         k == TermKind::kLeverArm) && gyro)
      continue;
    const int have = m.find(k);
    if (k == TermKind::kBiasTemperature || k == TermKind::kScaleTemperature) {
      const int cur = have >= 0 ? m.terms[static_cast<std::size_t>(have)].order : 0;
      for (int order = cur + 1; order <= std::min(3, cur + 2); ++order) {
        TermSpec t{k, order, 25.0};
        out.push_back({term_label(t), t});
      }
      continue;
    }
    if (have >= 0) continue;
    TermSpec t{k, 1, 25.0};
    out.push_back({term_label(t), t});
  }
  if (m.find(TermKind::kBias) < 0) out.insert(out.begin(), {"bias", TermSpec{TermKind::kBias, 1, 25.0}});
  return out;
}

std::string separating_experiment(TermKind a, TermKind b) {
  auto is = [&](TermKind x, TermKind y) { return (a == x && b == y) || (a == y && b == x); };
  auto in = [](TermKind x, std::initializer_list<TermKind> set) {
    return std::find(set.begin(), set.end(), x) != set.end();
  };
  const auto mag = {TermKind::kScale, TermKind::kNonlinearK3, TermKind::kOddQuadratic, TermKind::kGravityError,
                    TermKind::kNonlinearK2, TermKind::kBias};
  std::string A = model::term_name(a), B = model::term_name(b);
  // A wrong local g is a common scale of a static design (tumbles do not help); a known input apart
  // from gravity does: the centripetal ω×(ω×r) on a rate table, the offset r known (stend gap validate).
  if (is(TermKind::kGravityError, TermKind::kLeverArm))
    return A + " vs " + B + ": remount the sensor at a second known offset from the rate axis (with one mount, g "
           "and the radius both off by the same fraction look like a common scale)";
  if (is(TermKind::kGravityError, TermKind::kScale))
    return A + " vs " + B + ": an input of known size apart from gravity — the accelerometer off the axis of a "
           "rate table (centripetal ω²r at known offsets, two mounts), or a second reference for g";
  if (in(a, mag) && in(b, mag))
    return A + " vs " + B + ": add positions where the axis sees other inputs than 0 and ±g (tilts of 30°, 45°, "
           "60° about two axes, i.e. a tumble), or a centrifuge / a second known reference for g";
  if (is(TermKind::kBiasTemperature, TermKind::kTimeDrift) || is(TermKind::kScaleTemperature, TermKind::kTimeDrift))
    return A + " vs " + B + ": visit the temperatures in a different order (down-sweep after the up-sweep) or "
           "repeat one temperature at the end";
  if (is(TermKind::kThermalLag, TermKind::kThermalHysteresis))
    return A + " vs " + B + ": ramp at two different rates, and hold long enough that dT/dt reaches 0";
  if (a == TermKind::kThermalHysteresis || b == TermKind::kThermalHysteresis)
    return A + " vs " + B + ": approach the same temperatures from above and from below";
  if (a == TermKind::kLeverArm || b == TermKind::kLeverArm)
    return A + " vs " + B + ": rate segments at several rates (centripetal grows with ω²)";
  if (in(a, {TermKind::kTableAngleOffset, TermKind::kTableAxisTilt}) ||
      in(b, {TermKind::kTableAngleOffset, TermKind::kTableAxisTilt}))
    return A + " vs " + B + ": remount the sensor rotated by 90° on the table (sensor terms move with the "
           "sensor, table terms stay with the table)";
  if (a == TermKind::kCrossAxis || b == TermKind::kCrossAxis)
    return A + " vs " + B + ": tumble positions that excite two axes at once (45° tilts)";
  if (a == TermKind::kTimeDrift || b == TermKind::kTimeDrift)
    return A + " vs " + B + ": repeat the first positions at the end of the run";
  return A + " vs " + B + ": add segments where their regressors differ (other orientations/temperatures)";
}

namespace {

// Report fields known before any fit: units, display scale, source, segments, floor source, notes.
GapReport report_header(const GapInput& in) {
  GapReport rep;
  const bool accel = in.spec.model.instrument == model::Instrument::kAccelerometer;
  rep.unit = accel ? "m/s^2" : "rad/s";
  rep.display_unit = accel ? "mg" : "deg/h";
  rep.display_per_unit = accel ? 1.0 / physics::kMilliG : 1.0 / physics::kDegPerHour;
  rep.magnitude = in.magnitude;
  rep.model_name = in.spec.source.empty() ? "<model>" : in.spec.source;
  rep.source = in.source;
  rep.segments = in.segments;
  rep.floor_source = in.floor_source;
  rep.notes = in.notes;
  if (!in.truth_source.empty()) rep.notes.insert(rep.notes.begin(), "truth: " + in.truth_source);
  return rep;
}

// The model as given, fitted by batch_lsq (in the magnitude form: on the |f| rows).
batch_lsq::FitResult fit_model(const GapInput& in) {
  if (in.magnitude) return fit_magnitude_rows(in);
  std::vector<batch_lsq::StaticPoint> pts;
  for (const auto& s : in.segments) pts.push_back(s.point);
  return batch_lsq::fit_points(pts, in.spec);
}

// θ̂ in the model's full parameter order (parameters the fit did not estimate are 0).
VectorXd full_theta(const model::ErrorModel& M, const batch_lsq::FitResult& fit) {
  VectorXd theta = VectorXd::Zero(M.size());
  for (std::size_t j = 0; j < fit.param_index.size(); ++j)
    theta[fit.param_index[j]] = fit.lsq.min_norm_solution[static_cast<Eigen::Index>(j)];
  return theta;
}

// Axes that give rows: the fitted ones; in the magnitude form slot 0 (the |f| row).
std::vector<bool> fitted_axes(const GapInput& in) {
  if (in.magnitude) return {true, false, false};
  std::vector<bool> fitted(3, false);
  for (int a : in.spec.axes) fitted[static_cast<std::size_t>(a)] = true;
  return fitted;
}

// Noise floor per row slot: RMS over segments of the segment-mean standard error [unit]; NaN
// where no segment has one.
Eigen::Vector3d noise_floor(const GapInput& in, const std::vector<bool>& fitted) {
  std::vector<double> floor2(3, 0.0);
  std::vector<int> floor_n(3, 0);
  auto add = [&](int a, double se) {
    if (!std::isfinite(se)) return;
    floor2[static_cast<std::size_t>(a)] += se * se;
    ++floor_n[static_cast<std::size_t>(a)];
  };
  for (const auto& s : in.segments)
    if (in.magnitude) {
      add(0, magnitude_std_error(s));
    } else {
      for (int a = 0; a < 3; ++a)
        if (fitted[static_cast<std::size_t>(a)]) add(a, s.mean_std_error[a]);
    }
  Eigen::Vector3d floor = Eigen::Vector3d::Constant(kNaN);
  for (int a = 0; a < 3; ++a)
    if (floor_n[static_cast<std::size_t>(a)]) floor[a] = std::sqrt(floor2[static_cast<std::size_t>(a)] / floor_n[static_cast<std::size_t>(a)]);
  return floor;
}

// Row weight 1/floor² [1/unit²]; 1 where the floor is unknown or zero.
double floor_weight(double floor) {
  const double fl = std::isfinite(floor) && floor > 0 ? floor : 1.0;
  return 1.0 / (fl * fl);
}

// The rows of the problem (Δ = measured − true input, weight 1/floor²) and, per segment, the
// twin's residual measured − measure(θ̂, truth) on the row slots (NaN elsewhere) into rep.residual.
Rows build_rows(const GapInput& in, const VectorXd& theta, const std::vector<bool>& fitted, GapReport& rep) {
  Rows rows;
  std::vector<double> yv, wv;
  auto add_row = [&](std::size_t s, int slot, double y) {
    rows.seg.push_back(static_cast<int>(s));
    rows.axis.push_back(slot);
    yv.push_back(y);
    wv.push_back(floor_weight(rep.floor[slot]));
  };
  for (std::size_t s = 0; s < in.segments.size(); ++s) {
    const auto& p = in.segments[s].point;
    const Eigen::Vector3d twin = in.spec.model.measure<double>(theta.data(), p.stimulus);
    Eigen::Vector3d res = Eigen::Vector3d::Constant(kNaN);
    if (in.magnitude) {
      const Eigen::Vector3d u = p.stimulus.specific_force.normalized();
      res[0] = u.dot(p.measured - twin);
      rows.dir.push_back(u);
      add_row(s, 0, u.dot(p.measured - p.stimulus.input));
    } else {
      for (int a = 0; a < 3; ++a) {
        if (!fitted[static_cast<std::size_t>(a)]) continue;
        res[a] = p.measured[a] - twin[a];
        add_row(s, a, p.measured[a] - p.stimulus.input[a]);
      }
    }
    rep.residual.push_back(res);
  }
  rows.y = Eigen::Map<VectorXd>(yv.data(), static_cast<Eigen::Index>(yv.size()));
  rows.w = Eigen::Map<VectorXd>(wv.data(), static_cast<Eigen::Index>(wv.size()));
  return rows;
}

// Noise ratio of one slot: RMS segment sample std over the twin's white-noise std (or, when the
// source gives none, over the median segment std). The magnitude form pools the three axes.
double noise_ratio(const GapInput& in, int a) {
  std::vector<double> stds;
  for (const auto& seg : in.segments)
    for (int b = in.magnitude ? 0 : a; b <= (in.magnitude ? 2 : a); ++b)
      if (std::isfinite(seg.raw_std[b])) stds.push_back(seg.raw_std[b]);
  if (stds.empty()) return kNaN;
  double ref = in.twin_sample_std[a];
  if (!std::isfinite(ref)) {
    std::nth_element(stds.begin(), stds.begin() + static_cast<std::ptrdiff_t>(stds.size() / 2), stds.end());
    ref = stds[stds.size() / 2];
  }
  double q = 0;
  for (double v : stds) q += v * v;
  return std::sqrt(q / static_cast<double>(stds.size())) / ref;
}

// In-sample gap RMS [unit] and noise ratio per fitted slot, and the note saying what the ratio is
// against.
void gap_and_noise(const GapInput& in, const std::vector<bool>& fitted, GapReport& rep) {
  for (int a = 0; a < 3; ++a) {
    if (!fitted[static_cast<std::size_t>(a)]) continue;
    double s2 = 0;
    for (const auto& res : rep.residual) s2 += res[a] * res[a];
    rep.gap_rms[a] = std::sqrt(s2 / static_cast<double>(rep.residual.size()));
    rep.noise_ratio[a] = noise_ratio(in, a);
  }
  if (!std::isfinite(in.twin_sample_std[0]))
    rep.notes.push_back("noise ratio: segment std against the recording's median segment std (no twin noise "
                        "settings known for this source)");
  else
    rep.notes.push_back("noise ratio: segment std against the twin's white noise (sim_imu noise density and "
                        "low-pass of the run's experiment)");
}

// One "where" dimension: the squared gap of the rows grouped by key_of(segment, slot), each
// group's share of the total and RMS [unit], largest share first, appended to rep.where.
template <class KeyOf>
void add_places(const std::string& dim, const Rows& rows, double total, KeyOf key_of, GapReport& rep) {
  std::map<std::string, std::pair<double, int>> acc;
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const auto s = static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)]);
    const int a = rows.axis[static_cast<std::size_t>(r)];
    const double e = rep.residual[s][a];
    auto& v = acc[key_of(s, a)];
    v.first += e * e;
    ++v.second;
  }
  std::vector<Place> ps;
  for (auto& [k, v] : acc)
    ps.push_back({dim, k, total > 0 ? v.first / total : 0.0, std::sqrt(v.first / v.second), v.second});
  std::sort(ps.begin(), ps.end(), [](const Place& x, const Place& y) { return x.share > y.share; });
  rep.where.insert(rep.where.end(), ps.begin(), ps.end());
}

// Where the gap is: by axis, orientation, temperature [degC, ramp direction], time since the last
// change [s] and averaging time [s].
void locate_gap(const GapInput& in, const Rows& rows, GapReport& rep) {
  double total = 0;
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const double e = rep.residual[static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)])][rows.axis[static_cast<std::size_t>(r)]];
    total += e * e;
  }
  add_places("axis", rows, total, [&](std::size_t, int a) {
    return in.magnitude ? std::string("|f|") : std::string(1, "xyz"[a]);
  }, rep);
  add_places("orientation", rows, total, [&](std::size_t s, int) { return in.segments[s].orientation_name; }, rep);
  add_places("temperature", rows, total, [&](std::size_t s, int) {
    const auto& d = in.segments[s];
    const double t = std::isfinite(d.setpoint_c) ? d.setpoint_c : d.point.stimulus.temperature_c;
    std::string dir = d.ramp_direction > 0 ? " (heating)" : d.ramp_direction < 0 ? " (cooling)" : "";
    return fmt(std::round(t * 10) / 10, 4) + " degC" + dir;
  }, rep);
  add_places("time_since_change", rows, total, [&](std::size_t s, int) {
    const double t = in.segments[s].time_since_change_s;
    if (!std::isfinite(t)) return std::string("unknown");
    return std::string(t < 30 ? "< 30 s" : t < 120 ? "30-120 s" : t < 600 ? "120-600 s" : ">= 600 s");
  }, rep);
  add_places("averaging_time", rows, total, [&](std::size_t s, int) {
    const double t = in.segments[s].averaging_s;
    return std::string(t < 5 ? "< 5 s" : t < 20 ? "5-20 s" : t < 60 ? "20-60 s" : ">= 60 s");
  }, rep);
}

// The grouping of the held-out folds: auto = temperature with ≥ 3 levels, else orientation; ramp
// direction falls back to orientation with fewer than two directions.
FoldBy fold_grouping(const GapInput& in, FoldBy requested) {
  std::set<int> temperatures, directions;
  for (const auto& s : in.segments) {
    temperatures.insert(s.temperature_group);
    directions.insert(s.ramp_direction);
  }
  if (requested == FoldBy::kAuto) return temperatures.size() >= 3 ? FoldBy::kTemperature : FoldBy::kOrientation;
  if (requested == FoldBy::kRamp && directions.size() < 2) return FoldBy::kOrientation;
  return requested;
}

std::string fold_name(FoldBy fb) {
  return fb == FoldBy::kTemperature ? "temperature" : fb == FoldBy::kRamp ? "ramp direction" : "orientation";
}

// Held-out folds: the rows of each group, at most max_folds folds (groups dealt round-robin);
// returns the number of folds.
int deal_folds(const GapInput& in, FoldBy fb, int max_folds, Rows& rows) {
  std::map<int, std::vector<int>> groups;
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const auto& s = in.segments[static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)])];
    const int g = fb == FoldBy::kTemperature ? s.temperature_group : fb == FoldBy::kRamp ? s.ramp_direction : s.orientation;
    groups[g].push_back(static_cast<int>(r));
  }
  const std::size_t nf = max_folds > 0 ? std::min<std::size_t>(static_cast<std::size_t>(max_folds), groups.size())
                                       : groups.size();
  rows.folds.assign(nf, {});
  std::size_t i = 0;
  for (auto& [g, v] : groups) {
    auto& f = rows.folds[i++ % nf];
    f.insert(f.end(), v.begin(), v.end());
  }
  return static_cast<int>(nf);
}

// A candidate is significant when its p value is below the per-candidate level, BIC favours it
// and it lowers the held-out gap.
bool significant(const CandidateResult& r, double alpha_each) {
  return r.evaluated && std::isfinite(r.p_value) && r.p_value < alpha_each && r.delta_bic < 0 &&
         r.heldout_improvement > 0;
}

// The model of a selection step: its terms, design, fit and held-out errors.
struct Current {
  std::vector<TermSpec> terms;
  MatrixXd A;
  Fit fit;
  Heldout cv;
};

// What the candidates are judged on: the rows, each candidate's design columns, the GLS covariance.
struct Search {
  const GapInput& in;
  const Rows& rows;
  const std::vector<Candidate>& cands;
  const std::vector<MatrixXd>& blocks;
  const Gls& gls;
};

// One row of the selection table: held-out RMS and its floor, in-sample RMS [unit].
Step make_step(int step, const std::string& added, const Rows& rows, const Current& cur) {
  Step s;
  s.step = step;
  s.added = added;
  s.heldout_rms = rms_finite(cur.cv.err, &s.floor_rms, &cur.cv.var0);
  s.in_sample_rms = std::sqrt((rows.y - cur.A * cur.fit.lsq.min_norm_solution).squaredNorm() /
                              static_cast<double>(rows.y.size()));
  return s;
}

// Every candidate not yet used, against the current model; unused slots stay empty.
std::vector<Eval> evaluate_all(const Search& sr, const Current& cur, const GlsStep& gst, const std::vector<bool>& used) {
  std::vector<Eval> ev;
  for (std::size_t i = 0; i < sr.cands.size(); ++i)
    ev.push_back(used[i] ? Eval{} : evaluate(sr.in, sr.rows, cur.terms, cur.A, cur.fit, cur.cv, sr.cands[i],
                                             sr.blocks[i], &sr.gls, &gst));
  return ev;
}

// Significance of each evaluated candidate at α / (number evaluated) (Bonferroni).
void mark_significant(std::vector<Eval>& evals, double alpha) {
  int m = 0;
  for (const auto& e : evals) m += e.res.evaluated ? 1 : 0;
  for (auto& e : evals) e.res.significant = significant(e.res, alpha / std::max(1, m));
}

// Pairwise aliases among evaluated candidates of different kinds: the joint design has a lower
// rank than the two designs apart; each names the other and what would separate them.
void candidate_aliases(const Search& sr, const MatrixXd& A0, std::vector<Eval>& evals) {
  const auto& w = sr.rows.w;
  const MatrixXd As = scale_rows(A0, w);
  const int r0 = rank_of(As);
  const std::size_t n = sr.cands.size();
  std::vector<int> rc(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (evals[i].res.evaluated) rc[i] = rank_of(hstack(As, scale_rows(sr.blocks[i], w)));
  for (std::size_t i = 0; i < n; ++i) {
    if (!evals[i].res.evaluated) continue;
    for (std::size_t j = i + 1; j < n; ++j) {
      if (!evals[j].res.evaluated || sr.cands[i].term.kind == sr.cands[j].term.kind) continue;
      const int rij = rank_of(hstack(hstack(As, scale_rows(sr.blocks[i], w)), scale_rows(sr.blocks[j], w)));
      if (rij >= rc[i] + rc[j] - r0) continue;
      evals[i].res.aliases.push_back(sr.cands[j].name);
      evals[j].res.aliases.push_back(sr.cands[i].name);
      const std::string sep = separating_experiment(sr.cands[i].term.kind, sr.cands[j].term.kind);
      evals[i].res.separate.push_back(sep);
      evals[j].res.separate.push_back(sep);
    }
  }
}

// First-pass results ranked: significant first, then by held-out improvement.
std::vector<CandidateResult> ranked(const std::vector<Eval>& evals) {
  std::vector<CandidateResult> out;
  for (const auto& e : evals) out.push_back(e.res);
  std::stable_sort(out.begin(), out.end(), [](const CandidateResult& a, const CandidateResult& b) {
    const double x = std::isfinite(a.heldout_improvement) ? a.heldout_improvement : -1e300;
    const double y = std::isfinite(b.heldout_improvement) ? b.heldout_improvement : -1e300;
    if (a.significant != b.significant) return a.significant;
    return x > y;
  });
  return out;
}

// The significant unused candidate with the largest held-out improvement (α split over those
// evaluated); −1 when none.
int best_candidate(const std::vector<Eval>& ev, const std::vector<bool>& used, double alpha) {
  int m = 0;
  for (std::size_t i = 0; i < ev.size(); ++i) m += !used[i] && ev[i].res.evaluated ? 1 : 0;
  int best = -1;
  double best_imp = 0;
  for (std::size_t i = 0; i < ev.size(); ++i) {
    const auto& r = ev[i].res;
    if (used[i] || !significant(r, alpha / std::max(1, m))) continue;
    if (r.heldout_improvement > best_imp) {
      best_imp = r.heldout_improvement;
      best = static_cast<int>(i);
    }
  }
  return best;
}

// Forward selection on the held-out gap: add the best significant candidate, refit, until the
// held-out errors reach the noise floor, none is significant or max_steps are taken. Step 1
// reuses the first pass. Fills rep.steps / rep.selected / rep.at_floor; returns the final model.
Current forward_select(const Search& sr, Current cur, const std::vector<Eval>& first, const GapOptions& opt,
                       GapReport& rep) {
  std::vector<bool> used(sr.cands.size(), false);
  bool floor_now = at_noise_floor(cur.cv);
  for (int step = 1; step <= opt.max_steps && !floor_now; ++step) {
    const std::vector<Eval> ev =
        step == 1 ? first : evaluate_all(sr, cur, gls_prepare(sr.gls, sr.rows, cur.A), used);
    const int best = best_candidate(ev, used, opt.alpha);
    if (best < 0) break;
    const auto b = static_cast<std::size_t>(best);
    used[b] = true;
    cur.terms.push_back(sr.cands[b].term);
    cur.A = hstack(cur.A, sr.blocks[b]);
    cur.fit = solve(cur.A, sr.rows.y, sr.rows.w);
    cur.cv = ev[b].cv;
    rep.steps.push_back(make_step(step, sr.cands[b].name, sr.rows, cur));
    rep.selected.push_back(sr.cands[b].name);
    floor_now = at_noise_floor(cur.cv);
  }
  rep.at_floor = floor_now;
  return cur;
}

// The named explanation: the first selected term, when it closed at least explain_fraction of the
// excess squared held-out gap above the floor.
std::string explanation(const GapReport& rep, double explain_fraction) {
  if (rep.steps.size() < 2) return {};
  const Step& s0 = rep.steps[0];
  const Step& s1 = rep.steps[1];
  const double excess = s0.heldout_rms * s0.heldout_rms - s0.floor_rms * s0.floor_rms;
  const double closed = s0.heldout_rms * s0.heldout_rms - s1.heldout_rms * s1.heldout_rms;
  return excess > 0 && closed >= explain_fraction * excess ? s1.added : std::string();
}

// The plain-words verdict: at the floor already, unexplained, or (partly) explained by the
// selected terms; RMS in the display unit.
std::string statement(const GapReport& rep, bool floor0) {
  std::ostringstream st;
  const double dpu = rep.display_per_unit;
  if (floor0) {
    st << "The model as given is at the noise floor on held-out data (" << fmt(rep.steps[0].heldout_rms * dpu, 3)
       << " " << rep.display_unit << " held-out RMS vs " << fmt(rep.steps[0].floor_rms * dpu, 3)
       << " expected from noise): no gap to explain.";
    return st.str();
  }
  if (rep.selected.empty()) {
    st << "UNEXPLAINED: the held-out gap is " << fmt(rep.unexplained_heldout_rms * dpu, 3) << " "
       << rep.display_unit << " RMS, " << fmt(rep.unexplained_over_floor, 3)
       << "x the noise floor, and no candidate in the vocabulary explains it significantly.";
    return st.str();
  }
  if (rep.explanation.empty()) st << "PARTLY EXPLAINED: ";
  st << "Adding ";
  for (std::size_t i = 0; i < rep.selected.size(); ++i) st << (i ? ", then " : "") << rep.selected[i];
  st << " takes the held-out gap from " << fmt(rep.steps[0].heldout_rms * dpu, 3) << " to "
     << fmt(rep.unexplained_heldout_rms * dpu, 3) << " " << rep.display_unit << " RMS ("
     << fmt(rep.unexplained_over_floor, 3) << "x the noise floor). ";
  if (rep.at_floor)
    st << "What remains is at the noise floor.";
  else
    st << "UNEXPLAINED remainder: " << fmt(rep.unexplained_over_floor, 3)
       << "x the noise floor is left that no further candidate explains significantly.";
  return st.str();
}

// Steps 4–5: every candidate against the model as given, their aliases, the noise-stage
// candidates, then forward selection and the verdict.
void explain_gap(const GapInput& in, const Rows& rows, const GapOptions& opt, GapReport& rep) {
  const std::vector<Candidate> cands = opt.candidates.empty() ? default_candidates(in.spec.model) : opt.candidates;
  Current cur;
  cur.terms = in.spec.model.terms;
  cur.A = MatrixXd(rows.y.size(), 0);
  for (const auto& t : cur.terms) cur.A = hstack(cur.A, term_block(in, rows, t));
  std::vector<MatrixXd> blocks;
  MatrixXd Xall = cur.A;
  for (const auto& c : cands) {
    blocks.push_back(term_block(in, rows, c.term));
    Xall = hstack(Xall, blocks.back());
  }
  cur.fit = solve(cur.A, rows.y, rows.w);
  if (!cur.fit.lsq.ok()) {
    rep.message = "baseline fit failed: " + cur.fit.lsq.message;
    return;
  }
  cur.cv = cross_validate(cur.A, rows);
  const Gls gls = estimate_gls(in, rows, Xall);
  const Search sr{in, rows, cands, blocks, gls};
  rep.steps.push_back(make_step(0, "", rows, cur));
  const bool floor0 = at_noise_floor(cur.cv);
  std::vector<Eval> evals = evaluate_all(sr, cur, gls_prepare(gls, rows, cur.A), std::vector<bool>(cands.size(), false));
  mark_significant(evals, opt.alpha);
  if (opt.check_aliases) candidate_aliases(sr, cur.A, evals);
  // Noise and output-stage candidates (they cannot move the static means' fit; judged on the
  // raw samples — tests, levels and sizes in noise_stage.hpp).
  const std::vector<CandidateResult> noise = noise_stage::candidates(in, in.spec.axes, rep.unit, opt.alpha);
  rep.candidates = ranked(evals);
  rep.candidates.insert(rep.candidates.end(), noise.begin(), noise.end());
  const Current last = forward_select(sr, cur, evals, opt, rep);
  double fl = 0;
  rep.unexplained_heldout_rms = rms_finite(last.cv.err, &fl, &last.cv.var0);
  rep.unexplained_over_floor = fl > 0 ? rep.unexplained_heldout_rms / fl : kNaN;
  rep.explanation = explanation(rep, opt.explain_fraction);
  rep.statement = statement(rep, floor0);
  rep.ok = true;
}

}  // namespace

GapReport diagnose(const GapInput& in, const GapOptions& opt) {
  GapReport rep = report_header(in);
  // 1. Fit the model as given and replay every segment through the twin.
  rep.fit = fit_model(in);
  if (!rep.fit.ok) {
    rep.message = "the model could not be fitted: " + rep.fit.message;
    return rep;
  }
  const std::vector<bool> fitted = fitted_axes(in);
  rep.floor = noise_floor(in, fitted);
  Rows rows = build_rows(in, full_theta(in.spec.model, rep.fit), fitted, rep);
  gap_and_noise(in, fitted, rep);
  // 2. Where.
  locate_gap(in, rows, rep);
  // 3. Folds.
  const FoldBy fb = fold_grouping(in, opt.fold_by);
  rep.fold_by = fold_name(fb);
  rep.folds = deal_folds(in, fb, opt.max_folds, rows);
  if (rep.folds < 2) {
    rep.message = "the held-out comparison needs at least two " + rep.fold_by + " groups";
    return rep;
  }
  // 4.–5. Which, and how far.
  explain_gap(in, rows, opt, rep);
  return rep;
}

}  // namespace stend::diagnosis
