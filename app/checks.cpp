// Range checks of numeric command-line options (commands.hpp): a value outside is a usage error
// that names the allowed range.
#include "commands.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

namespace stend::cli {

namespace {

// The interval as a reader writes it: "[0, 1)", ">= 1", "> 0".
std::string interval_text(double lo, double hi, bool open_lo, bool open_hi) {
  if (std::isinf(hi)) return fmt::format("{} {:g}", open_lo ? ">" : ">=", lo);
  return fmt::format("{}{:g}, {:g}{}", open_lo ? "(" : "[", lo, hi, open_hi ? ")" : "]");
}

CLI::Validator interval(double lo, double hi, bool open_lo, bool open_hi) {
  const std::string allowed = interval_text(lo, hi, open_lo, open_hi);
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0.0;
        if (!CLI::detail::lexical_cast(text, v) || std::isnan(v)) return "'" + text + "' is not a number";
        const bool ok = (open_lo ? v > lo : v >= lo) && (open_hi ? v < hi : v <= hi);
        return ok ? std::string() : text + " is outside the allowed range " + allowed;
      },
      allowed);
}

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

CLI::Validator at_least(double lo) { return interval(lo, kInf, false, true); }
CLI::Validator above(double lo) { return interval(lo, kInf, true, true); }
CLI::Validator within(double lo, double hi) { return interval(lo, hi, false, false); }
CLI::Validator strictly_within(double lo, double hi) { return interval(lo, hi, true, true); }

}  // namespace stend::cli
