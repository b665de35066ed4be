// `stend gap validate`'s report: the text table and the stend.gap_validate/1 document. See
// stend/diagnosis/validate.hpp.
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <ostream>

#include "noise_validation.hpp"
#include "stend/diagnosis/validate.hpp"
#include "stend/estimation/report_section.hpp"

namespace stend::diagnosis {

namespace {

// The floor of a segment mean in the display unit of its quantity (estimation::display_unit: mg,
// deg/s) and in its own unit.
std::string floor_text(const ExperimentValidation& e) {
  const estimation::DisplayUnit du = estimation::display_unit(e.unit);
  char b[128];
  std::snprintf(b, sizeof b, "%.3g %s (%.3g %s)", e.floor * du.scale, du.unit.c_str(), e.floor, e.unit.c_str());
  return std::string(b);
}

// One table per experiment: every planted candidate at every size.
void print_planted(std::ostream& os, const ValidationReport& r) {
  char line[512];
  const std::string header =
      "planted effect                 ident  size  runs  top-1  strict  mean rank  closed  recovered/planted  CI cover\n";
  std::string current = "\x01";
  for (const auto& c : r.candidates) {
    if (c.experiment != current) {
      current = c.experiment;
      os << "\n== " << (c.experiment.empty() ? std::string("(experiment)") : c.experiment);
      for (const auto& e : r.experiments)
        if (e.experiment == c.experiment) os << " — floor " << floor_text(e);
      os << "\n" << header;
    }
    for (const auto& b : c.by_size) {
      std::snprintf(line, sizeof line, "%-30s %-5s  %4gx  %4d  %5.2f  %6.2f  %9.2f  %6.2f  %17.3f  %8s\n", c.term.c_str(),
                    c.identifiable ? "yes" : "no", b.size, b.runs, b.runs ? double(b.top1) / b.runs : 0.0,
                    b.runs ? double(b.top1_strict) / b.runs : 0.0, b.mean_rank, b.closed, b.recovered_ratio,
                    b.coverage_n ? (std::to_string(b.covered) + "/" + std::to_string(b.coverage_n)).c_str() : "-");
      os << line;
    }
  }
}

// Alias pairs declared beforehand, the per-experiment figures and the confusion matrix.
void print_per_experiment(std::ostream& os, const ValidationReport& r) {
  char line[512];
  os << "\nalias pairs declared beforehand (joint-design rank, per experiment):\n";
  for (const auto& c : r.candidates)
    if (!c.aliases.empty()) {
      os << "  " << c.term << " [" << c.experiment << "]:";
      for (const auto& a : c.aliases) os << " " << a << ";";
      os << "\n";
    }
  os << "\nper experiment (top-1 / closed / coverage over identifiable plants >= 5x floor):\n";
  for (const auto& e : r.experiments) {
    std::snprintf(line, sizeof line,
                  "  %-52s top-1 %5.3f (%d/%d)  closed %5.3f  coverage %5.3f  null %d (fp %d)  oov %d (unexplained %d, "
                  "named %d)\n",
                  e.experiment.c_str(), e.top1_at5, e.top1_ok_at5, e.planted_at5, e.closed_at5, e.coverage, e.null_runs,
                  e.null_false_positives, e.oov_runs, e.oov_unexplained, e.oov_wrong_name);
    os << line;
    if (!e.not_excited.empty()) {
      os << "    not excited by this design (not planted):";
      for (const auto& n : e.not_excited) os << " " << n;
      os << "\n";
    }
  }
  os << "\nconfusion (planted >= 5x floor → first named):\n";
  for (const auto& [p, m] : r.confusion) {
    os << "  " << p << " →";
    for (const auto& [n, k] : m) os << " " << n << ":" << k;
    os << "\n";
  }
}

// The totals against their targets, the run time [s] and the terms null runs named.
void print_totals(std::ostream& os, const ValidationReport& r) {
  char line[512];
  std::snprintf(line, sizeof line,
                "\ntop-1 (identifiable, >= 5x floor): %.3f   [target >= 0.9]\n"
                "explainable held-out gap closed (>= 5x): %.3f   [target >= 0.8]\n"
                "95%% interval coverage of the recovered size (>= 5x): %.3f\n"
                "null runs: %d, false positives (a term named or marked significant) %d (rate %.3f)   [target <= 0.05]\n"
                "out of vocabulary: %d runs, %d said unexplained, %d named a term\n"
                "time: %.1f s\n",
                r.top1_at5, r.closed_at5, r.coverage, r.null_runs, r.null_false_positives, r.false_positive_rate,
                r.oov_runs, r.oov_unexplained, r.oov_wrong_name, r.seconds);
  os << line;
  if (!r.null_named.empty()) {
    os << "false positives:";
    for (const auto& [n, k] : r.null_named) os << " " << n << ":" << k;
    os << "\n";
  }
}

// The design cases: runs passed, and what was named first.
void print_design_cases(std::ostream& os, const ValidationReport& r) {
  if (r.design_cases.empty()) return;
  os << "\ndesign cases (folds, aliases, placement): passed / runs — expected\n";
  for (const auto& c : r.design_cases) {
    os << "  " << c.name << ": " << c.passed << "/" << c.runs << " — " << c.expected << "\n    first named:";
    for (const auto& [n, k] : c.named) os << " " << n << " " << k << ";";
    os << "\n";
  }
}

}  // namespace

bool claims_an_effect(const GapReport& r) {
  if (!r.selected.empty() || r.placement.significant) return true;
  for (const auto& c : r.candidates)
    if (!c.noise_stage && c.significant) return true;
  return false;
}

bool design_case_met(const DesignCase& c) {
  // Planted: the expected thing in >= 90 % of runs; null: a false positive in <= 5 %.
  return c.runs > 0 && (c.null_case ? c.runs - c.passed <= 0.05 * c.runs : c.passed >= 0.9 * c.runs);
}

void print_validation(std::ostream& os, const ValidationReport& r) {
  os << "stend gap validate — segment-level generator; per experiment: the fitted model, the planted effect "
        "withheld from it, sizes in multiples of the averaged noise floor of a segment mean\n";
  print_planted(os, r);
  print_per_experiment(os, r);
  print_totals(os, r);
  print_design_cases(os, r);
  noise_stage::print_validation(os, r.noise_stage, r.noise_seconds);
}

std::string validation_json(const ValidationReport& r, int indent) {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["schema"] = "stend.gap_validate/1";
  j["noise_floor_mps2"] = r.floor_mps2;
  json cs = json::array();
  for (const auto& c : r.candidates) {
    json sz = json::array();
    for (const auto& b : c.by_size)
      sz.push_back({{"size_over_floor", b.size}, {"runs", b.runs}, {"top1", b.top1}, {"top1_strict", b.top1_strict},
                    {"mean_rank", num(b.mean_rank)}, {"closed", num(b.closed)},
                    {"recovered_over_planted", num(b.recovered_ratio)}, {"ci_covered", b.covered},
                    {"ci_checked", b.coverage_n}});
    cs.push_back({{"term", c.term}, {"experiment", c.experiment}, {"identifiable", c.identifiable},
                  {"aliases", c.aliases}, {"by_size", sz}});
  }
  j["candidates"] = cs;
  json ex = json::array();
  for (const auto& e : r.experiments)
    ex.push_back({{"experiment", e.experiment}, {"unit", e.unit}, {"noise_floor", e.floor},
                  {"planted_at_5x", e.planted_at5}, {"top1_ok_at_5x", e.top1_ok_at5}, {"top1_at_5x", num(e.top1_at5)},
                  {"closed_at_5x", num(e.closed_at5)}, {"coverage_at_5x", num(e.coverage)},
                  {"null_runs", e.null_runs}, {"null_false_positives", e.null_false_positives},
                  {"oov_runs", e.oov_runs}, {"oov_unexplained", e.oov_unexplained},
                  {"oov_wrong_name", e.oov_wrong_name}, {"not_excited", e.not_excited}});
  j["experiments"] = ex;
  j["confusion"] = r.confusion;
  j["summary"] = {{"top1_at_5x", num(r.top1_at5)},
                  {"closed_at_5x", num(r.closed_at5)},
                  {"coverage_at_5x", num(r.coverage)},
                  {"null_runs", r.null_runs},
                  {"null_false_positives", r.null_false_positives},
                  {"null_named", r.null_named},
                  {"false_positive_rate", num(r.false_positive_rate)},
                  {"oov_runs", r.oov_runs},
                  {"oov_unexplained", r.oov_unexplained},
                  {"oov_wrong_name", r.oov_wrong_name},
                  {"seconds", r.seconds}};
  json dc = json::array();
  for (const auto& c : r.design_cases)
    dc.push_back({{"case", c.name}, {"expected", c.expected}, {"null_case", c.null_case}, {"runs", c.runs},
                  {"passed", c.passed}, {"first_named", c.named}, {"met", design_case_met(c)}});
  j["design_cases"] = dc;
  noise_stage::add_json(j, r.noise_stage, r.noise_seconds);
  return j.dump(indent);
}

}  // namespace stend::diagnosis
