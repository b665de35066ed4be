// Exports of a run's results (see exports.hpp).
#include "stend/reporting/exports.hpp"

#include "fitted_model.hpp"
#include "stend/errors.hpp"
#include "stend/estimation/summary.hpp"
#include "stend/recording/files.hpp"
#include "stend/reporting/results.hpp"
#include "stend/recording/recording.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <matio.h>
#include <nlohmann/json.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <map>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace stend::reporting {

namespace fs = std::filesystem;
using detail::contribution;
using detail::FittedModel;
using detail::jnum;
using detail::jstr;
using nlohmann::json;

namespace {

const char* kAxisNames = "xyz";

std::optional<json> load_json(const fs::path& f) {
  if (!fs::exists(f)) return std::nullopt;
  std::ifstream in(f);
  try {
    return json::parse(in);
  } catch (const std::exception& e) {
    throw std::runtime_error(f.string() + ": not readable: " + e.what());
  }
}

bool doc_ok(const json& d) { return estimation::status_of(d) == estimation::FitStatus::kOk; }

std::string instrument_of(const json& fit) { return jstr(fit.value("model", json::object()), "instrument"); }

bool fits_axis(const json& fit, int k) {
  for (const auto& a : fit.value("model", json::object()).value("axes", json::array()))
    if (a.is_string() && a.get<std::string>() == std::string(1, kAxisNames[k])) return true;
  return false;
}

// Per output axis of one instrument: the calibration (bias, scale, cross-axis at the reference
// temperature) and the temperature model, and where each came from.
struct InstrumentModels {
  std::array<std::optional<FittedModel>, 3> calib;  // bias, scale, cross-axis at the reference temperature
  std::array<std::optional<FittedModel>, 3> temp;   // temp_poly (temperature polynomials)
  std::array<std::string, 3> calib_source, temp_source;
  double reference_c = 25.0;
  double tmin = NAN, tmax = NAN;
  bool has_calib() const {
    for (const auto& c : calib)
      if (c) return true;
    return false;
  }
  bool has_temp() const {
    for (const auto& t : temp)
      if (t) return true;
    return false;
  }
};

constexpr const char* kCeresEstimator = "ceres_nonlinear";
constexpr const char* kCeresFile = "ceres.json";

// The ceres_nonlinear calibration of one instrument from the run's results (the registry's summary
// of ceres.json, parameters accel_* / gyro_*), rebuilt as an error model of the vocabulary's terms
// bias, scale, cross_axis and g_sensitivity — those the fit reported. A parameter the fit held at
// 0 by its frame convention is 0 (named in `held`); nullopt when the run has no such result.
std::optional<FittedModel> ceres_model(const RunResults& rr, const std::string& instrument, std::vector<std::string>& held) {
  const std::string prefix = instrument == "gyroscope" ? "gyro_" : "accel_";
  auto find = [&](const std::string& name) { return rr.find(kCeresEstimator, prefix + name); };
  FittedModel f;
  f.m.instrument = instrument == "gyroscope" ? model::Instrument::kGyroscope : model::Instrument::kAccelerometer;
  for (const auto kind : {model::TermKind::kBias, model::TermKind::kScale, model::TermKind::kCrossAxis,
                          model::TermKind::kGSensitivity}) {
    model::TermSpec t;
    t.kind = kind;
    if (find(model::param_info(t, f.m.instrument).front().name)) f.m.terms.push_back(t);
  }
  if (f.m.terms.empty()) return std::nullopt;
  const auto info = f.m.params();
  f.theta.assign(info.size(), 0.0);
  std::vector<double> se;
  for (std::size_t i = 0; i < info.size(); ++i) {
    const ParameterResult* p = find(info[i].name);
    if (p && p->identifiable && std::isfinite(p->value)) {
      f.theta[i] = p->value;
      f.index.push_back(static_cast<int>(i));
      se.push_back(std::isfinite(p->std_error) ? p->std_error : 0.0);
    } else if (p && p->reason.rfind("held at 0", 0) == 0) {  // ceres_nonlinear's frame convention
      held.push_back(prefix + info[i].name);
    } else {
      f.not_identified.push_back(prefix + info[i].name);
    }
  }
  f.cov = Eigen::Map<const Eigen::VectorXd>(se.data(), static_cast<Eigen::Index>(se.size())).array().square().matrix().asDiagonal();
  f.ok = true;
  return f;
}

// The estimator that wrote `file` into the run, nullptr when the run has no such file.
const EstimatorUse* use_of(const RunResults& rr, const std::string& file) {
  for (const auto& e : rr.estimators)
    if (e.file == file) return &e;
  return nullptr;
}
std::string failure_of(const EstimatorUse& e) { return fmt::format("{}: the fit failed: {}", e.file, e.message); }

// The instrument's temperature model and its file: temp_poly.json, or another temp_poly*.json in
// the run folder (a run holds one per instrument: `stend fit RUN -m GYRO_MODEL` writes
// RUN/temp_poly-gyroscope.json, estimation::results_file_for); the first in name order whose fit is ok and is of this instrument.
std::optional<std::pair<json, std::string>> temp_poly_of(const fs::path& run, const std::string& instrument) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(run)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("temp_poly", 0) == 0 && e.path().extension() == ".json") names.push_back(n);
  }
  std::sort(names.begin(), names.end());
  for (const auto& n : names)
    if (auto d = load_json(run / n); d && doc_ok(*d) && jstr(d->value("options", json::object()), "instrument") == instrument)
      return std::make_pair(std::move(*d), n);
  return std::nullopt;
}

