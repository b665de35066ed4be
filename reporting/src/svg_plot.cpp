// A plot drawn as SVG for the reports (see svg_plot.hpp).
#include "stend/reporting/svg_plot.hpp"
#include "stend/sdk.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

namespace stend::reporting::svg {

namespace {

using estimation::figure::palette;
using estimation::figure::Plot;
using estimation::figure::Series;
using estimation::figure::Style;


struct Axis {
  double lo = 0.0, hi = 1.0;
  bool log = false;
  double pix0 = 0.0, pix1 = 1.0;  // pixel positions of lo and hi
  double map(double v) const {
    double a = log ? std::log10(v) : v, l = log ? std::log10(lo) : lo, h = log ? std::log10(hi) : hi;
    if (!(h > l)) return 0.5 * (pix0 + pix1);
    return pix0 + (a - l) / (h - l) * (pix1 - pix0);
  }
};

bool usable(double v, bool log_axis) { return std::isfinite(v) && (!log_axis || v > 0.0); }

void extend(double v, bool log_axis, double& lo, double& hi) {
  if (!usable(v, log_axis)) return;
  lo = std::min(lo, v);
  hi = std::max(hi, v);
}

// Pads a data range and makes it non-empty.
void finish_range(double& lo, double& hi, bool log_axis) {
  if (!(lo <= hi)) {  // no data
    lo = log_axis ? 0.1 : 0.0;
    hi = log_axis ? 10.0 : 1.0;
    return;
  }
  if (log_axis) {
    if (hi / lo < 1.5) {
      lo /= 1.5;
      hi *= 1.5;
    }
    lo = std::pow(10.0, std::floor(std::log10(lo) + 1e-9));
    hi = std::pow(10.0, std::ceil(std::log10(hi) - 1e-9));
    if (hi <= lo) hi = lo * 10.0;
    return;
  }
  if (hi == lo) {
    const double d = lo == 0.0 ? 1.0 : std::abs(lo) * 0.1;
    lo -= d;
    hi += d;
  }
  const double pad = 0.05 * (hi - lo);
  lo -= pad;
  hi += pad;
}

std::string num(double v) { return fmt::format("{:.2f}", v); }

}  // namespace

std::string escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string tick_text(double v) {
  if (v == 0.0) return "0";
  const double a = std::abs(v);
  if (a >= 1e-3 && a < 1e5) {
    std::string s = fmt::format("{:.6f}", v);
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
  }
  return fmt::format("{:.3g}", v);
}

std::vector<double> nice_ticks(double lo, double hi, bool log_axis, int target) {
  std::vector<double> t;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return t;
  if (log_axis) {
    if (lo <= 0.0) return t;
    const int d0 = static_cast<int>(std::floor(std::log10(lo) + 1e-9));
    const int d1 = static_cast<int>(std::ceil(std::log10(hi) - 1e-9));
    const bool minor = d1 - d0 <= 2;
    const int every = std::max(1, (d1 - d0) / std::max(1, target));
    for (int d = d0; d <= d1; ++d) {
      if ((d - d0) % every != 0) continue;
      for (double m : {1.0, 2.0, 5.0}) {
        if (m != 1.0 && !minor) continue;
        const double v = m * std::pow(10.0, d);
        if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) t.push_back(v);
      }
    }
    return t;
  }
  const double raw = (hi - lo) / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (int i = 0; i < 100; ++i) {
    double v = first + i * step;
    if (v > hi + 1e-9 * step) break;
    if (std::abs(v) < 1e-12 * step) v = 0.0;
    t.push_back(v);
  }
  return t;
}

namespace {

// --- Steps of Plot::render -------------------------------------------------------------------

// Data ranges of a plot: every drawable point, band edge and reference line, padded (or forced).
struct Ranges {
  double xlo = 0.0, xhi = 0.0, ylo = 0.0, yhi = 0.0;
  bool any = false;  // some point (or a band's lower edge) can be drawn
};

// Extends the ranges by the drawable points of one series.
void extend_by_series(const Plot& p, const Series& s, Ranges& r) {
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!usable(s.x[i], p.x_log)) continue;
    auto has = [&](const std::vector<double>& v) { return i < v.size() && usable(v[i], p.y_log); };
    if (s.style != Style::kBand && i < s.y.size() && usable(s.y[i], p.y_log)) {
      extend(s.x[i], p.x_log, r.xlo, r.xhi);
      extend(s.y[i], p.y_log, r.ylo, r.yhi);
      r.any = true;
    }
    if (has(s.y_lo)) {
      extend(s.x[i], p.x_log, r.xlo, r.xhi);
      extend(s.y_lo[i], p.y_log, r.ylo, r.yhi);
      r.any = true;
    }
    if (has(s.y_hi)) {
      extend(s.x[i], p.x_log, r.xlo, r.xhi);
      extend(s.y_hi[i], p.y_log, r.ylo, r.yhi);
    }
  }
}

