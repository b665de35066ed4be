// The run report's section of the sim-to-real gap diagnosis (see gap_section.hpp).
#include "gap_section.hpp"

#include "stend/estimation/json_fields.hpp"
#include "stend/physics/units.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace stend::reporting::detail {

namespace {

using estimation::Paragraph;
using estimation::ReportSection;
using estimation::Row;
using estimation::Span;
using estimation::Table;
using estimation::figure::palette;
using estimation::figure::Plot;
using estimation::figure::Series;
using estimation::figure::Style;
using nlohmann::json;

constexpr const char* kAxes = "xyz";

double num(const json& j, const char* key) { return estimation::number_field(j, key); }
double at(const json& a, std::size_t i) { return estimation::number_at(a, i); }
std::string str(const json& j, const char* key) { return estimation::text_field(j, key); }
std::string g3(double v) { return estimation::report_number(v, 3); }

// The unit the gap is shown in: the diagnosis' own choice (its "units": display, display_per_unit —
// mg for an accelerometer gap, deg/s for a gyroscope gap), mg for a document without one.
struct GapDisplay {
  double per_unit = 1.0 / physics::kMilliG;  // display value = stored value × per_unit
  std::string unit = "mg";
};
GapDisplay gap_display(const json& gp) {
  GapDisplay d;
  const json units = gp.value("units", json::object());
  if (const double k = num(units, "display_per_unit"); std::isfinite(k) && k > 0.0 && !str(units, "display").empty())
    d = {k, str(units, "display")};
  return d;
}

// Residual layout of a gap result: per axis (x y z), or the magnitude form (orientations unknown)
// with one |f| row per segment in slot 0 of every vector.
struct GapAxes {
  bool magnitude = false;
  int count = 3;
  std::string label(int k) const { return magnitude ? std::string("|f|") : std::string(1, kAxes[k]); }
};

// The magnitude-form note, and the static residual RMS [display unit] per axis and over the noise floor.
void add_summary(ReportSection& s, const json& gp, const GapAxes& axes, const GapDisplay& d) {
  const json gap = gp.value("gap", json::object());
  const json floor = gp.value("noise_floor", json::object());
  if (axes.magnitude)
    s.add_text("Magnitude form: the orientations were not recorded, only |g| is known; each segment is its mean "
               "along the estimated gravity direction, and rotations of the sensor frame cannot be seen.");
  std::string rms, ratio;
  for (int k = 0; k < axes.count; ++k) {
    rms += fmt::format("{}{} {}", k ? ", " : "", axes.label(k),
                       g3(at(gap.value("static_rms_mps2", json::array()), static_cast<std::size_t>(k)) * d.per_unit));
    ratio += fmt::format("{}{} {}", k ? ", " : "", axes.label(k),
                         g3(at(gap.value("static_rms_over_floor", json::array()), static_cast<std::size_t>(k))));
  }
  s.add_text(fmt::format("Static residual RMS [{}]: {}; over the noise floor: {} (floor source: {}).", d.unit, rms,
                         ratio, str(floor, "source")));
}

// Where: one bar chart per dimension (axis, orientation, temperature, time — in the diagnosis'
// order) of the share of the residual energy each of its places holds; a dimension's shares add up
// to 1, so the dimensions are not drawn against each other. Without a recorded temperature, the
// temperature places (all at the importer's placeholder) are left out.
void add_where(ReportSection& s, const json& where, bool temperature_recorded) {
  std::vector<std::string> dimensions;
  for (const auto& w : where)
    if (std::find(dimensions.begin(), dimensions.end(), str(w, "dimension")) == dimensions.end())
      dimensions.push_back(str(w, "dimension"));
  for (const std::string& dimension : dimensions) {
    if (dimension == "temperature" && !temperature_recorded) continue;
    std::string words = dimension;  // "time_since_change" → "time since change"
    std::replace(words.begin(), words.end(), '_', ' ');
    Plot p;
    p.title = "where the gap lies: by " + words;
    p.y_label = "share of the residual energy";
    p.x_label = words;
    p.width = 760;
    Series bars{"", Style::kBars, {}, {}, {}, {}, palette(3), false, 0.85};
    for (const auto& w : where) {
      if (str(w, "dimension") != dimension) continue;
      bars.x.push_back(static_cast<double>(p.x_categories.size()));
      p.x_categories.push_back(str(w, "place"));
      bars.y.push_back(num(w, "share"));
    }
    p.series = {bars};
    p.y_include_zero = true;
    s.add(p, "Localization by " + words + ": the share of the residual each " + words +
                 " holds (the shares of one dimension add up to 1).");
  }
}

// The span of the segments' values of `key` (temperature [°C], time since the last change [s]);
// NaN when none has one.
double segment_span(const json& segs, const char* key) {
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& sg : segs) {
    const double t = num(sg, key);
    if (!std::isfinite(t)) continue;
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  return hi >= lo ? hi - lo : kNaN;
}

// A residual against a range narrower than this is a vertical stripe: not plotted [°C, s].
constexpr double kMinPlottedSpanC = 2.0, kMinPlottedSpanS = 1.0;

// One plot of the segment residual per axis [display unit] against `key` of each segment.
Plot segment_residual_plot(const json& segs, const GapAxes& axes, const GapDisplay& d, const char* key,
                           const std::string& title, const std::string& x_label) {
  Plot p;
  p.title = title;
  p.x_label = x_label;
  p.y_label = "residual [" + d.unit + "]";
  for (int k = 0; k < axes.count; ++k) {
    Series s{fmt::format("axis {}", axes.label(k)), Style::kPoints, {}, {}, {}, {},
             palette(static_cast<std::size_t>(k)), false, 0.8};
    for (const auto& sg : segs) {
      s.x.push_back(num(sg, key));
      s.y.push_back(at(sg.value("axis_residual_mps2", json::array()), static_cast<std::size_t>(k)) * d.per_unit);
    }
    p.series.push_back(s);
  }
  p.lines.push_back({true, 0.0, "", "#555"});
  return p;
}

// Segment residual per axis [display unit] against temperature [°C] (when the segments span a range
// of temperatures) and against time since the last change [s] (when they began at different times).
void add_segments(ReportSection& s, const json& segs, const GapAxes& axes, const GapDisplay& d,
                  bool temperature_recorded) {
  const double span = temperature_recorded ? segment_span(segs, "temperature_c") : kNaN;
  const double span_s = segment_span(segs, "time_since_change_s");
  if (!std::isfinite(span))
    s.add_text("No temperature was recorded: no residual-against-temperature plot.");
  else if (span < kMinPlottedSpanC)
    s.add_text(fmt::format("The segments' temperatures span {} °C (under {} °C): no residual-against-temperature "
                           "plot (it would be a vertical stripe).",
                           g3(span), g3(kMinPlottedSpanC)));
  if (!(span_s >= kMinPlottedSpanS))
    s.add_text(fmt::format("All segments began {} after the last change: no residual-against-time plot.",
                           std::isfinite(span_s) ? "within " + g3(span_s) + " s of each other" : "at an unknown time"));
  const std::string caption = "Twin-minus-recording residual of each static segment, per axis.";
  if (span >= kMinPlottedSpanC)
    s.add(segment_residual_plot(segs, axes, d, "temperature_c", "segment residual against temperature", "temperature [°C]"),
          caption);
  if (span_s >= kMinPlottedSpanS)
    s.add(segment_residual_plot(segs, axes, d, "time_since_change_s", "segment residual against time since change",
                                "time since the last change [s]"),
          caption);
}

// Shrink: held-out and in-sample RMS [display unit] after each forward-selection step, against the
// noise floor.
void add_shrink(ReportSection& s, const json& steps, const GapDisplay& d) {
  Plot p;
  p.title = "how far the gap shrinks";
  p.y_label = "RMS [" + d.unit + "]";
  p.x_label = "model after step";
  p.width = 760;
  Series held{"held-out RMS", Style::kLinePoints, {}, {}, {}, {}, palette(0), false, 1.0};
  Series ins{"in-sample RMS", Style::kLinePoints, {}, {}, {}, {}, palette(1), true, 1.0};
  Series fl{"noise floor", Style::kLine, {}, {}, {}, {}, "#777", true, 1.0};
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const std::string added = str(steps[i], "added");
    p.x_categories.push_back(added.empty() ? fmt::format("step {}", i) : "+" + added);
    held.x.push_back(static_cast<double>(i));
    held.y.push_back(num(steps[i], "heldout_rms_mps2") * d.per_unit);
    ins.x.push_back(static_cast<double>(i));
    ins.y.push_back(num(steps[i], "in_sample_rms_mps2") * d.per_unit);
    fl.x.push_back(static_cast<double>(i));
    fl.y.push_back(num(steps[i], "noise_floor_mps2") * d.per_unit);
  }
  p.series = {held, ins, fl};
  p.y_include_zero = true;
  s.add(p, "Residual RMS on data not used to fit (held-out) as each candidate term is added, against the noise floor.");
}