// The calibration of one instrument by the rule of ExportOptions::from:
//   ceres      ceres.json (one model for the three axes)
//   batch_lsq  fit.json, axis by axis
//   temp_poly  temp_poly*.json at its reference temperature, axis by axis
//   auto       Ceres when it estimated this instrument's scale factors (a full 3-axis calibration),
//              else fit.json then temp_poly.json axis by axis, else a Ceres bias-only result.
// The temperature models always come from temp_poly*.json. What was used goes to res.notes.
InstrumentModels models_for(const fs::path& run, const RunResults& rr, const std::string& instrument,
                            const ExportOptions& o, ExportResult& res) {
  InstrumentModels im;
  auto take = [&](const FittedModel& m, int k, const std::string& source) {
    im.calib[static_cast<std::size_t>(k)] = m;
    im.calib_source[static_cast<std::size_t>(k)] = source;
  };
  if (o.from == "auto" || o.from == "batch_lsq")
    if (auto d = load_json(run / "fit.json"); d && doc_ok(*d) && instrument_of(*d) == instrument && d->contains("parameters"))
      for (int k = 0; k < 3; ++k)
        if (fits_axis(*d, k)) take(detail::fitted_model(*d), k, "fit.json");
  if (const auto tp = temp_poly_of(run, instrument)) {
    const json& d = tp->first;
    im.reference_c = jnum(d, "reference_c");
    const json vr = d.value("valid_range_c", json::array());
    im.tmin = detail::jat(vr, 0);
    im.tmax = detail::jat(vr, 1);
    for (const auto& ax : d.value("axes", json::array())) {
      const std::string a = jstr(ax, "axis");
      const auto pos = std::string(kAxisNames).find(a);
      if (a.size() != 1 || pos == std::string::npos || !ax.value("ok", false) || !ax.contains("fit") || ax["fit"].is_null())
        continue;
      im.temp[pos] = detail::fitted_model(ax["fit"]);
      im.temp_source[pos] = tp->second;
      if (!im.calib[pos] && (o.from == "auto" || o.from == "temp_poly")) take(*im.temp[pos], static_cast<int>(pos), tp->second);
    }
  }
  std::vector<std::string> held;
  const auto ceres = o.from == "auto" || o.from == "ceres" ? ceres_model(rr, instrument, held) : std::nullopt;
  const bool full = ceres && ceres->m.terms.size() > 1;
  if (ceres && (o.from == "ceres" || full || !im.has_calib())) {
    for (int k = 0; k < 3; ++k) take(*ceres, k, kCeresFile);
    if (!held.empty())
      res.notes.push_back(fmt::format("{}: held at 0 by the Ceres fit's frame convention (its fixed_cross_axis): {}",
                                      instrument, fmt::join(held, ", ")));
  }
  if (im.has_calib()) {
    std::string used;
    for (int k = 0; k < 3; ++k)
      if (im.calib[static_cast<std::size_t>(k)])
        used += fmt::format("{}{} from {}", used.empty() ? "" : ", ", kAxisNames[k], im.calib_source[static_cast<std::size_t>(k)]);
    if (im.calib_source[0] == im.calib_source[1] && im.calib_source[1] == im.calib_source[2])
      used = "from " + im.calib_source[0];
    res.notes.push_back(fmt::format("{} calibration {} (--from {})", instrument, used, o.from));
  }
  for (int k = 0; k < 3; ++k) {
    const auto& c = im.calib[static_cast<std::size_t>(k)];
    if (c && !c->not_identified.empty()) {
      res.warnings.push_back(fmt::format("{} axis {}: not identified, exported as 0: {}", instrument, kAxisNames[k],
                                         fmt::join(c->not_identified, ", ")));
      if (im.calib_source[static_cast<std::size_t>(k)] == kCeresFile) break;  // one model for the three axes
    }
  }
  return im;
}

// The calibrations of both instruments; refuses when the source named by --from has none, or when
// a results file that would have been the source failed and nothing else calibrates.
std::array<InstrumentModels, 2> calibrations(const fs::path& run, const RunResults& rr, const ExportOptions& o,
                                             ExportResult& res) {
  if (o.from != "auto" && o.from != "ceres" && o.from != "batch_lsq" && o.from != "temp_poly")
    throw std::runtime_error("unknown calibration source '" + o.from + "' (auto|ceres|batch_lsq|temp_poly)");
  std::array<InstrumentModels, 2> ims = {models_for(run, rr, "accelerometer", o, res),
                                         models_for(run, rr, "gyroscope", o, res)};
  if (ims[0].has_calib() || ims[1].has_calib()) return ims;
  const std::map<std::string, std::string> file = {{"ceres", kCeresFile}, {"batch_lsq", "fit.json"}, {"temp_poly", "temp_poly.json"}};
  if (o.from != "auto") {
    const std::string& f = file.at(o.from);
    const EstimatorUse* e = use_of(rr, f);
    throw std::runtime_error(fmt::format("--from {}: no accelerometer or gyroscope calibration: {}", o.from,
                                         !e                  ? fmt::format("no {} in {}", f, run.string())
                                         : e->status != "ok" ? failure_of(*e)
                                                             : f + " holds none"));
  }
  for (const auto& source : file)
    if (const EstimatorUse* e = use_of(rr, source.second); e && e->status != "ok")
      throw std::runtime_error(failure_of(*e) + "; no other accelerometer or gyroscope calibration in " + run.string());
  return ims;
}

