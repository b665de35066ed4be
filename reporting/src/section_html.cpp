// A section of the run report drawn as HTML (see section_html.hpp).
#include "section_html.hpp"

#include "stend/reporting/svg_plot.hpp"

#include <fmt/format.h>

namespace stend::reporting::detail {

namespace {

using estimation::Emphasis;
using svg::escape;

// The class attribute of a stressed paragraph or cell: "" | " class=\"warn\"" | " class=\"bad\"".
const char* emphasis_class(Emphasis e) {
  switch (e) {
    case Emphasis::kWarning: return " class=\"warn\"";
    case Emphasis::kFailure: return " class=\"bad\"";
    case Emphasis::kNormal: break;
  }
  return "";
}

struct BlockHtml {
  std::string operator()(const estimation::Paragraph& p) const {
    std::string o = fmt::format("<p{}>", emphasis_class(p.emphasis));
    for (const auto& s : p.spans) {
      switch (s.kind) {
        case estimation::Span::Kind::kPlain: o += escape(s.text); break;
        case estimation::Span::Kind::kStrong: o += "<b>" + escape(s.text) + "</b>"; break;
        case estimation::Span::Kind::kCode: o += "<code>" + escape(s.text) + "</code>"; break;
      }
    }
    return o + "</p>\n";
  }
  std::string operator()(const estimation::Subheading& h) const { return "<h3>" + escape(h.text) + "</h3>\n"; }
  std::string operator()(const estimation::Table& t) const {
    std::string o = t.kind == estimation::Table::Kind::kParameters ? "<table class=\"params\">" : "<table>";
    o += "<tr>";
    for (const auto& h : t.header) o += "<th>" + escape(h) + "</th>";
    o += "</tr>\n";
    for (const auto& r : t.rows) {
      o += r.mark == estimation::Row::Mark::kNotIdentified ? "<tr class=\"nid\">" : "<tr>";
      for (const auto& c : r.cells)
        o += fmt::format("<td{}{}>{}</td>", c.columns > 1 ? fmt::format(" colspan=\"{}\"", c.columns) : "",
                         emphasis_class(c.emphasis), escape(c.text));
      o += "</tr>\n";
    }
    return o + "</table>\n";
  }
  std::string operator()(const estimation::Figure& f) const {
    return "<figure>" + svg::render(f.plot) + "<figcaption>" + escape(f.caption) + "</figcaption></figure>\n";
  }
};

}  // namespace

std::string block_html(const estimation::Block& block) { return std::visit(BlockHtml{}, block); }

std::string section_html(const estimation::ReportSection& section) {
  std::string o = "<h2>" + escape(section.heading);
  if (!section.file.empty()) o += " <span class=\"file\">(" + escape(section.file) + ")</span>";
  o += "</h2>\n";
  for (const auto& b : section.blocks) o += block_html(b);
  return o;
}

}  // namespace stend::reporting::detail