// Groups of candidates that stand in for each other (each names another among its aliases, either
// by term or by term_axis): the group number of each candidate, 0 for one without a stand-in.
std::vector<int> alias_groups(const json& cands) {
  const std::size_t n = cands.size();
  std::vector<std::size_t> parent(n);
  for (std::size_t i = 0; i < n; ++i) parent[i] = i;
  auto root = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& a : cands[i].value("aliases", json::array())) {
      if (!a.is_string()) continue;
      for (std::size_t j = 0; j < n; ++j) {
        const std::string t = str(cands[j], "term");
        if (j != i && (a == t || a == t + "_" + str(cands[j], "axis"))) parent[root(i)] = root(j);
      }
    }
  std::map<std::size_t, int> size, number;
  for (std::size_t i = 0; i < n; ++i) ++size[root(i)];
  std::vector<int> group(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (size[root(i)] > 1) group[i] = number.emplace(root(i), static_cast<int>(number.size()) + 1).first->second;
  return group;
}

// Table of the candidate terms: held-out improvement, ΔBIC, p, size with its 95 % interval, aliases;
// candidates that stand in for each other are listed together under one group label, and only the
// group's best (largest held-out improvement) is called significant — the others can replace it.
Table candidates_table(const json& cands) {
  const std::vector<int> group = alias_groups(cands);
  std::vector<std::size_t> order(cands.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const int ga = group[a] ? group[a] : 1 << 20, gb = group[b] ? group[b] : 1 << 20;
    return ga != gb ? ga < gb : num(cands[a], "heldout_improvement") > num(cands[b], "heldout_improvement");
  });
  Table t;
  t.header = {"group", "term", "axis", "held-out improvement", "ΔBIC", "p", "size", "95 % interval", "aliases", "significant"};
  std::set<int> led;
  for (std::size_t i : order) {
    const json& c = cands[i];
    std::string al;
    for (const auto& a : c.value("aliases", json::array()))
      al += (al.empty() ? "" : ", ") + (a.is_string() ? a.get<std::string>() : a.dump());
    const bool sig = c.value("significant", false);
    std::string verdict = sig ? "YES" : "no";
    if (group[i] && sig)
      verdict = led.insert(group[i]).second ? "YES (for its group: the data cannot tell its members apart)"
                                            : "stands in for the group's first — not a separate finding";
    const json ci = c.value("ci95", json::array());
    t.rows.push_back(Row{{group[i] ? fmt::format("aliased group {}", group[i]) : "—", str(c, "term"), str(c, "axis"),
                          g3(num(c, "heldout_improvement")), g3(num(c, "delta_bic")), g3(num(c, "p_value")),
                          g3(num(c, "size")) + " " + str(c, "size_unit"),
                          fmt::format("[{}, {}]", g3(at(ci, 0)), g3(at(ci, 1))), al, verdict}});
  }
  return t;
}