const model::Vec3<double> kZero = model::Vec3<double>::Zero();

// Bias at temperature T, axis k (0 when no model fitted that axis).
double offset_at(const std::optional<FittedModel>& m, int k, double T) {
  return m && m->ok ? contribution(*m, k, kZero, T).first : 0.0;
}

// Row k of the input matrix A (y = A·u + b) at temperature T: ∂y_k/∂u_j through the model.
Eigen::RowVector3d input_row(const std::optional<FittedModel>& m, int k, double T) {
  Eigen::RowVector3d r = Eigen::RowVector3d::Zero();
  r[k] = 1.0;
  if (!m || !m->ok) return r;
  for (int j = 0; j < 3; ++j) {
    model::Vec3<double> e = kZero;
    e[j] = 1.0;
    r[j] += contribution(*m, k, e, T, &kZero).first;
  }
  return r;
}

// Row k of the gyro's g-sensitivity G (y = … + G·f) at temperature T: ∂y_k/∂f_j through the
// model (zero for an accelerometer or without the term).
Eigen::RowVector3d g_row(const std::optional<FittedModel>& m, int k, double T) {
  Eigen::RowVector3d r = Eigen::RowVector3d::Zero();
  if (!m || !m->ok || m->m.instrument != model::Instrument::kGyroscope) return r;
  model::Stimulus<double> s0;
  s0.temperature_c = T;
  const double y0 = m->m.measure<double>(m->theta.data(), s0)[k];
  for (int j = 0; j < 3; ++j) {
    model::Stimulus<double> s = s0;
    s.specific_force[j] = 1.0;
    r[j] = m->m.measure<double>(m->theta.data(), s)[k] - y0;
  }
  return r;
}

// One instrument's affine calibration at T [°C]: y = A·u + b + G·f (SI: m/s², rad/s). An axis no
// model fitted has an identity row and 0 bias (named in `unfitted`).
struct Triad {
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
  std::string unfitted;  // "x, y" or ""
};

Triad triad_at(const InstrumentModels& im, double T) {
  Triad t;
  for (int k = 0; k < 3; ++k) {
    const auto& m = im.calib[static_cast<std::size_t>(k)];
    if (!m) t.unfitted += std::string(t.unfitted.empty() ? "" : ", ") + kAxisNames[k];
    t.A.row(k) = input_row(m, k, T);
    t.b[k] = offset_at(m, k, T);
    t.G.row(k) = g_row(m, k, T);
  }
  return t;
}

double reference_of(const InstrumentModels& im) { return std::isfinite(im.reference_c) ? im.reference_c : 25.0; }

std::string g17(double v) { return fmt::format("{:.17g}", v); }

// ---- Noise (allan.json) -------------------------------------------------------------------------
// One Allan coefficient ("N", "K" or "B") per axis of an instrument, from the run's results (the
// registry's summary of allan.json, parameters N_ax … K_gz); NaN where not identified.
Eigen::Vector3d allan_per_axis(const RunResults& rr, const char* inst, const char* symbol) {
  Eigen::Vector3d v = Eigen::Vector3d::Constant(NAN);
  for (int k = 0; k < 3; ++k)
    if (const auto* p = rr.find("allan", fmt::format("{}_{}{}", symbol, inst[0] == 'a' ? 'a' : 'g', kAxisNames[k]));
        p && p->identifiable)
      v[k] = p->value;
  return v;
}

// ---- Kalibr -------------------------------------------------------------------------------------
// Kalibr takes one noise density and one random walk per sensor: the worst (largest) identified
// axis is written, and a note says which axis and what the others were. With no axis identified,
// allan.json's Kalibr block (its slope read-off or upper bound) is written with a warning.
std::pair<double, std::string> kalibr_value(const RunResults& rr, const json& block, const char* inst, const char* symbol,
                                            const char* key, ExportResult& res) {
  const Eigen::Vector3d v = allan_per_axis(rr, inst, symbol);
  int worst = -1;
  for (int k = 0; k < 3; ++k)
    if (std::isfinite(v[k]) && (worst < 0 || v[k] > v[worst])) worst = k;
  if (worst >= 0) {
    std::string note = fmt::format("worst axis of {}: {}", inst, kAxisNames[worst]);
    for (int k = 0; k < 3; ++k)
      note += fmt::format("; {} {}", kAxisNames[k], std::isfinite(v[k]) ? fmt::format("{:.4g}", v[k]) : "not identified");
    res.notes.push_back(std::string(key) + ": Kalibr takes one number per sensor; " + note);
    return {v[worst], note};
  }
  const double b = jnum(block, key);
  if (!std::isfinite(b)) throw std::runtime_error(std::string("allan.json: no value for ") + key + ": cannot export Kalibr");
  if (std::string(symbol) == "K" && block.value(std::string(inst) + "_random_walk_is_upper_bound", false)) {
    res.warnings.push_back(std::string(key) + " is an upper bound (the record is too short to identify it)");
    return {b, "UPPER BOUND: not identified"};
  }
  res.warnings.push_back(std::string(key) + ": no axis identified by the model fit; the largest slope read-off of the axes is written");
  return {b, "from the slope read-off, not the model fit"};
}

