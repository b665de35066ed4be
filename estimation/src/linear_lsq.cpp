// Weighted linear least squares with uncertainty and identifiability analysis.
// See stend/estimation/linear_lsq.hpp.
#include "stend/estimation/linear_lsq.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "stend/errors.hpp"
#include "stend/sdk.hpp"
#include "stend/stats/distributions.hpp"

namespace stend::estimation {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// A parameter whose row of the (scaled, orthonormal) null-space basis has a norm above this is not
// identifiable; two parameters whose null-space projector entry exceeds it are aliased.
constexpr double kNullTolerance = 1e-7;
// Columns with norm ≤ this × the largest column norm are treated as exactly zero (numerical dust
// such as g·sin(0) computed through rotations would otherwise be rescaled to unit length).
constexpr double kZeroColumnTolerance = 1e-12;


bool close(double a, double b, double rel, double abs_tol) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (std::isinf(a) || std::isinf(b)) return a == b;
  return std::abs(a - b) <= abs_tol + rel * std::max(std::abs(a), std::abs(b));
}

std::string combination_text(const std::vector<std::pair<int, double>>& coeffs,
                             const std::vector<ParameterEstimate>& params) {
  std::string s;
  for (const auto& [idx, c] : coeffs) {
    const double mag = std::abs(c);
    if (s.empty()) {
      if (c < 0) s += "-";
    } else {
      s += c < 0 ? " - " : " + ";
    }
    if (std::abs(mag - 1.0) > 1e-12) s += number_text(mag) + "*";
    s += params[static_cast<std::size_t>(idx)].name;
  }
  return s;
}

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(int n) : parent(static_cast<std::size_t>(n)) {
    std::iota(parent.begin(), parent.end(), 0);
  }
  int find(int i) {
    while (parent[static_cast<std::size_t>(i)] != i) i = parent[static_cast<std::size_t>(i)];
    return i;
  }
  void unite(int a, int b) { parent[static_cast<std::size_t>(find(a))] = find(b); }
};

// --- Steps of solve_lsq --------------------------------------------------------------------------

using Svd = Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::ColPivHouseholderQRPreconditioner>;

std::string join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : separator) + s;
  return out;
}

// One row per design column, named from the problem ("p<j>" when unnamed), every number NaN.
std::vector<ParameterEstimate> unsolved_parameters(const LsqProblem& pr) {
  std::vector<ParameterEstimate> out;
  for (Eigen::Index j = 0; j < pr.design.cols(); ++j) {
    ParameterEstimate e;
    const auto ju = static_cast<std::size_t>(j);
    e.name = ju < pr.names.size() ? pr.names[ju] : "p" + std::to_string(j);
    e.unit = ju < pr.units.size() ? pr.units[ju] : "";
    e.value = e.std_error = e.lower = e.upper = kNaN;
    out.push_back(e);
  }
  return out;
}

// The refused fit: the message, every parameter unidentified, no numbers.
LsqResult failed(LsqResult& r, const std::string& message) {
  r.status = LsqStatus::kFailed;
  r.message = message;
  for (auto& e : r.parameters) {
    e.identifiable = false;
    e.reason = "fit failed";
  }
  r.estimate.resize(0);
  r.covariance.resize(0, 0);
  return r;
}

}  // namespace

bool LsqOptions::IsValid(std::string* error) const {
  if (!(confidence > 0.0 && confidence < 1.0)) return invalid(error, "confidence level must lie in (0, 1)");
  if (!(rank_tolerance > 0.0 && rank_tolerance < 1.0)) return invalid(error, "rank_tolerance must lie in (0, 1)");
  if (!(condition_warning > 0.0) || !(observations_per_parameter_warning >= 0.0))
    return invalid(error, "condition_warning must be > 0 and observations_per_parameter_warning >= 0");
  return tolerances.IsValid(error);
}

