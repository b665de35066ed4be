// Internal: a section of the run report (stend/estimation/report_section.hpp) drawn as HTML —
// <h2> with the file it came from, then each block: <p> (class "warn" or "bad" by its emphasis),
// <h3>, <table> (class "params" for a parameter table, rows of unidentified parameters class
// "nid"), <figure> with the plot as inline SVG and its caption. Every text is escaped here.
#pragma once

#include "stend/estimation/report_section.hpp"

#include <string>

namespace stend::reporting::detail {

std::string section_html(const estimation::ReportSection& section);
std::string block_html(const estimation::Block& block);

}  // namespace stend::reporting::detail
