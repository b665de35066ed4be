// The gap's linear problem over static segment means (internal to stend_diagnosis): its rows,
// the design columns of a vocabulary term, and a weighted least-squares fit of a column set.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "stend/diagnosis/gap.hpp"
#include "stend/estimation/linear_lsq.hpp"

namespace stend::diagnosis {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// "cross_axis", "bias_temperature(order 2)": a term as the report names it.
std::string term_label(const model::TermSpec& term);

// The fitted instrument's mean of a segment [m/s² | rad/s].
const Eigen::Vector3d& measured(const GapInput& input, const SegmentData& segment);

// Rows of the problem: one per (segment, fitted axis) — in the magnitude form one per segment.
struct Rows {
  std::vector<int> seg, axis;  // segment index and axis (the row slot) of each row
  VectorXd y, w;               // Δ = measured − true input [unit]; weights 1/floor² [1/unit²]
  // Magnitude form only: the direction each row projects the segment's three axes on (û);
  // empty otherwise (row = one sensor axis).
  std::vector<Eigen::Vector3d> dir;
  std::vector<std::vector<int>> folds;  // row indices held out together
};

// Design columns of one term over all rows, from the vocabulary's regressor.
MatrixXd term_columns(const GapInput& input, const Rows& rows, const model::TermSpec& term);
// [a | b] (rows of the taller one; either may have no columns).
MatrixXd hstack(const MatrixXd& a, const MatrixXd& b);
// √w·A: the rows weighted.
MatrixXd scale_rows(const MatrixXd& A, const VectorXd& w);
// Column-scaled numerical rank (pivoted QR, threshold 1e-9 on unit columns).
int rank_of(const MatrixXd& A);
// Orthonormal basis of the column space of A (pivoted QR, relative rank threshold 1e-10).
MatrixXd column_basis(const MatrixXd& A);
// A with every non-zero column scaled to unit norm.
MatrixXd unit_columns(const MatrixXd& A);

// A weighted least-squares fit of some columns (estimation::solve_lsq, no few-rows warning). With
// known_variance the weights are taken as 1/variance (the floor's): covariances are (AᵀWA)⁺, not
// scaled by the residual variance (defined even for a fit without residual degrees of freedom).
struct Fit {
  estimation::LsqResult lsq;
  double rss = kNaN;  // weighted
  int rank = 0;
};
Fit solve(const MatrixXd& A, const VectorXd& y, const VectorXd& w, const std::vector<std::string>& names = {},
          const std::vector<std::string>& units = {}, bool known_variance = false);

// Parameter names and units of a term list, in design-column order.
struct ParamLabels {
  std::vector<std::string> names, units;
};
ParamLabels param_labels(const GapInput& input, const std::vector<model::TermSpec>& terms);

}  // namespace stend::diagnosis
