// Exports of a run's results (see exports.hpp).
#include "stend/reporting/exports.hpp"

#include "fitted_model.hpp"
#include "stend/estimation/summary.hpp"
#include "stend/reporting/results.hpp"

#include <fmt/format.h>
#include <matio.h>
#include <nlohmann/json.hpp>

#include <Eigen/Dense>

#include <array>
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

// Per output axis of one instrument: the model (from fit.json / ceres.json, else temp_poly) that
// fitted that axis, and where it came from.
struct InstrumentModels {
  std::array<std::optional<FittedModel>, 3> calib;  // bias, scale, cross-axis at the reference temperature
  std::array<std::optional<FittedModel>, 3> temp;   // temp_poly (temperature polynomials)
  std::array<std::string, 3> calib_source, temp_source;
  double reference_c = 25.0;
  double tmin = NAN, tmax = NAN;
  bool any() const {
    for (const auto& c : calib)
      if (c) return true;
    for (const auto& t : temp)
      if (t) return true;
    return false;
  }
};

InstrumentModels models_for(const fs::path& run, const std::string& instrument, std::vector<std::string>& warnings) {
  InstrumentModels im;
  for (const char* file : {"fit.json", "ceres.json"}) {
    auto d = load_json(run / file);
    if (!d || !doc_ok(*d) || instrument_of(*d) != instrument || !d->contains("parameters")) continue;
    for (int k = 0; k < 3; ++k)
      if (!im.calib[static_cast<std::size_t>(k)] && fits_axis(*d, k)) {
        im.calib[static_cast<std::size_t>(k)] = detail::fitted_model(*d);
        im.calib_source[static_cast<std::size_t>(k)] = file;
      }
  }
  if (auto tp = load_json(run / "temp_poly.json"); tp && doc_ok(*tp) &&
                                                  jstr(tp->value("options", json::object()), "instrument") == instrument) {
    im.reference_c = jnum(*tp, "reference_c");
    const json vr = tp->value("valid_range_c", json::array());
    im.tmin = detail::jat(vr, 0);
    im.tmax = detail::jat(vr, 1);
    for (const auto& ax : tp->value("axes", json::array())) {
      const std::string a = jstr(ax, "axis");
      const auto pos = std::string(kAxisNames).find(a);
      if (a.size() != 1 || pos == std::string::npos || !ax.value("ok", false) || !ax.contains("fit") || ax["fit"].is_null())
        continue;
      im.temp[pos] = detail::fitted_model(ax["fit"]);
      im.temp_source[pos] = "temp_poly.json";
      if (!im.calib[pos]) {
        im.calib[pos] = im.temp[pos];
        im.calib_source[pos] = "temp_poly.json";
      }
    }
  }
  for (int k = 0; k < 3; ++k) {
    const auto& c = im.calib[static_cast<std::size_t>(k)];
    if (c && !c->not_identified.empty()) {
      std::string names;
      for (const auto& n : c->not_identified) names += (names.empty() ? "" : ", ") + n;
      warnings.push_back(fmt::format("{} axis {}: not identified, exported as 0: {}", instrument, kAxisNames[k], names));
    }
  }
  return im;
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

std::string g17(double v) { return fmt::format("{:.17g}", v); }

// ---- Kalibr -------------------------------------------------------------------------------------
ExportResult export_kalibr(const fs::path& run, const RunResults& rr, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  auto al = load_json(run / "allan.json");
  if (!al || !al->contains("kalibr"))
    throw std::runtime_error(
        "no allan.json in " + run.string() +
        ": the Kalibr noise model comes from the Allan analysis; run `stend fit RUN -m estimators/allan/example/allan.yaml` "
        "on a long static recording first");
  const json& k = (*al)["kalibr"];
  auto value = [&](const char* key, const char* id_flag, const char* ub_flag) {
    const double v = jnum(k, key);
    if (!std::isfinite(v)) throw std::runtime_error(std::string("allan.json: no value for ") + key + ": cannot export Kalibr");
    std::string note = "identified";
    if (ub_flag && k.value(ub_flag, false)) {
      note = "UPPER BOUND: not identified";
      res.warnings.push_back(std::string(key) + " is an upper bound (the record is too short to identify it)");
    } else if (id_flag && !k.value(id_flag, false)) {
      note = "from the slope read-off, not the model fit";
    }
    return std::make_pair(v, note);
  };
  const auto an = value("accelerometer_noise_density", "accelerometer_noise_identified", nullptr);
  const auto ar = value("accelerometer_random_walk", "accelerometer_random_walk_identified", "accelerometer_random_walk_is_upper_bound");
  const auto gn = value("gyroscope_noise_density", "gyroscope_noise_identified", nullptr);
  const auto gr = value("gyroscope_random_walk", "gyroscope_random_walk_identified", "gyroscope_random_walk_is_upper_bound");
  std::ofstream f(out);
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
  if (!f) throw std::runtime_error(out.string() + ": write failed");
  res.files.push_back(out);
  return res;
}

// ---- IMU-TK -------------------------------------------------------------------------------------
void write_imutk(const fs::path& file, const Eigen::Matrix3d& T, const Eigen::Matrix3d& K, const Eigen::Vector3d& B) {
  std::ofstream f(file);
  for (int i = 0; i < 3; ++i) f << g17(T(i, 0)) << ' ' << g17(T(i, 1)) << ' ' << g17(T(i, 2)) << '\n';
  f << '\n';
  for (int i = 0; i < 3; ++i) f << g17(K(i, 0)) << ' ' << g17(K(i, 1)) << ' ' << g17(K(i, 2)) << '\n';
  f << '\n';
  for (int i = 0; i < 3; ++i) f << g17(B(i)) << '\n';
  if (!f) throw std::runtime_error(file.string() + ": write failed");
}

ExportResult export_imutk(const fs::path& run, const fs::path& prefix) {
  ExportResult res;
  for (const char* inst : {"accelerometer", "gyroscope"}) {
    const InstrumentModels im = models_for(run, inst, res.warnings);
    bool any = false;
    for (const auto& c : im.calib) any = any || c.has_value();
    if (!any) continue;
    const double T0 = std::isfinite(im.reference_c) ? im.reference_c : 25.0;
    Eigen::Matrix3d A;
    Eigen::Vector3d b;
    for (int k = 0; k < 3; ++k) {
      const auto& m = im.calib[static_cast<std::size_t>(k)];
      if (!m) res.warnings.push_back(fmt::format("{} axis {}: not fitted, exported as identity/0", inst, kAxisNames[k]));
      A.row(k) = input_row(m, k, T0);
      b[k] = offset_at(m, k, T0);
    }
    // IMU-TK: x = T·K·(y − B) with T unit-diagonal, K diagonal; ours: y = A·x + b.
    const Eigen::Matrix3d Ainv = A.inverse();
    const Eigen::Matrix3d K = Ainv.diagonal().asDiagonal();
    const Eigen::Matrix3d Tm = Ainv * K.inverse();
    const fs::path file = prefix.string() + (inst[0] == 'a' ? "_acc.calib" : "_gyro.calib");
    write_imutk(file, Tm, K, b);
    res.files.push_back(file);
  }
  if (res.files.empty())
    throw std::runtime_error("no accelerometer or gyroscope calibration in " + run.string() +
                             " (fit.json, ceres.json or temp_poly.json): nothing to export for IMU-TK");
  return res;
}

// ---- PX4 ----------------------------------------------------------------------------------------
ExportResult export_px4(const fs::path& run, const RunResults& rr, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  std::ostringstream body;
  for (const char* inst : {"accelerometer", "gyroscope"}) {
    const InstrumentModels im = models_for(run, inst, res.warnings);
    bool any = false;
    for (const auto& t : im.temp) any = any || t.has_value();
    if (!any) continue;
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
    auto real = [&](const std::string& name, double v) { body << fmt::format("1\t1\t{}\t{:.9g}\t9\n", name, v); };
    body << fmt::format("1\t1\tTC_{}_ENABLE\t1\t6\n", inst[0] == 'a' ? "A" : "G");
    body << fmt::format("1\t1\t{}_ID\t{}\t6\n", p, o.px4_device_id);
    if (o.px4_device_id == 0)
      res.warnings.push_back(p + "_ID = 0: set it to the sensor's PX4 device id on the vehicle, or PX4 ignores the calibration");
    real(p + "_TMAX", im.tmax);
    real(p + "_TMIN", im.tmin);
    real(p + "_TREF", tref);
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 3; ++k) real(fmt::format("{}_X{}_{}", p, c, k), coef[static_cast<std::size_t>(k)][c]);
  }
  if (body.str().empty())
    throw std::runtime_error("no temperature model (temp_poly.json) in " + run.string() +
                             ": run `stend fit RUN -m estimators/temp_poly/examples/temp_poly.yaml` on a temperature sweep first");
  std::ofstream f(out);
  f << "# Onboard parameters for Vehicle 1\n#\n";
  f << fmt::format("# PX4 thermal calibration written by Stend from {} (sensor {} {} serial '{}')\n",
                   run.filename().string(), rr.vendor, rr.model, rr.serial);
  f << "# offset(T) = X0 + X1*dT + X2*dT^2 + X3*dT^3, dT = T - TREF (degC, clamped to TMIN..TMAX); m/s^2 or rad/s\n#\n";
  f << "# Vehicle-Id Component-Id Name Value Type\n";
  f << body.str();
  if (!f) throw std::runtime_error(out.string() + ": write failed");
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
    Mat_VarWrite(mat, st, MAT_COMPRESSION_NONE);
    Mat_VarFree(st);  // frees the fields too
  }
};

