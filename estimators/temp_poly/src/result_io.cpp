// temp_poly's results document (schema "stend.temp_poly/1", README.md): its one writer and its
// reader back into the typed result. See stend/temp_poly/temp_poly.hpp and estimator.hpp.
#include "stend/temp_poly/estimator.hpp"
#include "stend/temp_poly/temp_poly.hpp"

#include "stend/estimation/result_io.hpp"

#include <nlohmann/json.hpp>

#include <optional>

#include <cmath>

namespace stend::temp_poly {

namespace {

using nlohmann::json;

json num_or_null(double v) { return std::isfinite(v) ? json(v) : json(); }

// "options": the settings the fit ran with.
json options_json(const TempPolyOptions& o) {
  json axes = json::array();
  for (int a : o.axes) axes.push_back(std::string(1, estimation::axis_name(a)));
  return {{"instrument", estimation::instrument_name(o.instrument)},
          {"axes", axes},
          {"selection", o.selection},
          {"max_order", o.max_order},
          {"order", o.order},
          {"reference_c", o.reference_c},
          {"min_span_c", o.min_span_c},
          {"level_tolerance_c", o.level_tolerance_c},
          {"scale", o.scale},
          {"bias_temperature", o.bias_temperature},
          {"scale_temperature", o.scale_temperature},
          {"cross_axis", o.cross_axis},
          {"confidence", o.confidence}};
}

// "levels": each temperature level [°C] with its point counts per leg.
json levels_json(const std::vector<TemperatureLevel>& levels) {
  json out = json::array();
  for (const auto& L : levels)
    out.push_back({{"temperature_c", L.temperature_c},
                   {"min_c", L.min_c},
                   {"max_c", L.max_c},
                   {"points", L.points},
                   {"heating_points", L.heating_points},
                   {"cooling_points", L.cooling_points},
                   {"unknown_points", L.unknown_points}});
  return out;
}

// "points": each static point's label, temperature [°C], level and leg.
json points_json(const TempPolyResult& r) {
  json pts = json::array();
  for (std::size_t i = 0; i < r.points.size(); ++i)
    pts.push_back({{"label", processing::label(r.points[i].segment)},
                   {"temperature_c", r.points[i].stimulus.temperature_c},
                   {"level", i < r.level_of.size() ? r.level_of[i] : -1},
                   {"leg", i < r.legs.size() ? leg_name(r.legs[i]) : "unknown"}});
  return pts;
}

// The candidate orders' scores (RSS, BIC, CV error) of an axis.
json scores_json(const std::vector<OrderScore>& scores) {
  json out = json::array();
  for (const auto& s : scores)
    out.push_back({{"order", s.order},
                   {"ok", s.ok},
                   {"observations", s.observations},
                   {"rank", s.parameters},
                   {"rss", num_or_null(s.rss)},
                   {"bic", num_or_null(s.bic)},
                   {"cv_ok", s.cv_ok},
                   {"cv_mse", num_or_null(s.cv_mse)},
                   {"note", s.note}});
  return out;
}

// The cooling-minus-heating hysteresis per level of an axis.
json hysteresis_json(const std::vector<Hysteresis>& hysteresis) {
  json out = json::array();
  for (const auto& h : hysteresis)
    out.push_back({{"temperature_c", h.temperature_c},
                   {"heating_points", h.heating_points},
                   {"cooling_points", h.cooling_points},
                   {"value", num_or_null(h.value)},
                   {"std_error", num_or_null(h.std_error)},
                   {"lower", num_or_null(h.lower)},
                   {"upper", num_or_null(h.upper)},
                   {"significant", h.significant}});
  return out;
}

// One axis: status, chosen order, scores, hysteresis and the chosen fit's own document.
json axis_json(const AxisResult& ax) {
  json a;
  a["axis"] = std::string(1, estimation::axis_name(ax.axis));
  a["ok"] = ax.ok();
  a["message"] = ax.message;
  a["chosen_order"] = ax.chosen_order;
  a["scores"] = scores_json(ax.scores);
  a["hysteresis"] = hysteresis_json(ax.hysteresis);
  a["max_abs_hysteresis"] = num_or_null(ax.max_abs_hysteresis);
  a["fit"] = ax.ok() ? json::parse(batch_lsq::to_json(ax.fit, -1)) : json();
  return a;
}

}  // namespace

std::string to_json(const TempPolyResult& r, int indent) {
  json j;
  j["schema"] = kSchema;
  j["estimator"] = {{"name", kEstimatorName}, {"version", kEstimatorVersion}};
  j["status"] = r.ok() ? "ok" : "failed";
  j["message"] = r.message;
  j["recording"] = {{"dir", r.recording_dir}, {"experiment", r.experiment_name}};
  j["options"] = options_json(r.options);
  j["unit"] = r.unit;
  j["reference_c"] = r.reference_c;
  j["valid_range_c"] = {num_or_null(r.valid_min_c), num_or_null(r.valid_max_c)};
  j["levels"] = levels_json(r.levels);
  j["points"] = points_json(r);
  json axes = json::array();
  for (const auto& ax : r.axes) axes.push_back(axis_json(ax));
  j["axes"] = axes;
  j["notes"] = r.notes;
  return j.dump(indent);
}

namespace {

// The summary: the document's status and message, every fitted axis's parameters together.
estimation::FitSummary summary_of(const json& doc) {
  estimation::FitSummary s = estimation::summary_from_json(doc);
  s.parameters.clear();
  if (!s.ok()) return s;
  std::optional<int> dof;  // the fewest of the axes' fits
  for (const auto& axis : doc.value("axes", json::array())) {
    if (!axis.contains("fit") || !axis["fit"].is_object()) continue;
    const estimation::FitSummary a = estimation::summary_from_json(axis["fit"]);
    if (!a.ok()) continue;
    if (!std::isfinite(s.confidence)) s.confidence = a.confidence;
    s.parameters.insert(s.parameters.end(), a.parameters.begin(), a.parameters.end());
    if (a.dof && (!dof || *a.dof < *dof)) dof = a.dof;
  }
  estimation::state_degrees_of_freedom(s, dof);
  return s;
}

int axis_index(const json& axis) {
  const std::string a = axis.value("axis", std::string());
  for (int k = 0; k < 3; ++k)
    if (a == std::string(1, estimation::axis_name(k))) return k;
  return -1;
}

double number_or_nan(const json& j) { return j.is_number() ? j.get<double>() : kNaN; }

// The axes' models merged into one of the instrument: the terms of the highest order any axis
// chose; each parameter from the fit of its axis, the ones no axis fitted (a lower order chosen,
// the axis failed) held at 0.
void merge_axes(const std::vector<estimation::InstrumentModel>& fits, estimation::InstrumentModel& m) {
  const estimation::InstrumentModel* widest = &fits.front();
  for (const auto& f : fits)
    if (f.model.size() > widest->model.size()) widest = &f;
  m.model = widest->model;
  m.confidence = widest->confidence;
  const auto info = m.model.params();
  const auto n = static_cast<Eigen::Index>(info.size());
  m.theta.assign(info.size(), 0.0);
  m.covariance = Eigen::MatrixXd::Zero(n, n);
  std::vector<std::pair<const estimation::InstrumentModel*, std::size_t>> source(info.size(), {nullptr, 0});
  for (std::size_t i = 0; i < info.size(); ++i) {
    estimation::ParameterEstimate p;
    p.name = info[i].name;
    p.unit = info[i].unit;
    p.held = true;
    p.zero_is_exact = true;  // the selection's order, or an axis left uncalibrated
    p.value = p.std_error = p.lower = p.upper = 0.0;
    p.reason = "not in the model its axis chose (a lower temperature order, or the axis not fitted)";
    for (const auto& f : fits)
      for (std::size_t j = 0; j < f.parameters.size(); ++j)
        if (f.parameters[j].name == p.name && !f.parameters[j].held) {
          p = f.parameters[j];
          m.theta[i] = f.theta[j];
          source[i] = {&f, j};
        }
    m.parameters.push_back(p);
  }
  for (std::size_t a = 0; a < info.size(); ++a)
    for (std::size_t b = 0; b < info.size(); ++b)
      if (source[a].first != nullptr && source[a].first == source[b].first)
        m.covariance(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) =
            source[a].first->covariance(static_cast<Eigen::Index>(source[a].second), static_cast<Eigen::Index>(source[b].second));
}

// The instrument's model: the axes' fits (each a stend.fit/1 document) merged, the failed axes
// named; the temperature reference and the range the fit saw. nullopt when the document names no
// instrument (neither in its options nor in an axis's fit).
std::optional<estimation::InstrumentModel> model_of(const json& doc) {
  std::vector<estimation::InstrumentModel> fits;
  estimation::InstrumentModel m;
  m.coverage = estimation::Coverage::kAxes;
  m.axes.clear();
  std::string instrument = doc.value("options", json::object()).value("instrument", std::string());
  for (const auto& ax : doc.value("axes", json::array())) {
    const int k = axis_index(ax);
    std::optional<estimation::InstrumentModel> f;
    if (ax.value("ok", false) && ax.contains("fit") && ax["fit"].is_object()) f = estimation::read_fit_model(ax["fit"]);
    if (!f || !f->ok()) {
      m.failed_axes.push_back({k, ax.value("message", std::string())});
      continue;
    }
    instrument = estimation::instrument_name(f->instrument());
    m.axes.push_back(k);
    fits.push_back(std::move(*f));
  }
  if (instrument == estimation::instrument_name(model::Instrument::kGyroscope))
    m.model.instrument = model::Instrument::kGyroscope;
  else if (instrument != estimation::instrument_name(model::Instrument::kAccelerometer))
    return std::nullopt;
  m.reference_c = number_or_nan(doc.value("reference_c", json()));
  const json range = doc.value("valid_range_c", json::array());
  if (range.is_array() && range.size() == 2) {
    m.min_temperature_c = number_or_nan(range[0]);
    m.max_temperature_c = number_or_nan(range[1]);
  }
  if (fits.empty()) {
    m.status = estimation::FitStatus::kFailed;
    m.message = doc.value("message", std::string());
    if (m.message.empty()) m.message = "no axis of this temperature fit succeeded";
    return m;
  }
  m.status = estimation::FitStatus::kOk;
  merge_axes(fits, m);
  return m;
}

}  // namespace

estimation::FitResult read_results(const json& doc) {
  estimation::FitResult r;
  r.summary = summary_of(doc);
  if (auto m = model_of(doc)) estimation::set_instrument(r, std::move(*m));
  r.document = doc;
  r.results_file = kResultsFile;
  return r;
}

}  // namespace stend::temp_poly
