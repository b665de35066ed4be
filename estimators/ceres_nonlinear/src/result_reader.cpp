// ceres.json (schema stend.ceres_nonlinear.results/1) read back as the typed result; the writer is
// result_writer.cpp. See stend/ceres_nonlinear/estimator.hpp.
#include "stend/ceres_nonlinear/estimator.hpp"

#include "stend/ceres_nonlinear/calibration.hpp"
#include "stend/estimation/result_io.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <map>

namespace stend::ceres_nonlinear {

namespace {

using nlohmann::json;

// Whether a held parameter's 0 is exact ("zero_is_exact"; documents written before that key: the
// frame convention's reason).
bool zero_is_exact(const json& p) {
  if (p.contains("zero_is_exact")) return p.value("zero_is_exact", false);
  return p.value("reason", "").find("frame convention") != std::string::npos;
}

// The parameters of a part's list ("parameters" or "gyro_parameters"): the summary fields (the
// interval under "ci95"), a parameter held at 0 by construction ("fixed") marked held.
std::vector<estimation::ParameterEstimate> part_parameters(const json& list) {
  json doc = {{"status", "ok"}, {"parameters", json::array()}};
  for (json p : list) {
    if (p.contains("ci95") && !p.contains("interval")) p["interval"] = p["ci95"];
    doc["parameters"].push_back(std::move(p));
  }
  std::vector<estimation::ParameterEstimate> out = estimation::summary_from_json(doc).parameters;
  for (std::size_t i = 0; i < out.size(); ++i)
    if (list[i].value("fixed", false)) {
      out[i].held = true;
      out[i].zero_is_exact = zero_is_exact(list[i]);
      out[i].value = out[i].std_error = out[i].lower = out[i].upper = 0.0;
    }
  return out;
}

using HeldGroups = std::vector<std::pair<std::string, std::vector<std::string>>>;

// `name` under its reason, the groups in the order their reasons first come.
void add_held(HeldGroups& groups, const std::string& reason, const std::string& name) {
  for (auto& [r, names] : groups)
    if (r == reason) {
      names.push_back(name);
      return;
    }
  groups.push_back({reason, {name}});
}

// The note for the parameters held for one reason: the frame convention of the unknown-orientation
// fit (its fixed_cross_axis), or the reason the procedure gave (e.g. earth_rate's axes never
// vertical).
std::string held_note(const std::string& reason, const std::vector<std::string>& names) {
  if (reason.empty() || reason.find("frame convention") != std::string::npos)
    return fmt::format("held at 0 by the Ceres fit's frame convention (its fixed_cross_axis): {}", fmt::join(names, ", "));
  return fmt::format("held by the Ceres fit: {} — {}", fmt::join(names, ", "), reason);
}

// One instrument's model of the three axes: θ from the part's parameters by name (held ones 0,
// unidentified NaN), the covariance from their standard errors (the document keeps no
// correlations), the frame convention's held parameters named in a note. `prefix` is the
// parameters' prefix in the document's flat list ("accel_", "gyro_").
estimation::InstrumentModel part_model(model::ErrorModel m, bool ok, const std::string& message,
                                       const std::vector<estimation::ParameterEstimate>& fitted, const std::string& prefix,
                                       double confidence) {
  estimation::InstrumentModel im;
  im.model = std::move(m);
  im.status = ok ? estimation::FitStatus::kOk : estimation::FitStatus::kFailed;
  im.message = message;
  im.coverage = estimation::Coverage::kTriad;
  im.confidence = confidence;
  std::map<std::string, const estimation::ParameterEstimate*> by_name;
  for (const auto& p : fitted) by_name[p.name] = &p;
  const auto info = im.model.params();
  const auto n = static_cast<Eigen::Index>(info.size());
  im.covariance = Eigen::MatrixXd::Zero(n, n);
  std::vector<std::pair<std::string, std::vector<std::string>>> held;  // by reason, in order
  for (std::size_t i = 0; i < info.size(); ++i) {
    estimation::ParameterEstimate p;
    p.name = info[i].name;
    p.unit = info[i].unit;
    p.reason = "not reported by the fit";
    if (const auto it = by_name.find(info[i].name); it != by_name.end()) p = *it->second;
    im.theta.push_back(p.held ? 0.0 : p.identifiable ? p.value : kNaN);
    if (p.identifiable && std::isfinite(p.std_error))
      im.covariance(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)) = p.std_error * p.std_error;
    if (p.held) add_held(held, p.reason, prefix + p.name);
    im.parameters.push_back(std::move(p));
  }
  if (ok)
    for (const auto& [reason, names] : held) im.notes.push_back(held_note(reason, names));
  return im;
}

bool names_g_sensitivity(const std::vector<estimation::ParameterEstimate>& ps) {
  for (const auto& p : ps)
    if (p.name.rfind("gsens", 0) == 0) return true;
  return false;
}

// The gyro bias an accelerometer fit estimated (gyroscope: bias_only), as a bias-only model.
estimation::InstrumentModel gyro_bias_model(const json& accel, double confidence) {
  std::vector<estimation::ParameterEstimate> ps = part_parameters(accel.value("gyro_parameters", json::array()));
  for (auto& p : ps)
    if (p.name.rfind("gyro_", 0) == 0) p.name = p.name.substr(5);  // gyro_bias_x → the vocabulary's bias_x
  model::ErrorModel m;
  m.instrument = model::Instrument::kGyroscope;
  m.terms = {{model::TermKind::kBias}};
  return part_model(m, true, {}, ps, "gyro_", confidence);
}

double number_or_nan(const json& j) { return j.is_number() ? j.get<double>() : kNaN; }

// A part of the document ("accelerometer", "gyroscope") as its instrument's model `m`: not
// applicable when it says so (its instrument absent from the recording), else fitted or failed as
// its status (or, in older documents, its "ok") says.
estimation::InstrumentModel part_of(const json& part, model::ErrorModel m,
                                    const std::vector<estimation::ParameterEstimate>& fitted,
                                    const std::string& prefix, double confidence) {
  const estimation::FitStatus status = estimation::status_of(part);
  const std::string message = part.value("message", "");
  if (status == estimation::FitStatus::kNotApplicable) return estimation::not_applicable(std::move(m), message);
  return part_model(std::move(m), status == estimation::FitStatus::kOk, message, fitted, prefix, confidence);
}

}  // namespace