// MATLAB imuSensor calibration arrays of one instrument at T0 [°C]: ConstantBias (1×3),
// AxesMisalignment (3×3, column-major, percent), TemperatureBias (per °C) and
// TemperatureScaleFactor (percent per °C); what is missing is noted in not_estimated.
struct MatlabCalibration {
  std::vector<double> bias = std::vector<double>(3), mis = std::vector<double>(9), tb = std::vector<double>(3),
                      tsf = std::vector<double>(3);
};

MatlabCalibration matlab_calibration(const InstrumentModels& im, const char* inst, double T0, std::string& not_estimated) {
  MatlabCalibration c;
  for (int k = 0; k < 3; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    const auto& m = im.calib[uk];
    c.bias[uk] = offset_at(m, k, T0);
    const Eigen::RowVector3d row = input_row(m, k, T0);
    // MATLAB's 3×3 AxesMisalignment in percent: diagonal 100·(1 + scale error), off-diagonal
    // 100·cross-axis sensitivity; column-major storage for MAT files.
    for (int j = 0; j < 3; ++j) c.mis[static_cast<std::size_t>(j * 3 + k)] = 100.0 * row[j];
    // Linear temperature coefficients at T0: central differences of the model over ±1 °C.
    const auto& t = im.temp[uk];
    c.tb[uk] = t ? 0.5 * (offset_at(t, k, T0 + 1) - offset_at(t, k, T0 - 1)) : 0.0;
    c.tsf[uk] = t ? 100.0 * 0.5 * (input_row(t, k, T0 + 1)[k] - input_row(t, k, T0 - 1)[k]) : 0.0;
    if (!m) not_estimated += fmt::format("{} axis {}: ConstantBias, AxesMisalignment; ", inst, kAxisNames[k]);
    if (!t) not_estimated += fmt::format("{} axis {}: TemperatureBias, TemperatureScaleFactor; ", inst, kAxisNames[k]);
  }
  return c;
}

