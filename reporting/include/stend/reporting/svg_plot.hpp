// Draws a plot (stend/estimation/figure.hpp: the plot as data) as SVG for self-contained HTML
// reports: linear or logarithmic axes with "nice" ticks, lines, markers with error bars, shaded
// bands, bars over categories, reference lines and a legend outside the data. Output is one <svg>
// element (inline, no external resources, no script).
#pragma once

#include <stend/estimation/figure.hpp>

#include <string>
#include <vector>

namespace stend::reporting::svg {

// The <svg> element of `plot`. Never throws for empty or non-finite data: an empty plot says
// "no data".
std::string render(const estimation::figure::Plot& plot);

// Ticks of an axis: "nice" linear steps (1, 2, 5 × 10^k) or decades (with 2 and 5 when the span is
// under two decades) on a log axis. Exposed for tests.
std::vector<double> nice_ticks(double lo, double hi, bool log_axis, int target = 6);
// Short tick text: "0.002", "1e-05", "250".
std::string tick_text(double v);
// XML text escaping (&, <, >, ", ').
std::string escape(const std::string& s);

}  // namespace stend::reporting::svg