Ranges data_ranges(const Plot& p) {
  Ranges r;
  r.xlo = r.ylo = std::numeric_limits<double>::infinity();
  r.xhi = r.yhi = -r.xlo;
  for (const auto& s : p.series) extend_by_series(p, s, r);
  for (const auto& l : p.lines) {
    if (l.horizontal) extend(l.value, p.y_log, r.ylo, r.yhi);
    else extend(l.value, p.x_log, r.xlo, r.xhi);
  }
  const bool bars = std::any_of(p.series.begin(), p.series.end(), [](const Series& s) { return s.style == Style::kBars; });
  if ((p.y_include_zero || bars) && !p.y_log && r.any) extend(0.0, false, r.ylo, r.yhi);
  if (!p.x_categories.empty()) {
    r.xlo = -0.6;
    r.xhi = static_cast<double>(p.x_categories.size()) - 0.4;
  } else {
    finish_range(r.xlo, r.xhi, p.x_log);
  }
  finish_range(r.ylo, r.yhi, p.y_log);
  // Forced ranges only widen: every drawable point stays inside the axes.
  if (p.fixed_x) {
    r.xlo = std::min(r.xlo, p.x_min);
    r.xhi = std::max(r.xhi, p.x_max);
  }
  if (p.fixed_y) {
    r.ylo = std::min(r.ylo, p.y_min);
    r.yhi = std::max(r.yhi, p.y_max);
  }
  return r;
}

// Estimated width [px] of a text line at `font_px` in the plots' sans-serif font: the UTF-8 code
// points times a generous mean advance (0.62 em), so that a text laid out by it is never clipped.
double text_width(const std::string& s, double font_px) {
  std::size_t points = 0;
  for (unsigned char c : s)
    if ((c & 0xC0) != 0x80) ++points;
  return 0.62 * font_px * static_cast<double>(points);
}

constexpr double kFont = 11.0, kTitleFont = 13.0;  // px
constexpr double kLegendRow = 15.0;                  // px per legend entry
constexpr double kMinLabelSpacing = 14.0;            // px between slanted category labels
constexpr double kLegendRightMax = 0.30;             // a wider legend goes below the plot (× plot width)

// Whether a series draws at least one mark (a band needs both its edges at a point; a line of one
// point is drawn as a marker): only such a series has a legend entry.
bool draws_a_mark(const Plot& p, const Series& s) {
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!usable(s.x[i], p.x_log)) continue;
    if (s.style == Style::kBand ? i < s.y_lo.size() && i < s.y_hi.size() && usable(s.y_lo[i], p.y_log) &&
                                      usable(s.y_hi[i], p.y_log)
                                : i < s.y.size() && usable(s.y[i], p.y_log))
      return true;
  }
  return false;
}

// The series in the legend: named, and drawn (a legend entry without a mark names nothing).
std::vector<std::size_t> named_series(const Plot& p) {
  std::vector<std::size_t> named;
  for (std::size_t k = 0; k < p.series.size(); ++k)
    if (!p.series[k].name.empty() && draws_a_mark(p, p.series[k])) named.push_back(k);
  return named;
}

// Where everything goes [px]: the plot box inside the margins, the legend outside it, the whole
// picture's size, and the axes mapping data onto the plot box.
struct Frame {
  bool slanted = false;  // category labels too long for their slot are drawn slanted
  double width = 0.0, height = 0.0;                   // the <svg> element
  double bottom = 0.0;  // from the plot box to the end of the x-axis label
  double px0 = 0.0, px1 = 0.0, py0 = 0.0, py1 = 0.0;  // plot box: left, right, top, bottom
  bool legend = false;
  double lx = 0.0, ly = 0.0, lw = 0.0, lh = 0.0;      // legend box
  Ranges data;
  Axis ax, ay;
};

