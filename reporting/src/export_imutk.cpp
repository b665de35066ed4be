// `stend export --to imutk`: IMU-TK's CalibratedTriad files, x = T·K·(y − B) (see exports.hpp
// and docs/reports.md).
#include "export_formats.hpp"

#include "stend/errors.hpp"
#include "stend/recording/files.hpp"

#include <fmt/format.h>

#include <Eigen/LU>

#include <sstream>

namespace stend::reporting::detail {

namespace fs = std::filesystem;

namespace {

void write_imutk(const fs::path& file, const Eigen::Matrix3d& T, const Eigen::Matrix3d& K, const Eigen::Vector3d& B) {
  std::ostringstream f;
  for (int i = 0; i < 3; ++i) f << g17(T(i, 0)) << ' ' << g17(T(i, 1)) << ' ' << g17(T(i, 2)) << '\n';
  f << '\n';
  for (int i = 0; i < 3; ++i) f << g17(K(i, 0)) << ' ' << g17(K(i, 1)) << ' ' << g17(K(i, 2)) << '\n';
  f << '\n';
  for (int i = 0; i < 3; ++i) f << g17(B(i)) << '\n';
  write_file_atomic(file, f.str());
}

}  // namespace

ExportResult export_imutk(const RunData& run, const fs::path& prefix, const ExportOptions& o) {
  ExportResult res;
  const auto ims = calibrations(run, o, res);
  for (int i = 0; i < 2; ++i) {
    const char* inst = i == 0 ? "accelerometer" : "gyroscope";
    if (const std::string why = run.absent(instrument_of(inst)); !why.empty()) {
      res.notes.push_back(fmt::format("{}: {}: no IMU-TK file written for it", inst, why));
      continue;
    }
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
    throw InputError("no accelerometer or gyroscope calibration in " + run.dir.string() +
                             " (ceres.json, fit.json or temp_poly.json): nothing to export for IMU-TK");
  return res;
}

}  // namespace stend::reporting::detail
