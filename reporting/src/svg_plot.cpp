// SVG plotting for the reports (see svg_plot.hpp).
#include "stend/reporting/svg_plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

namespace stend::reporting::svg {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

std::string palette(std::size_t k) {
  static const char* colors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e",
                                 "#8c564b", "#e377c2", "#17becf", "#7f7f7f", "#bcbd22"};
  return colors[k % (sizeof(colors) / sizeof(colors[0]))];
}

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

// Plot area inside the drawing [px]: x from px0 (left) to px1, y from py0 (top) to py1; category
// labels too long for their slot are drawn slanted, the bottom margin making room.
struct Frame {
  bool slanted = false;
  double px0 = 0.0, px1 = 0.0, py0 = 0.0, py1 = 0.0;
};

Frame plot_frame(const Plot& p) {
  std::size_t longest_category = 0;
  for (const auto& c : p.x_categories) longest_category = std::max(longest_category, c.size());
  const double slot = p.x_categories.empty() ? 0.0 : (p.width - 94.0) / static_cast<double>(std::min<std::size_t>(p.x_categories.size(), 12));
  Frame f;
  f.slanted = !p.x_categories.empty() && 6.0 * static_cast<double>(longest_category) > slot;
  const double left = 78, right = 16, top = p.title.empty() ? 14 : 32,
               bottom = f.slanted ? 50 + std::min(170.0, 4.0 * static_cast<double>(longest_category)) : 50;
  f.px0 = left;
  f.px1 = p.width - right;
  f.py0 = top;
  f.py1 = p.height - bottom;
  return f;
}

// Data range of both axes (with the reference lines, zero for bars or y_include_zero, padded or
// fixed) and whether any point is drawable.
struct Ranges {
  double xlo, xhi, ylo, yhi;
  bool any = false;
};

// Extends the ranges by every drawable value of the series (bands by their bounds only).
void extend_by_series(const Plot& p, Ranges& r) {
  for (const auto& s : p.series) {
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
}

Ranges data_ranges(const Plot& p) {
  const double inf = std::numeric_limits<double>::infinity();
  Ranges r{inf, -inf, inf, -inf};
  extend_by_series(p, r);
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
  if (p.fixed_x) {
    r.xlo = p.x_min;
    r.xhi = p.x_max;
  }
  if (p.fixed_y) {
    r.ylo = p.y_min;
    r.yhi = p.y_max;
  }
  return r;
}

// The <svg> element's opening, white background, title and plot-area outline.
std::string svg_open(const Plot& p, const Frame& f) {
  std::string o = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"sans-serif\" font-size=\"11\" role=\"img\" aria-label=\"{2}\">\n",
      p.width, p.height, escape(p.title));
  o += fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#fff\"/>\n", p.width, p.height);
  if (!p.title.empty())
    o += fmt::format("<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\">{}</text>\n",
                     num(static_cast<double>(p.width) / 2), escape(p.title));
  o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/>\n", num(f.px0),
                   num(f.py0), num(f.px1 - f.px0), num(f.py1 - f.py0));
  return o;
}

// Category ticks and labels (at most about 12, slanted when long).
std::string category_ticks(const Plot& p, const Frame& f, const Axis& ax) {
  std::string o;
  const std::size_t n = p.x_categories.size();
  const std::size_t every = std::max<std::size_t>(1, n / 12 + (n % 12 ? 1 : 0));
  for (std::size_t i = 0; i < n; i += every) {
    const double X = ax.map(static_cast<double>(i));
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

// Grid lines and tick labels of both axes, the axis labels, and "no data" when nothing is drawable.
std::string grid_and_labels(const Plot& p, const Frame& f, const Axis& ax, const Axis& ay, bool any) {
  std::string o;
  if (!p.x_categories.empty()) {
    o += category_ticks(p, f, ax);
  } else {
    for (double v : nice_ticks(ax.lo, ax.hi, p.x_log)) {
      const double X = ax.map(v);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#e4e4e4\"/>", num(X), num(f.py0),
                       num(f.py1));
      o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", num(X), num(f.py1 + 16),
                       escape(tick_text(v)));
    }
  }
  for (double v : nice_ticks(ay.lo, ay.hi, p.y_log)) {
    const double Y = ay.map(v);
    o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"#e4e4e4\"/>", num(f.px0), num(Y),
                     num(f.px1));
    o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>\n", num(f.px0 - 5), num(Y + 4),
                     escape(tick_text(v)));
  }
  o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", num((f.px0 + f.px1) / 2),
                   num(static_cast<double>(p.height) - 12), escape(p.x_label));
  o += fmt::format("<text x=\"14\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 14 {0})\">{1}</text>\n",
                   num((f.py0 + f.py1) / 2), escape(p.y_label));
  if (!any) {
    o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#999\">no data</text>\n",
                     num((f.px0 + f.px1) / 2), num((f.py0 + f.py1) / 2));
  }
  return o;
}

