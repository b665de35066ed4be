// The held-out folds of the gap: the schemes, and the choice of the one that fits the design. See
// steps.hpp (choose_folds) and gap.hpp (FoldBy).
#include <algorithm>
#include <set>
#include <sstream>

#include "heldout.hpp"
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

const char* to_string(FamilyRule r) {
  for (const auto& n : kFamilyRuleNames)
    if (n.value == r) return n.name;
  return "?";
}

std::optional<FamilyRule> family_rule_from_key(std::string_view key) {
  for (const auto& n : kFamilyRuleNames)
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

namespace {

// Blocks in time: this many contiguous blocks of segments (fewer when there are fewer segments).
constexpr int kTimeBlocks = 12;
// A scheme fits the design when it predicts every held-out row of the model as given and at least
// this share of the rows of every candidate that adds rank.
constexpr double kMinCandidateShare = 0.5;

// The group of one segment under a scheme (the segment's index for leave-one-segment-out, its
// block for blocks in time; segments are in time order).
int group_of(const GapInput& in, FoldBy grouping, std::size_t s) {
  const SegmentData& d = in.segments[s];
  const std::size_t n = in.segments.size();
  switch (grouping) {
    case FoldBy::kTemperature: return d.temperature_group;
    case FoldBy::kRamp: return d.ramp_direction;
    case FoldBy::kSegment: return static_cast<int>(s);
    case FoldBy::kTime: {
      const std::size_t k = std::min<std::size_t>(kTimeBlocks, n);
      return static_cast<int>(s * k / n);
    }
    default: return d.orientation;
  }
}

// How well a scheme's training folds determine the held-out rows.
struct SchemeCheck {
  FoldBy grouping = FoldBy::kOrientation;
  int folds = 0;
  int model_dropped = 0;        // rows of the model as given not predicted
  int weak_candidates = 0;      // candidates with less than kMinCandidateShare of their rows predicted
  int candidate_dropped = 0;    // over all candidates
  std::vector<std::string> weak_names;
  bool fits() const { return folds >= 2 && model_dropped == 0 && weak_candidates == 0; }
  // Lexicographic: fewer rows of the model lost, then fewer weak candidates, then fewer rows.
  bool better_than(const SchemeCheck& o) const {
    if ((folds >= 2) != (o.folds >= 2)) return folds >= 2;
    if (model_dropped != o.model_dropped) return model_dropped < o.model_dropped;
    if (weak_candidates != o.weak_candidates) return weak_candidates < o.weak_candidates;
    return candidate_dropped < o.candidate_dropped;
  }
};

SchemeCheck check_scheme(const CandidateSearchColumns& cols, Rows& rows) {
  SchemeCheck c;
  const Heldout h0 = cross_validate(cols.model, rows);
  c.model_dropped = h0.dropped() + (h0.failed_folds > 0 ? 1 : 0);
  const Eigen::Index n = rows.y.size();
  for (std::size_t i = 0; i < cols.candidates.size(); ++i) {
    if (!cols.adds_rank[i]) continue;
    const Heldout h = cross_validate(hstack(cols.model, cols.candidates[i]), rows);
    c.candidate_dropped += h.dropped();
    if (static_cast<double>(n - h.dropped()) < kMinCandidateShare * static_cast<double>(n)) {
      ++c.weak_candidates;
      c.weak_names.push_back(cols.names[i]);
    }
  }
  return c;
}

// What a scheme left undetermined, in words.
std::string shortfall(const SchemeCheck& c, Eigen::Index rows) {
  std::ostringstream os;
  os << to_string(c.grouping) << " folds (" << c.folds << ")";
  if (c.folds < 2) return os.str() + ": fewer than two groups";
  os << ":";
  if (c.model_dropped > 0)
    os << " " << c.model_dropped << " of " << rows << " held-out rows of the model as given are not determined by "
       << "their training folds (parameters left inseparable or extrapolated beyond 3x the floor)";
  if (c.weak_candidates > 0) {
    os << (c.model_dropped > 0 ? ";" : "") << " " << c.weak_candidates << " candidate(s) predict less than half the rows (";
    for (std::size_t i = 0; i < c.weak_names.size() && i < 4; ++i) os << (i ? ", " : "") << c.weak_names[i];
    os << (c.weak_names.size() > 4 ? ", ..." : "") << ")";
  }
  return os.str();
}

std::vector<FoldBy> schemes_to_try(const GapInput& in, FoldBy requested) {
  if (requested != FoldBy::kAuto) return {fold_grouping(in, requested)};
  std::vector<FoldBy> s;
  if (fold_grouping(in, FoldBy::kAuto) == FoldBy::kTemperature) s.push_back(FoldBy::kTemperature);
  for (FoldBy f : {FoldBy::kOrientation, FoldBy::kSegment, FoldBy::kTime}) s.push_back(f);
  return s;
}

}  // namespace

int deal_folds(const GapInput& in, FoldBy grouping, int max_folds, Rows& rows) {
  std::vector<int> group_of_row;
  for (const int s : rows.seg) group_of_row.push_back(group_of(in, grouping, static_cast<std::size_t>(s)));
  // Leave-one-segment-out is strict (dealing segments round-robin would hold out repeats together).
  rows.folds = stats::group_folds(group_of_row, grouping == FoldBy::kSegment ? 0 : max_folds);
  return static_cast<int>(rows.folds.size());
}

std::string untestable_design_advice() {
  return "To make it testable: repeat each orientation (re-place the sensor) so that every parameter is seen in at "
         "least two segments, or add orientations between the faces (tilts of 30-60 degrees about two axes)";
}

bool choose_folds(const GapInput& in, const GapOptions& opt, const CandidateSearchColumns& cols, Rows& rows,
                  GapReport& rep) {
  const std::vector<FoldBy> schemes = schemes_to_try(in, opt.fold_by);
  std::vector<SchemeCheck> tried;
  std::size_t best = 0;
  for (std::size_t k = 0; k < schemes.size(); ++k) {
    const int folds = deal_folds(in, schemes[k], opt.max_folds, rows);
    SchemeCheck c = folds >= 2 ? check_scheme(cols, rows) : SchemeCheck{};
    c.grouping = schemes[k];
    c.folds = folds;
    tried.push_back(c);
    if (c.better_than(tried[best])) best = k;
    if (c.fits()) {
      best = k;
      break;
    }
  }
  const SchemeCheck& chosen = tried[best];
  deal_folds(in, chosen.grouping, opt.max_folds, rows);
  rep.fold_by = chosen.grouping;
  rep.folds = chosen.folds;
  rep.heldout_dropped = chosen.model_dropped;
  const Eigen::Index n = rows.y.size();
  std::ostringstream why;
  for (const auto& c : tried)
    if (&c != &chosen) why << shortfall(c, n) << "; ";
  if (chosen.folds < 2 || chosen.model_dropped >= n) {
    rep.message = "no fold scheme can test this design held out — " + why.str() + shortfall(chosen, n) +
                  ". Every held-out row needs parameters that only its own fold determines. " + untestable_design_advice();
    return false;
  }
  if (tried.size() > 1 || !chosen.fits()) {
    why << "used " << to_string(chosen.grouping) << " folds (" << chosen.folds << ")";
    if (!chosen.fits()) why << " — the best available: " << shortfall(chosen, n) << "; those rows are left out of the held-out gap";
    rep.fold_reason = why.str();
  } else {
    rep.fold_reason = std::string(to_string(chosen.grouping)) + " folds determine every held-out row";
  }
  return true;
}

}  // namespace stend::diagnosis
