// The typed estimator result (see stend/estimation/summary.hpp).
#include "stend/estimation/summary.hpp"

#include "stend/estimation/report_section.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <ostream>
#include <sstream>

namespace stend::estimation {

using nlohmann::json;

namespace {

double number_or_nan(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return NAN;
  return j[key].get<double>();
}
std::string string_or_empty(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_string()) return {};
  return j[key].get<std::string>();
}
json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

double confidence_of(const json& doc) {
  const double c = number_or_nan(doc.value("solution", json::object()), "confidence");
  return std::isfinite(c) ? c : number_or_nan(doc, "confidence");
}

std::optional<int> dof_of(const json& doc) {
  for (const json& j : {doc.value("solution", json::object()), doc})
    if (j.is_object() && j.contains("dof") && j["dof"].is_number_integer()) return j["dof"].get<int>();
  return std::nullopt;
}

ParameterEstimate parameter_from_json(const json& p) {
  ParameterEstimate e;
  e.name = string_or_empty(p, "name");
  e.unit = string_or_empty(p, "unit");
  e.identifiable = p.value("identifiable", false);
  e.reason = string_or_empty(p, "reason");
  e.tolerance = number_or_nan(p, "tolerance");
  if (!e.identifiable) {
    if (e.reason.empty()) e.reason = "not identifiable";
    return e;  // never a default as a result
  }
  e.value = number_or_nan(p, "value");
  e.std_error = number_or_nan(p, "std_error");
  // Documents written before verdicts: identified is determined.
  e.verdict = string_or_empty(p, "verdict") == to_string(Verdict::kImprecise) ? Verdict::kImprecise
                                                                              : Verdict::kDetermined;
  const json iv = p.value("interval", json::array());
  if (iv.is_array() && iv.size() == 2 && iv[0].is_number() && iv[1].is_number()) {
    e.lower = iv[0].get<double>();
    e.upper = iv[1].get<double>();
  }
  return e;
}

}  // namespace

bool nearly_equal(double a, double b, double rel_tol, double abs_tol) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::abs(a - b) <= abs_tol + rel_tol * std::max(std::abs(a), std::abs(b));
}

std::string number_text(double v, int digits, bool fixed) {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  if (fixed)
    std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  else
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

namespace {

// The one name table of FitStatus: its name in documents, and how a report says it.
struct StatusNames {
  FitStatus status;
  const char* name;
  const char* text;
};
constexpr StatusNames kStatusNames[] = {{FitStatus::kOk, "ok", "ok"},
                                        {FitStatus::kFailed, "failed", "FAILED"},
                                        {FitStatus::kNotApplicable, "not_applicable", "not applicable"}};

const StatusNames& names_of(FitStatus s) {
  for (const auto& n : kStatusNames)
    if (n.status == s) return n;
  return kStatusNames[1];
}

}  // namespace

const char* to_string(FitStatus s) { return names_of(s).name; }

const char* status_text(FitStatus s) { return names_of(s).text; }

FitStatus fit_status_from_string(const std::string& s) {
  for (const auto& n : kStatusNames)
    if (s == n.name) return n.status;
  return FitStatus::kFailed;
}

FitStatus combined_status(const std::vector<FitStatus>& parts) {
  const auto any = [&parts](FitStatus s) { return std::find(parts.begin(), parts.end(), s) != parts.end(); };
  if (any(FitStatus::kFailed)) return FitStatus::kFailed;
  return any(FitStatus::kOk) ? FitStatus::kOk : FitStatus::kNotApplicable;
}

// One row in the parameter's display unit (display_unit: mg, deg/s, ppm, …), as the report's table;
// the JSON document keeps SI with its unit string.
void ParameterEstimate::print(std::ostream& os) const {
  const DisplayUnit du = display_unit(unit);
  if (identifiable)
    os << fmt::format("{:<18} {:>14.7g} {:<14} {:>11.3g}  [{:.7g}, {:.7g}]  {}{}", name, value * du.scale, du.unit,
                      std_error * du.scale, lower * du.scale, upper * du.scale, to_string(judged()),
                      judged() == Verdict::kImprecise ? ": " + reason : "");
  else
    os << fmt::format("{:<18} {:>14} {:<14} {:>11}  {:<26}  NO: {}", name, "not estimated", du.unit, "-", "-", reason);
}

std::ostream& operator<<(std::ostream& os, const ParameterEstimate& p) {
  p.print(os);
  return os;
}

void print_parameter_header(std::ostream& os, double confidence) {
  os << fmt::format("{:<18} {:>14} {:<14} {:>11}  {:<26}  {}\n", "parameter", "value", "unit", "std error",
                    fmt::format("{:.6g}% interval", 100 * confidence), "verdict");
}

bool ParameterEstimate::equals(const ParameterEstimate& o, double rel_tol, double abs_tol) const {
  return name == o.name && unit == o.unit && identifiable == o.identifiable && held == o.held && judged() == o.judged() &&
         nearly_equal(value, o.value, rel_tol, abs_tol) && nearly_equal(std_error, o.std_error, rel_tol, abs_tol) &&
         nearly_equal(lower, o.lower, rel_tol, abs_tol) && nearly_equal(upper, o.upper, rel_tol, abs_tol);
}

const ParameterEstimate* FitSummary::find(const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name) return &p;
  return nullptr;
}

