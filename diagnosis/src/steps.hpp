// The steps of diagnose() (gap.cpp) after the fit and the twin's replay, one file each (internal
// to stend_diagnosis).
#pragma once

#include "linear_problem.hpp"

namespace stend::diagnosis {

// Where the gap is (where.cpp): shares of the squared twin residual by axis, orientation,
// temperature, time since the last change and averaging time, into report.where.
void locate_gap(const GapInput& input, const Rows& rows, GapReport& report);

// The held-out folds (folds.cpp): the grouping `requested` resolves to on this input (auto:
// temperature with ≥ 3 levels, else orientation; ramp without two directions: orientation), and
// the rows of each group dealt into at most max_folds folds (rows.folds; leave-one-segment-out is
// always strict); returns their number.
FoldBy fold_grouping(const GapInput& input, FoldBy requested);
int deal_folds(const GapInput& input, FoldBy grouping, int max_folds, Rows& rows);

// The columns the folds must serve: the model's, each candidate's, whether it adds rank beyond
// the model on the whole design, and its name.
struct CandidateSearchColumns {
  const MatrixXd& model;
  const std::vector<MatrixXd>& candidates;
  std::vector<bool> adds_rank;
  std::vector<std::string> names;
};

// Folds that fit the design (folds.cpp). The schemes are tried in order — the requested one
// alone, or for auto: temperature (≥ 3 levels), orientation, leave-one-segment-out, blocks in time —
// and each is checked by cross-validating the model's columns and every candidate's (model +
// candidate): a held-out row its training fold cannot determine (aliased, or predicted with more
// than kMaxPredictionVariance × floor²) is dropped. The first scheme that predicts every row of
// the model and at least half the rows of every candidate is used, else the one that loses least;
// report.fold_by / folds / fold_reason say which and why. Returns false, with report.message
// giving the reason and the experiment that would make it testable, when no scheme predicts any
// row of the model.
// The experiment that makes an untestable design testable (the refusal's advice).
std::string untestable_design_advice();
bool choose_folds(const GapInput& input, const GapOptions& options, const CandidateSearchColumns& columns, Rows& rows,
                  GapReport& report);

// Which, and how far (selection.cpp): the folds (choose_folds), every candidate against the model
// as given, their aliases (near-collinear ones resolved by what the experiment excites), the
// noise-stage candidates, then forward selection on the held-out gap and the verdict.
void explain_gap(const GapInput& input, Rows& rows, const GapOptions& options, GapReport& report);

// Placement of hand-placed faces (placement.cpp): on nominal-orientation data (axes form, no table
// angles) whose held-out gap is above the floor after the selection, each face's rotation fitted
// with the final model's columns; fills report.placement and, when it is significant or the only
// consistent account, adds it to the statement.
void assess_placement(const GapInput& input, const Rows& rows, const std::vector<model::TermSpec>& final_terms,
                      const MatrixXd& final_columns, const GapOptions& options, GapReport& report);

}  // namespace stend::diagnosis
