// Comparison of units and vendors under one procedure (see compare.hpp).
#include "stend/reporting/compare.hpp"

#include "stend/estimation/linear_lsq.hpp"
#include "stend/estimation/report_section.hpp"
#include "stend/reporting/run_report.hpp"
#include "stend/reporting/svg_plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace stend::reporting {

namespace {

std::string g(double v) { return std::isfinite(v) ? fmt::format("{:.5g}", v) : "—"; }
std::string vendor_key(const RunResults& r) { return r.model.empty() ? r.vendor : r.vendor + " " + r.model; }

}  // namespace

std::string VendorStats::count_text() const {
  const std::string u = fmt::format("{} unit{}", units, units == 1 ? "" : "s");
  return runs == units ? u : fmt::format("{} ({} runs)", u, runs);
}

const ParameterComparison* Comparison::find(const std::string& estimator, const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name && (estimator.empty() || p.estimator == estimator)) return &p;
  return nullptr;
}

namespace {

// The runs' common procedure fingerprint; refuses runs measured with different (or no) procedures.
std::string common_fingerprint(const std::vector<RunResults>& runs) {
  std::map<std::string, std::vector<std::string>> by_fp;
  for (const auto& r : runs) by_fp[r.procedure_fingerprint].push_back(r.run_name);
  if (by_fp.size() == 1 && !by_fp.begin()->first.empty()) return by_fp.begin()->first;
  std::string msg =
      "refusing to compare: the runs were not measured with the same procedure, so their parameters are not "
      "comparable (a different procedure excites, heats and averages the unit differently). Procedure "
      "fingerprints:";
  for (const auto& [fp, names] : by_fp) {
    msg += "\n  " + (fp.empty() ? std::string("(none: no experiment.yaml)") : fp.substr(0, 16)) + ": ";
    for (std::size_t i = 0; i < names.size(); ++i) msg += (i ? ", " : "") + names[i];
  }
  msg += "\nCompare one group at a time (stend compare --procedure FINGERPRINT).";
  throw ComparisonRefused(msg);
}

// (estimator, parameter) pairs in order of first appearance.
std::vector<std::pair<std::string, std::string>> parameter_keys(const std::vector<RunResults>& runs) {
  std::vector<std::pair<std::string, std::string>> keys;
  for (const auto& r : runs)
    for (const auto& p : r.parameters)
      if (std::find(keys.begin(), keys.end(), std::make_pair(p.estimator, p.name)) == keys.end())
        keys.emplace_back(p.estimator, p.name);
  return keys;
}

// One vendor's runs: how many, of how many distinct units, the mean of the identified values, their
// SD with the 95 % t interval of the mean (two or more values), and the median standard error.
VendorStats vendor_stats(const std::string& vendor, const std::vector<const UnitValue*>& units) {
  VendorStats s;
  s.vendor = vendor;
  std::vector<double> vals, ses;
  std::set<std::string> serials;
  for (const UnitValue* u : units) {
    ++s.runs;
    serials.insert(u->serial.empty() ? "run " + u->run_name : "serial " + u->serial);
    if (!u->p.identifiable || !std::isfinite(u->p.value)) continue;
    ++s.identified;
    vals.push_back(u->p.value);
    if (std::isfinite(u->p.std_error)) ses.push_back(u->p.std_error);
  }
  if (!vals.empty()) {
    double sum = 0.0;
    for (double x : vals) sum += x;
    s.mean = sum / static_cast<double>(vals.size());
  }
  if (vals.size() >= 2) {
    double ss = 0.0;
    for (double x : vals) ss += (x - s.mean) * (x - s.mean);
    s.spread_sd = std::sqrt(ss / static_cast<double>(vals.size() - 1));
    const double n = static_cast<double>(vals.size());
    const double t = estimation::student_t_quantile(0.975, n - 1.0);
    s.mean_lo = s.mean - t * s.spread_sd / std::sqrt(n);
    s.mean_hi = s.mean + t * s.spread_sd / std::sqrt(n);
  }
  if (!ses.empty()) {
    std::sort(ses.begin(), ses.end());
    const std::size_t m = ses.size() / 2;
    s.median_std_error = ses.size() % 2 ? ses[m] : 0.5 * (ses[m - 1] + ses[m]);
  }
  s.units = static_cast<int>(serials.size());
  return s;
}

// One parameter across the runs: every unit's value, and the statistics per vendor (in order of
// first appearance).
ParameterComparison compare_parameter(const std::vector<RunResults>& runs, const std::string& est,
                                      const std::string& name) {
  ParameterComparison pc;
  pc.estimator = est;
  pc.name = name;
  for (const auto& r : runs)
    if (const ParameterResult* p = r.find(est, name)) {
      pc.unit = p->unit;
      pc.units.push_back({r.run_name, vendor_key(r), r.model, r.serial, *p});
    }
  std::map<std::string, std::vector<const UnitValue*>> groups;
  std::vector<std::string> order;
  for (const auto& u : pc.units) {
    if (!groups.count(u.vendor)) order.push_back(u.vendor);
    groups[u.vendor].push_back(&u);
  }
  for (const auto& v : order) pc.vendors.push_back(vendor_stats(v, groups[v]));
  return pc;
}

}  // namespace

