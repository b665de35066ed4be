// `stend export --to matlab`: stend_params.mat (MAT 5) with MATLAB's accelparams / gyroparams
// fields and stend_info (see exports.hpp and docs/reports.md).
#include "export_formats.hpp"

#include "stend/errors.hpp"
#include "stend/recording/files.hpp"

#include <fmt/format.h>
#include <stend/matio_library.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

namespace stend::reporting::detail {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

double jnum(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return kNaN;
  return j[key].get<double>();
}

struct MatStruct {
  std::vector<std::string> names;
  std::vector<matvar_t*> values;
  void add(const std::string& n, std::vector<double> v, std::size_t rows, std::size_t cols) {
    std::size_t dims[2] = {rows, cols};
    names.push_back(n);
    values.push_back(matio().Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, v.data(), 0));
  }
  void add_text(const std::string& n, const std::string& s) {
    std::size_t dims[2] = {1, s.size()};
    std::string copy = s;
    names.push_back(n);
    values.push_back(matio().Mat_VarCreate(nullptr, MAT_C_CHAR, MAT_T_UINT8, 2, dims, copy.data(), 0));
  }
  void write(mat_t* mat, const char* name) {
    std::vector<const char*> fields;
    for (const auto& n : names) fields.push_back(n.c_str());
    std::size_t dims[2] = {1, 1};
    matvar_t* st = matio().Mat_VarCreateStruct(name, 2, dims, fields.data(), static_cast<unsigned>(fields.size()));
    for (std::size_t i = 0; i < names.size(); ++i) matio().Mat_VarSetStructFieldByName(st, names[i].c_str(), 0, values[i]);
    const int failed = matio().Mat_VarWrite(mat, st, MAT_COMPRESSION_NONE);
    matio().Mat_VarFree(st);  // frees the fields too
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

// NoiseDensity, BiasInstability and RandomWalk per axis from the noise analysis (the N, B and K of
// each axis); 0 where not identified (noted in not_estimated).
void add_matlab_noise(MatStruct& s, const estimation::NoiseResult* noise, const char* inst, std::string& not_estimated) {
  for (const auto& [symbol, field] : {std::pair{'N', "NoiseDensity"}, {'B', "BiasInstability"}, {'K', "RandomWalk"}}) {
    const Eigen::Vector3d v =
        noise ? noise_per_axis(*noise, instrument_of(inst), symbol) : Eigen::Vector3d(Eigen::Vector3d::Constant(kNaN));
    std::vector<double> out(3);
    for (int k = 0; k < 3; ++k) {
      out[static_cast<std::size_t>(k)] = std::isfinite(v[k]) ? v[k] : 0.0;
      if (!std::isfinite(v[k])) not_estimated += fmt::format("{} axis {}: {}; ", inst, kAxisNames[k], field);
    }
    s.add(field, out, 1, 3);
  }
}

// The accelparams / gyroparams struct of one instrument (sensor description from run.json `info`).
void write_matlab_params(mat_t* mat, const estimation::NoiseResult* noise, const json& info, const InstrumentModels& im,
                         const char* inst, ExportResult& res, std::string& not_estimated) {
  const bool accel = inst[0] == 'a';
  MatStruct s;
  s.add("MeasurementRange", {jnum(info, accel ? "accel_range_mps2" : "gyro_range_radps")}, 1, 1);
  s.add("Resolution", {jnum(info, accel ? "accel_lsb_mps2" : "gyro_lsb_radps")}, 1, 1);
  const MatlabCalibration c = matlab_calibration(im, inst, not_estimated, res);
  s.add("ConstantBias", c.bias, 1, 3);
  s.add("AxesMisalignment", c.mis, 3, 3);
  add_matlab_noise(s, noise, inst, not_estimated);
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

}  // namespace

ExportResult export_matlab(const RunData& run, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  json runj;
  {
    std::ifstream in(run.dir / "run.json");
    runj = json::parse(in);
  }
  const json info = runj.value("sensor", json::object()).value("info", json::object());
  const auto ims = calibrations(run, o, res);
  const RunResult* noise_result = run.noise();
  const estimation::NoiseResult* noise = noise_result ? &*noise_result->fit.noise : nullptr;
  if (!ims[0].has_calib() && !ims[1].has_calib() && !ims[0].has_temp() && !ims[1].has_temp() &&
      !(noise && noise->any_identified()))
    throw InputError("no calibration (ceres.json, fit.json, temp_poly.json) and no noise model (allan.json) in " +
                     run.dir.string() + ": nothing to export for MATLAB");
  std::string not_estimated;
  write_file_atomic(out, [&](const fs::path& tmp) {
    mat_t* mat = matio().Mat_CreateVer(tmp.c_str(), nullptr, MAT_FT_MAT5);
    if (!mat) throw IoError("cannot write " + out.string() + ": matio could not create the .mat file");
    try {
      for (const char* inst : {"accelerometer", "gyroscope"}) {
        if (const std::string why = run.absent(instrument_of(inst)); !why.empty()) {
          res.notes.push_back(fmt::format("{}: {}: no {} written", inst, why,
                                          inst[0] == 'a' ? "accelparams" : "gyroparams"));
          continue;
        }
        write_matlab_params(mat, noise, info, ims[inst[0] == 'a' ? 0 : 1], inst, res, not_estimated);
      }
      write_matlab_info(mat, run.identity, not_estimated);
    } catch (...) {
      matio().Mat_Close(mat);
      throw;
    }
    if (matio().Mat_Close(mat) != 0) throw IoError("cannot write " + out.string() + ": matio could not close the .mat file");
  });
  if (!not_estimated.empty()) res.warnings.push_back("exported as 0 (not estimated): " + not_estimated);
  res.files.push_back(out);
  return res;
}

}  // namespace stend::reporting::detail
