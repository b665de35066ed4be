// Held-out prediction of the gap's rows (internal to stend_diagnosis): leave-one-fold-out fits, the
// held-out errors and what they would be if the model were right, and their comparison with the
// noise floor.
#pragma once

#include "linear_problem.hpp"

namespace stend::diagnosis {

// A held-out row is predicted only when its prediction from the training fold is no noisier than
// this many times the row's own noise variance (floor²): beyond it the training design barely
// determines the row (a fold that leaves two parameters nearly inseparable) and the prediction is
// an extrapolation whose error says more about the fold than about the model. 9 = a prediction
// standard error of 3× the floor.
inline constexpr double kMaxPredictionVariance = 9.0;

struct Heldout {
  VectorXd err;    // held-out error per row [unit]; NaN where the row is not predictable from its training fold
  VectorXd var0;   // variance of the prediction error if the model were right [unit²]
  int not_estimable = 0;  // rows outside the training design's row space (aliases in the training fold)
  int extrapolated = 0;   // rows whose prediction variance exceeds kMaxPredictionVariance × floor²
  int failed_folds = 0;   // training fits that failed
  int dropped() const { return not_estimable + extrapolated; }
};

// Leave-one-fold-out (rows.folds): fit the columns A on the other folds, predict the held-out rows
// — only where a row is estimable from the training design (no guessing across aliases) and its
// prediction is not an extrapolation (kMaxPredictionVariance).
Heldout cross_validate(const MatrixXd& A, const Rows& rows);

// RMS [unit] of two held-out error sets over the rows finite in both, and the floor RMS of the
// second over the same rows.
struct CvCompare {
  double before = kNaN, after = kNaN, floor = kNaN;
  int n = 0;
};
CvCompare compare(const Heldout& before, const Heldout& after);

// RMS of the finite held-out errors [unit]; with floor_rms, the RMS of their var0 (the floor).
double rms_finite(const Heldout& h, double* floor_rms = nullptr);

// Held-out errors consistent with the floor: Σ e²/var0 below the χ² 95 % point (p > 0.05).
bool at_noise_floor(const Heldout& h);

}  // namespace stend::diagnosis
