// `stend export --to px4`: PX4 parameters (QGroundControl .params) — the static calibration CAL_*,
// and the thermal calibration TC_* where the run has a temperature model (the offsets then in TC_*,
// the accelerometer scale factors still in CAL_*) (see exports.hpp and docs/reports.md).
#include "export_formats.hpp"

#include "stend/errors.hpp"
#include "stend/recording/files.hpp"

#include <fmt/format.h>

#include <Eigen/QR>

#include <cmath>
#include <sstream>

namespace stend::reporting::detail {

namespace fs = std::filesystem;

namespace {

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
      for (const auto& t : m->model.terms)
        if (t.kind == model::TermKind::kScaleTemperature) {
          res.warnings.push_back(fmt::format(
              "{} axis {}: the scale-factor temperature polynomial is not exported (PX4's thermal compensation "
              "corrects offsets only; the scale factor at TREF is{})",
              inst, kAxisNames[k], inst[0] == 'a' ? " CAL_ACC*_*SCALE" : " not exported either: PX4 has no gyro scale"));
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
// (raw − TC offset(T) − XOFF)·XSCALE per axis and a gyroscope as raw − TC offset(T) − XOFF
// (src/lib/sensor_calibration; the TC offset 0 without thermal compensation): XOFF = b, or 0 when
// the TC_* polynomial (`thermal`) carries the offsets; accelerometer XSCALE = 1/A_kk at the
// reference temperature either way; what PX4 cannot apply is named in a warning.
void px4_static(std::ostringstream& body, const InstrumentModels& im, const char* inst, const ExportOptions& o,
                bool thermal, ExportResult& res) {
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
  for (int k = 0; k < 3; ++k) real(fmt::format("{}_{}OFF", p, static_cast<char>('X' + k)), thermal ? 0.0 : t.b[k]);
  if (accel)
    for (int k = 0; k < 3; ++k) real(fmt::format("{}_{}SCALE", p, static_cast<char>('X' + k)), 1.0 / t.A(k, k));
}

}  // namespace

ExportResult export_px4(const RunData& run, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  const auto ims = calibrations(run, o, res);
  std::ostringstream body;
  for (int i = 0; i < 2; ++i) {
    const char* inst = i == 0 ? "accelerometer" : "gyroscope";
    const InstrumentModels& im = ims[static_cast<std::size_t>(i)];
    if (const std::string why = run.absent(instrument_of(inst)); !why.empty()) {
      res.notes.push_back(fmt::format("{}: {}: no PX4 parameters for it", inst, why));
      continue;
    }
    // Per instrument: the thermal offsets where the run has a temperature model, and the static
    // calibration (its offsets 0 beside thermal ones).
    if (im.has_temp()) {
      px4_thermal(body, im, inst, o, res);
      px4_static(body, im, inst, o, true, res);
      res.notes.push_back(fmt::format("{}: offsets from the temperature model as TC_*; CAL_*_*OFF written as 0 (PX4 "
                                      "adds them to the thermal ones){}", inst,
                                      inst[0] == 'a' ? "; CAL_ACC*_*SCALE at TREF from the calibration" : ""));
    } else if (im.has_calib()) {
      px4_static(body, im, inst, o, false, res);
    } else {
      res.warnings.push_back(fmt::format("{}: no calibration or temperature model in the run: no PX4 parameters for it", inst));
    }
  }
  if (body.str().empty())
    throw InputError("no calibration (ceres.json, fit.json) or temperature model (temp_poly.json) in " +
                     run.dir.string() + ": nothing to export for PX4");
  std::ostringstream f;
  f << "# Onboard parameters for Vehicle 1\n#\n";
  f << fmt::format("# PX4 calibration written by Stend from {} (sensor {} {} serial '{}')\n", run.dir.filename().string(),
                   run.identity.vendor, run.identity.model, run.identity.serial);
  f << "# TC_*: offset(T) = X0 + X1*dT + X2*dT^2 + X3*dT^3, dT = T - TREF (degC, clamped to TMIN..TMAX)\n";
  f << "# CAL_*: accel corrected = (raw - TC offset - OFF) * SCALE, gyro corrected = raw - TC offset - OFF; SI units "
       "(m/s^2, rad/s)\n#\n";
  f << "# Vehicle-Id Component-Id Name Value Type\n";
  f << body.str();
  write_file_atomic(out, f.str());
  res.files.push_back(out);
  return res;
}

}  // namespace stend::reporting::detail
