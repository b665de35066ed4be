// A fitted calibration read back and applied. See stend/calibration/calibration.hpp.
#include "stend/calibration/calibration.hpp"

#include "stend/errors.hpp"
#include "stend/estimation/model_spec.hpp"

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

// A parameter the fit did not determine: its instrument, θ index and estimate (name, unit, why).
struct Undetermined {
  model::Instrument instrument;
  std::size_t index;
  const estimation::ParameterEstimate* parameter;
};

// The instrument's prefix in an assumption's name ("accel_bias_x").
std::string prefix_of(model::Instrument i) { return i == model::Instrument::kAccelerometer ? "accel_" : "gyro_"; }

// Whether assumption `name` names parameter `u` (bare, or with its instrument's prefix).
bool names(const std::string& name, const Undetermined& u) {
  return name == u.parameter->name || name == prefix_of(u.instrument) + u.parameter->name;
}

// The parameters that need a value, one line each, and the --assume that would give them all 0.
std::string refusal(const std::vector<Undetermined>& open, bool both_instruments) {
  std::string lines, assume;
  for (const auto& u : open) {
    const std::string name = (both_instruments ? prefix_of(u.instrument) : std::string()) + u.parameter->name;
    lines += fmt::format("\n  {} {} [{}]: {}", name_of(u.instrument), u.parameter->name, u.parameter->unit,
                         u.parameter->reason.empty() ? "not identifiable" : u.parameter->reason);
    assume += (assume.empty() ? "" : ",") + name + "=0";
  }
  return fmt::format("cannot apply: the fit did not determine {} parameter(s), and applying them as 0 would be a "
                     "guess:{}\nfit on data that determine them, or state the values to use (each in its unit as "
                     "listed), e.g. --assume {}",
                     open.size(), lines, assume);
}

// θ of the undetermined parameters from the assumptions (each recorded in `cal.assumed`); throws
// when an assumption names none of them, names two, or one is left without a value.
void assume(Calibration& c, const std::vector<Undetermined>& open, const std::vector<Assumption>& assumed) {
  const bool both = c.accel.present() && c.gyro.present();
  std::vector<bool> given(open.size(), false);
  for (const auto& a : assumed) {
    std::vector<std::size_t> hits;
    for (std::size_t k = 0; k < open.size(); ++k)
      if (names(a.name, open[k])) hits.push_back(k);
    if (hits.empty())
      refuse(c.source, fmt::format("--assume {}: not a parameter the fit left undetermined{}", a.name,
                                   open.empty() ? " (this calibration has none)" : "; " + refusal(open, both)));
    if (hits.size() > 1)
      refuse(c.source, fmt::format("--assume {}: both instruments have it: write {}{} or {}{}", a.name,
                                   prefix_of(model::Instrument::kAccelerometer), a.name,
                                   prefix_of(model::Instrument::kGyroscope), a.name));
    const Undetermined& u = open[hits.front()];
    given[hits.front()] = true;
    (u.instrument == model::Instrument::kAccelerometer ? c.accel : c.gyro).theta[u.index] = a.value;
    c.assumed.push_back(fmt::format("{} {} = {} {} ({})", name_of(u.instrument), u.parameter->name,
                                    estimation::number_text(a.value, 9), u.parameter->unit,
                                    u.parameter->reason.empty() ? "not identifiable" : u.parameter->reason));
  }
  std::vector<Undetermined> left;
  for (std::size_t k = 0; k < open.size(); ++k)
    if (!given[k]) left.push_back(open[k]);
  if (!left.empty()) refuse(c.source, refusal(left, both));
}

// The correction of one instrument model: its θ as applied (what the fit did not determine as 0
// until assumed); the parameters it did not determine appended to `open`.
InstrumentCalibration build(const estimation::InstrumentModel& m, std::vector<Undetermined>& open) {
  InstrumentCalibration ic;
  ic.model = m.model;
  ic.theta = m.applied_theta();
  ic.parameters = m.parameters;
  ic.axes = m.axes;
  for (std::size_t i = 0; i < m.parameters.size() && i < m.theta.size(); ++i)
    if (!m.determined(i)) open.push_back({m.instrument(), i, &m.parameters[i]});
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

std::vector<Assumption> parse_assumptions(const std::string& text) {
  std::vector<Assumption> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const std::size_t eq = item.find('=');
    Assumption a;
    bool ok = eq != std::string::npos && eq > 0;
    if (ok) {
      a.name = item.substr(0, eq);
      try {
        std::size_t used = 0;
        a.value = std::stod(item.substr(eq + 1), &used);
        ok = used == item.size() - eq - 1 && std::isfinite(a.value);
      } catch (const std::exception&) {
        ok = false;
      }
    }
    if (!ok)
      throw std::invalid_argument("--assume '" + item +
                                  "': expected NAME=VALUE (comma-separated), the value a finite number in the "
                                  "parameter's unit as the results list it, e.g. bias_x=0 or gyro_bias_z=0.001");
    out.push_back(a);
    start = comma + 1;
  }
  return out;
}

Calibration calibration_from(const estimation::FitResult& result, const std::string& source,
                             const std::vector<Assumption>& assumed) {
  Calibration c;
  c.source = source;
  c.estimator = result.summary.estimator;
  bool any_model = false, any_applied = false;
  std::vector<Undetermined> open;
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
    (m->instrument() == model::Instrument::kAccelerometer ? c.accel : c.gyro) = build(*m, open);
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
  assume(c, open, assumed);
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