// A = L·Q with L lower-triangular (positive diagonal) and Q a rotation: Kalibr's M and C.
std::pair<Eigen::Matrix3d, Eigen::Matrix3d> lower_times_rotation(const Eigen::Matrix3d& A) {
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr(A.transpose());
  const Eigen::Matrix3d L = Eigen::Matrix3d(qr.matrixQR().triangularView<Eigen::Upper>()).transpose();
  const Eigen::Matrix3d Q = Eigen::Matrix3d(qr.householderQ()).transpose();
  const Eigen::Matrix3d D = L.diagonal().array().sign().matrix().asDiagonal();
  return {L * D, D * Q};
}

std::string yaml_matrix(const Eigen::Matrix3d& m, const char* indent) {
  std::string s;
  for (int i = 0; i < 3; ++i) s += fmt::format("{}- [{}, {}, {}]\n", indent, g17(m(i, 0)), g17(m(i, 1)), g17(m(i, 2)));
  return s;
}

// Kalibr's scale-misalignment IMU model (IccScaledMisalignedImu) in the layout Kalibr writes its
// results: accelerometer a = M_a·a_i + b, gyroscope w = M_g·C_gyro_i·w_i + A·C_gyro_i·a_i + b,
// M lower-triangular. Ours y = A·u + b (+ G·f): A_acc = M_a·R (R: the sensor frame to Kalibr's
// accelerometer-defined IMU frame, identity for a Ceres unknown-orientations fit), then
// M_g·C_gyro_i = A_gyro·Rᵀ and A = G·Rᵀ·C_gyro_iᵀ.
std::string kalibr_intrinsics(const std::array<InstrumentModels, 2>& ims, ExportResult& res) {
  if (!ims[0].has_calib() || !ims[1].has_calib()) {
    res.notes.push_back("kalibr: no intrinsics written (Kalibr's scale-misalignment model needs both an accelerometer and "
                        "a gyroscope calibration)");
    return {};
  }
  const Triad a = triad_at(ims[0], reference_of(ims[0])), g = triad_at(ims[1], reference_of(ims[1]));
  for (const Triad* t : {&a, &g})
    if (!t->unfitted.empty())
      res.warnings.push_back(fmt::format("kalibr: {} axes {} not calibrated: identity rows in M",
                                         t == &a ? "accelerometer" : "gyroscope", t->unfitted));
  const auto [Ma, R] = lower_times_rotation(a.A);
  const auto [Mg, C] = lower_times_rotation(g.A * R.transpose());
  const Eigen::Matrix3d Ag = g.G * R.transpose() * C.transpose();
  const double tilt = Eigen::AngleAxisd(R).angle();
  if (tilt > 1e-12)
    res.notes.push_back(fmt::format("kalibr: the accelerometer frame is turned {:.3g} rad from the sensor frame; Kalibr's "
                                    "T_i_b absorbs it", tilt));
  std::string s = "# Intrinsics: Kalibr's scale-misalignment model (--imu-models scale-misalignment), as Kalibr writes its\n"
                  "# results; Kalibr re-estimates them from its own data. Biases are not part of Kalibr's model file.\n";
  s += "model: scale-misalignment\n";
  s += "accelerometers:\n  M:\n" + yaml_matrix(Ma, "    ");
  s += "gyroscopes:\n  M:\n" + yaml_matrix(Mg, "    ");
  s += "  A:  # [(rad/s)/(m/s^2)]\n" + yaml_matrix(Ag, "    ");
  s += "  C_gyro_i:\n" + yaml_matrix(C, "    ");
  return s;
}

ExportResult export_kalibr(const fs::path& run, const RunResults& rr, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  auto al = load_json(run / "allan.json");
  if (!al || !al->contains("kalibr"))
    throw std::runtime_error(
        "no allan.json in " + run.string() +
        ": the Kalibr noise model comes from the Allan analysis; run `stend fit RUN -m estimators/allan/example/allan.yaml` "
        "on a long static recording first");
  const json& k = (*al)["kalibr"];
  const auto an = kalibr_value(rr, k, "accelerometer", "N", "accelerometer_noise_density", res);
  const auto ar = kalibr_value(rr, k, "accelerometer", "K", "accelerometer_random_walk", res);
  const auto gn = kalibr_value(rr, k, "gyroscope", "N", "gyroscope_noise_density", res);
  const auto gr = kalibr_value(rr, k, "gyroscope", "K", "gyroscope_random_walk", res);
  std::string intrinsics;
  try {
    intrinsics = kalibr_intrinsics(calibrations(run, rr, o, res), res);
  } catch (const std::runtime_error& e) {  // the noise model stands alone unless a source was asked for
    if (o.from != "auto") throw;
    res.warnings.push_back(std::string("kalibr: no intrinsics written: ") + e.what());
  }
  std::ostringstream f;
  f << fmt::format("# Kalibr IMU noise model (imu.yaml), written by Stend from {}/allan.json\n", run.filename().string());
  f << fmt::format("# sensor: {} {} serial '{}'; Allan analysis of {} samples\n", rr.vendor, rr.model, rr.serial,
                   g17(jnum(*al, "samples")));
  f << "# Accelerometers\n";
  f << fmt::format("accelerometer_noise_density: {}  # [m/s^2/sqrt(Hz)] {}\n", g17(an.first), an.second);
  f << fmt::format("accelerometer_random_walk: {}  # [m/s^3/sqrt(Hz)] {}\n", g17(ar.first), ar.second);
  f << "# Gyroscopes\n";
  f << fmt::format("gyroscope_noise_density: {}  # [rad/s/sqrt(Hz)] {}\n", g17(gn.first), gn.second);
  f << fmt::format("gyroscope_random_walk: {}  # [rad/s^2/sqrt(Hz)] {}\n", g17(gr.first), gr.second);
  f << fmt::format("rostopic: {}\n", o.rostopic);
  f << fmt::format("update_rate: {}  # [Hz]\n", g17(jnum(k, "update_rate")));
  f << intrinsics;
  write_file_atomic(out, f.str());
  res.files.push_back(out);
  return res;
}

