// Number formatting for the gap diagnoser's statements (gap.cpp, noise_stage.cpp).
#pragma once

#include <cmath>
#include <sstream>
#include <string>

namespace stend::diagnosis {

// `prec` significant digits; "n/a" for NaN or infinity.
inline std::string fmt(double v, int prec = 4) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream os;
  os.precision(prec);
  os << v;
  return os.str();
}

}  // namespace stend::diagnosis
