// The plot layout check (see plot_layout.hpp).
#include "stend/testing/plot_layout.hpp"

#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

namespace stend::testing {

namespace {

// The value of attribute `name` in the tag text `tag`, or "" when absent.
std::string attribute(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const auto at = tag.find(key);
  if (at == std::string::npos) return {};
  const auto begin = at + key.size();
  const auto end = tag.find('"', begin);
  return end == std::string::npos ? std::string() : tag.substr(begin, end - begin);
}

// All numbers of a text ("1.5,2 3,4" → 1.5 2 3 4; "M1,2L3,4" → 1 2 3 4).
std::vector<double> numbers(const std::string& s) {
  std::vector<double> v;
  const char* p = s.c_str();
  while (*p) {
    char* end = nullptr;
    const double x = std::strtod(p, &end);
    if (end == p) {
      ++p;
      continue;
    }
    v.push_back(x);
    p = end;
  }
  return v;
}

bool box_of(const std::string& text, double (&box)[4]) {
  const std::vector<double> v = numbers(text);
  if (v.size() != 4) return false;
  for (int i = 0; i < 4; ++i) box[i] = v[static_cast<std::size_t>(i)];
  return true;
}

// The data coordinates [px] of one data element: marker centres, line and band vertices, error-bar
// ends, the top and bottom centre of a bar.
std::vector<std::pair<double, double>> coordinates(const std::string& tag) {
  std::vector<std::pair<double, double>> xy;
  if (tag.rfind("<circle", 0) == 0) {
    xy.emplace_back(std::atof(attribute(tag, "cx").c_str()), std::atof(attribute(tag, "cy").c_str()));
  } else if (tag.rfind("<rect", 0) == 0) {
    const double x = std::atof(attribute(tag, "x").c_str()), y = std::atof(attribute(tag, "y").c_str());
    const double w = std::atof(attribute(tag, "width").c_str()), h = std::atof(attribute(tag, "height").c_str());
    xy.emplace_back(x + w / 2, y);
    xy.emplace_back(x + w / 2, y + h);
  } else {
    const std::vector<double> v = numbers(attribute(tag, tag.rfind("<path", 0) == 0 ? "d" : "points"));
    for (std::size_t i = 0; i + 1 < v.size(); i += 2) xy.emplace_back(v[i], v[i + 1]);
  }
  return xy;
}

std::string at_text(double x, double y) {
  char b[64];
  std::snprintf(b, sizeof b, "(%.1f, %.1f)", x, y);
  return b;
}

// Checks one coordinate against the plot box (0.5 px rounding allowance) and the legend box.
void check_point(PlotLayout& p, double x, double y) {
  ++p.points;
  constexpr double tol = 0.51;
  if (x < p.box[0] - tol || x > p.box[2] + tol || y < p.box[1] - tol || y > p.box[3] + tol)
    p.violations.push_back("point " + at_text(x, y) + " outside the axes");
  if (p.has_legend && x >= p.legend[0] && x <= p.legend[2] && y >= p.legend[1] && y <= p.legend[3])
    p.violations.push_back("point " + at_text(x, y) + " under the legend");
}

// Horizontal texts (titles, tick and axis labels, legend entries) inside the picture: their
// extent estimated at 0.62 em a character (what a sans-serif font stays under), or their
// textLength when the plotter squeezed them. Rotated texts are left to the screenshots.
void check_texts(PlotLayout& p, const std::string& svg) {
  for (auto at = svg.find("<text"); at != std::string::npos; at = svg.find("<text", at + 1)) {
    const auto open_end = svg.find('>', at), close = svg.find("</text>", at);
    if (open_end == std::string::npos || close == std::string::npos || close < open_end) break;
    if (svg.find('<', open_end) != close) continue;  // a text with child elements: left to the screenshots
    const std::string attrs = " " + svg.substr(at + 5, open_end - at - 5) + " ";
    if (attrs.find("transform=") != std::string::npos) continue;
    std::string text = svg.substr(open_end + 1, close - open_end - 1);
    std::size_t chars = 0;
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '&') i = text.find(';', i);  // one escaped character
      else if ((static_cast<unsigned char>(text[i]) & 0xC0) == 0x80) continue;
      ++chars;
      if (i == std::string::npos) break;
    }
    const std::string size = attribute(attrs, "font-size"), length = attribute(attrs, "textLength");
    const double font = size.empty() ? 11.0 : std::atof(size.c_str());
    const double w = length.empty() ? 0.62 * font * static_cast<double>(chars) : std::atof(length.c_str());
    const double x = std::atof(attribute(attrs, "x").c_str());
    const std::string anchor = attribute(attrs, "text-anchor");
    const double x0 = anchor == "middle" ? x - w / 2 : anchor == "end" ? x - w : x;
    if (x0 < -0.5 || x0 + w > p.width + 0.5) p.violations.push_back("text '" + text + "' is clipped at the picture's edge");
  }
}