// Width [px] of the widest x tick label (numbers; categories are laid out on their own).
double x_tick_width(const Plot& p, const Ranges& r) {
  double w = 0.0;
  if (p.x_categories.empty())
    for (double v : nice_ticks(r.xlo, r.xhi, p.x_log)) w = std::max(w, text_width(tick_text(v), kFont));
  return w;
}

// Width [px] of the widest y tick label.
double y_tick_width(const Plot& p, const Ranges& r) {
  double w = 0.0;
  for (double v : nice_ticks(r.ylo, r.yhi, p.y_log)) w = std::max(w, text_width(tick_text(v), kFont));
  return w;
}

// The layout rule every plot obeys by construction: the legend sits outside the plot box — to the
// right when it is narrow, else below the x-axis label — so it never covers data; the axis ranges
// contain every drawable point (data_ranges); the margins make room for the tick, category and
// axis labels, so no text is clipped.
Frame layout(const Plot& p) {
  Frame f;
  f.data = data_ranges(p);
  double longest_category = 0.0;
  for (const auto& c : p.x_categories) longest_category = std::max(longest_category, text_width(c, kFont));
  // Horizontal labels when the longest fits its category's slot, else slanted.
  const double slot = p.x_categories.empty() ? 0.0 : (p.width - 94.0) / static_cast<double>(p.x_categories.size());
  f.slanted = !p.x_categories.empty() && longest_category > slot;
  // Slanted (−40°) labels reach down 0.64 and left 0.77 of their length from their tick; label i's
  // tick is about (i + 0.6) slots right of the plot box's left edge.
  double slanted_reach = 0.0;
  if (f.slanted)
    for (std::size_t i = 0; i < p.x_categories.size(); ++i)
      slanted_reach = std::max(slanted_reach, 0.77 * text_width(p.x_categories[i], kFont) -
                                                  (static_cast<double>(i) + 0.6) * slot + 6.0);
  const double bottom = f.slanted ? 50 + 0.64 * longest_category : 50;
  const double left = std::max({50.0, 26.0 + y_tick_width(p, f.data) + 6.0, slanted_reach});
  const double top = p.title.empty() ? 14 : 32;
  const std::vector<std::size_t> named = named_series(p);
  double longest_name = 0.0;
  for (std::size_t k : named) longest_name = std::max(longest_name, text_width(p.series[k].name, kFont));
  f.legend = !named.empty();
  f.lw = 30 + longest_name;
  f.lh = 6 + kLegendRow * static_cast<double>(named.size());
  const bool right = f.lw <= kLegendRightMax * p.width;
  f.width = p.width + (f.legend && right ? f.lw + 12 : 0.0);
  f.height = p.height + bottom - 50 + (f.legend && !right ? f.lh + 6 : 0.0);
  f.bottom = bottom;
  f.px0 = left;
  f.px1 = p.width - std::max(16.0, 0.5 * x_tick_width(p, f.data) + 4.0);
  f.py0 = top;
  f.py1 = f.height - bottom - (f.legend && !right ? f.lh + 6 : 0.0);
  if (right) {
    f.lx = f.px1 + 10;
    f.ly = f.py0;
  } else {
    f.lx = f.px0;
    f.ly = f.py1 + bottom;
    if (f.legend) f.width = std::max(f.width, f.lx + f.lw + 6);  // a legend wider than the plot widens the picture
  }
  f.ax = Axis{f.data.xlo, f.data.xhi, p.x_log, f.px0, f.px1};
  f.ay = Axis{f.data.ylo, f.data.yhi, p.y_log, f.py1, f.py0};
  return f;
}

// A text attribute that squeezes a text into `room` [px] when its estimated width exceeds it.
std::string fit_text(const std::string& s, double font_px, double room) {
  return text_width(s, font_px) > room ? fmt::format(" textLength=\"{}\" lengthAdjust=\"spacingAndGlyphs\"", num(room)) : "";
}

// The <svg> element's opening, white background, title and plot box.
std::string svg_open(const Plot& p, const Frame& f) {
  std::string o = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"sans-serif\" font-size=\"11\" role=\"img\" aria-label=\"{2}\" data-plot-box=\"{3} {4} {5} {6}\"",
      num(f.width), num(f.height), escape(p.title), num(f.px0), num(f.py0), num(f.px1), num(f.py1));
  if (f.legend) o += fmt::format(" data-legend-box=\"{} {} {} {}\"", num(f.lx), num(f.ly), num(f.lx + f.lw), num(f.ly + f.lh));
  o += ">\n";
  o += fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#fff\"/>\n", num(f.width), num(f.height));
  if (!p.title.empty())
    o += fmt::format("<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\"{}>{}</text>\n",
                     num(f.width / 2.0), fit_text(p.title, kTitleFont, f.width - 8), escape(p.title));
  o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/>\n", num(f.px0),
                   num(f.py0), num(f.px1 - f.px0), num(f.py1 - f.py0));
  return o;
}