// A band: polygon along y_hi and back along y_lo, color c.
std::string band_svg(const Series& s, const std::string& c, const Axis& ax, const Axis& ay) {
  std::string up, down;
  for (std::size_t i = 0; i < s.x.size() && i < s.y_lo.size() && i < s.y_hi.size(); ++i) {
    if (!usable(s.x[i], ax.log) || !usable(s.y_lo[i], ay.log) || !usable(s.y_hi[i], ay.log)) continue;
    up += fmt::format("{},{} ", num(ax.map(s.x[i])), num(ay.map(s.y_hi[i])));
    down = fmt::format("{},{} ", num(ax.map(s.x[i])), num(ay.map(s.y_lo[i]))) + down;
  }
  if (up.empty()) return "";
  return fmt::format("<polygon points=\"{}{}\" fill=\"{}\" fill-opacity=\"{}\" stroke=\"none\"/>\n", up, down, c,
                     s.opacity < 1.0 ? s.opacity : 0.25);
}

// Bars from ybase to each value, 70 % of a slot wide (at least 2 px).
std::string bars_svg(const Series& s, const std::string& c, const Axis& ax, const Axis& ay, const Frame& f,
                     double ybase) {
  std::string o;
  const double w = std::max(2.0, 0.7 * (f.px1 - f.px0) / std::max<double>(1.0, static_cast<double>(s.x.size()) + 1.0));
  for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!usable(s.x[i], ax.log) || !usable(s.y[i], ay.log)) continue;
    const double X = ax.map(s.x[i]), Y = ay.map(s.y[i]), Y0 = ay.map(ybase);
    o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\" fill-opacity=\"{}\"/>\n",
                     num(X - w / 2), num(std::min(Y, Y0)), num(w), num(std::abs(Y0 - Y)), c, s.opacity);
  }
  return o;
}

// Polylines through the values, broken where a value cannot be drawn.
std::string line_svg(const Series& s, const std::string& c, const Axis& ax, const Axis& ay) {
  std::string o, pts;
  const char* dash = s.dashed ? " stroke-dasharray=\"6 4\"" : "";
  auto flush = [&] {
    if (!pts.empty())
      o += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.6\"{}/>\n", pts, c, dash);
    pts.clear();
  };
  for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!usable(s.x[i], ax.log) || !usable(s.y[i], ay.log)) {
      flush();
      continue;
    }
    pts += fmt::format("{},{} ", num(ax.map(s.x[i])), num(ay.map(s.y[i])));
  }
  flush();
  return o;
}

// Points, each with its error bar (y_lo..y_hi) when both bounds can be drawn.
std::string points_svg(const Series& s, const std::string& c, const Axis& ax, const Axis& ay) {
  std::string o;
  for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!usable(s.x[i], ax.log)) continue;
    const double X = ax.map(s.x[i]);
    if (i < s.y_lo.size() && i < s.y_hi.size() && usable(s.y_lo[i], ay.log) && usable(s.y_hi[i], ay.log)) {
      const double a = ay.map(s.y_lo[i]), b = ay.map(s.y_hi[i]);
      o += fmt::format(
          "<path d=\"M{0},{1}V{2}M{3},{1}H{4}M{3},{2}H{4}\" stroke=\"{5}\" stroke-width=\"1.2\" fill=\"none\"/>",
          num(X), num(a), num(b), num(X - 3), num(X + 3), c);
    }
    if (!usable(s.y[i], ay.log)) continue;
    o += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"3\" fill=\"{}\" fill-opacity=\"{}\"/>\n", num(X),
                     num(ay.map(s.y[i])), c, s.opacity);
  }
  return o;
}

// Every series, in three passes: bands first, then bars, then lines and points.
std::string series_svg(const Plot& p, const Frame& f, const Axis& ax, const Axis& ay) {
  std::string o;
  const double ybase = p.y_log ? ay.lo : std::clamp(0.0, ay.lo, ay.hi);
  for (int pass = 0; pass < 3; ++pass) {
    for (std::size_t k = 0; k < p.series.size(); ++k) {
      const Series& s = p.series[k];
      const std::string c = s.color.empty() ? palette(k) : s.color;
      if (pass == 0 && s.style == Style::kBand) o += band_svg(s, c, ax, ay);
      if (pass == 1 && s.style == Style::kBars) o += bars_svg(s, c, ax, ay, f, ybase);
      if (pass == 2 && (s.style == Style::kLine || s.style == Style::kLinePoints)) o += line_svg(s, c, ax, ay);
      if (pass == 2 && (s.style == Style::kPoints || s.style == Style::kLinePoints)) o += points_svg(s, c, ax, ay);
    }
  }
  return o;
}