std::string FitSummary::BriefReport() const {
  const std::string who = version.empty() ? estimator : estimator + " " + version;
  if (!ok()) return fmt::format("{}: {} — {}", who, status_text(status), message.empty() ? "no reason given" : message);
  const auto identified = std::count_if(parameters.begin(), parameters.end(),
                                        [](const ParameterEstimate& p) { return p.identifiable; });
  const auto imprecise = std::count_if(parameters.begin(), parameters.end(),
                                       [](const ParameterEstimate& p) { return p.judged() == Verdict::kImprecise; });
  return fmt::format("{}: ok — {} parameters, {} identified{}{}", who, parameters.size(), identified,
                     imprecise > 0 ? fmt::format(" ({} imprecise)", imprecise) : "",
                     dof ? fmt::format(", {} dof", *dof) : "");
}

std::string FitSummary::FullReport() const {
  std::ostringstream os;
  print(os);
  return os.str();
}

void FitSummary::print(std::ostream& os) const {
  os << BriefReport() << "\n";
  if (!ok()) return;
  print_parameter_header(os, confidence);
  for (const auto& p : parameters) os << p << "\n";
  for (const auto& n : notes) os << "note: " << n << "\n";
}

bool FitSummary::equals(const FitSummary& o, double rel_tol, double abs_tol) const {
  if (estimator != o.estimator || version != o.version || status != o.status || message != o.message ||
      !nearly_equal(confidence, o.confidence, rel_tol, abs_tol) || parameters.size() != o.parameters.size() ||
      notes != o.notes || dof != o.dof)
    return false;
  for (std::size_t i = 0; i < parameters.size(); ++i)
    if (!parameters[i].equals(o.parameters[i], rel_tol, abs_tol)) return false;
  return true;
}

std::string degrees_of_freedom_note(int dof) {
  if (dof <= 0)
    return fmt::format("{} degrees of freedom: no more observations than estimated parameters, so the residual is "
                       "zero by construction and is no check of the fit; the intervals rest on the a-priori sigmas "
                       "alone",
                       dof);
  if (dof < kFewDegreesOfFreedom)
    return fmt::format("few degrees of freedom: {} (fewer than {}): the residual scatter rests on {} number{}, so the "
                       "intervals are wide (Student t) and the residual is no measure of accuracy",
                       dof, kFewDegreesOfFreedom, dof, dof == 1 ? "" : "s");
  return {};
}

void state_degrees_of_freedom(FitSummary& s, std::optional<int> dof) {
  s.dof = dof;
  if (!dof) return;
  const std::string note = degrees_of_freedom_note(*dof);
  if (!note.empty() && std::find(s.notes.begin(), s.notes.end(), note) == s.notes.end()) s.notes.push_back(note);
}

FitStatus status_of(const json& doc) {
  if (doc.contains("status") && doc["status"].is_string()) return fit_status_from_string(doc["status"]);
  return doc.value("ok", false) ? FitStatus::kOk : FitStatus::kFailed;
}

json to_json(const FitSummary& s) {
  json j;
  j["estimator"] = {{"name", s.estimator}, {"version", s.version}};
  j["status"] = to_string(s.status);
  j["message"] = s.message;
  j["confidence"] = finite_or_null(s.confidence);
  j["parameters"] = json::array();
  for (const auto& p : s.parameters)
    j["parameters"].push_back({{"name", p.name},
                               {"unit", p.unit},
                               {"identifiable", p.identifiable},
                               {"verdict", to_string(p.judged())},
                               {"tolerance", finite_or_null(p.tolerance)},
                               {"value", finite_or_null(p.value)},
                               {"std_error", finite_or_null(p.std_error)},
                               {"interval", {finite_or_null(p.lower), finite_or_null(p.upper)}},
                               {"reason", p.reason}});
  j["notes"] = s.notes;
  j["dof"] = s.dof ? json(*s.dof) : json(nullptr);
  return j;
}

FitSummary summary_from_json(const json& doc) {
  FitSummary s;
  if (doc.contains("estimator") && doc["estimator"].is_string()) s.estimator = doc["estimator"];
  if (doc.contains("estimator") && doc["estimator"].is_object()) {
    s.estimator = string_or_empty(doc["estimator"], "name");
    s.version = string_or_empty(doc["estimator"], "version");
  }
  s.status = status_of(doc);
  s.message = string_or_empty(doc, "message");
  s.confidence = confidence_of(doc);
  for (const auto& n : doc.value("notes", json::array()))
    if (n.is_string()) s.notes.push_back(n);
  if (!s.ok()) return s;
  state_degrees_of_freedom(s, dof_of(doc));
  for (const auto& p : doc.value("parameters", json::array())) s.parameters.push_back(parameter_from_json(p));
  return s;
}

}  // namespace stend::estimation
