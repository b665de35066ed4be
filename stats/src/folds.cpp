// Held-out folds by group. See stend/stats/folds.hpp.
#include "stend/stats/folds.hpp"

#include <algorithm>
#include <cstddef>
#include <map>

namespace stend::stats {

std::vector<std::vector<int>> group_folds(const std::vector<int>& group_of_row, int max_folds) {
  std::map<int, std::vector<int>> groups;
  for (std::size_t r = 0; r < group_of_row.size(); ++r) groups[group_of_row[r]].push_back(static_cast<int>(r));
  const std::size_t n = max_folds > 0 ? std::min(static_cast<std::size_t>(max_folds), groups.size()) : groups.size();
  std::vector<std::vector<int>> folds(n);
  std::size_t i = 0;
  for (const auto& [group, rows] : groups) {
    auto& fold = folds[i++ % n];
    fold.insert(fold.end(), rows.begin(), rows.end());
  }
  return folds;
}

}  // namespace stend::stats