// ---- IMU-TK -------------------------------------------------------------------------------------
void write_imutk(const fs::path& file, const Eigen::Matrix3d& T, const Eigen::Matrix3d& K, const Eigen::Vector3d& B) {
  std::ostringstream f;
  for (int i = 0; i < 3; ++i) f << g17(T(i, 0)) << ' ' << g17(T(i, 1)) << ' ' << g17(T(i, 2)) << '\n';
  f << '\n';
  for (int i = 0; i < 3; ++i) f << g17(K(i, 0)) << ' ' << g17(K(i, 1)) << ' ' << g17(K(i, 2)) << '\n';
  f << '\n';
  for (int i = 0; i < 3; ++i) f << g17(B(i)) << '\n';
  write_file_atomic(file, f.str());
}

ExportResult export_imutk(const fs::path& run, const RunResults& rr, const fs::path& prefix, const ExportOptions& o) {
  ExportResult res;
  const auto ims = calibrations(run, rr, o, res);
  for (int i = 0; i < 2; ++i) {
    const char* inst = i == 0 ? "accelerometer" : "gyroscope";
    if (!ims[static_cast<std::size_t>(i)].has_calib()) {
      res.warnings.push_back(fmt::format("{}: no calibration in the run: no IMU-TK file written for it", inst));
      continue;
    }
    const Triad t = triad_at(ims[static_cast<std::size_t>(i)], reference_of(ims[static_cast<std::size_t>(i)]));
    if (!t.unfitted.empty())
      res.warnings.push_back(fmt::format("{} axes {}: not fitted, exported as identity/0", inst, t.unfitted));
    if (!t.G.isZero(0.0))
      res.warnings.push_back(fmt::format("{}: the g-sensitivity (max |G| {:.3g} (rad/s)/(m/s^2)) is not exported: IMU-TK's "
                                         "triad model has no such term", inst, t.G.cwiseAbs().maxCoeff()));
    // IMU-TK: x = T·K·(y − B) with T unit-diagonal, K diagonal; ours: y = A·x + b.
    const Eigen::Matrix3d Ainv = t.A.inverse();
    const Eigen::Matrix3d K = Ainv.diagonal().asDiagonal();
    const Eigen::Matrix3d Tm = Ainv * K.inverse();
    const fs::path file = prefix.string() + (i == 0 ? "_acc.calib" : "_gyro.calib");
    write_imutk(file, Tm, K, t.b);
    res.files.push_back(file);
  }
  if (res.files.empty())
    throw std::runtime_error("no accelerometer or gyroscope calibration in " + run.string() +
                             " (ceres.json, fit.json or temp_poly.json): nothing to export for IMU-TK");
  return res;
}

// ---- PX4 ----------------------------------------------------------------------------------------
// TC_<A|G><n>_*: the offset polynomial X0…X3 about TREF of the instrument's temperature model.
void px4_thermal(std::ostringstream& body, const InstrumentModels& im, const char* inst, const ExportOptions& o,
                 ExportResult& res) {
  const std::string p = fmt::format("TC_{}{}", inst[0] == 'a' ? "A" : "G", o.px4_instance);
  const double tref = im.reference_c;
  // Coefficients of the offset polynomial about TREF, recovered by an exact cubic fit through the
  // model's offsets at seven temperatures (the model is evaluated, not re-derived).
  Eigen::Matrix<double, 7, 4> V;
  for (int i = 0; i < 7; ++i) {
    const double dT = (i - 3) * 10.0;
    for (int c = 0; c < 4; ++c) V(i, c) = std::pow(dT, c);
  }
  std::array<Eigen::Vector4d, 3> coef;
  for (int k = 0; k < 3; ++k) {
    const auto& m = im.temp[static_cast<std::size_t>(k)];
    Eigen::Matrix<double, 7, 1> y;
    for (int i = 0; i < 7; ++i) y[i] = offset_at(m, k, tref + (i - 3) * 10.0);
    coef[static_cast<std::size_t>(k)] = V.colPivHouseholderQr().solve(y);
    // Round-off of the exact fit (≈1e-20 where the model has no such power) is not a coefficient.
    const double scale = y.cwiseAbs().maxCoeff();
    for (int c = 0; c < 4; ++c)
      if (std::abs(coef[static_cast<std::size_t>(k)][c]) * std::pow(30.0, c) < 1e-10 * scale)
        coef[static_cast<std::size_t>(k)][c] = 0.0;
    const double resid = (V * coef[static_cast<std::size_t>(k)] - y).cwiseAbs().maxCoeff();
    if (resid > 1e-8 * (1e-12 + scale))
      res.warnings.push_back(fmt::format("{} axis {}: the offset polynomial is above order 3; PX4 keeps X0…X3 only",
                                         inst, kAxisNames[k]));
    if (!m) res.warnings.push_back(fmt::format("{} axis {}: no temperature fit, offsets exported as 0", inst, kAxisNames[k]));
    if (m) {
      for (const auto& t : m->m.terms)
        if (t.kind == model::TermKind::kScaleTemperature) {
          res.warnings.push_back(fmt::format(
              "{} axis {}: the scale-factor temperature polynomial is not exported (PX4's thermal compensation "
              "corrects offsets only)",
              inst, kAxisNames[k]));
          break;
        }
    }
  }
  body << fmt::format("1\t1\tTC_{}_ENABLE\t1\t6\n", inst[0] == 'a' ? "A" : "G");
  body << fmt::format("1\t1\t{}_ID\t{}\t6\n", p, o.px4_device_id);
  if (o.px4_device_id == 0)
    res.warnings.push_back(p + "_ID = 0: set it to the sensor's PX4 device id on the vehicle, or PX4 ignores the calibration");
  auto real = [&](const std::string& name, double v) { body << fmt::format("1\t1\t{}\t{:.9g}\t9\n", name, v); };
  real(p + "_TMAX", im.tmax);
  real(p + "_TMIN", im.tmin);
  real(p + "_TREF", tref);
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 3; ++k) real(fmt::format("{}_X{}_{}", p, c, k), coef[static_cast<std::size_t>(k)][c]);
}

