// Where the gap is: the squared twin residual of the rows grouped by axis, orientation,
// temperature, time since the last change and averaging time. See steps.hpp.
#include <algorithm>
#include <cmath>
#include <map>

#include "steps.hpp"
#include "text.hpp"

namespace stend::diagnosis {

namespace {

// One "where" dimension: the squared gap of the rows grouped by key_of(segment, slot), each
// group's share of the total and RMS [unit], largest share first, appended to rep.where.
template <class KeyOf>
void add_places(const std::string& dim, const Rows& rows, double total, KeyOf key_of, GapReport& rep) {
  std::map<std::string, std::pair<double, int>> acc;
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const auto s = static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)]);
    const int a = rows.axis[static_cast<std::size_t>(r)];
    const double e = rep.residual[s][a];
    auto& v = acc[key_of(s, a)];
    v.first += e * e;
    ++v.second;
  }
  std::vector<Place> ps;
  for (auto& [k, v] : acc)
    ps.push_back({dim, k, total > 0 ? v.first / total : 0.0, std::sqrt(v.first / v.second), v.second});
  std::sort(ps.begin(), ps.end(), [](const Place& x, const Place& y) { return x.share > y.share; });
  rep.where.insert(rep.where.end(), ps.begin(), ps.end());
}

// Where the gap is: by axis, orientation, temperature [degC, ramp direction], time since the last
// change [s] and averaging time [s].
}  // namespace

void locate_gap(const GapInput& in, const Rows& rows, GapReport& rep) {
  double total = 0;
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const double e = rep.residual[static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)])][rows.axis[static_cast<std::size_t>(r)]];
    total += e * e;
  }
  add_places("axis", rows, total, [&](std::size_t, int a) {
    return in.magnitude ? std::string("|f|") : std::string(1, "xyz"[a]);
  }, rep);
  add_places("orientation", rows, total, [&](std::size_t s, int) { return in.segments[s].orientation_name; }, rep);
  const bool temperature_recorded = std::any_of(in.segments.begin(), in.segments.end(),
                                                [](const SegmentData& d) { return d.temperature_group >= 0; });
  if (temperature_recorded) add_places("temperature", rows, total, [&](std::size_t s, int) {
    const auto& d = in.segments[s];
    const double t = std::isfinite(d.setpoint_c) ? d.setpoint_c : d.point.stimulus.temperature_c;
    std::string dir = d.ramp_direction > 0 ? " (heating)" : d.ramp_direction < 0 ? " (cooling)" : "";
    return fmt(std::round(t * 10) / 10, 4) + " degC" + dir;
  }, rep);
  add_places("time_since_change", rows, total, [&](std::size_t s, int) {
    const double t = in.segments[s].time_since_change_s;
    if (!std::isfinite(t)) return std::string("unknown");
    return std::string(t < 30 ? "< 30 s" : t < 120 ? "30-120 s" : t < 600 ? "120-600 s" : ">= 600 s");
  }, rep);
  add_places("averaging_time", rows, total, [&](std::size_t s, int) {
    const double t = in.segments[s].averaging_s;
    return std::string(t < 5 ? "< 5 s" : t < 20 ? "5-20 s" : t < 60 ? "20-60 s" : ">= 60 s");
  }, rep);
}

}  // namespace stend::diagnosis