Comparison compare_runs(const std::vector<RunResults>& runs) {
  if (runs.empty()) throw ComparisonRefused("nothing to compare: no runs were selected");
  Comparison c;
  c.fingerprint = common_fingerprint(runs);
  c.runs = runs;
  std::stable_sort(c.runs.begin(), c.runs.end(), [](const RunResults& a, const RunResults& b) {
    return std::tie(a.vendor, a.model, a.serial, a.run_name) < std::tie(b.vendor, b.model, b.serial, b.run_name);
  });
  for (const auto& [est, name] : parameter_keys(c.runs)) c.parameters.push_back(compare_parameter(c.runs, est, name));
  return c;
}

std::string comparison_text(const Comparison& c) {
  std::string o = fmt::format("procedure fingerprint {} — {} run(s)\n", c.fingerprint, c.runs.size());
  o += fmt::format("{:<11} {:<18} {:<22} {:<18} {:>10} {:>13} {:>11} {:>29} {:>11}  {}\n", "estimator", "parameter",
                   "vendor", "units", "identified", "mean", "SD", "95% interval of the mean", "median SE", "unit");
  for (const auto& p : c.parameters)
    for (const auto& v : p.vendors)
      o += fmt::format("{:<11} {:<18} {:<22} {:<18} {:>4}/{:<5} {:>13} {:>11} {:>29} {:>11}  {}\n", p.estimator, p.name,
                       v.vendor, v.count_text(), v.identified, v.runs, g(v.mean), g(v.spread_sd),
                       std::isfinite(v.mean_lo) ? fmt::format("[{}, {}]", g(v.mean_lo), g(v.mean_hi)) : "—",
                       g(v.median_std_error), p.unit);
  return o;
}