// CAL_ACC<n>_* / CAL_GYRO<n>_*: PX4's static calibration. PX4 corrects an accelerometer as
// (raw − XOFF)·XSCALE per axis and a gyroscope as raw − XOFF (src/lib/sensor_calibration): XOFF = b,
// accelerometer XSCALE = 1/A_kk; what PX4 cannot apply is named in a warning.
void px4_static(std::ostringstream& body, const InstrumentModels& im, const char* inst, const ExportOptions& o,
                ExportResult& res) {
  const bool accel = inst[0] == 'a';
  const std::string p = fmt::format("CAL_{}{}", accel ? "ACC" : "GYRO", o.px4_instance);
  const Triad t = triad_at(im, reference_of(im));
  if (!t.unfitted.empty()) res.warnings.push_back(fmt::format("{} axes {}: not fitted, exported as offset 0, scale 1", inst, t.unfitted));
  const Eigen::Matrix3d off = t.A - Eigen::Matrix3d(t.A.diagonal().asDiagonal());
  if (!off.isZero(0.0))
    res.warnings.push_back(fmt::format("{}: the cross-axis terms (max |{:.3g}|) are not exported: PX4 applies per-axis "
                                       "offsets{} only", inst, off.cwiseAbs().maxCoeff(), accel ? " and scales" : ""));
  if (!accel && !(t.A - Eigen::Matrix3d::Identity()).diagonal().isZero(0.0))
    res.warnings.push_back("gyroscope: the scale factors are not exported: PX4 applies gyro offsets only");
  if (!t.G.isZero(0.0)) res.warnings.push_back("gyroscope: the g-sensitivity is not exported: PX4 has no such parameter");
  body << fmt::format("1\t1\t{}_ID\t{}\t6\n", p, o.px4_device_id);
  if (o.px4_device_id == 0)
    res.warnings.push_back(p + "_ID = 0: set it to the sensor's PX4 device id on the vehicle, or PX4 ignores the calibration");
  auto real = [&](const std::string& name, double v) { body << fmt::format("1\t1\t{}\t{:.9g}\t9\n", name, v); };
  for (int k = 0; k < 3; ++k) real(fmt::format("{}_{}OFF", p, static_cast<char>('X' + k)), t.b[k]);
  if (accel)
    for (int k = 0; k < 3; ++k) real(fmt::format("{}_{}SCALE", p, static_cast<char>('X' + k)), 1.0 / t.A(k, k));
}

// Per instrument: the thermal calibration where the run has a temperature model, else the static
// calibration.
ExportResult export_px4(const fs::path& run, const RunResults& rr, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  const auto ims = calibrations(run, rr, o, res);
  std::ostringstream body;
  for (int i = 0; i < 2; ++i) {
    const char* inst = i == 0 ? "accelerometer" : "gyroscope";
    const InstrumentModels& im = ims[static_cast<std::size_t>(i)];
    if (im.has_temp()) {
      px4_thermal(body, im, inst, o, res);
      for (const auto& source : im.calib_source)
        if (!source.empty() && source.rfind("temp_poly", 0) != 0) {
          res.notes.push_back(fmt::format("{}: thermal parameters (TC_*) written; the static calibration from {} is not "
                                          "(PX4 would add its offsets to the thermal ones)", inst, source));
          break;
        }
    } else if (im.has_calib()) {
      px4_static(body, im, inst, o, res);
    } else {
      res.warnings.push_back(fmt::format("{}: no calibration or temperature model in the run: no PX4 parameters for it", inst));
    }
  }
  if (body.str().empty())
    throw std::runtime_error("no calibration (ceres.json, fit.json) or temperature model (temp_poly.json) in " +
                             run.string() + ": nothing to export for PX4");
  std::ostringstream f;
  f << "# Onboard parameters for Vehicle 1\n#\n";
  f << fmt::format("# PX4 calibration written by Stend from {} (sensor {} {} serial '{}')\n", run.filename().string(),
                   rr.vendor, rr.model, rr.serial);
  f << "# TC_*: offset(T) = X0 + X1*dT + X2*dT^2 + X3*dT^3, dT = T - TREF (degC, clamped to TMIN..TMAX)\n";
  f << "# CAL_*: accel corrected = (raw - OFF) * SCALE, gyro corrected = raw - OFF; SI units (m/s^2, rad/s)\n#\n";
  f << "# Vehicle-Id Component-Id Name Value Type\n";
  f << body.str();
  write_file_atomic(out, f.str());
  res.files.push_back(out);
  return res;
}