namespace {

// Why the problem cannot be solved as posed (sizes, confidence, k ≥ p, finite input, positive
// weights); "" when it can.
std::string problem_error(const LsqProblem& pr, const LsqOptions& opt,
                          const std::vector<ParameterEstimate>& params) {
  const Eigen::Index k = pr.design.rows(), p = pr.design.cols();
  if (pr.observations.size() != k) return "observation vector length differs from design rows";
  if (pr.weights.size() != 0 && pr.weights.size() != k)
    return "weight vector length differs from design rows";
  if ((!pr.names.empty() && pr.names.size() != static_cast<std::size_t>(p)) ||
      (!pr.units.empty() && pr.units.size() != static_cast<std::size_t>(p)))
    return "parameter names/units do not match the design's column count";
  if (std::string why; !opt.IsValid(&why)) return why;
  if (p == 0) return "no parameters to estimate";
  if (k < p) {
    std::vector<std::string> names;
    for (const auto& e : params) names.push_back(e.name);
    return "underdetermined: k = " + std::to_string(k) + " observations for p = " +
           std::to_string(p) + " parameters (" + join(names, ", ") +
           "); a least-squares fit needs k >= p and should have k >> p. Add orientations, axes or "
           "segments, or remove terms from the model.";
  }
  if (!pr.design.allFinite() || !pr.observations.allFinite())
    return "design matrix or observations contain NaN or infinity";
  for (Eigen::Index i = 0; i < pr.weights.size(); ++i)
    if (!(pr.weights[i] > 0.0) || !std::isfinite(pr.weights[i]))
      return "weight " + std::to_string(i) + " is not a positive finite number";
  return {};
}

// The design as solved: weighted, then column-scaled to unit norms.
struct Design {
  Eigen::MatrixXd Aw;          // W^½ A
  Eigen::VectorXd yw;          // W^½ y
  Eigen::MatrixXd As;          // A_s = W^½ A D⁻¹ (zero columns where not excited)
  Eigen::VectorXd scale;       // D: the column norms of W^½ A (1 for a zero column)
  std::vector<bool> zero_col;  // column j is not excited (norm ≤ kZeroColumnTolerance × largest)
};

// W^½ A and W^½ y (unit weights when the problem gives none).
Design weighted_design(const LsqProblem& pr) {
  Eigen::VectorXd sw = Eigen::VectorXd::Ones(pr.design.rows());
  if (pr.weights.size() == pr.design.rows()) sw = pr.weights.cwiseSqrt();
  Design d;
  d.Aw = sw.asDiagonal() * pr.design;
  d.yw = sw.cwiseProduct(pr.observations);
  return d;
}

// A_s = W^½ A D⁻¹; false when every column is zero (nothing is excited).
bool scale_columns(Design& d) {
  const Eigen::Index p = d.Aw.cols();
  d.scale = d.Aw.colwise().norm().transpose();
  const double max_norm = d.scale.maxCoeff();
  if (!(max_norm > 0.0)) return false;
  d.zero_col.assign(static_cast<std::size_t>(p), false);
  d.As = d.Aw;
  for (Eigen::Index j = 0; j < p; ++j) {
    if (d.scale[j] <= kZeroColumnTolerance * max_norm) {
      d.zero_col[static_cast<std::size_t>(j)] = true;
      d.scale[j] = 1.0;
      d.As.col(j).setZero();
    } else {
      d.As.col(j) /= d.scale[j];
    }
  }
  return true;
}

// Numerical rank: singular values above rank_tolerance × σ_max.
int numerical_rank(const Eigen::VectorXd& s, double rank_tolerance) {
  int rank = 0;
  for (Eigen::Index i = 0; i < s.size(); ++i)
    if (s[i] > rank_tolerance * s[0]) ++rank;
  return rank;
}

// Solution x_s and unit covariance (A_sᵀA_s)⁺ in scaled coordinates.
struct ScaledSolution {
  Eigen::VectorXd xs;
  Eigen::MatrixXd cov_unit;
  bool by_qr = false;
};

// Column-pivoting QR when asked for and the design has full rank; else the truncated SVD
// (minimum-norm solution).
ScaledSolution solve_scaled(const Design& d, const Svd& svd, int rank, LsqMethod method) {
  const Eigen::Index p = d.As.cols();
  ScaledSolution out;
  out.xs = Eigen::VectorXd::Zero(p);
  out.cov_unit = Eigen::MatrixXd::Zero(p, p);
  if (method == LsqMethod::kQr && rank == p) {
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(d.As);
    out.xs = qr.solve(d.yw);
    const Eigen::MatrixXd R = qr.matrixR().topLeftCorner(p, p).triangularView<Eigen::Upper>();
    // (RᵀR)⁻¹ = R⁻¹R⁻ᵀ by two triangular solves, then undo the column permutation.
    const Eigen::MatrixXd Rinv = R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(p, p));
    const Eigen::MatrixXd C = Rinv * Rinv.transpose();
    const auto& P = qr.colsPermutation();
    out.cov_unit = P * C * P.transpose();
    out.by_qr = true;
    return out;
  }
  const Eigen::VectorXd& s = svd.singularValues();
  const Eigen::MatrixXd& U = svd.matrixU();
  const Eigen::MatrixXd& V = svd.matrixV();
  for (int i = 0; i < rank; ++i) {
    out.xs += V.col(i) * (U.col(i).dot(d.yw) / s[i]);
    out.cov_unit += V.col(i) * V.col(i).transpose() / (s[i] * s[i]);
  }
  return out;
}