estimation::FitResult read_results(const json& doc) {
  estimation::FitResult r;
  r.summary = estimation::summary_from_json(doc);
  const double confidence = r.summary.confidence;
  if (doc.contains("accelerometer") && doc["accelerometer"].is_object()) {
    const json& a = doc["accelerometer"];
    estimation::InstrumentModel m =
        part_of(a, accelerometer_model(), part_parameters(a.value("parameters", json::array())), "accel_", confidence);
    m.gravity_mps2 = number_or_nan(a.value("gravity_mps2", json()));
    const bool bias_only = m.ok() && !doc.contains("gyroscope") && !a.value("gyro_parameters", json::array()).empty();
    r.accelerometer = std::move(m);
    if (bias_only) r.gyroscope = gyro_bias_model(a, confidence);
  }
  if (doc.contains("gyroscope") && doc["gyroscope"].is_object()) {
    const json& g = doc["gyroscope"];
    const auto ps = part_parameters(g.value("parameters", json::array()));
    r.gyroscope = part_of(g, gyroscope_model(names_g_sensitivity(ps)), ps, "gyro_", confidence);
    const std::string method = g.value("method", "");
    if (r.gyroscope->ok() && (method == method_name(Method::kTurns) || method == method_name(Method::kEarthRate)) && !g.value("uncertainty", "").empty())
      r.gyroscope->notes.push_back("uncertainty (" + method + "): " + g.value("uncertainty", ""));
  }
  r.document = doc;
  r.results_file = kResultsFile;
  return r;
}

}  // namespace stend::ceres_nonlinear
