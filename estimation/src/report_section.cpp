// A section of the run report as data (see stend/estimation/report_section.hpp).
#include "stend/estimation/report_section.hpp"

#include "stend/estimation/summary.hpp"
#include "stend/physics/units.hpp"

#include <cmath>
#include <ostream>

namespace stend::estimation {

const char* to_string(Emphasis e) {
  switch (e) {
    case Emphasis::kNormal: return "normal";
    case Emphasis::kWarning: return "warning";
    case Emphasis::kFailure: return "failure";
  }
  return "?";
}

std::string Paragraph::text() const {
  std::string t;
  for (const auto& s : spans) t += s.text;
  return t;
}

void ReportSection::add_text(std::string text, Emphasis emphasis) {
  add(Paragraph{{Span{std::move(text), Span::Kind::kPlain}}, emphasis});
}

void ReportSection::append(const std::vector<Paragraph>& paragraphs) {
  for (const auto& p : paragraphs) add(p);
}

void ReportSection::append(const std::vector<Figure>& figures) {
  for (const auto& f : figures) add(f);
}

namespace {

// The block as plain text (ReportSection::print).
struct PrintBlock {
  std::ostream& os;
  void operator()(const Paragraph& p) const {
    if (p.emphasis != Emphasis::kNormal) os << to_string(p.emphasis) << ": ";
    os << p.text() << "\n";
  }
  void operator()(const Subheading& h) const { os << "-- " << h.text << "\n"; }
  void operator()(const Table& t) const {
    auto line = [&](const std::vector<Cell>& cells) {
      for (std::size_t i = 0; i < cells.size(); ++i) os << (i ? " | " : "") << cells[i].text;
      os << "\n";
    };
    line(std::vector<Cell>(t.header.begin(), t.header.end()));
    for (const auto& r : t.rows) line(r.cells);
  }
  void operator()(const Figure& f) const { os << "[figure: " << f.plot.title << "] " << f.caption << "\n"; }
};

struct SameBlock {
  template <class A, class B>
  bool operator()(const A&, const B&) const { return false; }
  bool operator()(const Figure& a, const Figure& b) const { return a.equals(b); }
  template <class A>
  bool operator()(const A& a, const A& b) const { return a == b; }
};

}  // namespace

void ReportSection::print(std::ostream& os) const {
  os << heading << (file.empty() ? "" : " (" + file + ")") << "\n";
  for (const auto& b : blocks) std::visit(PrintBlock{os}, b);
}

bool ReportSection::equals(const ReportSection& o) const {
  if (heading != o.heading || file != o.file || topic != o.topic || blocks.size() != o.blocks.size()) return false;
  for (std::size_t i = 0; i < blocks.size(); ++i)
    if (!std::visit(SameBlock{}, blocks[i], o.blocks[i])) return false;
  return true;
}

std::ostream& operator<<(std::ostream& os, const ReportSection& s) {
  s.print(os);
  return os;
}

std::string report_number(double v, int significant) {
  return std::isfinite(v) ? number_text(v, significant) : "—";
}

DisplayUnit display_unit(const std::string& unit) {
  // A temperature coefficient ("m/s^2/degC", "1/degC^2", …): its base unit's display, per degC^k.
  if (const auto per = unit.find("/degC"); per != std::string::npos && per > 0) {
    DisplayUnit base = display_unit(unit.substr(0, per));
    return {base.scale, base.unit + unit.substr(per)};
  }
  // One choice per quantity (issue 36): acceleration in mg, angular rate in deg/s, a dimensionless
  // factor (scale, cross-axis) in ppm, g-sensitivity in (deg/s)/g.
  if (unit == "m/s^2" || unit == "m/s²") return {1.0 / physics::kMilliG, "mg"};
  if (unit == "rad/s") return {1.0 / physics::kDegPerSecond, "deg/s"};
  if (unit.empty() || unit == "1" || unit == "-") return {1e6, "ppm"};
  if (unit == "rad/s/(m/s^2)") return {physics::kStandardGravity / physics::kDegPerSecond, "(deg/s)/g"};
  return {1.0, unit};
}

}  // namespace stend::estimation