std::string comparison_html(const Comparison& c) {
  using svg::escape;
  namespace figure = estimation::figure;
  std::string b = "<h1>Stend comparison of units and vendors</h1>\n";
  b += fmt::format("<p>{} run(s), all measured with procedure fingerprint <code>{}</code>. Vendor mean intervals are "
                   "95 % Student-t intervals from the unit-to-unit spread; each unit's interval is its own fit's.</p>\n",
                   c.runs.size(), escape(c.fingerprint));
  b += "<table><tr><th>run</th><th>vendor</th><th>model</th><th>serial</th><th>estimators</th></tr>\n";
  for (const auto& r : c.runs) {
    std::string e;
    for (const auto& x : r.estimators) e += (e.empty() ? "" : ", ") + x.name + " " + x.version;
    b += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", escape(r.run_name),
                     escape(r.vendor), escape(r.model), escape(r.serial), escape(e));
  }
  b += "</table>\n<h2>Summary</h2>\n<table><tr><th>estimator</th><th>parameter</th><th>vendor</th><th>identified / "
       "runs</th><th>units</th><th>mean</th><th>SD (unit-to-unit, or run-to-run where runs repeat a unit)</th>"
       "<th>95 % interval of the mean</th><th>median unit SE</th><th>unit</th></tr>\n";
  // Shown in the display units (estimation::display_unit: mg, deg/s, ppm), as the plots below are.
  for (const auto& p : c.parameters) {
    const estimation::DisplayUnit du = estimation::display_unit(p.unit);
    for (const auto& v : p.vendors)
      b += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}/{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
                       "<td>{}</td><td>{}</td></tr>\n",
                       escape(p.estimator), escape(p.name), escape(v.vendor), v.identified, v.runs, escape(v.count_text()),
                       g(v.mean * du.scale),
                       g(v.spread_sd * du.scale),
                       std::isfinite(v.mean_lo)
                           ? fmt::format("[{}, {}]", g(v.mean_lo * du.scale), g(v.mean_hi * du.scale))
                           : "—",
                       g(v.median_std_error * du.scale), escape(du.unit));
  }
  b += "</table>\n<h2>Parameters by unit</h2>\n";
  for (const auto& p : c.parameters) {
    bool any = false;
    for (const auto& u : p.units) any = any || u.p.identifiable;
    if (!any) continue;
    const estimation::DisplayUnit du = estimation::display_unit(p.unit);
    const double k = du.scale;
    figure::Plot plot;
    plot.title = p.estimator + ": " + p.name;
    plot.y_label = p.name + " [" + du.unit + "]";
    plot.x_label = "unit (grouped by vendor)";
    plot.width = 520;
    plot.height = 320;
    std::map<std::string, std::size_t> color;
    for (const auto& v : p.vendors) color.emplace(v.vendor, color.size());
    std::map<std::string, figure::Series> units, means, bands;
    std::vector<std::string> order;
    for (std::size_t i = 0; i < p.units.size(); ++i) {
      const UnitValue& u = p.units[i];
      plot.x_categories.push_back(u.serial.empty() ? u.run_name : u.serial);
      if (!units.count(u.vendor)) {
        order.push_back(u.vendor);
        units[u.vendor] = {u.vendor, figure::Style::kPoints, {}, {}, {}, {}, figure::palette(color[u.vendor]), false, 1.0};
      }
      auto& s = units[u.vendor];
      s.x.push_back(static_cast<double>(i));
      s.y.push_back(u.p.value * k);
      s.y_lo.push_back(u.p.lo * k);
      s.y_hi.push_back(u.p.hi * k);
    }
    for (const auto& v : p.vendors) {
      const auto& s = units[v.vendor];
      if (s.x.empty()) continue;
      const double x0 = s.x.front() - 0.3, x1 = s.x.back() + 0.3;
      const std::string vendor_color = figure::palette(color[v.vendor]);
      figure::Series m{"", figure::Style::kLine, {x0, x1}, {v.mean * k, v.mean * k}, {}, {}, vendor_color, true, 1.0};
      figure::Series band{"", figure::Style::kBand, {x0, x1}, {}, {v.mean_lo * k, v.mean_lo * k},
                          {v.mean_hi * k, v.mean_hi * k}, vendor_color, false, 0.18};
      plot.series.push_back(band);
      plot.series.push_back(m);
    }
    for (const auto& v : order) plot.series.push_back(units[v]);
    b += "<figure>" + svg::render(plot) + "<figcaption>" + escape(p.name) +
         ": each unit's value with its own interval; dashed: vendor mean, shaded: its 95 % interval.</figcaption>"
         "</figure>\n";
  }
  return html_page("Stend comparison", b);
}

nlohmann::json comparison_json(const Comparison& c) {
  using nlohmann::json;
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["fingerprint"] = c.fingerprint;
  j["runs"] = json::array();
  for (const auto& r : c.runs)
    j["runs"].push_back({{"name", r.run_name}, {"dir", r.dir.string()}, {"vendor", r.vendor}, {"model", r.model}, {"serial", r.serial}});
  j["parameters"] = json::array();
  for (const auto& p : c.parameters) {
    json q = {{"estimator", p.estimator}, {"name", p.name}, {"unit", p.unit}, {"vendors", json::array()}, {"units", json::array()}};
    for (const auto& v : p.vendors)
      q["vendors"].push_back({{"vendor", v.vendor},
                              {"runs", v.runs},
                              {"units", v.units},
                              {"identified", v.identified},
                              {"mean", num(v.mean)},
                              {"spread_sd", num(v.spread_sd)},
                              {"mean_interval", {num(v.mean_lo), num(v.mean_hi)}},
                              {"median_std_error", num(v.median_std_error)}});
    for (const auto& u : p.units)
      q["units"].push_back({{"run", u.run_name},
                            {"vendor", u.vendor},
                            {"model", u.model},
                            {"serial", u.serial},
                            {"identifiable", u.p.identifiable},
                            {"value", num(u.p.value)},
                            {"std_error", num(u.p.std_error)},
                            {"interval", {num(u.p.lo), num(u.p.hi)}}});
    j["parameters"].push_back(std::move(q));
  }
  return j;
}

}  // namespace stend::reporting
