// What the exports write from (see export_sources.hpp).
#include "export_sources.hpp"

#include "stend/estimation/assumption.hpp"

#include "stend/errors.hpp"
#include "stend/estimation/model_spec.hpp"
#include "stend/recording/instruments.hpp"
#include "stend/recording/recording.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <set>

namespace stend::reporting::detail {

namespace fs = std::filesystem;

// ---- the run's results ----------------------------------------------------------------------

const RunResult* RunData::noise() const {
  for (const auto& r : results)
    if (r.fit.ok() && r.fit.noise) return &r;
  return nullptr;
}

std::string RunData::absent(model::Instrument instrument) const {
  return has_instrument(sensor, instrument) ? std::string() : absent_text(instrument);
}

namespace {

// The results files of the run folder: each estimator's (and its gyroscope's) and any other
// "<stem>*.json" of an estimator's results file, in name order.
std::vector<std::string> results_files(const fs::path& run, const estimation::Registry& registry) {
  std::set<std::string> names;
  std::vector<std::string> stems;
  for (const auto& e : registry.entries()) {
    if (e.results_file.empty()) continue;
    for (const auto& f : estimation::results_files_of(e.results_file))
      if (fs::is_regular_file(run / f)) names.insert(f);
    stems.push_back(fs::path(e.results_file).stem().string());
  }
  for (const auto& entry : fs::directory_iterator(run)) {
    const std::string n = entry.path().filename().string();
    if (entry.path().extension() != ".json" || !entry.is_regular_file()) continue;
    for (const auto& stem : stems)
      if (n.rfind(stem, 0) == 0) names.insert(n);
  }
  return {names.begin(), names.end()};
}

nlohmann::json parse_file(const fs::path& f) {
  std::ifstream in(f);
  try {
    return nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw InputError(f.string() + ": not readable: " + e.what());
  }
}

}  // namespace

RunData read_run(RunResults identity, const estimation::Registry& registry) {
  RunData d;
  d.identity = std::move(identity);
  d.dir = d.identity.dir;
  d.registry = &registry;
  for (const auto& name : results_files(d.dir, registry))
    d.results.push_back({name, registry.read(parse_file(d.dir / name), name)});
  try {
    d.sensor = Recording::open(d.dir, SampleLoading::kStream, TruthLoading::kSkip).header.info;
  } catch (const InputError&) {
    // A folder of results without its samples: what the results hold is all there is to export.
  }
  return d;
}

// ---- the calibration source rule --------------------------------------------------------------

bool InstrumentModels::has_calib() const {
  return std::any_of(calib.begin(), calib.end(), [](const auto* m) { return m != nullptr; });
}
bool InstrumentModels::has_temp() const {
  return std::any_of(temp.begin(), temp.end(), [](const auto* m) { return m != nullptr; });
}

model::Instrument instrument_of(const char* name) {
  return std::string(name) == "gyroscope" ? model::Instrument::kGyroscope : model::Instrument::kAccelerometer;
}

namespace {

// The successful model of `instrument` in a successful result, nullptr when none.
const estimation::InstrumentModel* model_in(const RunResult& r, model::Instrument instrument) {
  const estimation::InstrumentModel* m = r.fit.instrument(instrument);
  return r.fit.ok() && m != nullptr && m->ok() ? m : nullptr;
}

// The kinds of model the rule tells apart.
bool is_temperature_model(const estimation::InstrumentModel& m) { return m.states_temperature_range(); }
bool is_axis_model(const estimation::InstrumentModel& m) {
  return m.coverage == estimation::Coverage::kAxes && !is_temperature_model(m);
}
bool is_triad_model(const estimation::InstrumentModel& m) {
  return m.coverage == estimation::Coverage::kTriad && !is_temperature_model(m);
}
// A full three-axis calibration: one model of the triad that estimated the scale factors.
bool is_full(const estimation::InstrumentModel& m) { return is_triad_model(m) && m.has(model::TermKind::kScale); }

struct Rule {
  const RunData& run;
  const ExportOptions& o;
  std::string named;  // the estimator --from names ("" for auto)
  bool allowed(const RunResult& r) const { return named.empty() || r.fit.summary.estimator == named; }
};

void take(InstrumentModels& im, const estimation::InstrumentModel* m, int k, const std::string& source) {
  im.calib[static_cast<std::size_t>(k)] = m;
  im.calib_source[static_cast<std::size_t>(k)] = source;
}

// What was used (one note).
void report_use(const InstrumentModels& im, const char* instrument, const ExportOptions& o, ExportResult& res) {
  if (im.has_calib()) {
    std::string used;
    for (int k = 0; k < 3; ++k)
      if (im.calib[static_cast<std::size_t>(k)])
        used += fmt::format("{}{} from {}", used.empty() ? "" : ", ", kAxisNames[k], im.calib_source[static_cast<std::size_t>(k)]);
    if (im.calib_source[0] == im.calib_source[1] && im.calib_source[1] == im.calib_source[2])
      used = "from " + im.calib_source[0];
    res.notes.push_back(fmt::format("{} calibration {} (--from {})", instrument, used, o.from));
  }
}

// The models both instruments' exports write, replaced by copies whose undetermined parameters
// hold the user's --assume values (refused without one: a 0 written for them would be a guess);
// each value used goes to res.notes.
void settle(std::array<InstrumentModels, 2>& ims, const ExportOptions& o, const std::string& source, ExportResult& res) {
  std::vector<const estimation::InstrumentModel*> used;
  for (auto& im : ims)
    for (auto* slots : {&im.calib, &im.temp})
      for (const auto* m : *slots)
        if (m && std::find(used.begin(), used.end(), m) == used.end()) used.push_back(m);
  std::vector<std::shared_ptr<estimation::InstrumentModel>> copies;
  std::vector<estimation::InstrumentModel*> editable;
  for (const auto* m : used) {
    copies.push_back(std::make_shared<estimation::InstrumentModel>(*m));
    editable.push_back(copies.back().get());
  }
  for (const auto& line : estimation::settle_undetermined(editable, o.assumed, source, "export"))
    res.notes.push_back("assumed by the user: " + line);
  for (auto& im : ims) {
    for (auto* slots : {&im.calib, &im.temp})
      for (auto& m : *slots)
        if (m) m = copies[static_cast<std::size_t>(std::find(used.begin(), used.end(), m) - used.begin())].get();
    im.settled.assign(copies.begin(), copies.end());
  }
}

// The calibration of one instrument by the rule of ExportOptions::from:
//   auto   one model of the three axes with scale factors (a full calibration); else the
//          axis-wise models, then the temperature models at their reference, axis by axis; else a
//          model of the three axes without scale factors (e.g. a bias-only result);
//   NAME   that estimator's models only.
// The temperature models always come from the first temperature model of the instrument.
InstrumentModels models_for(const Rule& rule, const char* instrument, ExportResult& res) {
  const model::Instrument inst = instrument_of(instrument);
  InstrumentModels im;
  for (const auto& r : rule.run.results)
    if (const auto* m = model_in(r, inst); m && is_axis_model(*m) && rule.allowed(r))
      for (int k : m->axes)
        if (k >= 0 && k < 3 && !im.calib[static_cast<std::size_t>(k)]) take(im, m, k, r.file);
  for (const auto& r : rule.run.results) {
    const auto* m = model_in(r, inst);
    if (!m || !is_temperature_model(*m)) continue;
    im.reference_c = m->reference_c;
    im.tmin = m->min_temperature_c;
    im.tmax = m->max_temperature_c;
    for (int k : m->axes) {
      if (k < 0 || k >= 3) continue;
      im.temp[static_cast<std::size_t>(k)] = m;
      im.temp_source[static_cast<std::size_t>(k)] = r.file;
      if (!im.calib[static_cast<std::size_t>(k)] && rule.allowed(r)) take(im, m, k, r.file);
    }
    break;
  }
  for (const auto& r : rule.run.results) {
    const auto* m = model_in(r, inst);
    if (!m || !is_triad_model(*m) || !rule.allowed(r)) continue;
    if (!rule.named.empty() || is_full(*m) || !im.has_calib()) {
      for (int k = 0; k < 3; ++k) take(im, m, k, r.file);
      for (const auto& n : m->notes) res.notes.push_back(fmt::format("{}: {}", instrument, n));
    }
    break;
  }
  report_use(im, instrument, rule.o, res);
  return im;
}

// A result that would have calibrated (it has an instrument model) but failed.
bool failed_calibration(const RunResult& r) {
  return !r.fit.ok() && (r.fit.accelerometer || r.fit.gyroscope);
}
std::string failure_of(const RunResult& r) { return fmt::format("{}: the fit failed: {}", r.file, r.fit.summary.message); }

const RunResult* result_named(const RunData& run, const std::string& file) {
  for (const auto& r : run.results)
    if (r.file == file) return &r;
  return nullptr;
}

}  // namespace

std::array<InstrumentModels, 2> calibrations(const RunData& run, const ExportOptions& o, ExportResult& res) {
  const estimation::EstimatorEntry* named = calibration_source(*run.registry, o.from);
  const Rule rule{run, o, named ? named->name : std::string()};
  std::array<InstrumentModels, 2> ims = {models_for(rule, "accelerometer", res), models_for(rule, "gyroscope", res)};
  if (ims[0].has_calib() || ims[1].has_calib()) {
    settle(ims, o, run.dir.string(), res);
    return ims;
  }
  if (named) {
    const std::string& f = named->results_file;
    const RunResult* r = result_named(run, f);
    throw InputError(fmt::format("--from {}: no accelerometer or gyroscope calibration: {}", o.from,
                                 !r               ? fmt::format("no {} in {}", f, run.dir.string())
                                 : !r->fit.ok()   ? failure_of(*r)
                                                  : f + " holds none"));
  }
  for (const auto& r : run.results)
    if (failed_calibration(r))
      throw InputError(failure_of(r) + "; no other accelerometer or gyroscope calibration in " + run.dir.string());
  return ims;
}

// ---- the affine calibration at a temperature ---------------------------------------------------

namespace {
const model::Vec3<double> kZero = model::Vec3<double>::Zero();
}  // namespace

double offset_at(const estimation::InstrumentModel* m, int k, double T) {
  return m ? m->contribution(k, kZero, T).first : 0.0;
}

Eigen::RowVector3d input_row(const estimation::InstrumentModel* m, int k, double T) {
  Eigen::RowVector3d r = Eigen::RowVector3d::Zero();
  r[k] = 1.0;
  if (!m) return r;
  for (int j = 0; j < 3; ++j) {
    model::Vec3<double> e = kZero;
    e[j] = 1.0;
    r[j] += m->contribution(k, e, T, &kZero).first;
  }
  return r;
}

namespace {

// Row k of the gyro's g-sensitivity G (y = … + G·f) at temperature T: ∂y_k/∂f_j through the
// model (zero for an accelerometer or without the term).
Eigen::RowVector3d g_row(const estimation::InstrumentModel* m, int k, double T) {
  Eigen::RowVector3d r = Eigen::RowVector3d::Zero();
  if (!m || m->instrument() != model::Instrument::kGyroscope) return r;
  const std::vector<double> theta = m->applied_theta();
  model::Stimulus<double> s0;
  s0.temperature_c = T;
  const double y0 = m->model.measure<double>(theta.data(), s0)[k];
  for (int j = 0; j < 3; ++j) {
    model::Stimulus<double> s = s0;
    s.specific_force[j] = 1.0;
    r[j] = m->model.measure<double>(theta.data(), s)[k] - y0;
  }
  return r;
}

}  // namespace

Triad triad_at(const InstrumentModels& im, double T) {
  Triad t;
  for (int k = 0; k < 3; ++k) {
    const auto* m = im.calib[static_cast<std::size_t>(k)];
    if (!m) t.unfitted += std::string(t.unfitted.empty() ? "" : ", ") + kAxisNames[k];
    t.A.row(k) = input_row(m, k, T);
    t.b[k] = offset_at(m, k, T);
    t.G.row(k) = g_row(m, k, T);
  }
  return t;
}

double reference_of(const InstrumentModels& im) { return std::isfinite(im.reference_c) ? im.reference_c : 25.0; }

// ---- noise -------------------------------------------------------------------------------------

Eigen::Vector3d noise_per_axis(const estimation::NoiseResult& noise, model::Instrument instrument, char symbol) {
  Eigen::Vector3d v = Eigen::Vector3d::Constant(kNaN);
  for (int k = 0; k < 3; ++k) {
    const estimation::ChannelNoise* c = noise.find(instrument, k);
    if (!c) continue;
    const estimation::ParameterEstimate& p =
        symbol == 'N' ? c->white_noise : symbol == 'K' ? c->random_walk : c->bias_instability;
    if (p.identifiable) v[k] = p.value;
  }
  return v;
}

std::string g17(double v) { return fmt::format("{:.17g}", v); }

}  // namespace stend::reporting::detail

namespace stend::reporting {

const estimation::EstimatorEntry* calibration_source(const estimation::Registry& registry, const std::string& from) {
  if (from == "auto") return nullptr;
  if (const auto* e = registry.find(from)) return e;
  const estimation::EstimatorEntry* match = nullptr;
  int matches = 0;
  for (const auto& e : registry.entries())
    if (!from.empty() && e.name.rfind(from, 0) == 0) {
      match = &e;
      ++matches;
    }
  if (matches == 1) return match;
  throw InputError(fmt::format("unknown calibration source '{}' (auto, or an estimator: {})", from, registry.names()));
}

}  // namespace stend::reporting