// Category ticks and labels under the plot box: every category labelled while the labels stay
// kMinLabelSpacing apart (slanted ones are one text line high), else every k-th.
std::string category_ticks(const Plot& p, const Frame& f) {
  std::string o;
  const std::size_t n = p.x_categories.size();
  const double slot = (f.px1 - f.px0) / static_cast<double>(std::max<std::size_t>(1, n));
  double longest = 0.0;
  for (const auto& c : p.x_categories) longest = std::max(longest, text_width(c, kFont));
  const double needed = f.slanted ? kMinLabelSpacing : longest + 6.0;
  const auto every = static_cast<std::size_t>(std::max(1.0, std::ceil(needed / std::max(slot, 1e-9))));
  for (std::size_t i = 0; i < n; i += every) {
    const double X = f.ax.map(static_cast<double>(i));
    o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#333\"/>", num(X), num(f.py1),
                     num(f.py1 + 4));
    if (f.slanted)
      o += fmt::format("<text x=\"{0}\" y=\"{1}\" text-anchor=\"end\" transform=\"rotate(-40 {0} {1})\">{2}</text>\n",
                       num(X), num(f.py1 + 12), escape(p.x_categories[i]));
    else
      o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", num(X), num(f.py1 + 16),
                       escape(p.x_categories[i]));
  }
  return o;
}

// Grid lines and tick labels of both axes.
std::string grid_and_ticks(const Plot& p, const Frame& f) {
  std::string o;
  if (!p.x_categories.empty()) {
    o += category_ticks(p, f);
  } else {
    for (double v : nice_ticks(f.data.xlo, f.data.xhi, p.x_log)) {
      const double X = f.ax.map(v);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#e4e4e4\"/>", num(X), num(f.py0),
                       num(f.py1));
      o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", num(X), num(f.py1 + 16),
                       escape(tick_text(v)));
    }
  }
  for (double v : nice_ticks(f.data.ylo, f.data.yhi, p.y_log)) {
    const double Y = f.ay.map(v);
    o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"#e4e4e4\"/>", num(f.px0), num(Y),
                     num(f.px1));
    o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>\n", num(f.px0 - 5), num(Y + 4),
                     escape(tick_text(v)));
  }
  return o;
}

// Axis labels (x below, y rotated on the left), and "no data" in an empty plot.
std::string axis_labels(const Plot& p, const Frame& f) {
  const double x_label_y = f.py1 + f.bottom - 12.0;
  std::string o = fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\"{}>{}</text>\n", num((f.px0 + f.px1) / 2),
                              num(x_label_y), fit_text(p.x_label, kFont, f.width - 8), escape(p.x_label));
  o += fmt::format("<text x=\"14\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 14 {0})\"{1}>{2}</text>\n",
                   num((f.py0 + f.py1) / 2), fit_text(p.y_label, kFont, f.py1 - 4), escape(p.y_label));
  if (!f.data.any)
    o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#999\">no data</text>\n",
                     num((f.px0 + f.px1) / 2), num((f.py0 + f.py1) / 2));
  return o;
}

// A clip path on the plot box and the group drawn through it (closed by the caller).
std::string clip_open(const Frame& f) {
  // Unique clip id within a document (plots of one report are rendered by one process).
  static std::atomic<unsigned> clip_counter{0};
  const unsigned clip = ++clip_counter;
  std::string o = fmt::format("<clipPath id=\"clip{0}\"><rect x=\"{1}\" y=\"{2}\" width=\"{3}\" height=\"{4}\"/></clipPath>",
                              clip, num(f.px0), num(f.py0), num(f.px1 - f.px0), num(f.py1 - f.py0));
  o += fmt::format("<g clip-path=\"url(#clip{})\">\n", clip);
  return o;
}