// Residuals y − Aθ̂, weighted RSS, σ² (1 when the variance is known) and the interval quantile
// (interval_quantile: normal when the variance is known, else Student t with k − rank dof).
void residual_statistics(LsqResult& r, const LsqProblem& pr, const Design& d,
                         const Eigen::VectorXd& x, const LsqOptions& opt) {
  r.residuals = pr.observations - pr.design * x;
  r.rss = (d.yw - d.Aw * x).squaredNorm();
  r.sigma2 = opt.known_variance ? 1.0 : r.rss / r.dof;
  r.quantile = interval_quantile(opt.confidence, opt.known_variance ? kAPrioriDof : r.dof);
}

// Orthonormal basis of the null space in unscaled parameter coordinates, from the scaled one.
Eigen::MatrixXd unscaled_null_basis(const Eigen::MatrixXd& Ns, const Eigen::VectorXd& dinv) {
  Eigen::MatrixXd Nu = dinv.asDiagonal() * Ns;
  if (Nu.cols() > 0)
    Nu = Eigen::HouseholderQR<Eigen::MatrixXd>(Nu).householderQ() *
         Eigen::MatrixXd::Identity(Nu.rows(), Nu.cols());
  return Nu;
}

// Parameter j is identifiable when its row of the scaled null-space projector P has
// √P_jj ≤ kNullTolerance.
std::vector<bool> identifiable_parameters(const Eigen::MatrixXd& P) {
  std::vector<bool> ident(static_cast<std::size_t>(P.rows()));
  for (Eigen::Index j = 0; j < P.rows(); ++j)
    ident[static_cast<std::size_t>(j)] = std::sqrt(std::max(0.0, P(j, j))) <= kNullTolerance;
  return ident;
}

