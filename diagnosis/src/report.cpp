// stend gap: printed report and the stend.gap/1 JSON document.
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <ostream>
#include <string>

#include "stend/diagnosis/gap.hpp"

namespace stend::diagnosis {

namespace {

using nlohmann::json;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json vec3(const Eigen::Vector3d& v) { return json::array({num(v[0]), num(v[1]), num(v[2])}); }

std::string f(double v, const char* spec = "%.4g") {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
  std::snprintf(buf, sizeof buf, spec, v);  // spec: one of the literals in this file
#pragma GCC diagnostic pop
  return buf;
}

// Per segment: residual per axis [m/s² or rad/s], temperature, groups, history, floor.
json segments_json(const GapReport& r) {
  json segs = json::array();
  for (std::size_t i = 0; i < r.segments.size() && i < r.residual.size(); ++i) {
    const auto& s = r.segments[i];
    const double t = std::isfinite(s.setpoint_c) ? s.setpoint_c : s.point.stimulus.temperature_c;
    segs.push_back({{"id", s.point.segment.id},
                    {"label", processing::label(s.point.segment)},
                    {"axis_residual_mps2", vec3(r.residual[i])},
                    {"temperature_c", num(t)},
                    {"die_temperature_c", num(s.point.stimulus.temperature_c)},
                    {"orientation", s.orientation},
                    {"orientation_name", s.orientation_name},
                    {"ramp_direction", s.ramp_direction},
                    {"time_since_change_s", num(s.time_since_change_s)},
                    {"averaging_s", num(s.averaging_s)},
                    {"noise_floor_mps2", vec3(s.mean_std_error)}});
  }
  return segs;
}

json where_json(const GapReport& r) {
  json where = json::array();
  for (const auto& p : r.where)
    where.push_back({{"dimension", p.dimension}, {"place", p.place}, {"share", num(p.share)}, {"rms_mps2", num(p.rms)},
                     {"rows", p.rows}});
  return where;
}

json candidate_json(const CandidateResult& c) {
  json a = json::array();
  for (const auto& s : c.aliases) a.push_back(s);
  json sep = json::array();
  for (const auto& s : c.separate) sep.push_back(s);
  return {{"term", c.term},
          {"axis", c.axis},
          {"evaluated", c.evaluated},
          {"noise_stage", c.noise_stage},
          {"heldout_improvement", num(c.heldout_improvement)},
          {"heldout_rms_mps2", num(c.heldout_rms)},
          {"heldout_rms_before_mps2", num(c.heldout_rms_before)},
          {"delta_bic", num(c.delta_bic)},
          {"p_value", num(c.p_value)},
          {"added_rank", c.added_rank},
          {"size", num(c.size)},
          {"size_parameter", c.size_param},
          {"size_unit", c.size_unit},
          {"ci95", json::array({num(c.ci_lo), num(c.ci_hi)})},
          {"aliases", a},
          {"separate_by", sep},
          {"significant", c.significant},
          {"remark", c.reason}};
}

json steps_json(const GapReport& r) {
  json steps = json::array();
  for (const auto& s : r.steps)
    steps.push_back({{"step", s.step},
                     {"added", s.added.empty() ? json(nullptr) : json(s.added)},
                     {"heldout_rms_mps2", num(s.heldout_rms)},
                     {"in_sample_rms_mps2", num(s.in_sample_rms)},
                     {"noise_floor_mps2", num(s.floor_rms)},
                     {"heldout_rows", s.heldout_rows},
                     {"rows", s.rows}});
  return steps;
}

// 1. The gap per axis: RMS in the gap unit and the display unit, floor, gap/floor, noise ratio.
void print_gap(std::ostream& os, const GapReport& r) {
  const double k = r.display_per_unit;
  const char* du = r.display_unit.c_str();
  os << "\n1. THE GAP (recording − twin with the fitted model), static segment means\n";
  os << "   noise floor of a segment mean: " << r.floor_source << "\n";
  if (r.magnitude)
    os << "   magnitude form: orientations unknown, only |g| known; one row per segment (the mean along the\n"
          "   estimated gravity direction); rotations of the sensor frame cannot be seen\n";
  os << "   axis   gap RMS [" << r.unit << "]   [" << du << "]   floor [" << du << "]   gap/floor   noise ratio\n";
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(r.gap_rms[a])) continue;
    os << "   " << (r.magnitude ? std::string("|f|") : std::string(1, "xyz"[a])) << (r.magnitude ? "    " : "      ")
       << f(r.gap_rms[a], "%-12.4g") << "      " << f(r.gap_rms[a] * k, "%-7.3f")
       << "  " << f(r.floor[a] * k, "%-9.4f") << "   " << f(r.gap_rms[a] / r.floor[a], "%-9.2f") << "   "
       << f(r.noise_ratio[a], "%.2f") << "\n";
  }
}

