// The unit a parameter is shown in by the reports (run report and comparison): m/s² as mg, rad/s
// as deg/h, a dimensionless factor as ppm, any other unit as it is stored (SI inside, readable out).
#pragma once

#include "stend/physics/units.hpp"

#include <string>

namespace stend::reporting::detail {

struct DisplayUnit {
  double scale = 1.0;  // display value = stored value × scale
  std::string unit;
};

inline DisplayUnit display_unit(const std::string& unit) {
  if (unit == "m/s^2" || unit == "m/s²") return {1.0 / physics::kMilliG, "mg"};
  if (unit == "rad/s") return {1.0 / physics::kDegPerHour, "deg/h"};
  if (unit.empty() || unit == "1" || unit == "-") return {1e6, "ppm"};
  return {1.0, unit};
}

}  // namespace stend::reporting::detail