// Estimates, covariance, standard errors and intervals of the identifiable parameters (NaN for
// the others); the fit is ok from here on.
void fill_identified(LsqResult& r, const Eigen::VectorXd& x, const std::vector<bool>& ident,
                     const PrecisionTolerances& tolerances) {
  const Eigen::Index p = x.size();
  r.estimate = Eigen::VectorXd::Constant(p, kNaN);
  r.covariance = Eigen::MatrixXd::Constant(p, p, kNaN);
  for (Eigen::Index i = 0; i < p; ++i) {
    if (!ident[static_cast<std::size_t>(i)]) continue;
    r.estimate[i] = x[i];
    for (Eigen::Index j = 0; j < p; ++j)
      if (ident[static_cast<std::size_t>(j)]) r.covariance(i, j) = r.pinv_covariance(i, j);
  }
  r.status = LsqStatus::kOk;
  for (Eigen::Index j = 0; j < p; ++j) {
    ParameterEstimate& e = r.parameters[static_cast<std::size_t>(j)];
    e.identifiable = ident[static_cast<std::size_t>(j)];
    if (!e.identifiable) continue;
    e.value = x[j];
    e.std_error = std::sqrt(std::max(0.0, r.pinv_covariance(j, j)));
    e.lower = e.value - r.quantile * e.std_error;
    e.upper = e.value + r.quantile * e.std_error;
  }
  for (auto& e : r.parameters) judge(e, tolerances, {r.confidence, r.quantile});
}

// Groups of non-identifiable parameters connected through the null space (projector entries
// |P_ij| > kNullTolerance), in order of their representative's index.
std::vector<std::vector<int>> null_space_groups(const Eigen::MatrixXd& P, const std::vector<bool>& ident) {
  const int p = static_cast<int>(P.rows());
  UnionFind uf(p);
  for (int i = 0; i < p; ++i)
    for (int j = i + 1; j < p; ++j)
      if (!ident[static_cast<std::size_t>(i)] && !ident[static_cast<std::size_t>(j)] &&
          std::abs(P(i, j)) > kNullTolerance)
        uf.unite(i, j);
  std::vector<std::vector<int>> by_root(static_cast<std::size_t>(p)), groups;
  for (int j = 0; j < p; ++j)
    if (!ident[static_cast<std::size_t>(j)]) by_root[static_cast<std::size_t>(uf.find(j))].push_back(j);
  for (auto& g : by_root)
    if (!g.empty()) groups.push_back(std::move(g));
  return groups;
}

// An aliased group: its unobservable directions (unscaled, normalised) and the combinations of
// its parameters the data identify (the complement of those directions, in reduced row form).
AliasGroup alias_group(const LsqResult& r, const std::vector<int>& g, const Eigen::MatrixXd& P,
                       const Eigen::VectorXd& dinv) {
  const int m = static_cast<int>(g.size());
  const Eigen::Index p = P.rows();
  AliasGroup ag;
  ag.parameters = g;
  Eigen::MatrixXd Pg(m, m);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) Pg(a, b) = P(g[static_cast<std::size_t>(a)], g[static_cast<std::size_t>(b)]);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Pg);
  for (int a = 0; a < m; ++a)
    if (es.eigenvalues()[a] > 0.5) {
      Eigen::VectorXd n(m);
      for (int b = 0; b < m; ++b) n[b] = es.eigenvectors()(b, a) * dinv[g[static_cast<std::size_t>(b)]];
      n.normalize();
      ag.null_directions.push_back(n);
    }
  ag.null_dimension = static_cast<int>(ag.null_directions.size());
  Eigen::MatrixXd Nt(ag.null_dimension, m);
  for (int a = 0; a < ag.null_dimension; ++a) Nt.row(a) = ag.null_directions[static_cast<std::size_t>(a)].transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> nsvd(Nt, Eigen::ComputeFullV);
  const Eigen::MatrixXd comp = nsvd.matrixV().rightCols(m - ag.null_dimension);
  const Eigen::MatrixXd combos = reduced_row_echelon(comp.transpose());
  for (Eigen::Index c = 0; c < combos.rows(); ++c) {
    Eigen::VectorXd full = Eigen::VectorXd::Zero(p);
    for (int b = 0; b < m; ++b) full[g[static_cast<std::size_t>(b)]] = combos(c, b);
    ag.identified.push_back(r.combination(full));
  }
  return ag;
}

