// A small SVG plotting module for self-contained HTML reports: linear or logarithmic axes with
// "nice" ticks, lines, markers with error bars, shaded bands, bars over categories, reference
// lines and a legend. Output is one <svg> element (inline, no external resources, no script).
#pragma once

#include <string>
#include <vector>

namespace stend::reporting::svg {

enum class Style {
  kLine,        // polyline through (x, y); NaN breaks the line
  kPoints,      // markers; y_lo/y_hi (when given) draw vertical error bars
  kLinePoints,  // both
  kBand,        // filled area between y_lo and y_hi (y ignored), drawn under everything else
  kBars,        // vertical bars from 0 (or the axis floor on a log axis) to y, at x
};

struct Series {
  std::string name;  // legend text; empty: not in the legend
  Style style = Style::kPoints;
  std::vector<double> x, y;
  std::vector<double> y_lo, y_hi;  // error bars (kPoints/kLinePoints) or the band (kBand)
  std::string color;               // CSS color; empty: from the palette by series index
  bool dashed = false;
  double opacity = 1.0;            // bands default to 0.25 when left at 1
};

struct RefLine {
  bool horizontal = true;  // y = value (true) or x = value
  double value = 0.0;
  std::string label;
  std::string color = "#888";
};

struct Plot {
  std::string title, x_label, y_label;
  bool x_log = false, y_log = false;
  int width = 640, height = 380;
  std::vector<Series> series;
  std::vector<RefLine> lines;
  // When non-empty, x ticks are these labels at x = 0, 1, 2 … (categories, e.g. orientations).
  std::vector<std::string> x_categories;
  // Forced ranges, used when fixed_x / fixed_y.
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  bool fixed_x = false, fixed_y = false;
  bool y_include_zero = false;

  // The <svg> element. Never throws for empty or non-finite data: an empty plot says "no data".
  std::string render() const;
};

// Palette color k (cycled), used when a series gives none.
std::string palette(std::size_t k);

// Ticks of an axis: "nice" linear steps (1, 2, 5 × 10^k) or decades (with 2 and 5 when the span is
// under two decades) on a log axis. Exposed for tests.
std::vector<double> nice_ticks(double lo, double hi, bool log_axis, int target = 6);
// Short tick text: "0.002", "1e-05", "250".
std::string tick_text(double v);
// XML text escaping (&, <, >, ", ').
std::string escape(const std::string& s);

}  // namespace stend::reporting::svg
