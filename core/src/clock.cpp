// The clock kinds' name table and the clock of each kind (stend/core/clock.hpp).
#include "stend/core/clock.hpp"

#include <ostream>
#include <utility>

namespace stend {

namespace {
constexpr std::pair<ClockKind, const char*> kClockKindNames[] = {
    {ClockKind::kAuto, "auto"}, {ClockKind::kSimulated, "simulated"}, {ClockKind::kWall, "wall"}};
}  // namespace

const char* to_string(ClockKind k) {
  for (const auto& [kind, name] : kClockKindNames)
    if (kind == k) return name;
  return "?";
}

std::optional<ClockKind> clock_kind_from_string(std::string_view name) {
  for (const auto& [kind, text] : kClockKindNames)
    if (name == text) return kind;
  return std::nullopt;
}

const std::vector<std::string>& clock_kind_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& [kind, name] : kClockKindNames) out.emplace_back(name);
    return out;
  }();
  return names;
}

std::ostream& operator<<(std::ostream& os, ClockKind k) { return os << to_string(k); }

std::unique_ptr<Clock> make_clock(ClockKind kind) {
  if (kind == ClockKind::kSimulated) return std::make_unique<SimulatedClock>();
  return std::make_unique<WallClock>();
}

}  // namespace stend
