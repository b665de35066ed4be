// Weighted linear least squares with honest uncertainty and an identifiability analysis.
//
//     minimise Σ_i w_i (y_i − a_iᵀ θ)²        A: k × p design, y: k observations, w_i > 0
//
// Solved on the column-scaled design A_s = W^½ A D⁻¹ (D = diag of column norms, so every column
// has unit length and the condition number reflects the experiment, not the units) by SVD
// (default) or column-pivoting Householder QR — never by forming or inverting AᵀA.
//
// Uncertainty: Cov(θ̂) = σ² (AᵀWA)⁺ with σ² = RSS_w / (k − r) (r = rank; r = p for a full-rank
// design, so this is the usual RSS/(k − p)), or σ² = 1 when the weights are known inverse
// variances (LsqOptions::known_variance). Intervals: θ̂ ± t_{(1+c)/2, k−r} · se (Student t; the
// normal quantile when the variance is known).
//
// Identifiability: the null space of A_s (singular values ≤ rank_tolerance · σ_max) is computed
// from the SVD. A parameter is identifiable iff its unit vector is orthogonal to that null space
// (then θ̂_j is the same for every least-squares solution). Otherwise no value is reported for it
// (value = NaN) and it is explained as either
//   - "not excited": its column is zero in every observation, or
//   - "aliased": it shares a null-space direction with other parameters; the group's identified
//     linear combinations (the row-space part, e.g. bias_z + 10·bias_tc1_z) are reported with
//     value, standard error and interval instead.
// Every identified parameter carries a precision verdict against LsqOptions::tolerances
// (stend/estimation/identifiability.hpp); a large standard error never withholds it.
// Fits are refused (status kFailed, a message, no numbers) when k < p, when no degree of freedom is
// left for the noise (k = rank without known variance), or on non-finite input.
#pragma once

#include <stend/estimation/summary.hpp>
#include <stend/stats/distributions.hpp>

#include <Eigen/Core>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

namespace stend::estimation {

enum class LsqMethod { kSvd, kQr };
enum class LsqStatus { kOk, kFailed };

struct LsqOptions {
  LsqMethod method = LsqMethod::kSvd;
  double confidence = 0.95;  // two-sided interval level
  // Singular values of the column-scaled design below rank_tolerance · σ_max count as zero.
  double rank_tolerance = 1e-10;
  // true: weights are exact inverse variances 1/σ_i²; covariance (AᵀWA)⁻¹ is not rescaled by the
  // residual variance and intervals use the normal quantile. false: weights are relative only.
  bool known_variance = false;
  // Warn when the column-scaled condition number (identified subspace) exceeds this.
  double condition_warning = 1e6;
  // Precision tolerances of the parameters' verdicts (by unit).
  PrecisionTolerances tolerances;
  // Warn when the number of observations k is below this multiple of the parameter count p.
  double observations_per_parameter_warning = 3.0;

  // Confidence in (0, 1), rank tolerance in (0, 1), positive condition and observation warnings,
  // valid tolerances.
  bool IsValid(std::string* error = nullptr) const;
};

struct LsqProblem {
  Eigen::MatrixXd design;        // k × p
  Eigen::VectorXd observations;  // k
  Eigen::VectorXd weights;       // k positive weights, or empty for unit weights
  std::vector<std::string> names;  // p parameter names (empty: "p0", "p1", …)
  std::vector<std::string> units;  // p units (empty: "")
};

// A linear combination cᵀθ with its estimate (estimable combinations only).
struct Combination {
  std::vector<std::pair<int, double>> coefficients;  // (parameter index, coefficient), nonzero only
  std::string text;                                  // e.g. "bias_z + 10·bias_tc1_z"
  double value = 0.0, std_error = 0.0, lower = 0.0, upper = 0.0;
};

// Parameters that share null-space directions, and what the data do determine about them.
struct AliasGroup {
  std::vector<int> parameters;            // indices into LsqResult::parameters
  int null_dimension = 0;                 // how many independent directions are unobservable
  std::vector<Combination> identified;    // (size − null_dimension) estimable combinations
  std::vector<Eigen::VectorXd> null_directions;  // unscaled, each normalised, over `parameters`
};

struct LsqResult {
  LsqStatus status = LsqStatus::kFailed;
  std::string message;  // why it failed; empty on success
  bool ok() const { return status == LsqStatus::kOk; }

  int observations = 0;  // k
  int parameter_count = 0;  // p
  int rank = 0;
  int dof = 0;           // k − rank
  double rss = 0.0;      // weighted residual sum of squares
  double sigma2 = 0.0;   // residual variance used for the covariance (1 if known_variance)
  double confidence = 0.95;
  double quantile = 0.0;  // t (or z) quantile used for the intervals
  // Column-scaled design: σ_max/σ_min over all p singular values (infinity when rank-deficient)
  // and over the identified subspace (σ_max/σ_rank).
  double condition_number = 0.0;
  double condition_number_identified = 0.0;
  LsqMethod method = LsqMethod::kSvd;

  std::vector<ParameterEstimate> parameters;
  Eigen::VectorXd estimate;     // p; NaN for non-identifiable parameters
  Eigen::MatrixXd covariance;   // p × p; NaN rows/columns for non-identifiable parameters
  Eigen::VectorXd residuals;    // k, y − A θ̂ (unweighted)
  std::vector<AliasGroup> aliases;
  std::vector<std::string> warnings;

  // Internals kept for estimable combinations: the minimum-norm solution, the covariance from the
  // pseudo-inverse (valid for estimable cᵀθ only), and an orthonormal basis (unscaled parameter
  // coordinates) of the null space.
  Eigen::VectorXd min_norm_solution;
  Eigen::MatrixXd pinv_covariance;
  Eigen::MatrixXd null_space;

  int index(const std::string& name) const;  // −1 when absent
  const ParameterEstimate& parameter(const std::string& name) const;  // throws when absent
  // Correlation matrix of the identifiable parameters (NaN elsewhere).
  Eigen::MatrixXd correlation() const;
  // Is cᵀθ estimable (c orthogonal to the null space, relative tolerance)?
  bool estimable(const Eigen::VectorXd& c, double tolerance = 1e-8) const;
  // Estimate, standard error and interval of cᵀθ + offset. Throws std::domain_error when cᵀθ is
  // not estimable or the fit failed.
  Combination combination(const Eigen::VectorXd& c, double offset = 0.0) const;
};

LsqResult solve_lsq(const LsqProblem& problem, const LsqOptions& options = {});

// Text report: status, k, p, rank, dof, σ, condition numbers, a parameter table (value, unit,
// std error, interval, identifiable + reason), aliased groups with their identified
// combinations, warnings.
std::ostream& operator<<(std::ostream& os, const LsqResult& r);
std::ostream& operator<<(std::ostream& os, const Combination& c);

// Same status, rank, identifiability pattern and names; values, standard errors and bounds equal
// within |a − b| ≤ abs_tol + rel_tol·max(|a|, |b|) (NaN matches NaN).
bool approx_equal(const LsqResult& a, const LsqResult& b, double rel_tol = 1e-9,
                  double abs_tol = 0.0);

// The intervals' distributions, defined once in stend/stats/distributions.hpp: Student t with
// `dof` > 0 degrees of freedom (dof = ∞ gives the normal), the normal quantile.
using stats::normal_quantile;
using stats::student_t_cdf;
using stats::student_t_quantile;

}  // namespace stend::estimation