// A kBand series: the polygon between y_lo and y_hi.
std::string band(const Plot& p, const Frame& f, const Series& s, std::size_t k, const std::string& color) {
  std::string up, down;
  for (std::size_t i = 0; i < s.x.size() && i < s.y_lo.size() && i < s.y_hi.size(); ++i) {
    if (!usable(s.x[i], p.x_log) || !usable(s.y_lo[i], p.y_log) || !usable(s.y_hi[i], p.y_log)) continue;
    up += fmt::format("{},{} ", num(f.ax.map(s.x[i])), num(f.ay.map(s.y_hi[i])));
    down = fmt::format("{},{} ", num(f.ax.map(s.x[i])), num(f.ay.map(s.y_lo[i]))) + down;
  }
  if (up.empty()) return {};
  return fmt::format("<polygon class=\"d\" data-series=\"{}\" points=\"{}{}\" fill=\"{}\" fill-opacity=\"{}\" "
                     "stroke=\"none\"/>\n",
                     k, up, down, color, s.opacity < 1.0 ? s.opacity : 0.25);
}

// A kBars series: bars from the base (0, or the floor of a log axis) to y.
std::string bars(const Plot& p, const Frame& f, const Series& s, std::size_t k, const std::string& color) {
  std::string o;
  const double ybase = p.y_log ? f.data.ylo : std::clamp(0.0, f.data.ylo, f.data.yhi);
  const double w = std::max(2.0, 0.7 * (f.px1 - f.px0) / std::max<double>(1.0, static_cast<double>(s.x.size()) + 1.0));
  for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!usable(s.x[i], p.x_log) || !usable(s.y[i], p.y_log)) continue;
    const double X = f.ax.map(s.x[i]), Y = f.ay.map(s.y[i]), Y0 = f.ay.map(ybase);
    o += fmt::format("<rect class=\"d\" data-series=\"{}\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\" "
                     "fill-opacity=\"{}\"/>\n",
                     k, num(X - w / 2), num(std::min(Y, Y0)), num(w), num(std::abs(Y0 - Y)), color, s.opacity);
  }
  return o;
}

// The line of a kLine/kLinePoints series, broken where a point cannot be drawn; a piece of one
// point (a line of one step, a point between gaps) is drawn as a small marker, so it shows.
std::string polyline(const Plot& p, const Frame& f, const Series& s, std::size_t k, const std::string& color) {
  std::string o, pts;
  int count = 0;
  double last_x = 0.0, last_y = 0.0;
  const char* dash = s.dashed ? " stroke-dasharray=\"6 4\"" : "";
  auto flush = [&] {
    if (count == 1 && s.style == Style::kLine)
      o += fmt::format("<circle class=\"d\" data-series=\"{}\" cx=\"{}\" cy=\"{}\" r=\"2.5\" fill=\"{}\"/>\n", k,
                       num(last_x), num(last_y), color);
    else if (count >= 2)
      o += fmt::format("<polyline class=\"d\" data-series=\"{}\" points=\"{}\" fill=\"none\" stroke=\"{}\" "
                       "stroke-width=\"1.6\"{}/>\n",
                       k, pts, color, dash);
    pts.clear();
    count = 0;
  };
  for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!usable(s.x[i], p.x_log) || !usable(s.y[i], p.y_log)) {
      flush();
      continue;
    }
    last_x = f.ax.map(s.x[i]);
    last_y = f.ay.map(s.y[i]);
    pts += fmt::format("{},{} ", num(last_x), num(last_y));
    ++count;
  }
  flush();
  return o;
}

// The markers of a kPoints/kLinePoints series, with error bars where y_lo and y_hi are given.
std::string markers(const Plot& p, const Frame& f, const Series& s, std::size_t k, const std::string& color) {
  std::string o;
  for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!usable(s.x[i], p.x_log)) continue;
    const double X = f.ax.map(s.x[i]);
    if (i < s.y_lo.size() && i < s.y_hi.size() && usable(s.y_lo[i], p.y_log) && usable(s.y_hi[i], p.y_log)) {
      const double a = f.ay.map(s.y_lo[i]), b = f.ay.map(s.y_hi[i]);
      o += fmt::format("<path class=\"d\" data-series=\"{4}\" d=\"M{0},{1}L{0},{2}\" stroke=\"{3}\" stroke-width=\"1.2\"/>",
                       num(X), num(a), num(b), color, k);
      o += fmt::format("<path d=\"M{0},{1}H{2}M{0},{3}H{2}\" stroke=\"{4}\" stroke-width=\"1.2\" fill=\"none\"/>",
                       num(X - 3), num(a), num(X + 3), num(b), color);
    }
    if (!usable(s.y[i], p.y_log)) continue;
    o += fmt::format("<circle class=\"d\" data-series=\"{}\" cx=\"{}\" cy=\"{}\" r=\"3\" fill=\"{}\" fill-opacity=\"{}\"/>\n",
                     k, num(X), num(f.ay.map(s.y[i])), color, s.opacity);
  }
  return o;
}

