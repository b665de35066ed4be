// The plot layout check of the reports (issue 16): every <svg class="plot"> written into an HTML
// file declares its plot box (data-plot-box="x0 y0 x1 y1") and, when it has one, its legend box
// (data-legend-box="x0 y0 x1 y1") in pixels; every drawn data element carries class="d" (markers,
// error bars, lines, bands, bars) and the series it draws (data-series="K"), as does each legend
// entry (<text class="legend-entry" data-series="K">). The check reads what was written — not the
// plotter's objects — and reports each point outside its axes, each point under the legend, each
// legend entry whose series has no drawn mark, and each horizontal text that reaches past the
// picture's edge (its width estimated generously, or its textLength).
#pragma once

#include <string>
#include <vector>

namespace stend::testing {

struct PlotLayout {
  std::string title;                    // the plot's aria-label
  double box[4] = {0, 0, 0, 0};         // plot box [px]: left, top, right, bottom
  bool has_legend = false;
  double legend[4] = {0, 0, 0, 0};      // legend box [px]: left, top, right, bottom
  double width = 0, height = 0;         // the <svg> element [px]
  std::size_t points = 0;               // data coordinates checked
  std::size_t legend_entries = 0;       // legend entries checked for a drawn mark
  std::vector<std::string> violations;  // "point (x, y) outside the axes", "point (x, y) under the legend",
                                        // "legend entry 'noise floor' has no drawn mark", …
};

// Every plot of an HTML document, laid out and checked.
std::vector<PlotLayout> check_plot_layout(const std::string& html);

// One line per violation of every plot ("title: violation"), empty when all plots pass; a document
// without plots or a plot without data coordinates is a violation too (the check would be empty).
std::string plot_layout_violations(const std::string& html);

// The gap verdicts of a report (<p><b>HEADING</b> … R × floor). STATEMENT</p>) whose heading
// contradicts its own numbers or statement: "Unexplained:" with R ≤ 1 or a statement of no gap;
// "No gap:" or "Explained:" with R > 2 or an UNEXPLAINED statement. One line each, empty when every
// verdict agrees; `count`, when given, receives the number of verdicts checked.
std::string verdict_violations(const std::string& html, std::size_t* count = nullptr);

}  // namespace stend::testing
