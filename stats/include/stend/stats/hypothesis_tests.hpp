// Tests of linear-model effects on possibly correlated rows (the gap diagnosis' candidates): the
// partial F test of nested fits, the Wald χ² test, the Newey–West long-run covariance of scores,
// and the numerical rank they share.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <vector>

namespace stend::stats {

struct TestResult {
  double statistic = std::numeric_limits<double>::quiet_NaN();
  double p_value = 1.0;
};

// Partial F test of nested least-squares fits: the full fit adds `added_rank` > 0 to the rank of
// the reduced one; rss_* their (weighted) residual sums of squares, dof_full = rows − rank of the
// full fit. Rows that are correlated count as fewer: with an effective share s ∈ (0, 1] of
// independent rows, F = ((rss_reduced − rss_full)/added_rank)/(rss_full/dof_full)·s on
// (added_rank, max(1, s·dof_full)) degrees of freedom.
TestResult nested_f_test(double rss_reduced, double rss_full, int added_rank, int dof_full,
                         double effective_share = 1.0);

// Wald test of H0: β = 0 for an estimate β with covariance S: W = βᵀS⁻¹β (LDLᵀ solve) against
// χ²_q, q = β's size; p = 1 when W is not finite.
TestResult wald_test(const Eigen::VectorXd& estimate, const Eigen::MatrixXd& covariance);

// Newey–West (Bartlett kernel, L = max(1, T/4) lags) long-run covariance Σ_l w_l Γ_l of the
// q × T matrix of scores, one column per time step.
Eigen::MatrixXd long_run_covariance(const Eigen::MatrixXd& scores);

// Number of leading singular values (sorted, largest first) above `relative` × the largest.
int numerical_rank(const Eigen::VectorXd& singular_values, double relative = 1e-8);

// F test of extra columns C against a model, everything already whitened (GLS): Q an orthonormal
// basis of the model's columns (0 columns: no model), r the residual of the observations on Q,
// `rows` the number of observations. C's part outside Q is reduced to its numerical rank q; with
// β its coordinates, F = (‖β‖²/q)/((‖r‖² − ‖β‖²)/(rows − Q.cols() − q)). p = 1 when q = 0, no
// degree of freedom is left or the residual vanishes.
double projected_f_p_value(const Eigen::MatrixXd& Q, const Eigen::VectorXd& r, const Eigen::MatrixXd& C,
                           Eigen::Index rows);

// Benjamini–Yekutieli step-up over a family of m p values: with p_(1) ≤ … ≤ p_(m) and
// c(m) = Σ_{i≤m} 1/i, reject the k smallest for the largest k with p_(k) ≤ k·q/(m·c(m)). Controls
// the false discovery rate at q under ANY dependence between the tests (Benjamini & Yekutieli
// 2001, Thm 1.3); when no effect is real the FDR is the probability of any rejection. NaN p
// values count in m and are never rejected. Returns one flag per p value.
std::vector<bool> benjamini_yekutieli(const std::vector<double>& p_values, double q);

}  // namespace stend::stats
