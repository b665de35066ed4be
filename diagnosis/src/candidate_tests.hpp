// One candidate term judged against the current model (internal to stend_diagnosis): the fit with
// it, its added rank and aliases with the model's terms, three significance tests (partial F on
// segment means shrunk by their lag-1 correlation, Newey–West on per-segment scores, GLS under the
// segments' time covariance: the largest p counts), ΔBIC, the held-out gain and the effect size
// with its interval.
#pragma once

#include <vector>

#include "heldout.hpp"
#include "linear_problem.hpp"
#include "segment_covariance.hpp"

namespace stend::diagnosis {

// The model of a selection step: its terms, design, fit and held-out errors.
struct CurrentModel {
  std::vector<model::TermSpec> terms;
  MatrixXd columns;
  Fit fit;
  Heldout heldout;
};

// What the candidates are judged on: the input, the rows, each candidate's design columns and the
// segments' time covariance.
struct CandidateSearch {
  const GapInput& input;
  const Rows& rows;
  const std::vector<Candidate>& candidates;
  const std::vector<MatrixXd>& columns;  // per candidate
  const SegmentCovariance& covariance;
};

// A candidate's result and its held-out errors (kept for the forward selection's next step).
struct Evaluation {
  CandidateResult result;
  Heldout heldout;
};

// Candidate `i` of the search against `model` (gls: the model's whitened basis per covariance).
Evaluation evaluate(const CandidateSearch& search, const CurrentModel& model, const GlsStep& gls, std::size_t i);

}  // namespace stend::diagnosis