// 2. Where: the first four places of each dimension, share [%] and RMS [display unit].
void print_where(std::ostream& os, const GapReport& r) {
  os << "\n2. WHERE (share of the squared gap; top places)\n";
  for (const char* dim : {"axis", "orientation", "temperature", "time_since_change", "averaging_time"}) {
    os << "   " << dim << ":";
    int n = 0;
    for (const auto& p : r.where)
      if (p.dimension == dim && n < 4) {
        os << "  " << p.place << " " << f(100 * p.share, "%.0f") << "% (" << f(p.rms * r.display_per_unit, "%.3g")
           << " " << r.display_unit << ")";
        ++n;
      }
    os << (n == 0 ? "  none recorded\n" : "\n");  // a recording without temperature
  }
}

// One ranked vocabulary candidate: gain, ΔBIC, p, size with its interval, remarks and aliases.
void print_candidate(std::ostream& os, int rank, const CandidateResult& c) {
  char line[512];
  std::snprintf(line, sizeof line, "   %-4d  %-28s  %-4s  %12s   %-8s  %-9s  %s %s [%s, %s]%s\n", rank, c.term.c_str(),
                c.axis.c_str(), (f(100 * c.heldout_improvement, "%.1f") + " %").c_str(),
                f(c.delta_bic, "%.1f").c_str(), f(c.p_value, "%.2g").c_str(), f(c.size).c_str(),
                c.size_unit.c_str(), f(c.ci_lo).c_str(), f(c.ci_hi).c_str(), c.significant ? "  SIGNIFICANT" : "");
  os << line;
  if (!c.reason.empty()) os << "         " << c.reason << "\n";
  if (c.aliases.empty()) return;
  os << "         cannot be told apart here from:";
  for (const auto& a : c.aliases) os << " " << a << ";";
  os << "\n";
  if (!c.separate.empty()) os << "         separate by: " << c.separate.front() << "\n";
}

// One noise / output-stage candidate: verdict, reason and size (with its interval when not a point).
void print_noise_candidate(std::ostream& os, const CandidateResult& c) {
  os << "     " << c.term << (c.significant ? " [SUSPECT]" : "") << ": " << c.reason
     << (std::isfinite(c.size) ? " (" + c.size_param + " = " + f(c.size) +
                                     (std::isfinite(c.ci_lo) && c.ci_lo != c.ci_hi
                                          ? " [" + f(c.ci_lo) + ", " + f(c.ci_hi) + "]"
                                          : std::string()) +
                                     (c.size_unit == "1" ? std::string() : " " + c.size_unit) + ")"
                               : "")
     << "\n";
}

// 3. Which: the evaluated vocabulary candidates ranked, those not assessable, the noise stage.
void print_which(std::ostream& os, const GapReport& r) {
  os << "\n3. WHICH — candidates the model lacks, held out by " << to_string(r.fold_by) << " (" << r.folds << " folds)\n";
  if (!r.fold_reason.empty()) os << "   folds: " << r.fold_reason << "\n";
  os << "   rank  term                          axis  held-out gain  dBIC      p          size [unit] (95% CI)\n";
  int rank = 0;
  for (const auto& c : r.candidates)
    if (!c.noise_stage && c.evaluated) print_candidate(os, ++rank, c);
  os << "   not assessable with this experiment:";
  for (const auto& c : r.candidates)
    if (!c.evaluated && !c.noise_stage) os << " " << c.term << ";";
  os << "\n   noise / output stage:\n";
  for (const auto& c : r.candidates)
    if (c.noise_stage) print_noise_candidate(os, c);
}

