// One candidate term judged against the current model. See candidate_tests.hpp.
#include "candidate_tests.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <set>

#include "stend/stats/hypothesis_tests.hpp"

namespace stend::diagnosis {

namespace {

// Model terms the candidate aliases with (null-space groups of the joint fit that hold a candidate
// parameter, p0 = model columns), and the experiment that would separate each from it.
void add_model_aliases(const Fit& with, const std::vector<model::TermSpec>& current, int p0, model::TermKind kind,
                       CandidateResult& r) {
  std::set<std::string> aliased;
  for (const auto& g : with.lsq.aliases) {
    bool mine = false;
    for (int idx : g.parameters) mine = mine || idx >= p0;
    if (!mine) continue;
    for (int idx : g.parameters)
      if (idx < p0) {
        int first = 0;
        for (const auto& t : current) {
          const int np = model::param_count(t);
          if (idx >= first && idx < first + np) aliased.insert(term_label(t));
          first += np;
        }
      }
  }
  for (const auto& a : aliased) r.aliases.push_back(a + " (in the model)");
  for (const auto& a : aliased) {
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
    const int seg = rows.seg[static_cast<std::size_t>(i)];
    for (Eigen::Index j = i + 1; j < res.size() && rows.seg[static_cast<std::size_t>(j)] <= seg + 1; ++j)
      if (rows.seg[static_cast<std::size_t>(j)] == seg + 1 &&
          rows.axis[static_cast<std::size_t>(j)] == rows.axis[static_cast<std::size_t>(i)])
        num += std::sqrt(rows.w[i] * rows.w[j]) * res[i] * res[j];
  }
  return den > 0 ? std::clamp(num / den, 0.0, 0.9) : 0.0;
}

// Partial F test and ΔBIC of the candidate. Segment means are not independent when the bias
// wanders slowly (instability, random walk): the lag-1 autocorrelation ρ of the residuals WITH the
// candidate shrinks the evidence to an effective (1 − ρ)/(1 + ρ) share of the segments.
void f_test(const Rows& rows, const Fit& without, const Fit& with, CandidateResult& r) {
  const int k = static_cast<int>(rows.y.size());
  const double rho = lag1_correlation(rows, with.lsq.residuals);
  const stats::TestResult t =
      stats::nested_f_test(without.rss, with.rss, r.added_rank, k - with.rank, (1 - rho) / (1 + rho));
  r.f_stat = t.statistic;
  r.p_value = t.p_value;
  r.delta_bic = k * std::log(with.rss / without.rss) + r.added_rank * std::log(static_cast<double>(k));
}

// Second test, robust to slowly correlated segment means: the candidate's component orthogonal
// to the model, with a Newey–West long-run variance of its per-segment scores (residuals with the
// candidate), scaled by T/(T − rank per segment) for small samples like the residual variance;
// χ²_q. The candidate must pass both: p is the larger.
void newey_west_test(const Rows& rows, const MatrixXd& A0, const MatrixXd& C, const Fit& with, CandidateResult& r) {
  const VectorXd sw = rows.w.cwiseSqrt();
  MatrixXd Ct = sw.asDiagonal() * C;
  if (A0.cols() > 0) {
    const MatrixXd Q = column_basis(sw.asDiagonal() * A0);
    Ct -= Q * (Q.transpose() * Ct);
  }
  Eigen::JacobiSVD<MatrixXd> svd(Ct, Eigen::ComputeThinU);
  const int q = stats::numerical_rank(svd.singularValues());
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
  const VectorXd e1 = sw.asDiagonal() * with.lsq.residuals;
  MatrixXd g = MatrixXd::Zero(q, T);
  for (Eigen::Index i = 0; i < e1.size(); ++i) g.col(rows.seg[static_cast<std::size_t>(i)]) += Z.row(i).transpose() * e1[i];
  const int rows_total = static_cast<int>(rows.y.size());
  const MatrixXd S = stats::long_run_covariance(g) *
                     (static_cast<double>(T) / std::max(1, T - with.rank / std::max(1, rows_total / std::max(1, T))));
  r.p_value = std::max(r.p_value, stats::wald_test(beta, S).p_value);
}

// Held-out RMS without and with the candidate on the rows both predict, and the relative gain.
void heldout_gain(const Heldout& without, const Heldout& with, CandidateResult& r) {
  const CvCompare cc = compare(without, with);
  if (cc.n == 0) {
    r.reason += std::string(r.reason.empty() ? "" : "; ") +
                "held out: no row is determined by its training fold with this candidate (its parameters are seen "
                "only in the held-out fold, or extrapolated beyond 3x the floor) — it cannot be tested held out here";
    return;
  }
  r.heldout_rms_before = cc.before;
  r.heldout_rms = cc.after;
  if (cc.n > 0 && cc.before > 0) r.heldout_improvement = 1.0 - cc.after / cc.before;
}

// Effect size: the candidate parameter (columns from p0 on) with the largest |value|/se.
void effect_size(const Fit& with, int p0, Eigen::Index columns, CandidateResult& r) {
  double best = -1;
  for (int j = p0; j < static_cast<int>(columns); ++j) {
    const auto& pe = with.lsq.parameters[static_cast<std::size_t>(j)];
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

// Under a time-correlated covariance of the segment means (region found) the interval of the
// effect-size parameter comes from the whitened fit; the widest over the likelihood region is
// kept, as for the p value (independent-mean intervals under-cover when the bias wanders).
void widen_by_gls(const SegmentCovariance& cov, const Rows& rows, const MatrixXd& A1, const ParamLabels& labels,
                  CandidateResult& r) {
  const VectorXd ones = VectorXd::Ones(rows.y.size());
  double widest = r.ci_hi - r.ci_lo;
  for (const auto& c : cov.region) {
    const Fit fg = solve(whiten(c, rows, A1), whiten(c, rows, rows.y), ones, labels.names, labels.units);
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
std::string dominant_axis(const GapInput& in, const Rows& rows, const MatrixXd& C, const Fit& with) {
  const VectorXd th = with.lsq.min_norm_solution.tail(C.cols());
  const VectorXd contrib = C * th;
  double ax[3] = {0, 0, 0};
  for (Eigen::Index i = 0; i < contrib.size(); ++i) ax[rows.axis[static_cast<std::size_t>(i)]] += contrib[i] * contrib[i];
  const int amax = static_cast<int>(std::max_element(ax, ax + 3) - ax);
  return in.magnitude ? "|f|" : std::string(1, "xyz"[amax]);
}

}  // namespace

Evaluation evaluate(const CandidateSearch& sr, const CurrentModel& cur, const GlsStep& gls, std::size_t i) {
  const Candidate& c = sr.candidates[i];
  const MatrixXd& C = sr.columns[i];
  Evaluation e;
  CandidateResult& r = e.result;
  r.term = c.name;
  r.spec = c.term;
  if (C.cols() == 0 || C.norm() == 0.0) {
    r.reason = "not excited by this experiment (its regressor is zero in every segment)";
    return e;
  }
  const MatrixXd A1 = hstack(cur.columns, C);
  std::vector<model::TermSpec> terms = cur.terms;
  terms.push_back(c.term);
  const ParamLabels labels = param_labels(sr.input, terms);
  const Fit with = solve(A1, sr.rows.y, sr.rows.w, labels.names, labels.units);
  if (!with.lsq.ok()) {
    r.reason = "fit with it failed: " + with.lsq.message;
    return e;
  }
  r.added_rank = with.rank - cur.fit.rank;
  const int p0 = static_cast<int>(cur.columns.cols());
  add_model_aliases(with, cur.terms, p0, c.term.kind, r);
  if (r.added_rank <= 0) {
    r.reason = "aliased with the model's own terms: this experiment cannot see it beyond them";
    return e;
  }
  r.evaluated = true;
  if (static_cast<int>(sr.rows.y.size()) - with.rank > 0 && with.rss > 0) {
    f_test(sr.rows, cur.fit, with, r);
    newey_west_test(sr.rows, cur.columns, C, with, r);
    // Third: GLS F test under the segments' time covariance (when found).
    if (sr.covariance.found) r.p_value = std::max(r.p_value, gls_p_value(sr.covariance, gls, sr.rows, C));
  }
  e.heldout = cross_validate(A1, sr.rows);
  heldout_gain(cur.heldout, e.heldout, r);
  effect_size(with, p0, A1.cols(), r);
  if (sr.covariance.found && !r.size_param.empty()) widen_by_gls(sr.covariance, sr.rows, A1, labels, r);
  r.axis = dominant_axis(sr.input, sr.rows, C, with);
  return e;
}

}  // namespace stend::diagnosis