// Every legend entry (<text class="legend-entry" data-series="K">) names a series with a drawn mark.
void check_legend_entries(PlotLayout& p, const std::string& svg, const std::set<std::string>& drawn) {
  const std::string open = "<text class=\"legend-entry\"";
  for (auto at = svg.find(open); at != std::string::npos; at = svg.find(open, at + 1)) {
    const auto end = svg.find('>', at), close = svg.find("</text>", at);
    if (end == std::string::npos || close == std::string::npos) break;
    ++p.legend_entries;
    const std::string series = attribute(svg.substr(at, end + 1 - at), "data-series");
    if (series.empty() || !drawn.count(series))
      p.violations.push_back("legend entry '" + svg.substr(end + 1, close - end - 1) + "' has no drawn mark");
  }
}

PlotLayout check_svg(const std::string& svg) {
  PlotLayout p;
  const std::string open = svg.substr(0, svg.find('>'));
  p.title = attribute(open, "aria-label");
  p.width = std::atof(attribute(open, "width").c_str());
  p.height = std::atof(attribute(open, "height").c_str());
  if (!box_of(attribute(open, "data-plot-box"), p.box)) {
    p.violations.push_back("no data-plot-box attribute");
    return p;
  }
  p.has_legend = box_of(attribute(open, "data-legend-box"), p.legend);
  if (p.has_legend) {
    const bool apart = p.legend[0] >= p.box[2] || p.legend[2] <= p.box[0] || p.legend[1] >= p.box[3] || p.legend[3] <= p.box[1];
    if (!apart) p.violations.push_back("the legend box overlaps the plot box");
    if (p.legend[2] > p.width || p.legend[3] > p.height) p.violations.push_back("the legend box leaves the picture");
  }
  // Data elements: <circle|rect|polyline|polygon|path class="d" …> (scanned, not matched with
  // std::regex, whose recursion overflows the stack on a long polyline under ASan). A mark is
  // drawn when it has a point (a line, two): the series it belongs to (data-series) shows.
  std::set<std::string> drawn;
  for (auto at = svg.find('<'); at != std::string::npos; at = svg.find('<', at + 1)) {
    const auto end = svg.find('>', at);
    if (end == std::string::npos) break;
    const std::string tag = svg.substr(at, end + 1 - at);
    for (const char* name : {"circle", "rect", "polyline", "polygon", "path"}) {
      if (tag.rfind("<" + std::string(name) + " class=\"d\"", 0) == 0) {
        const auto xy = coordinates(tag);
        for (const auto& [x, y] : xy) check_point(p, x, y);
        const bool line = tag.rfind("<polyline", 0) == 0 || tag.rfind("<path", 0) == 0;
        if (xy.size() >= (line ? 2u : 1u)) drawn.insert(attribute(tag, "data-series"));
        break;
      }
    }
  }
  check_legend_entries(p, svg, drawn);
  if (p.has_legend && p.legend_entries == 0) p.violations.push_back("a legend box without legend entries");
  check_texts(p, svg);
  return p;
}

}  // namespace

std::vector<PlotLayout> check_plot_layout(const std::string& html) {
  std::vector<PlotLayout> plots;
  for (auto at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) {
    const auto end = html.find("</svg>", at);
    plots.push_back(check_svg(html.substr(at, end == std::string::npos ? std::string::npos : end - at)));
  }
  return plots;
}

std::string plot_layout_violations(const std::string& html) {
  const std::vector<PlotLayout> plots = check_plot_layout(html);
  std::ostringstream o;
  if (plots.empty()) o << "no plot in the document\n";
  for (const auto& p : plots) {
    if (p.points == 0 && p.violations.empty()) o << p.title << ": no data coordinates to check\n";
    std::size_t shown = 0;
    for (const auto& v : p.violations)
      if (++shown <= 5) o << p.title << ": " << v << "\n";
    if (p.violations.size() > 5) o << p.title << ": … " << p.violations.size() - 5 << " more\n";
  }
  return o.str();
}

std::string verdict_violations(const std::string& html, std::size_t* count) {
  std::ostringstream o;
  std::size_t n = 0;
  for (const char* heading : {"Unexplained:", "No gap:", "Explained:"}) {
    const std::string open = std::string("<p><b>") + heading + "</b>";
    for (auto at = html.find(open); at != std::string::npos; at = html.find(open, at + 1)) {
      const auto end = html.find("</p>", at);
      const std::string text = html.substr(at, end == std::string::npos ? std::string::npos : end - at);
      ++n;
      const auto times = text.find(" × floor");
      const auto start = times == std::string::npos ? std::string::npos : text.rfind(' ', times - 1);
      const double ratio = start == std::string::npos ? -1.0 : std::atof(text.c_str() + start + 1);
      const bool unexplained = std::string(heading) == "Unexplained:";
      const bool says_none = text.find("no gap to explain") != std::string::npos ||
                             text.find("What remains is at the noise floor") != std::string::npos;
      const bool says_unexplained = text.find("UNEXPLAINED") != std::string::npos;
      if (ratio < 0) o << heading << " no 'R × floor' in: " << text << "\n";
      else if (unexplained && (ratio <= 1.0 || says_none)) o << "an 'Unexplained' verdict at the floor: " << text << "\n";
      else if (!unexplained && (ratio > 2.0 || says_unexplained)) o << "a '" << heading << "' verdict above the floor: " << text << "\n";
    }
  }
  if (count) *count = n;
  return o.str();
}

}  // namespace stend::testing
