// The held-out folds of the gap, and the names of their groupings. See steps.hpp and gap.hpp
// (FoldBy).
#include <set>

#include "stend/stats/folds.hpp"
#include "steps.hpp"

namespace stend::diagnosis {

const char* to_string(FoldBy f) {
  for (const auto& n : kFoldByNames)
    if (n.value == f) return n.name;
  return "?";
}

std::optional<FoldBy> fold_by_from_key(std::string_view key) {
  for (const auto& n : kFoldByNames)
    if (key == n.key) return n.value;
  return std::nullopt;
}

FoldBy fold_grouping(const GapInput& in, FoldBy requested) {
  std::set<int> temperatures, directions;
  for (const auto& s : in.segments) {
    temperatures.insert(s.temperature_group);
    directions.insert(s.ramp_direction);
  }
  if (requested == FoldBy::kAuto) return temperatures.size() >= 3 ? FoldBy::kTemperature : FoldBy::kOrientation;
  if (requested == FoldBy::kRamp && directions.size() < 2) return FoldBy::kOrientation;
  return requested;
}

int deal_folds(const GapInput& in, FoldBy grouping, int max_folds, Rows& rows) {
  std::vector<int> group_of_row;
  for (const int s : rows.seg) {
    const SegmentData& d = in.segments[static_cast<std::size_t>(s)];
    group_of_row.push_back(grouping == FoldBy::kTemperature ? d.temperature_group
                           : grouping == FoldBy::kRamp      ? d.ramp_direction
                                                            : d.orientation);
  }
  rows.folds = stats::group_folds(group_of_row, max_folds);
  return static_cast<int>(rows.folds.size());
}

}  // namespace stend::diagnosis