// NoiseDensity, BiasInstability and RandomWalk from allan.json: the mean over the instrument's
// axes of N, B and K where identified, else 0 (noted in not_estimated).
void add_matlab_noise(MatStruct& s, const std::optional<json>& al, const char* inst, std::string& not_estimated) {
  double N = 0, B = 0, K = 0;
  int nN = 0, nB = 0, nK = 0;
  if (al)
    for (const auto& ch : al->value("channels", json::array())) {
      if (jstr(ch, "instrument") != inst) continue;
      const json m = ch.value("model", json::object());
      auto take = [&](const char* sym, double& acc, int& n) {
        const json c = m.value(sym, json::object());
        if (c.value("identified", false)) {
          acc += jnum(c, "value");
          ++n;
        }
      };
      take("N", N, nN);
      take("B", B, nB);
      take("K", K, nK);
    }
  auto mean_or_zero = [&](double acc, int n, const char* field) {
    if (n == 0) not_estimated += fmt::format("{}: {}; ", inst, field);
    return n ? acc / n : 0.0;
  };
  s.add("NoiseDensity", std::vector<double>(3, mean_or_zero(N, nN, "NoiseDensity")), 1, 3);
  s.add("BiasInstability", std::vector<double>(3, mean_or_zero(B, nB, "BiasInstability")), 1, 3);
  s.add("RandomWalk", std::vector<double>(3, mean_or_zero(K, nK, "RandomWalk")), 1, 3);
}