// The verdict under its heading, both from the numbers the diagnosis judged (at_noise_floor, its
// held-out χ² test against the floor, and over_floor): "No gap:" when the model as given is at the
// noise floor, "Explained:" when the terms it added brought it there, else "Unexplained:" — then
// the diagnosis' own statement.
Paragraph verdict_paragraph(const json& un, bool terms_added, const GapDisplay& d) {
  const bool at_floor = un.value("at_noise_floor", false);
  const std::string numbers = fmt::format("held-out RMS {} {} = {} × floor", g3(num(un, "heldout_rms_mps2") * d.per_unit),
                                          d.unit, g3(num(un, "over_floor")));
  const char* heading = !at_floor ? "Unexplained:" : terms_added ? "Explained:" : "No gap:";
  const std::string verdict = !at_floor     ? "the held-out residual is above the noise floor"
                              : terms_added ? "with the added terms the held-out residual is within the noise floor"
                                            : "the held-out residual is within the noise floor";
  return Paragraph{{Span{heading, Span::Kind::kStrong},
                    Span{fmt::format(" {} ({}). {}", verdict, numbers, str(un, "statement"))}}};
}

}  // namespace

ReportSection gap_section(const json& gp, bool temperature_recorded) {
  ReportSection s;
  s.heading = "Sim-to-real gap — " + str(gp, "model");
  GapAxes axes;
  axes.magnitude = str(gp, "form") == "magnitude";
  axes.count = axes.magnitude ? 1 : 3;
  const GapDisplay d = gap_display(gp);
  add_summary(s, gp, axes, d);
  const json where = gp.value("where", json::array());
  if (!where.empty()) add_where(s, where, temperature_recorded);
  const json segs = gp.value("segments", json::array());
  if (!segs.empty()) add_segments(s, segs, axes, d, temperature_recorded);
  const json steps = gp.value("steps", json::array());
  if (!steps.empty()) add_shrink(s, steps, d);
  const json cands = gp.value("candidates", json::array());
  if (!cands.empty()) s.add(candidates_table(cands));
  const json un = gp.value("unexplained", json::object());
  if (!un.empty()) s.add(verdict_paragraph(un, steps.size() > 1, d));
  return s;
}

}  // namespace stend::reporting::detail