// Says why each non-identifiable parameter is not identified (not excited, in the null space,
// or aliased, with what the data do identify); records the alias groups. Returns their names.
std::vector<std::string> explain_unidentified(LsqResult& r, const Eigen::MatrixXd& P,
                                              const std::vector<bool>& ident,
                                              const std::vector<bool>& zero_col,
                                              const Eigen::VectorXd& dinv) {
  std::vector<std::string> not_identified;
  for (const auto& g : null_space_groups(P, ident)) {
    if (g.size() == 1) {
      const auto j = static_cast<std::size_t>(g[0]);
      not_identified.push_back(r.parameters[j].name);
      r.parameters[j].reason =
          zero_col[j] ? "not excited: its regressor column is zero in every observation, so the "
                        "data carry no information about it"
                      : "not identifiable: its direction lies in the null space of the design";
      continue;
    }
    AliasGroup ag = alias_group(r, g, P, dinv);
    std::vector<std::string> identified, unseen, group_names;
    for (const auto& c : ag.identified) identified.push_back(c.text);
    for (int j : g) group_names.push_back(r.parameters[static_cast<std::size_t>(j)].name);
    Eigen::MatrixXd basis(static_cast<Eigen::Index>(g.size()), ag.null_dimension);
    for (int a = 0; a < ag.null_dimension; ++a) basis.col(a) = ag.null_directions[static_cast<std::size_t>(a)];
    unseen = null_space_text(basis, group_names);
    for (int j : g) {
      std::vector<std::string> others;
      for (int o : g)
        if (o != j) others.push_back(r.parameters[static_cast<std::size_t>(o)].name);
      auto& e = r.parameters[static_cast<std::size_t>(j)];
      e.reason = "aliased with " + join(others, ", ") + ": the data do not see " + join(unseen, "; ") +
                 (identified.empty() ? std::string() : " and identify only " + join(identified, "; "));
      not_identified.push_back(e.name);
    }
    r.aliases.push_back(std::move(ag));
  }
  return not_identified;
}

// Warnings: few observations per parameter, a rank-deficient design, an ill-conditioned one
// (with its weakest direction in unscaled parameters).
void add_warnings(LsqResult& r, const LsqOptions& opt, const std::vector<std::string>& not_identified,
                  const Eigen::MatrixXd& V, const Eigen::VectorXd& dinv) {
  const int k = r.observations, p = r.parameter_count, rank = r.rank;
  if (static_cast<double>(k) < opt.observations_per_parameter_warning * static_cast<double>(p))
    r.warnings.push_back("few observations: k = " + std::to_string(k) + " for p = " +
                         std::to_string(p) + " parameters (k < " +
                         number_text(opt.observations_per_parameter_warning) +
                         "p); the residual variance and the intervals rest on " +
                         std::to_string(r.dof) + " degrees of freedom (the paper asks for k >> p)");
  if (rank < p)
    r.warnings.push_back("rank-deficient design: rank " + std::to_string(rank) + " < p = " +
                         std::to_string(p) + "; not identifiable: " + join(not_identified, ", "));
  if (rank < p) {
    std::vector<std::string> names;
    for (const auto& e : r.parameters) names.push_back(e.name);
    for (const auto& c : null_space_text(r.null_space, names))
      r.warnings.push_back("unidentified combination: " + c +
                           " (a singular direction of the design; add orientations or inputs that separate these "
                           "parameters)");
  }
  if (r.condition_number_identified > opt.condition_warning) {
    const Eigen::VectorXd w = dinv.cwiseProduct(V.col(rank - 1));
    const double mx = w.cwiseAbs().maxCoeff();
    std::vector<std::pair<int, double>> terms;
    for (Eigen::Index j = 0; j < p; ++j)
      if (std::abs(w[j]) > 0.1 * mx) terms.emplace_back(static_cast<int>(j), w[j] / mx);
    r.warnings.push_back("ill-conditioned design (column-scaled condition number " +
                         number_text(r.condition_number_identified, 3) +
                         "): the weakest direction is " + combination_text(terms, r.parameters) +
                         "; these parameters are strongly correlated and poorly determined");
  }
}

}  // namespace

