// A fitted calibration read back and applied. See stend/calibration/calibration.hpp.
#include "stend/calibration/calibration.hpp"

#include "stend/errors.hpp"
#include "stend/estimation/assumption.hpp"
#include "stend/estimation/model_spec.hpp"
#include "stend/recording/instruments.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <ostream>
#include <stdexcept>

namespace stend::calibration {

using nlohmann::json;

namespace {

[[noreturn]] void refuse(const std::string& source, const std::string& why) { throw InputError(source + ": " + why); }

const char* name_of(model::Instrument i) { return estimation::instrument_name(i); }

// The correction of one instrument model (its undetermined parameters settled): θ as applied.
InstrumentCalibration build(const estimation::InstrumentModel& m) {
  InstrumentCalibration ic;
  ic.model = m.model;
  ic.theta = m.applied_theta();
  ic.parameters = m.parameters;
  ic.axes = m.axes;
  return ic;
}

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
  for (const auto& a : assumed) os << "assumed: " << a << "\n";
}

Calibration calibration_from(const estimation::FitResult& result, const std::string& source,
                             const std::vector<Assumption>& assumed) {
  Calibration c;
  c.source = source;
  c.estimator = result.summary.estimator;
  bool any_model = false, any_applied = false;
  std::vector<estimation::InstrumentModel> applied;  // the models applied, settled below
  for (const auto* m : {result.accelerometer ? &*result.accelerometer : nullptr,
                        result.gyroscope ? &*result.gyroscope : nullptr}) {
    if (m == nullptr) continue;
    any_model = true;
    if (!m->ok()) {
      c.notes.push_back(fmt::format("{}: {} ({}), not applied", name_of(m->instrument()),
                                    m->status == estimation::FitStatus::kNotApplicable ? estimation::status_text(m->status) : "the fit failed",
                                    m->message));
      continue;
    }
    for (const auto& f : m->failed_axes)
      c.notes.push_back(fmt::format("axis {}: the fit failed, left uncalibrated", estimation::axis_name(f.axis)));
    applied.push_back(*m);
    if (std::isfinite(m->gravity_mps2) && m->instrument() == model::Instrument::kAccelerometer)
      c.gravity_mps2 = m->gravity_mps2;
    if (m->states_temperature_range()) {
      c.valid_min_c = m->min_temperature_c;
      c.valid_max_c = m->max_temperature_c;
    }
    any_applied = true;
  }
  if (!any_model)
    refuse(source, "not a calibration: the results of " + (c.estimator.empty() ? std::string("this fit") : c.estimator) +
                       " hold no accelerometer or gyroscope model");
  if (!any_applied)
    refuse(source, "this fit failed (" + result.summary.message + "): nothing to apply");
  std::vector<estimation::InstrumentModel*> settle;
  for (auto& m : applied) settle.push_back(&m);
  c.assumed = estimation::settle_undetermined(settle, assumed, source, "apply");
  for (const auto& m : applied) (m.instrument() == model::Instrument::kAccelerometer ? c.accel : c.gyro) = build(m);
  return c;
}

Calibration load_calibration(const std::filesystem::path& file, const estimation::Registry& registry,
                             const std::vector<Assumption>& assumed) {
  std::ifstream in(file);
  if (!in) throw InputError(file.string() + ": cannot open the calibration (a results JSON file)");
  json doc;
  try {
    doc = json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(file.string() + ": not JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  }
  if (!doc.is_object()) refuse(file.string(), "not a results document (expected a JSON object)");
  return calibration_from(registry.read(doc, file.filename().string()), file.string(), assumed);
}

namespace {

// Throws when sample i of recording `name` has no temperature (which temperature terms need).
void require_temperature(const std::string& name, std::uint64_t i, const ImuSample& s) {
  if (!std::isfinite(s.temperature_c))
    throw InputError(fmt::format("{}: sample {} (t = {} s) has no temperature, which the calibration's "
                                         "temperature terms need",
                                         name, i, s.t_s));
}

// Throws when the gyroscope's calibration reads the specific force (its g-sensitivity) and the
// recording `raw` has no accelerometer to give it. A calibrated instrument the recording lacks
// is left as it is (its values NaN).
void require_inputs_of(const Recording& raw, const Calibration& cal) {
  if (!cal.gyro.present() || has_instrument(raw.header.info, model::Instrument::kAccelerometer)) return;
  const auto& terms = cal.gyro.model.terms;
  if (std::any_of(terms.begin(), terms.end(), [](const auto& t) { return t.kind == model::TermKind::kGSensitivity; }))
    throw InputError(fmt::format("{}: the gyroscope calibration's g_sensitivity needs the specific force, and {}",
                                 raw.dir.string(), absent_text(model::Instrument::kAccelerometer)));
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
  require_inputs_of(raw, cal);
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
    throw InputError(out_dir.string() + ": already exists; name a new folder for the calibrated recording");
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
  for (const auto& a : cal.assumed) e.message += "; assumed by the user: " + a;
  w.add_event(e);
  for (const auto& ev : calibrated.events) w.add_event(ev);
  for_each_chunk(samples, [&](const ImuSample* c, std::size_t n, std::uint64_t) { w.add_samples(c, n); });
  w.add_truth(*calibrated.recorded_truth());
  for (const auto& s : calibrated.segments) w.add_segment(s);
  w.finish(calibrated.header.status == RunStatus::kRunning ? RunStatus::kInterrupted : calibrated.header.status);
}

}  // namespace stend::calibration
