// The text report of a temp_poly fit. See stend/temp_poly/temp_poly.hpp.
#include <cmath>
#include <cstdio>
#include <ostream>

#include "stend/temp_poly/temp_poly.hpp"

namespace stend::temp_poly {

namespace {

// Formats are literals at every call site (printf-style helper).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}
#pragma GCC diagnostic pop

}  // namespace

void print_report(std::ostream& os, const TempPolyResult& r) {
  const TempPolyOptions& o = r.options;
  os << "temp_poly " << kEstimatorVersion << " — bias and scale versus temperature ("
     << estimation::instrument_name(o.instrument) << ")\n";
  if (!r.recording_dir.empty()) os << "recording: " << r.recording_dir << " (" << r.experiment_name << ")\n";
  os << "selection: " << o.selection;
  if (o.selection == "fixed") os << ", order " << o.order;
  else os << ", orders 0.." << o.max_order;
  os << "; terms: bias" << (o.scale ? ", scale" : "") << (o.cross_axis ? ", cross_axis" : "")
     << (o.bias_temperature ? ", bias_temperature" : "") << (o.scale_temperature ? ", scale_temperature" : "")
     << "; reference T0 = " << o.reference_c << " degC; min_span_c = " << o.min_span_c << " degC\n";
  if (!r.ok() && r.axes.empty()) {
    os << "TEMPERATURE FIT REFUSED: " << r.message << "\n";
    for (const auto& nt : r.notes) os << "note: " << nt << "\n";
    return;
  }
  os << "valid temperature range: " << fmt("%.2f", r.valid_min_c) << " … " << fmt("%.2f", r.valid_max_c)
     << " degC; " << r.points.size() << " static points\n";
  os << "levels (degC: points heating/cooling/unknown):\n";
  for (const auto& L : r.levels)
    os << "  " << fmt("%8.2f", L.temperature_c) << "  [" << fmt("%.2f", L.min_c) << ", " << fmt("%.2f", L.max_c)
       << "]  " << L.points << " (" << L.heating_points << "/" << L.cooling_points << "/" << L.unknown_points << ")\n";
  for (const auto& ax : r.axes) {
    const char name = estimation::axis_name(ax.axis);
    os << "\n== axis " << name << " ==\n";
    os << "  order  n    rank  RSS            BIC          CV-MSE        note\n";
    for (const auto& s : ax.scores)
      os << (s.order == ax.chosen_order ? "* " : "  ") << fmt("%5.0f", s.order) << fmt("%5.0f", s.observations)
         << fmt("%6.0f", s.parameters) << "  " << fmt("%-13.6g", s.rss) << "  " << fmt("%-11.6g", s.bic) << "  "
         << (s.cv_ok ? fmt("%-12.6g", s.cv_mse) : std::string("-           ")) << "  " << s.note << "\n";
    if (!ax.ok()) {
      os << "  AXIS FAILED: " << ax.message << "\n";
      continue;
    }
    os << "  chosen order " << ax.chosen_order << " (" << o.selection << ")\n";
    for (const auto& p : ax.fit.lsq.parameters) os << "  " << p << "\n";
    os << "  residual RMS " << fmt("%.4g", ax.fit.residual_rms[ax.axis]) << " " << r.unit << " ("
       << fmt("%.4g", ax.fit.residual_rms_display[ax.axis]) << " " << ax.fit.display_unit << ")\n";
    for (const auto& w : ax.fit.lsq.warnings) os << "  warning: " << w << "\n";
    if (ax.hysteresis.empty()) {
      os << "  hysteresis: no level was visited on both the heating and the cooling leg\n";
    } else {
      os << "  hysteresis (cooling − heating mean residual, " << r.unit << "):\n";
      for (const auto& h : ax.hysteresis)
        os << "    " << fmt("%8.2f", h.temperature_c) << " degC  " << fmt("%+.4g", h.value) << " ± "
           << fmt("%.2g", h.std_error) << "  [" << fmt("%.4g", h.lower) << ", " << fmt("%.4g", h.upper) << "]  ("
           << h.heating_points << " heating, " << h.cooling_points << " cooling)"
           << (h.significant ? "  SIGNIFICANT" : "") << "\n";
    }
  }
  if (!r.ok()) os << "\nTEMPERATURE FIT FAILED: " << r.message << "\n";
  for (const auto& nt : r.notes) os << "note: " << nt << "\n";
}

std::ostream& operator<<(std::ostream& os, const TempPolyResult& r) {
  print_report(os, r);
  return os;
}

}  // namespace stend::temp_poly
