// Held-out folds for cross-validation by group (leave-one-group-out, capped).
#pragma once

#include <vector>

namespace stend::stats {

// The rows (indices into group_of_row) of each group form one fold, groups in increasing label
// order, up to max_folds folds; with more groups than that they are dealt round-robin into
// max_folds folds. max_folds ≤ 0: one fold per group (strict leave-one-group-out).
std::vector<std::vector<int>> group_folds(const std::vector<int>& group_of_row, int max_folds);

}  // namespace stend::stats