int LsqResult::index(const std::string& name) const {
  for (std::size_t i = 0; i < parameters.size(); ++i)
    if (parameters[i].name == name) return static_cast<int>(i);
  return -1;
}

const ParameterEstimate& LsqResult::parameter(const std::string& name) const {
  const int i = index(name);
  if (i < 0) throw std::out_of_range("no parameter named '" + name + "' in this fit");
  return parameters[static_cast<std::size_t>(i)];
}

Eigen::MatrixXd LsqResult::correlation() const {
  const Eigen::Index p = covariance.rows();
  Eigen::MatrixXd c(p, p);
  for (Eigen::Index i = 0; i < p; ++i)
    for (Eigen::Index j = 0; j < p; ++j)
      c(i, j) = covariance(i, j) / std::sqrt(covariance(i, i) * covariance(j, j));
  return c;
}

bool LsqResult::estimable(const Eigen::VectorXd& c, double tolerance) const {
  if (!ok() || c.size() != parameter_count) return false;
  if (null_space.cols() == 0) return true;
  return (null_space.transpose() * c).norm() <= tolerance * c.norm();
}

Combination LsqResult::combination(const Eigen::VectorXd& c, double offset) const {
  if (!ok()) throw std::domain_error("combination of a failed fit: " + message);
  if (c.size() != parameter_count)
    throw std::domain_error("combination: coefficient vector has the wrong size");
  if (!estimable(c))
    throw std::domain_error("combination is not estimable: it has a component along the null "
                            "space of the design (the data cannot determine it)");
  Combination out;
  for (Eigen::Index i = 0; i < c.size(); ++i)
    if (c[i] != 0.0) out.coefficients.emplace_back(static_cast<int>(i), c[i]);
  out.text = combination_text(out.coefficients, parameters);
  if (offset != 0.0) out.text += (offset < 0 ? " - " : " + ") + number_text(std::abs(offset));
  out.value = c.dot(min_norm_solution) + offset;
  out.std_error = std::sqrt(std::max(0.0, c.dot(pinv_covariance * c)));
  out.lower = out.value - quantile * out.std_error;
  out.upper = out.value + quantile * out.std_error;
  return out;
}

