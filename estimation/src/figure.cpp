// A plot as data (see stend/estimation/figure.hpp).
#include "stend/estimation/figure.hpp"

#include <cmath>
#include <ostream>

namespace stend::estimation::figure {

namespace {

bool same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

bool same(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!same(a[i], b[i])) return false;
  return true;
}

template <class T>
bool all_equal(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!a[i].equals(b[i])) return false;
  return true;
}

}  // namespace

const char* to_string(Style s) {
  switch (s) {
    case Style::kLine: return "line";
    case Style::kPoints: return "points";
    case Style::kLinePoints: return "line+points";
    case Style::kBand: return "band";
    case Style::kBars: return "bars";
  }
  return "?";
}

std::string palette(std::size_t k) {
  static const char* colors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e",
                                 "#8c564b", "#e377c2", "#17becf", "#7f7f7f", "#bcbd22"};
  return colors[k % (sizeof(colors) / sizeof(colors[0]))];
}

void Series::print(std::ostream& os) const {
  os << (name.empty() ? "(unnamed)" : name) << ": " << to_string(style) << ", " << x.size() << " points"
     << (color.empty() ? "" : ", " + color) << (dashed ? ", dashed" : "");
}

bool Series::equals(const Series& o) const {
  return name == o.name && style == o.style && same(x, o.x) && same(y, o.y) && same(y_lo, o.y_lo) &&
         same(y_hi, o.y_hi) && color == o.color && dashed == o.dashed && same(opacity, o.opacity);
}

bool RefLine::equals(const RefLine& o) const {
  return horizontal == o.horizontal && same(value, o.value) && label == o.label && color == o.color;
}

void Plot::print(std::ostream& os) const {
  os << "plot '" << title << "': x " << x_label << (x_log ? " (log)" : "") << ", y " << y_label
     << (y_log ? " (log)" : "") << "\n";
  for (const auto& s : series) {
    os << "  ";
    s.print(os);
    os << "\n";
  }
}

bool Plot::equals(const Plot& o) const {
  return title == o.title && x_label == o.x_label && y_label == o.y_label && x_log == o.x_log && y_log == o.y_log &&
         width == o.width && height == o.height && all_equal(series, o.series) && all_equal(lines, o.lines) &&
         x_categories == o.x_categories && same(x_min, o.x_min) && same(x_max, o.x_max) && same(y_min, o.y_min) &&
         same(y_max, o.y_max) && fixed_x == o.fixed_x && fixed_y == o.fixed_y && y_include_zero == o.y_include_zero;
}

}  // namespace stend::estimation::figure
