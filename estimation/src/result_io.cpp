// Reading results documents back as typed results (see stend/estimation/result_io.hpp).
#include "stend/estimation/result_io.hpp"

#include "stend/estimation/model_spec.hpp"
#include "stend/sdk.hpp"  // kNaN

#include <nlohmann/json.hpp>

#include <map>

namespace stend::estimation {

using nlohmann::json;

namespace {

double number_or_nan(const json& j) { return j.is_number() ? j.get<double>() : kNaN; }

std::string string_of(const json& j, const char* key) {
  return j.is_object() && j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : std::string();
}

// The terms of a `model` section; the unknown kind's name when one is not the vocabulary's.
std::string read_terms(const json& section, model::ErrorModel& m) {
  for (const auto& t : section.value("terms", json::array())) {
    const std::string kind = string_of(t, "kind");
    const auto k = model::term_from_name(kind);
    if (!k) return kind;
    model::TermSpec s;
    s.kind = *k;
    if (t.contains("order") && t["order"].is_number_integer()) s.order = t["order"].get<int>();
    if (t.contains("reference_c") && t["reference_c"].is_number()) s.reference_c = t["reference_c"].get<double>();
    m.terms.push_back(s);
  }
  return {};
}

std::vector<int> read_axes(const json& section) {
  if (!section.contains("axes") || !section["axes"].is_array()) return {0, 1, 2};
  std::vector<int> axes;
  for (const auto& a : section["axes"])
    for (int k = 0; k < 3; ++k)
      if (a.is_string() && a.get<std::string>() == std::string(1, axis_name(k))) axes.push_back(k);
  return axes;
}

// θ and the parameters: the document's estimates by name, the model's other parameters held at 0.
void read_estimates(const json& doc, InstrumentModel& im) {
  const auto info = im.model.params();
  const FitSummary summary = summary_from_json(doc);
  im.confidence = summary.confidence;
  std::map<std::string, std::size_t> listed;  // name → position in the document's list
  for (std::size_t j = 0; j < summary.parameters.size(); ++j) listed[summary.parameters[j].name] = j;
  im.theta.assign(info.size(), 0.0);
  im.parameters.clear();
  for (std::size_t i = 0; i < info.size(); ++i) {
    const auto it = listed.find(info[i].name);
    if (it == listed.end()) {
      ParameterEstimate held;
      held.name = info[i].name;
      held.unit = info[i].unit;
      held.held = true;
      held.zero_is_exact = true;  // it affects no fitted axis: those it does are left uncalibrated
      held.value = held.std_error = held.lower = held.upper = 0.0;
      held.reason = "not in this fit";
      im.parameters.push_back(held);
      continue;
    }
    const ParameterEstimate& e = summary.parameters[it->second];
    im.theta[i] = e.identifiable ? e.value : kNaN;
    im.parameters.push_back(e);
  }
  // Covariance from the standard errors and the correlation over the document's list.
  const auto n = static_cast<Eigen::Index>(info.size());
  im.covariance = Eigen::MatrixXd::Zero(n, n);
  const json corr = doc.value("correlation", json::array());
  for (std::size_t a = 0; a < info.size(); ++a) {
    const auto ia = listed.find(info[a].name);
    if (ia == listed.end()) continue;
    for (std::size_t b = 0; b < info.size(); ++b) {
      const auto ib = listed.find(info[b].name);
      if (ib == listed.end()) continue;
      double c = a == b ? 1.0 : 0.0;
      if (corr.is_array() && ia->second < corr.size() && corr[ia->second].is_array() && ib->second < corr[ia->second].size())
        c = number_or_nan(corr[ia->second][ib->second]);
      const double v = c * im.parameters[a].std_error * im.parameters[b].std_error;
      im.covariance(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) = std::isfinite(v) ? v : 0.0;
    }
  }
}

// A failed model: every parameter without a number, the failure as the reason.
void fail_estimates(InstrumentModel& im) {
  im.theta.assign(static_cast<std::size_t>(im.model.size()), kNaN);
  im.parameters.clear();
  for (const auto& info : im.model.params()) {
    ParameterEstimate p;
    p.name = info.name;
    p.unit = info.unit;
    p.reason = im.message.empty() ? "the fit failed" : im.message;
    im.parameters.push_back(p);
  }
}

}  // namespace

std::optional<InstrumentModel> read_fit_model(const json& doc) {
  if (!doc.is_object() || !doc.contains("model") || !doc["model"].is_object()) return std::nullopt;
  const json& section = doc["model"];
  const auto instrument = instrument_from_name(string_of(section, "instrument"));
  if (!instrument) return std::nullopt;
  InstrumentModel im;
  im.model.instrument = *instrument;
  im.status = status_of(doc);
  im.message = string_of(doc, "message");
  im.coverage = Coverage::kAxes;
  im.axes = read_axes(section);
  if (const std::string unknown = read_terms(section, im.model); !unknown.empty()) {
    im.status = FitStatus::kFailed;
    im.message = "unknown error-model term '" + unknown + "' in the document's model";
  }
  for (const auto& t : im.model.terms)
    if (model::is_temperature_polynomial(t.kind)) {
      im.reference_c = t.reference_c;
      break;
    }
  if (im.ok())
    read_estimates(doc, im);
  else
    fail_estimates(im);
  return im;
}

void set_instrument(FitResult& r, InstrumentModel m) {
  (m.instrument() == model::Instrument::kAccelerometer ? r.accelerometer : r.gyroscope) = std::move(m);
}

FitResult read_fit_document(const json& doc) {
  FitResult r;
  r.summary = summary_from_json(doc);
  if (auto m = read_fit_model(doc)) set_instrument(r, std::move(*m));
  r.document = doc;
  return r;
}

FitResult not_applicable_fit(const std::string& estimator, const std::string& version, InstrumentModel model) {
  FitResult r = failed_fit(estimator, version, model.message);
  r.summary.status = FitStatus::kNotApplicable;
  r.document = to_json(r.summary);
  set_instrument(r, std::move(model));
  return r;
}

FitResult failed_fit(const std::string& estimator, const std::string& version, const std::string& message) {
  FitResult r;
  r.summary.estimator = estimator;
  r.summary.version = version;
  r.summary.status = FitStatus::kFailed;
  r.summary.message = message;
  r.document = to_json(r.summary);
  return r;
}

}  // namespace stend::estimation