LsqResult solve_lsq(const LsqProblem& pr, const LsqOptions& opt) {
  LsqResult r;
  r.confidence = opt.confidence;
  r.method = opt.method;
  const Eigen::Index k = pr.design.rows(), p = pr.design.cols();
  r.observations = static_cast<int>(k);
  r.parameter_count = static_cast<int>(p);
  r.parameters = unsolved_parameters(pr);
  if (const std::string why = problem_error(pr, opt, r.parameters); !why.empty()) return failed(r, why);
  Design d = weighted_design(pr);
  if (!scale_columns(d)) return failed(r, "every column of the design is zero: nothing is excited");

  const Svd svd(d.As, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  const int rank = numerical_rank(s, opt.rank_tolerance);
  r.rank = rank;
  r.dof = static_cast<int>(k) - rank;
  r.condition_number = rank == p ? s[0] / s[p - 1] : kInf;
  r.condition_number_identified = s[0] / s[rank - 1];
  if (r.dof <= 0 && !opt.known_variance)
    return failed(r, "no degrees of freedom left for the noise: k = " + std::to_string(k) +
                         " observations, rank " + std::to_string(rank) +
                         "; the residual variance (and so every uncertainty) cannot be estimated. "
                         "Add observations, or supply known inverse-variance weights.");

  const ScaledSolution sol = solve_scaled(d, svd, rank, opt.method);
  if (opt.method == LsqMethod::kQr && !sol.by_qr)
    r.warnings.push_back("QR was requested but the design is rank-deficient; solved by SVD "
                         "(minimum-norm solution, identifiable parameters only)");
  r.method = sol.by_qr ? LsqMethod::kQr : LsqMethod::kSvd;
  const Eigen::VectorXd x = sol.xs.cwiseQuotient(d.scale);
  residual_statistics(r, pr, d, x, opt);
  const Eigen::VectorXd dinv = d.scale.cwiseInverse();
  r.min_norm_solution = x;
  r.pinv_covariance = r.sigma2 * dinv.asDiagonal() * sol.cov_unit * dinv.asDiagonal();

  const Eigen::MatrixXd Ns = svd.matrixV().rightCols(p - rank);  // scaled null space
  r.null_space = unscaled_null_basis(Ns, dinv);
  const Eigen::MatrixXd P = Ns * Ns.transpose();
  const std::vector<bool> ident = identifiable_parameters(P);
  fill_identified(r, x, ident, opt.tolerances);
  const std::vector<std::string> not_identified = explain_unidentified(r, P, ident, d.zero_col, dinv);
  add_warnings(r, opt, not_identified, svd.matrixV(), dinv);
  return r;
}

std::ostream& operator<<(std::ostream& os, const Combination& c) {
  return os << c.text << " = " << number_text(c.value, 7) << " +/- " << number_text(c.std_error, 3)
            << " [" << number_text(c.lower, 7) << ", " << number_text(c.upper, 7) << "]";
}

std::ostream& operator<<(std::ostream& os, const LsqResult& r) {
  if (!r.ok()) return os << "FIT FAILED: " << r.message << "\n";
  os << "least squares (" << (r.method == LsqMethod::kQr ? "QR" : "SVD") << "): k = "
     << r.observations << ", p = " << r.parameter_count << ", rank = " << r.rank
     << ", dof = " << r.dof << ", sigma = " << number_text(std::sqrt(r.sigma2), 4)
     << ", cond = " << number_text(r.condition_number, 4)
     << " (identified subspace " << number_text(r.condition_number_identified, 4) << ")\n";
  print_parameter_header(os, r.confidence);
  for (const auto& e : r.parameters) os << e << "\n";
  for (const auto& a : r.aliases) {
    os << "aliased group (" << a.null_dimension << " unobservable direction"
       << (a.null_dimension == 1 ? "" : "s") << "):";
    for (int j : a.parameters) os << " " << r.parameters[static_cast<std::size_t>(j)].name;
    os << "\n";
    for (const auto& c : a.identified) os << "  identified: " << c << "\n";
  }
  for (const auto& w : r.warnings) os << "warning: " << w << "\n";
  return os;
}

bool approx_equal(const LsqResult& a, const LsqResult& b, double rel_tol, double abs_tol) {
  if (a.status != b.status || a.parameters.size() != b.parameters.size()) return false;
  if (!a.ok()) return a.message == b.message;
  if (a.rank != b.rank || a.observations != b.observations || a.dof != b.dof) return false;
  for (std::size_t i = 0; i < a.parameters.size(); ++i) {
    if (!a.parameters[i].equals(b.parameters[i], rel_tol, abs_tol)) return false;
  }
  if (a.aliases.size() != b.aliases.size()) return false;
  for (std::size_t g = 0; g < a.aliases.size(); ++g) {
    const auto &x = a.aliases[g], &y = b.aliases[g];
    if (x.parameters != y.parameters || x.identified.size() != y.identified.size()) return false;
    for (std::size_t c = 0; c < x.identified.size(); ++c)
      if (!close(x.identified[c].value, y.identified[c].value, rel_tol, abs_tol) ||
          !close(x.identified[c].std_error, y.identified[c].std_error, rel_tol, abs_tol))
        return false;
  }
  return close(std::sqrt(a.sigma2), std::sqrt(b.sigma2), rel_tol, abs_tol);
}

}  // namespace stend::estimation