// ---- MATLAB -------------------------------------------------------------------------------------
struct MatStruct {
  std::vector<std::string> names;
  std::vector<matvar_t*> values;
  void add(const std::string& n, std::vector<double> v, std::size_t rows, std::size_t cols) {
    std::size_t dims[2] = {rows, cols};
    names.push_back(n);
    values.push_back(Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, v.data(), 0));
  }
  void add_text(const std::string& n, const std::string& s) {
    std::size_t dims[2] = {1, s.size()};
    std::string copy = s;
    names.push_back(n);
    values.push_back(Mat_VarCreate(nullptr, MAT_C_CHAR, MAT_T_UINT8, 2, dims, copy.data(), 0));
  }
  void write(mat_t* mat, const char* name) {
    std::vector<const char*> fields;
    for (const auto& n : names) fields.push_back(n.c_str());
    std::size_t dims[2] = {1, 1};
    matvar_t* st = Mat_VarCreateStruct(name, 2, dims, fields.data(), static_cast<unsigned>(fields.size()));
    for (std::size_t i = 0; i < names.size(); ++i) Mat_VarSetStructFieldByName(st, names[i].c_str(), 0, values[i]);
    const int failed = Mat_VarWrite(mat, st, MAT_COMPRESSION_NONE);
    Mat_VarFree(st);  // frees the fields too
    if (failed != 0) throw IoError(fmt::format("cannot write the variable {} to the .mat file", name));
  }
};

// MATLAB imuSensor calibration arrays of one instrument at T0 [°C]: ConstantBias (1×3),
// AxesMisalignment (3×3, column-major, percent), TemperatureBias (per °C) and
// TemperatureScaleFactor (percent per °C); gyroscope AccelerationBias (1×3, the diagonal of G);
// what is missing is noted in not_estimated.
struct MatlabCalibration {
  std::vector<double> bias = std::vector<double>(3), mis = std::vector<double>(9), tb = std::vector<double>(3),
                      tsf = std::vector<double>(3), gbias = std::vector<double>(3);
};

MatlabCalibration matlab_calibration(const InstrumentModels& im, const char* inst, std::string& not_estimated,
                                     ExportResult& res) {
  MatlabCalibration c;
  const double T0 = reference_of(im);
  const Triad t = triad_at(im, T0);
  for (int k = 0; k < 3; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    c.bias[uk] = t.b[k];
    // MATLAB's 3×3 AxesMisalignment in percent: diagonal 100·(1 + scale error), off-diagonal
    // 100·cross-axis sensitivity; column-major storage for MAT files.
    for (int j = 0; j < 3; ++j) c.mis[static_cast<std::size_t>(j * 3 + k)] = 100.0 * t.A(k, j);
    c.gbias[uk] = t.G(k, k);
    // Linear temperature coefficients at T0: central differences of the model over ±1 °C.
    const auto& tm = im.temp[uk];
    c.tb[uk] = tm ? 0.5 * (offset_at(tm, k, T0 + 1) - offset_at(tm, k, T0 - 1)) : 0.0;
    c.tsf[uk] = tm ? 100.0 * 0.5 * (input_row(tm, k, T0 + 1)[k] - input_row(tm, k, T0 - 1)[k]) : 0.0;
    if (!tm) not_estimated += fmt::format("{} axis {}: TemperatureBias, TemperatureScaleFactor; ", inst, kAxisNames[k]);
  }
  if (!t.unfitted.empty()) not_estimated += fmt::format("{} axes {}: ConstantBias, AxesMisalignment; ", inst, t.unfitted);
  const Eigen::Matrix3d off = t.G - Eigen::Matrix3d(t.G.diagonal().asDiagonal());
  if (!off.isZero(0.0))
    res.warnings.push_back(fmt::format("{}: the off-diagonal g-sensitivity (max |{:.3g}| (rad/s)/(m/s^2)) is not exported: "
                                       "MATLAB's AccelerationBias holds one number per axis", inst, off.cwiseAbs().maxCoeff()));
  return c;
}

// NoiseDensity, BiasInstability and RandomWalk per axis from allan.json (the Allan N, B and K of
// each axis); 0 where not identified (noted in not_estimated).
void add_matlab_noise(MatStruct& s, const RunResults& rr, const char* inst, std::string& not_estimated) {
  for (const auto& [symbol, field] : {std::pair{"N", "NoiseDensity"}, {"B", "BiasInstability"}, {"K", "RandomWalk"}}) {
    const Eigen::Vector3d v = allan_per_axis(rr, inst, symbol);
    std::vector<double> out(3);
    for (int k = 0; k < 3; ++k) {
      out[static_cast<std::size_t>(k)] = std::isfinite(v[k]) ? v[k] : 0.0;
      if (!std::isfinite(v[k])) not_estimated += fmt::format("{} axis {}: {}; ", inst, kAxisNames[k], field);
    }
    s.add(field, out, 1, 3);
  }
}

