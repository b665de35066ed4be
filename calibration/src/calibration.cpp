// A fitted calibration read back and applied. See stend/calibration/calibration.hpp.
#include "stend/calibration/calibration.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <ostream>
#include <set>
#include <stdexcept>

namespace stend::calibration {

using nlohmann::json;

namespace {

// A part of a results document: which instrument, its parameters as fitted (names without the
// document's prefix), the temperature polynomials' reference.
struct Part {
  model::Instrument instrument = model::Instrument::kAccelerometer;
  std::vector<estimation::ParameterEstimate> parameters;
  double reference_c = 25.0;
};

[[noreturn]] void refuse(const std::string& source, const std::string& why) {
  throw std::runtime_error(source + ": " + why);
}

model::Instrument instrument_named(const std::string& name, const std::string& source) {
  if (name == "accelerometer") return model::Instrument::kAccelerometer;
  if (name == "gyroscope") return model::Instrument::kGyroscope;
  refuse(source, "unknown instrument '" + name + "' (expected accelerometer or gyroscope)");
}

// The reference temperature of the document's temperature polynomials (stend.fit/1 `model.terms`).
double fit_reference_c(const json& fit) {
  for (const auto& t : fit.value("model", json::object()).value("terms", json::array()))
    if (t.contains("reference_c") && t["reference_c"].is_number()) return t["reference_c"].get<double>();
  return 25.0;
}

// A "stend.fit/1" document (batch_lsq, one axis of temp_poly).
Part fit_part(const json& fit, const std::string& source) {
  Part p;
  p.instrument = instrument_named(fit.value("model", json::object()).value("instrument", ""), source);
  p.parameters = estimation::summary_from_json(fit).parameters;
  p.reference_c = fit_reference_c(fit);
  return p;
}

// A Ceres part (`accelerometer` / `gyroscope`): its parameters, fixed ones included (held at 0).
Part ceres_part(const json& part, model::Instrument inst) {
  Part p;
  p.instrument = inst;
  json doc = part;
  doc["status"] = part.value("ok", false) ? "ok" : "failed";
  p.parameters = estimation::summary_from_json(doc).parameters;
  return p;
}

// The Ceres accelerometer part's gyro bias (gyroscope: bias_only), renamed to the vocabulary's bias_*.
Part ceres_gyro_bias(const json& accel) {
  Part p;
  p.instrument = model::Instrument::kGyroscope;
  for (const auto& prm : accel.value("gyro_parameters", json::array())) {
    json one = {{"status", "ok"}, {"parameters", json::array({prm})}};
    auto e = estimation::summary_from_json(one).parameters.at(0);
    if (e.name.rfind("gyro_", 0) == 0) e.name = e.name.substr(5);
    p.parameters.push_back(e);
  }
  return p;
}

// θ for the part: each parameter of the model named like a fitted one takes its value; the ones
// the fit did not identify are 0 and noted.
InstrumentCalibration build(const Part& part, std::vector<std::string>& notes) {
  InstrumentCalibration ic;
  std::vector<std::string> names;
  for (const auto& e : part.parameters) names.push_back(e.name);
  ic.model = model_from_names(part.instrument, names, part.reference_c);
  ic.parameters = part.parameters;
  const auto info = ic.model.params();
  ic.theta.assign(info.size(), 0.0);
  std::vector<std::string> zero;
  for (std::size_t i = 0; i < info.size(); ++i) {
    const auto* e = ic.find(info[i].name);
    if (e && e->identifiable && std::isfinite(e->value)) ic.theta[i] = e->value;
    else if (e && e->reason.rfind("held at 0", 0) != 0) zero.push_back(info[i].name);
  }
  if (!zero.empty()) {
    std::string list;
    for (const auto& z : zero) list += (list.empty() ? "" : ", ") + z;
    notes.push_back(fmt::format("{}: not identified by the fit, applied as 0: {}",
                                estimation::instrument_name(part.instrument), list));
  }
  return ic;
}

// temp_poly: every axis's fit merged into one part (the axes' parameters are disjoint).
Part temp_poly_part(const json& doc, const std::string& source, std::vector<std::string>& notes) {
  Part p;
  bool any = false;
  for (const auto& ax : doc.value("axes", json::array())) {
    if (!ax.value("ok", false) || !ax.contains("fit") || !ax["fit"].is_object()) {
      notes.push_back("axis " + ax.value("axis", std::string("?")) + ": the fit failed, left uncalibrated");
      continue;
    }
    const Part a = fit_part(ax["fit"], source);
    p.instrument = a.instrument;
    p.parameters.insert(p.parameters.end(), a.parameters.begin(), a.parameters.end());
    any = true;
  }
  if (!any) refuse(source, "no axis of this temp_poly fit succeeded: nothing to apply");
  if (doc.contains("reference_c") && doc["reference_c"].is_number()) p.reference_c = doc["reference_c"].get<double>();
  return p;
}

void set_part(Calibration& c, const Part& part) {
  InstrumentCalibration ic = build(part, c.notes);
  (part.instrument == model::Instrument::kAccelerometer ? c.accel : c.gyro) = std::move(ic);
}

double number_or_nan(const json& j) { return j.is_number() ? j.get<double>() : std::nan(""); }

}  // namespace

const estimation::ParameterEstimate* InstrumentCalibration::find(const std::string& name) const {
  for (const auto& e : parameters)
    if (e.name == name) return &e;
  return nullptr;
}

double InstrumentCalibration::std_error(const std::string& name) const {
  const auto* e = find(name);
  return e && std::isfinite(e->std_error) ? e->std_error : 0.0;
}

bool Calibration::needs_temperature() const {
  for (const auto* ic : {&accel, &gyro})
    for (const auto& t : ic->model.terms)
      if (model::is_temperature_polynomial(t.kind) || t.kind == model::TermKind::kThermalLag) return true;
  return false;
}

void Calibration::print(std::ostream& os) const {
  os << estimator << " calibration from " << source << ":";
  bool first = true;
  for (const auto* ic : {&accel, &gyro}) {
    if (!ic->present()) continue;
    os << (first ? " " : "; ");
    ic->model.print(os);
    first = false;
  }
  os << "\n";
  for (const auto& n : notes) os << "note: " << n << "\n";
}

model::ErrorModel model_from_names(model::Instrument instrument, const std::vector<std::string>& names,
                                   double reference_c) {
  const std::set<std::string> have(names.begin(), names.end());
  model::ErrorModel m;
  m.instrument = instrument;
  for (model::TermKind k : model::kAllTermKinds) {
    if (k == model::TermKind::kGSensitivity && instrument != model::Instrument::kGyroscope) continue;
    // The highest order whose own parameters (those order − 1 lacks) are named.
    model::TermSpec t{k, 1, reference_c};
    const int max_order = model::is_temperature_polynomial(k) ? 6 : 1;
    int order = 0;
    std::set<std::string> lower;
    for (int o = 1; o <= max_order; ++o) {
      t.order = o;
      std::set<std::string> these;
      for (const auto& info : model::param_info(t, instrument)) {
        these.insert(info.name);
        if (!lower.count(info.name) && have.count(info.name)) order = o;
      }
      lower = std::move(these);
    }
    if (order == 0) continue;
    t.order = order;
    m.terms.push_back(t);
  }
  return m;
}

Calibration calibration_from_json(const json& doc, const std::string& source) {
  if (!doc.is_object()) refuse(source, "not a results document (expected a JSON object)");
  Calibration c;
  c.source = source;
  const json est = doc.value("estimator", json());
  c.estimator = est.is_object() ? est.value("name", "") : est.is_string() ? est.get<std::string>() : "";
  if (doc.contains("accelerometer") || doc.contains("gyroscope")) {  // ceres_nonlinear
    bool any = false;
    if (doc.contains("accelerometer")) {
      const json& a = doc["accelerometer"];
      if (a.value("ok", false)) {
        set_part(c, ceres_part(a, model::Instrument::kAccelerometer));
        c.gravity_mps2 = number_or_nan(a.value("gravity_mps2", json()));
        any = true;
        if (!doc.contains("gyroscope") && !a.value("gyro_parameters", json::array()).empty())
          set_part(c, ceres_gyro_bias(a));
      } else {
        c.notes.push_back("accelerometer: the fit failed (" + a.value("message", std::string()) + "), not applied");
      }
    }
    if (doc.contains("gyroscope")) {
      const json& g = doc["gyroscope"];
      if (g.value("ok", false)) {
        set_part(c, ceres_part(g, model::Instrument::kGyroscope));
        any = true;
      } else {
        c.notes.push_back("gyroscope: the fit failed (" + g.value("message", std::string()) + "), not applied");
      }
    }
    if (!any) refuse(source, "every part of this fit failed: nothing to apply (" + doc.value("message", std::string()) + ")");
  } else if (doc.contains("axes") && doc["axes"].is_array()) {  // temp_poly
    set_part(c, temp_poly_part(doc, source, c.notes));
    const json range = doc.value("valid_range_c", json::array());
    if (range.is_array() && range.size() == 2) {
      c.valid_min_c = number_or_nan(range[0]);
      c.valid_max_c = number_or_nan(range[1]);
    }
  } else if (doc.contains("model") && doc.contains("parameters")) {  // batch_lsq, stend.fit/1
    if (estimation::status_of(doc) != estimation::FitStatus::kOk)
      refuse(source, "this fit failed (" + doc.value("message", std::string()) + "): nothing to apply");
    set_part(c, fit_part(doc, source));
  } else {
    refuse(source, "not a calibration: expected the results of batch_lsq (model, parameters), temp_poly (axes) or "
                   "ceres_nonlinear (accelerometer, gyroscope)");
  }
  if (!std::isfinite(c.gravity_mps2)) c.gravity_mps2 = 0.0;
  return c;
}

Calibration load_calibration(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot open the calibration (a results JSON file)");
  json doc;
  try {
    doc = json::parse(in);
  } catch (const json::parse_error& e) {
    throw std::runtime_error(file.string() + ": not JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  }
  return calibration_from_json(doc, file.string());
}

namespace {

// Throws when sample i of recording `name` has no temperature (which temperature terms need).
void require_temperature(const std::string& name, std::uint64_t i, const ImuSample& s) {
  if (!std::isfinite(s.temperature_c))
    throw std::runtime_error(fmt::format("{}: sample {} (t = {} s) has no temperature, which the calibration's "
                                         "temperature terms need",
                                         name, i, s.t_s));
}

}  // namespace

CalibratedSamples::CalibratedSamples(std::shared_ptr<const SampleSource> raw, const Calibration& cal, std::string name)
    : raw_(std::move(raw)), cal_(cal), name_(std::move(name)) {}

void CalibratedSamples::read(std::uint64_t first, std::size_t count, ImuSample* out) const {
  raw_->read(first, count, out);
  const bool temperature = cal_.needs_temperature();
  for (std::size_t k = 0; k < count; ++k) {
    ImuSample& s = out[k];
    if (temperature) require_temperature(name_, first + k, s);
    model::Stimulus<double> st;
    st.temperature_c = s.temperature_c;
    if (cal_.accel.present()) s.accel_mps2 = cal_.accel.model.correct(cal_.accel.theta.data(), s.accel_mps2, st);
    if (cal_.gyro.present()) {
      st.specific_force = s.accel_mps2;
      s.gyro_radps = cal_.gyro.model.correct(cal_.gyro.theta.data(), s.gyro_radps, st);
    }
  }
}

Recording apply_calibration(const Recording& raw, const Calibration& cal) {
  Recording out;
  out.dir = raw.dir;
  out.header = raw.header;
  out.experiment_yaml = raw.experiment_yaml;
  out.truth_t = raw.truth_t;
  out.truth = raw.truth;
  out.truth_store = raw.truth_store;
  out.segments = raw.segments;
  out.events = raw.events;
  out.dropped_partial_lines = raw.dropped_partial_lines;
  std::shared_ptr<const SampleSource> samples = raw.source;
  if (!samples) samples = std::make_shared<MemorySamples>(raw.samples);  // a view of raw's
  if (cal.needs_temperature())  // before anything is written
    for_each_chunk(*samples, [&](const ImuSample* c, std::size_t n, std::uint64_t first) {
      for (std::size_t k = 0; k < n; ++k) require_temperature(raw.dir.string(), first + k, c[k]);
    });
  out.source = std::make_shared<CalibratedSamples>(std::move(samples), cal, raw.dir.string());
  return out;
}

void write_calibrated(const Recording& calibrated, const Calibration& cal, const std::filesystem::path& out_dir) {
  if (std::filesystem::exists(out_dir))
    throw std::runtime_error(out_dir.string() + ": already exists; name a new folder for the calibrated recording");
  RecordingHeader h = calibrated.header;
  h.status = RunStatus::kRunning;
  RecordingWriter w(out_dir, h, calibrated.experiment_yaml);
  Event e;
  const SampleSource& samples = calibrated.sample_source();
  e.t_s = samples.size() == 0 ? 0.0 : read_column(samples, Channel::kTime, 0, 1).front();
  e.level = "info";
  e.source = "calibration";
  std::string parts;
  for (const auto* ic : {&cal.accel, &cal.gyro}) {
    if (!ic->present()) continue;
    parts += (parts.empty() ? "" : ", ") + std::string(estimation::instrument_name(ic->model.instrument));
  }
  e.message = fmt::format("SI columns calibrated with {} ({}; {}) from recording {}; counts are the raw readings",
                          cal.source, cal.estimator, parts, calibrated.dir.string());
  w.add_event(e);
  for (const auto& ev : calibrated.events) w.add_event(ev);
  for_each_chunk(samples, [&](const ImuSample* c, std::size_t n, std::uint64_t) { w.add_samples(c, n); });
  w.add_truth(*calibrated.recorded_truth());
  for (const auto& s : calibrated.segments) w.add_segment(s);
  w.finish(calibrated.header.status == RunStatus::kRunning ? RunStatus::kInterrupted : calibrated.header.status);
}

}  // namespace stend::calibration