// The accelparams / gyroparams struct of one instrument (sensor description from run.json `info`).
void write_matlab_params(mat_t* mat, const fs::path& run, const json& info, const std::optional<json>& al,
                         const char* inst, ExportResult& res, std::string& not_estimated) {
  const bool accel = inst[0] == 'a';
  const InstrumentModels im = models_for(run, inst, res.warnings);
  const double T0 = std::isfinite(im.reference_c) ? im.reference_c : 25.0;
  MatStruct s;
  s.add("MeasurementRange", {jnum(info, accel ? "accel_range_mps2" : "gyro_range_radps")}, 1, 1);
  s.add("Resolution", {jnum(info, accel ? "accel_lsb_mps2" : "gyro_lsb_radps")}, 1, 1);
  const MatlabCalibration c = matlab_calibration(im, inst, T0, not_estimated);
  s.add("ConstantBias", c.bias, 1, 3);
  s.add("AxesMisalignment", c.mis, 3, 3);
  add_matlab_noise(s, al, inst, not_estimated);
  s.add("TemperatureBias", c.tb, 1, 3);
  s.add("TemperatureScaleFactor", c.tsf, 1, 3);
  if (!accel) s.add("AccelerationBias", {0.0, 0.0, 0.0}, 1, 3);
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

ExportResult export_matlab(const fs::path& run, const RunResults& rr, const fs::path& out) {
  ExportResult res;
  json runj;
  {
    std::ifstream in(run / "run.json");
    runj = json::parse(in);
  }
  const json info = runj.value("sensor", json::object()).value("info", json::object());
  auto al = load_json(run / "allan.json");
  mat_t* mat = Mat_CreateVer(out.c_str(), nullptr, MAT_FT_MAT5);
  if (!mat) throw std::runtime_error(out.string() + ": cannot create the .mat file");
  std::string not_estimated;
  for (const char* inst : {"accelerometer", "gyroscope"}) write_matlab_params(mat, run, info, al, inst, res, not_estimated);
  write_matlab_info(mat, rr, not_estimated);
  Mat_Close(mat);
  if (!not_estimated.empty()) res.warnings.push_back("exported as 0 (not estimated): " + not_estimated);
  res.files.push_back(out);
  return res;
}

}  // namespace

const std::vector<std::string>& export_formats() {
  static const std::vector<std::string> f = {"kalibr", "matlab", "imutk", "px4", "json"};
  return f;
}

ExportResult export_run(const fs::path& run_dir, const std::string& format, fs::path out, const ExportOptions& options) {
  const RunResults rr = load_run_results(run_dir);
  const fs::path run = rr.dir;
  if (out.empty()) {
    fs::create_directories(run / "export");
    const std::map<std::string, std::string> names = {{"kalibr", "imu.yaml"},        {"matlab", "stend_params.mat"},
                                                      {"imutk", "imutk"},            {"px4", "px4_thermal.params"},
                                                      {"json", "results.json"}};
    const auto it = names.find(format);
    if (it == names.end()) throw std::runtime_error("unknown export format '" + format + "' (kalibr|matlab|imutk|px4|json)");
    out = run / "export" / it->second;
  } else if (out.has_parent_path()) {
    fs::create_directories(out.parent_path());
  }
  if (format == "kalibr") return export_kalibr(run, rr, out, options);
  if (format == "imutk") return export_imutk(run, out);
  if (format == "px4") return export_px4(run, rr, out, options);
  if (format == "matlab") return export_matlab(run, rr, out);
  if (format == "json") {
    std::ofstream f(out);
    f << to_json(rr).dump(2) << '\n';
    if (!f) throw std::runtime_error(out.string() + ": write failed");
    ExportResult r;
    r.files.push_back(out);
    return r;
  }
  throw std::runtime_error("unknown export format '" + format + "' (kalibr|matlab|imutk|px4|json)");
}

}  // namespace stend::reporting
