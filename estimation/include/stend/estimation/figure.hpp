// A plot as data: what to draw (series of points, lines, bands or bars; reference lines; axis
// labels, ranges and scales), not how. The run report's sections (report_section.hpp) describe
// their figures with it; reporting draws them as inline SVG (stend/reporting/svg_plot.hpp).
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

namespace stend::estimation::figure {

enum class Style {
  kLine,        // polyline through (x, y); NaN breaks the line
  kPoints,      // markers; y_lo/y_hi (when given) draw vertical error bars
  kLinePoints,  // both
  kBand,        // filled area between y_lo and y_hi (y ignored), drawn under everything else
  kBars,        // vertical bars from 0 (or the axis floor on a log axis) to y, at x
};
const char* to_string(Style s);  // "line", "points", "line+points", "band", "bars"

struct Series {
  std::string name;  // legend text; empty: not in the legend
  Style style = Style::kPoints;
  std::vector<double> x, y;
  std::vector<double> y_lo, y_hi;  // error bars (kPoints/kLinePoints) or the band (kBand)
  std::string color;               // CSS color; empty: from the palette by series index
  bool dashed = false;
  double opacity = 1.0;            // bands default to 0.25 when left at 1

  // One line: name, style, point count, color.
  void print(std::ostream& os) const;
  // Same everything; numbers equal or both NaN.
  bool equals(const Series& other) const;
};

struct RefLine {
  bool horizontal = true;  // y = value (true) or x = value
  double value = 0.0;
  std::string label;
  std::string color = "#888";

  bool equals(const RefLine& other) const;
};

struct Plot {
  std::string title, x_label, y_label;
  bool x_log = false, y_log = false;
  int width = 640, height = 380;  // of the plot area with its axes [px]
  std::vector<Series> series;
  std::vector<RefLine> lines;
  // When non-empty, x ticks are these labels at x = 0, 1, 2 … (categories, e.g. orientations).
  std::vector<std::string> x_categories;
  // Forced ranges, used when fixed_x / fixed_y.
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  bool fixed_x = false, fixed_y = false;
  bool y_include_zero = false;

  // The title, the axes and one line per series.
  void print(std::ostream& os) const;
  bool equals(const Plot& other) const;
};

// Palette color k (cycled): the color of the k-th series when it gives none, and the one the
// sections give the x, y, z axes (0, 1, 2).
std::string palette(std::size_t k);

}  // namespace stend::estimation::figure