std::string series_color(const Series& s, std::size_t k) { return s.color.empty() ? palette(k) : s.color; }

// All series in three layers: bands first, then bars, then lines and markers.
std::string series_layers(const Plot& p, const Frame& f) {
  std::string o;
  for (int pass = 0; pass < 3; ++pass) {
    for (std::size_t k = 0; k < p.series.size(); ++k) {
      const Series& s = p.series[k];
      const std::string c = series_color(s, k);
      const bool line = s.style == Style::kLine || s.style == Style::kLinePoints;
      const bool points = s.style == Style::kPoints || s.style == Style::kLinePoints;
      if (pass == 0 && s.style == Style::kBand) o += band(p, f, s, k, c);
      if (pass == 1 && s.style == Style::kBars) o += bars(p, f, s, k, c);
      if (pass == 2 && line) o += polyline(p, f, s, k, c);
      if (pass == 2 && points) o += markers(p, f, s, k, c);
    }
  }
  return o;
}

// Dashed reference lines across the plot box, each with its label.
std::string reference_lines(const Plot& p, const Frame& f) {
  std::string o;
  for (const auto& l : p.lines) {
    if (!usable(l.value, l.horizontal ? p.y_log : p.x_log)) continue;
    if (l.horizontal) {
      const double Y = f.ay.map(l.value);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"{3}\" stroke-dasharray=\"3 3\"/>",
                       num(f.px0), num(Y), num(f.px1), l.color);
      o += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>\n", num(f.px0 + 4), num(Y - 3), l.color,
                       escape(l.label));
    } else {
      const double X = f.ax.map(l.value);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"{3}\" stroke-dasharray=\"3 3\"/>",
                       num(X), num(f.py0), num(f.py1), l.color);
      o += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>\n", num(X + 3), num(f.py0 + 12), l.color,
                       escape(l.label));
    }
  }
  return o;
}

// The legend of the named series in its box outside the plot (Frame): one swatch and name a row.
std::string legend(const Plot& p, const Frame& f) {
  if (!f.legend) return {};
  const std::vector<std::size_t> named = named_series(p);
  const double lx = f.lx, ly = f.ly;
  std::string o = fmt::format("<rect class=\"legend\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#fff\" "
                              "stroke=\"#bbb\"/>\n",
                              num(lx), num(ly), num(f.lw), num(f.lh));
  for (std::size_t j = 0; j < named.size(); ++j) {
    const Series& s = p.series[named[j]];
    const std::string c = series_color(s, named[j]);
    const double Y = ly + 13 + kLegendRow * static_cast<double>(j);
    if (s.style == Style::kBand || s.style == Style::kBars)
      o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"16\" height=\"9\" fill=\"{}\" fill-opacity=\"{}\"/>",
                       num(lx + 5), num(Y - 8), c, s.style == Style::kBand ? 0.3 : 1.0);
    else if (s.style == Style::kPoints)
      o += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"3\" fill=\"{}\"/>", num(lx + 13), num(Y - 4), c);
    else
      o += fmt::format("<line x1=\"{0}\" y1=\"{2}\" x2=\"{1}\" y2=\"{2}\" stroke=\"{3}\" stroke-width=\"2\"{4}/>",
                       num(lx + 5), num(lx + 21), num(Y - 4), c, s.dashed ? " stroke-dasharray=\"4 3\"" : "");
    o += fmt::format("<text class=\"legend-entry\" data-series=\"{}\" x=\"{}\" y=\"{}\">{}</text>\n", named[j], num(lx + 26),
                     num(Y), escape(s.name));
  }
  return o;
}

}  // namespace

std::string render(const Plot& p) {
  const Frame f = layout(p);
  std::string o = svg_open(p, f);
  o += grid_and_ticks(p, f);
  o += axis_labels(p, f);
  o += clip_open(f);
  o += series_layers(p, f);
  o += reference_lines(p, f);
  o += "</g>\n";
  o += legend(p, f);
  o += "</svg>\n";
  return o;
}

}  // namespace stend::reporting::svg
