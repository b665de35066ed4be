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
// the rows of each group dealt into at most max_folds folds (rows.folds); returns their number.
FoldBy fold_grouping(const GapInput& input, FoldBy requested);
int deal_folds(const GapInput& input, FoldBy grouping, int max_folds, Rows& rows);

// Which, and how far (selection.cpp): every candidate against the model as given, their aliases,
// the noise-stage candidates, then forward selection on the held-out gap and the verdict.
void explain_gap(const GapInput& input, const Rows& rows, const GapOptions& options, GapReport& report);

}  // namespace stend::diagnosis