// Dashed horizontal or vertical reference lines with their labels.
std::string reference_lines_svg(const Plot& p, const Frame& f, const Axis& ax, const Axis& ay) {
  std::string o;
  for (const auto& l : p.lines) {
    if (!usable(l.value, l.horizontal ? p.y_log : p.x_log)) continue;
    if (l.horizontal) {
      const double Y = ay.map(l.value);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"{3}\" stroke-dasharray=\"3 3\"/>",
                       num(f.px0), num(Y), num(f.px1), l.color);
      o += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>\n", num(f.px0 + 4), num(Y - 3), l.color,
                       escape(l.label));
    } else {
      const double X = ax.map(l.value);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"{3}\" stroke-dasharray=\"3 3\"/>",
                       num(X), num(f.py0), num(f.py1), l.color);
      o += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>\n", num(X + 3), num(f.py0 + 12), l.color,
                       escape(l.label));
    }
  }
  return o;
}

// Legend box inside the plot, top right: a swatch and the name of every named series.
std::string legend_svg(const Plot& p, const Frame& f) {
  std::vector<std::size_t> named;
  for (std::size_t k = 0; k < p.series.size(); ++k)
    if (!p.series[k].name.empty()) named.push_back(k);
  if (named.empty()) return "";
  std::size_t longest = 0;
  for (std::size_t k : named) longest = std::max(longest, p.series[k].name.size());
  const double lw = 30 + 6.2 * static_cast<double>(longest), lh = 6 + 15.0 * static_cast<double>(named.size());
  const double lx = f.px1 - lw - 6, ly = f.py0 + 6;
  std::string o = fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#fff\" fill-opacity=\"0.85\" "
                              "stroke=\"#bbb\"/>\n",
                              num(lx), num(ly), num(lw), num(lh));
  for (std::size_t j = 0; j < named.size(); ++j) {
    const Series& s = p.series[named[j]];
    const std::string c = s.color.empty() ? palette(named[j]) : s.color;
    const double Y = ly + 13 + 15.0 * static_cast<double>(j);
    if (s.style == Style::kBand || s.style == Style::kBars)
      o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"16\" height=\"9\" fill=\"{}\" fill-opacity=\"{}\"/>",
                       num(lx + 5), num(Y - 8), c, s.style == Style::kBand ? 0.3 : 1.0);
    else if (s.style == Style::kPoints)
      o += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"3\" fill=\"{}\"/>", num(lx + 13), num(Y - 4), c);
    else
      o += fmt::format("<line x1=\"{0}\" y1=\"{2}\" x2=\"{1}\" y2=\"{2}\" stroke=\"{3}\" stroke-width=\"2\"{4}/>",
                       num(lx + 5), num(lx + 21), num(Y - 4), c, s.dashed ? " stroke-dasharray=\"4 3\"" : "");
    o += fmt::format("<text x=\"{}\" y=\"{}\">{}</text>\n", num(lx + 26), num(Y), escape(s.name));
  }
  return o;
}

}  // namespace

std::string Plot::render() const {
  const Frame f = plot_frame(*this);
  const Ranges r = data_ranges(*this);
  const Axis ax{r.xlo, r.xhi, x_log, f.px0, f.px1};
  const Axis ay{r.ylo, r.yhi, y_log, f.py1, f.py0};
  std::string o = svg_open(*this, f) + grid_and_labels(*this, f, ax, ay, r.any);
  // Unique clip id within a document (plots of one report are rendered by one process).
  static std::atomic<unsigned> clip_counter{0};
  const unsigned clip = ++clip_counter;
  o += fmt::format("<clipPath id=\"clip{0}\"><rect x=\"{1}\" y=\"{2}\" width=\"{3}\" height=\"{4}\"/></clipPath>",
                   clip, num(f.px0), num(f.py0), num(f.px1 - f.px0), num(f.py1 - f.py0));
  o += fmt::format("<g clip-path=\"url(#clip{})\">\n", clip);
  o += series_svg(*this, f, ax, ay) + reference_lines_svg(*this, f, ax, ay) + "</g>\n";
  o += legend_svg(*this, f);
  o += "</svg>\n";
  return o;
}

}  // namespace stend::reporting::svg