// The accelparams / gyroparams struct of one instrument (sensor description from run.json `info`).
void write_matlab_params(mat_t* mat, const RunResults& rr, const json& info, const InstrumentModels& im,
                         const char* inst, ExportResult& res, std::string& not_estimated) {
  const bool accel = inst[0] == 'a';
  MatStruct s;
  s.add("MeasurementRange", {jnum(info, accel ? "accel_range_mps2" : "gyro_range_radps")}, 1, 1);
  s.add("Resolution", {jnum(info, accel ? "accel_lsb_mps2" : "gyro_lsb_radps")}, 1, 1);
  const MatlabCalibration c = matlab_calibration(im, inst, not_estimated, res);
  s.add("ConstantBias", c.bias, 1, 3);
  s.add("AxesMisalignment", c.mis, 3, 3);
  add_matlab_noise(s, rr, inst, not_estimated);
  s.add("TemperatureBias", c.tb, 1, 3);
  s.add("TemperatureScaleFactor", c.tsf, 1, 3);
  if (!accel) s.add("AccelerationBias", c.gbias, 1, 3);
  s.write(mat, accel ? "accelparams" : "gyroparams");
}

// The stend_info struct: run identity, procedure, what was exported as 0, units.
void write_matlab_info(mat_t* mat, const RunResults& rr, const std::string& not_estimated) {
  MatStruct meta;
  meta.add_text("run", rr.run_name);
  meta.add_text("vendor", rr.vendor);
  meta.add_text("model", rr.model);
  meta.add_text("serial", rr.serial);
  meta.add_text("procedure_fingerprint", rr.procedure_fingerprint);
  meta.add_text("not_estimated", not_estimated);
  meta.add_text("units", "SI: m/s^2, rad/s, degC; AxesMisalignment and TemperatureScaleFactor in percent");
  meta.write(mat, "stend_info");
}

ExportResult export_matlab(const fs::path& run, const RunResults& rr, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  json runj;
  {
    std::ifstream in(run / "run.json");
    runj = json::parse(in);
  }
  const json info = runj.value("sensor", json::object()).value("info", json::object());
  const auto ims = calibrations(run, rr, o, res);
  const bool noise = std::any_of(rr.parameters.begin(), rr.parameters.end(), [](const ParameterResult& p) {
    return p.estimator == "allan" && p.identifiable;
  });
  if (!ims[0].has_calib() && !ims[1].has_calib() && !ims[0].has_temp() && !ims[1].has_temp() && !noise)
    throw std::runtime_error("no calibration (ceres.json, fit.json, temp_poly.json) and no noise model (allan.json) in " +
                             run.string() + ": nothing to export for MATLAB");
  std::string not_estimated;
  write_file_atomic(out, [&](const fs::path& tmp) {
    mat_t* mat = Mat_CreateVer(tmp.c_str(), nullptr, MAT_FT_MAT5);
    if (!mat) throw IoError("cannot write " + out.string() + ": matio could not create the .mat file");
    try {
      write_matlab_params(mat, rr, info, ims[0], "accelerometer", res, not_estimated);
      write_matlab_params(mat, rr, info, ims[1], "gyroscope", res, not_estimated);
      write_matlab_info(mat, rr, not_estimated);
    } catch (...) {
      Mat_Close(mat);
      throw;
    }
    if (Mat_Close(mat) != 0) throw IoError("cannot write " + out.string() + ": matio could not close the .mat file");
  });
  if (!not_estimated.empty()) res.warnings.push_back("exported as 0 (not estimated): " + not_estimated);
  res.files.push_back(out);
  return res;
}

}  // namespace

const std::vector<std::string>& export_formats() {
  static const std::vector<std::string> f = {"kalibr", "matlab", "imutk", "px4", "json", "csv"};
  return f;
}

ExportResult export_run(const fs::path& run_dir, const std::string& format, fs::path out,
                        const estimation::Registry& registry, const ExportOptions& options) {
  if (format == "csv") {  // the recording itself, as a CSV run folder
    if (out.empty()) out = run_dir / "export" / "csv";
    const Recording rec = Recording::open(run_dir, SampleLoading::kStream);
    if (!options.accept_damaged) require_whole(rec);
    write_recording(rec, out, RecordingWriterOptions{RecordingFormat::kCsv});
    ExportResult r;
    for (const char* f : {"run.json", "experiment.yaml", "imu.csv", "truth.csv", "segments.csv", "events.csv"})
      r.files.push_back(out / f);
    if (!rec.damage.empty()) r.warnings.push_back(fmt::format("{} of {} samples exported: {}", rec.sample_count(), rec.written_samples, rec.damage));
    return r;
  }
  const RunResults rr = load_run_results(run_dir, registry);
  const fs::path run = rr.dir;
  if (out.empty()) {
    fs::create_directories(run / "export");
    const std::map<std::string, std::string> names = {{"kalibr", "imu.yaml"},        {"matlab", "stend_params.mat"},
                                                      {"imutk", "imutk"},            {"px4", "px4.params"},
                                                      {"json", "results.json"}};
    const auto it = names.find(format);
    if (it == names.end()) throw std::runtime_error("unknown export format '" + format + "' (kalibr|matlab|imutk|px4|json)");
    out = run / "export" / it->second;
  } else if (out.has_parent_path()) {
    fs::create_directories(out.parent_path());
  }
  if (format == "kalibr") return export_kalibr(run, rr, out, options);
  if (format == "imutk") return export_imutk(run, rr, out, options);
  if (format == "px4") return export_px4(run, rr, out, options);
  if (format == "matlab") return export_matlab(run, rr, out, options);
  if (format == "json") {
    write_file_atomic(out, to_json(rr).dump(2) + '\n');
    ExportResult r;
    r.files.push_back(out);
    return r;
  }
  throw std::runtime_error("unknown export format '" + format + "' (kalibr|matlab|imutk|px4|json)");
}

}  // namespace stend::reporting
