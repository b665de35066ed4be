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

std::string Plot::render() const {
  const double W = width, H = height;
  // Category labels too long for their slot are drawn slanted; the bottom margin makes room.
  std::size_t longest_category = 0;
  for (const auto& c : x_categories) longest_category = std::max(longest_category, c.size());
  const double slot = x_categories.empty() ? 0.0 : (width - 94.0) / static_cast<double>(std::min<std::size_t>(x_categories.size(), 12));
  const bool slanted = !x_categories.empty() && 6.0 * static_cast<double>(longest_category) > slot;
  const double left = 78, right = 16, top = title.empty() ? 14 : 32,
               bottom = slanted ? 50 + std::min(170.0, 4.0 * static_cast<double>(longest_category)) : 50;
  // Legend entries decide the right margin: a legend box inside the plot, top right.
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
  bool any = false;
  for (const auto& s : series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!usable(s.x[i], x_log)) continue;
      auto has = [&](const std::vector<double>& v) { return i < v.size() && usable(v[i], y_log); };
      if (s.style != Style::kBand && i < s.y.size() && usable(s.y[i], y_log)) {
        extend(s.x[i], x_log, xlo, xhi);
        extend(s.y[i], y_log, ylo, yhi);
        any = true;
      }
      if (has(s.y_lo)) {
        extend(s.x[i], x_log, xlo, xhi);
        extend(s.y_lo[i], y_log, ylo, yhi);
        any = true;
      }
      if (has(s.y_hi)) {
        extend(s.x[i], x_log, xlo, xhi);
        extend(s.y_hi[i], y_log, ylo, yhi);
      }
    }
  }
  for (const auto& l : lines) {
    if (l.horizontal) extend(l.value, y_log, ylo, yhi);
    else extend(l.value, x_log, xlo, xhi);
  }
  const bool bars = std::any_of(series.begin(), series.end(), [](const Series& s) { return s.style == Style::kBars; });
  if ((y_include_zero || bars) && !y_log && any) extend(0.0, false, ylo, yhi);
  if (!x_categories.empty()) {
    xlo = -0.6;
    xhi = static_cast<double>(x_categories.size()) - 0.4;
  } else {
    finish_range(xlo, xhi, x_log);
  }
  finish_range(ylo, yhi, y_log);
  if (fixed_x) {
    xlo = x_min;
    xhi = x_max;
  }
  if (fixed_y) {
    ylo = y_min;
    yhi = y_max;
  }
  Axis ax{xlo, xhi, x_log, left, W - right};
  Axis ay{ylo, yhi, y_log, H - bottom, top};

  std::string o;
  o += fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"sans-serif\" font-size=\"11\" role=\"img\" aria-label=\"{2}\">\n",
      width, height, escape(title));
  o += fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#fff\"/>\n", width, height);
  if (!title.empty())
    o += fmt::format("<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\">{}</text>\n",
                     num(W / 2), escape(title));
  const double px0 = left, px1 = W - right, py0 = top, py1 = H - bottom;
  o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/>\n", num(px0),
                   num(py0), num(px1 - px0), num(py1 - py0));
  // Grid and ticks.
  if (!x_categories.empty()) {
    const std::size_t n = x_categories.size();
    const std::size_t every = std::max<std::size_t>(1, n / 12 + (n % 12 ? 1 : 0));
    for (std::size_t i = 0; i < n; i += every) {
      const double X = ax.map(static_cast<double>(i));
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#333\"/>", num(X), num(py1),
                       num(py1 + 4));
      if (slanted)
        o += fmt::format("<text x=\"{0}\" y=\"{1}\" text-anchor=\"end\" transform=\"rotate(-40 {0} {1})\">{2}</text>\n",
                         num(X), num(py1 + 12), escape(x_categories[i]));
      else
        o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", num(X), num(py1 + 16),
                         escape(x_categories[i]));
    }
  } else {
    for (double v : nice_ticks(xlo, xhi, x_log)) {
      const double X = ax.map(v);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#e4e4e4\"/>", num(X), num(py0),
                       num(py1));
      o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", num(X), num(py1 + 16),
                       escape(tick_text(v)));
    }
  }
  for (double v : nice_ticks(ylo, yhi, y_log)) {
    const double Y = ay.map(v);
    o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"#e4e4e4\"/>", num(px0), num(Y),
                     num(px1));
    o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>\n", num(px0 - 5), num(Y + 4),
                     escape(tick_text(v)));
  }
  o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", num((px0 + px1) / 2), num(H - 12),
                   escape(x_label));
  o += fmt::format("<text x=\"14\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 14 {0})\">{1}</text>\n",
                   num((py0 + py1) / 2), escape(y_label));
  if (!any) {
    o += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#999\">no data</text>\n",
                     num((px0 + px1) / 2), num((py0 + py1) / 2));
  }
  // Unique clip id within a document (plots of one report are rendered by one process).
  static std::atomic<unsigned> clip_counter{0};
  const unsigned clip = ++clip_counter;
  o += fmt::format("<clipPath id=\"clip{0}\"><rect x=\"{1}\" y=\"{2}\" width=\"{3}\" height=\"{4}\"/></clipPath>",
                   clip, num(px0), num(py0), num(px1 - px0), num(py1 - py0));
  o += fmt::format("<g clip-path=\"url(#clip{})\">\n", clip);
  const double ybase = y_log ? ylo : std::clamp(0.0, ylo, yhi);
  // Bands first, then bars, lines and points.
  for (int pass = 0; pass < 3; ++pass) {
    for (std::size_t k = 0; k < series.size(); ++k) {
      const Series& s = series[k];
      const std::string c = s.color.empty() ? palette(k) : s.color;
      const char* dash = s.dashed ? " stroke-dasharray=\"6 4\"" : "";
      if (pass == 0 && s.style == Style::kBand) {
        std::string up, down;
        for (std::size_t i = 0; i < s.x.size() && i < s.y_lo.size() && i < s.y_hi.size(); ++i) {
          if (!usable(s.x[i], x_log) || !usable(s.y_lo[i], y_log) || !usable(s.y_hi[i], y_log)) continue;
          up += fmt::format("{},{} ", num(ax.map(s.x[i])), num(ay.map(s.y_hi[i])));
          down = fmt::format("{},{} ", num(ax.map(s.x[i])), num(ay.map(s.y_lo[i]))) + down;
        }
        if (!up.empty())
          o += fmt::format("<polygon points=\"{}{}\" fill=\"{}\" fill-opacity=\"{}\" stroke=\"none\"/>\n", up, down, c,
                           s.opacity < 1.0 ? s.opacity : 0.25);
      }
      if (pass == 1 && s.style == Style::kBars) {
        const double w = std::max(2.0, 0.7 * (px1 - px0) / std::max<double>(1.0, static_cast<double>(s.x.size()) + 1.0));
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
          if (!usable(s.x[i], x_log) || !usable(s.y[i], y_log)) continue;
          const double X = ax.map(s.x[i]), Y = ay.map(s.y[i]), Y0 = ay.map(ybase);
          o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\" fill-opacity=\"{}\"/>\n",
                           num(X - w / 2), num(std::min(Y, Y0)), num(w), num(std::abs(Y0 - Y)), c, s.opacity);
        }
      }
      if (pass == 2 && (s.style == Style::kLine || s.style == Style::kLinePoints)) {
        std::string pts;
        auto flush = [&] {
          if (!pts.empty())
            o += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.6\"{}/>\n", pts, c,
                             dash);
          pts.clear();
        };
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
          if (!usable(s.x[i], x_log) || !usable(s.y[i], y_log)) {
            flush();
            continue;
          }
          pts += fmt::format("{},{} ", num(ax.map(s.x[i])), num(ay.map(s.y[i])));
        }
        flush();
      }
      if (pass == 2 && (s.style == Style::kPoints || s.style == Style::kLinePoints)) {
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
          if (!usable(s.x[i], x_log)) continue;
          const double X = ax.map(s.x[i]);
          if (i < s.y_lo.size() && i < s.y_hi.size() && usable(s.y_lo[i], y_log) && usable(s.y_hi[i], y_log)) {
            const double a = ay.map(s.y_lo[i]), b = ay.map(s.y_hi[i]);
            o += fmt::format(
                "<path d=\"M{0},{1}V{2}M{3},{1}H{4}M{3},{2}H{4}\" stroke=\"{5}\" stroke-width=\"1.2\" fill=\"none\"/>",
                num(X), num(a), num(b), num(X - 3), num(X + 3), c);
          }
          if (!usable(s.y[i], y_log)) continue;
          o += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"3\" fill=\"{}\" fill-opacity=\"{}\"/>\n", num(X),
                           num(ay.map(s.y[i])), c, s.opacity);
        }
      }
    }
  }
  for (const auto& l : lines) {
    if (!usable(l.value, l.horizontal ? y_log : x_log)) continue;
    if (l.horizontal) {
      const double Y = ay.map(l.value);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"{3}\" stroke-dasharray=\"3 3\"/>",
                       num(px0), num(Y), num(px1), l.color);
      o += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>\n", num(px0 + 4), num(Y - 3), l.color,
                       escape(l.label));
    } else {
      const double X = ax.map(l.value);
      o += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"{3}\" stroke-dasharray=\"3 3\"/>",
                       num(X), num(py0), num(py1), l.color);
      o += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>\n", num(X + 3), num(py0 + 12), l.color,
                       escape(l.label));
    }
  }
  o += "</g>\n";
  // Legend.
  std::vector<std::size_t> named;
  for (std::size_t k = 0; k < series.size(); ++k)
    if (!series[k].name.empty()) named.push_back(k);
  if (!named.empty()) {
    std::size_t longest = 0;
    for (std::size_t k : named) longest = std::max(longest, series[k].name.size());
    const double lw = 30 + 6.2 * static_cast<double>(longest), lh = 6 + 15.0 * static_cast<double>(named.size());
    const double lx = px1 - lw - 6, ly = py0 + 6;
    o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#fff\" fill-opacity=\"0.85\" "
                     "stroke=\"#bbb\"/>\n",
                     num(lx), num(ly), num(lw), num(lh));
    for (std::size_t j = 0; j < named.size(); ++j) {
      const Series& s = series[named[j]];
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
  }
  o += "</svg>\n";
  return o;
}

}  // namespace stend::reporting::svg
