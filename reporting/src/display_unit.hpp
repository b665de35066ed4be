// The unit a parameter is shown in by the reports (run report and comparison): m/s² as mg, rad/s
// as deg/h, a dimensionless factor as ppm, a temperature coefficient as its base unit's display per
// degC^k, any other unit as it is stored (SI inside, readable out).
#pragma once

#include "stend/physics/units.hpp"

#include <string>

namespace stend::reporting::detail {

struct DisplayUnit {
  double scale = 1.0;  // display value = stored value × scale
  std::string unit;
};

inline DisplayUnit display_unit(const std::string& unit) {
  // A temperature coefficient ("m/s^2/degC", "1/degC^2", …): its base unit's display, per degC^k.
  if (const auto per = unit.find("/degC"); per != std::string::npos && per > 0) {
    DisplayUnit base = display_unit(unit.substr(0, per));
    return {base.scale, base.unit + unit.substr(per)};
  }
  if (unit == "m/s^2" || unit == "m/s²") return {1.0 / physics::kMilliG, "mg"};
  if (unit == "rad/s") return {1.0 / physics::kDegPerHour, "deg/h"};
  if (unit.empty() || unit == "1" || unit == "-") return {1e6, "ppm"};
  return {1.0, unit};
}

}  // namespace stend::reporting::detail