// 4. How far: held-out, in-sample and floor RMS of every selection step [display unit].
void print_how_far(std::ostream& os, const GapReport& r) {
  const double k = r.display_per_unit;
  const std::string& du = r.display_unit;
  os << "\n4. HOW FAR — forward selection on the held-out gap\n";
  for (const auto& s : r.steps)
    os << "   step " << s.step << "  " << (s.added.empty() ? std::string("(model as given)") : "+ " + s.added)
       << ": held-out " << f(s.heldout_rms * k, "%.4f") << " " << du << ", in-sample " << f(s.in_sample_rms * k, "%.4f")
       << " " << du << ", floor " << f(s.floor_rms * k, "%.4f") << " " << du
       << (s.heldout_rows < s.rows
               ? " (held out on " + std::to_string(s.heldout_rows) + " of " + std::to_string(s.rows) +
                     " rows: the others are not determined by their training folds)"
               : std::string())
       << "\n";
  for (const auto& a : r.alias_resolution) os << "   aliases: " << a << "\n";
  if (r.placement.assessed) {
    os << "   placement (a rotation per face, in-sample): " << r.placement.reason << "\n     faces placed off by";
    for (const auto& [face, deg] : r.placement.face_deg) os << " " << face << " " << f(deg, "%.2f") << " deg;";
    os << "\n";
  }
  os << "\n   " << r.statement << "\n";
}

}  // namespace

std::string to_json(const GapReport& r, int indent) {
  json j;
  j["schema"] = kGapSchema;
  j["model"] = r.model_name;
  j["source"] = r.source;
  j["status"] = r.ok ? "ok" : "failed";
  j["message"] = r.message;
  // "axes": the three sensor axes; "magnitude": one |f| row per segment (slot 0 of every vector).
  j["form"] = r.magnitude ? "magnitude" : "axes";
  j["units"] = {{"gap", r.unit}, {"display", r.display_unit}, {"display_per_unit", r.display_per_unit}};
  j["noise_floor"] = {{"static_mean_mps2", vec3(r.floor)}, {"source", r.floor_source}};
  Eigen::Vector3d over;
  for (int a = 0; a < 3; ++a) over[a] = r.gap_rms[a] / r.floor[a];
  j["gap"] = {{"static_rms_mps2", vec3(r.gap_rms)}, {"static_rms_over_floor", vec3(over)},
              {"noise_ratio", vec3(r.noise_ratio)}};
  j["segments"] = segments_json(r);
  j["where"] = where_json(r);
  json cands = json::array();
  for (const auto& c : r.candidates) cands.push_back(candidate_json(c));
  j["candidates"] = cands;
  j["steps"] = steps_json(r);
  j["heldout"] = {{"fold_by", to_string(r.fold_by)},
                  {"folds", r.folds},
                  {"fold_reason", r.fold_reason},
                  {"rows_not_predicted", r.heldout_dropped}};
  j["alias_resolution"] = r.alias_resolution;
  {
    const PlacementResult& p = r.placement;
    json faces = json::array();
    for (const auto& [face, deg] : p.face_deg) faces.push_back({{"face", face}, {"deg", num(deg)}});
    j["placement"] = {{"assessed", p.assessed},        {"reason", p.reason},
                      {"faces", p.faces},              {"added_rank", p.added_rank},
                      {"dof", p.dof},                  {"p_value", num(p.p_value)},
                      {"delta_bic", num(p.delta_bic)}, {"across_share", num(p.across_share)},
                      {"rms_deg", num(p.rms_deg)},     {"max_deg", num(p.max_deg)},
                      {"max_face", p.max_face},        {"per_face", faces},
                      {"significant", p.significant},  {"consistent", p.consistent},
                      {"aliases", p.aliases}};
  }
  j["unexplained"] = {{"heldout_rms_mps2", num(r.unexplained_heldout_rms)},
                      {"over_floor", num(r.unexplained_over_floor)},
                      {"at_noise_floor", r.at_floor},
                      {"explanation", r.explanation.empty() ? json(nullptr) : json(r.explanation)},
                      {"statement", r.statement}};
  j["notes"] = r.notes;
  return j.dump(indent);
}

void print_report(std::ostream& os, const GapReport& r) {
  os << "stend gap — " << r.source << "\nmodel: " << r.model_name << "\n";
  if (!r.ok) {
    os << "GAP DIAGNOSIS FAILED: " << r.message << "\n";
    return;
  }
  print_gap(os, r);
  print_where(os, r);
  print_which(os, r);
  print_how_far(os, r);
  if (!r.notes.empty()) {
    os << "\nnotes:\n";
    for (const auto& n : r.notes) os << "   - " << n << "\n";
  }
}

}  // namespace stend::diagnosis
