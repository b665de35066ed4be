// `stend export --to kalibr`: Kalibr's imu.yaml — the noise densities of the run's noise analysis
// and, with an accelerometer and a gyroscope calibration, Kalibr's scale-misalignment intrinsics
// (see exports.hpp and docs/reports.md).
#include "export_formats.hpp"

#include "stend/errors.hpp"
#include "stend/recording/files.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/QR>

#include <sstream>

namespace stend::reporting::detail {

namespace fs = std::filesystem;

namespace {

// Kalibr takes one noise density and one random walk per sensor: the worst (largest) identified
// axis is written, and a note says which axis and what the others were. With no axis identified,
// the noise analysis's stand-in for the sensor (its slope read-off or upper bound) is written with
// a warning.
std::pair<double, std::string> kalibr_value(const RunResult& noise, const char* inst, char symbol, const char* key,
                                            ExportResult& res) {
  const estimation::NoiseResult& n = *noise.fit.noise;
  const Eigen::Vector3d v = noise_per_axis(n, instrument_of(inst), symbol);
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
  const estimation::SensorNoise& sensor = n.sensor(instrument_of(inst));
  const estimation::UnidentifiedDensity& d = symbol == 'N' ? sensor.white_noise : sensor.random_walk;
  if (!std::isfinite(d.value)) throw InputError(noise.file + ": no value for " + key + ": cannot export Kalibr");
  if (symbol == 'K' && d.upper_bound) {
    res.warnings.push_back(std::string(key) + " is an upper bound (the record is too short to identify it)");
    return {d.value, "UPPER BOUND: not identified"};
  }
  res.warnings.push_back(std::string(key) + ": no axis identified by the model fit; the largest slope read-off of the axes is written");
  return {d.value, "from the slope read-off, not the model fit"};
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

}  // namespace

ExportResult export_kalibr(const RunData& run, const fs::path& out, const ExportOptions& o) {
  ExportResult res;
  const RunResult* noise = run.noise();
  if (!noise)
    throw InputError(
        "no allan.json in " + run.dir.string() +
        ": the Kalibr noise model comes from the Allan analysis; run `stend fit RUN -m estimators/allan/example/allan.yaml` "
        "on a long static recording first");
  for (const auto inst : {model::Instrument::kAccelerometer, model::Instrument::kGyroscope})
    if (const std::string why = run.absent(inst); !why.empty())
      throw InputError(run.dir.string() + ": " + why +
                       ": Kalibr's imu.yaml needs the noise of both the accelerometer and the gyroscope; nothing "
                       "written (the noise of the one present is in allan.json; `stend export RUN --to matlab` "
                       "writes it alone)");
  const auto an = kalibr_value(*noise, "accelerometer", 'N', "accelerometer_noise_density", res);
  const auto ar = kalibr_value(*noise, "accelerometer", 'K', "accelerometer_random_walk", res);
  const auto gn = kalibr_value(*noise, "gyroscope", 'N', "gyroscope_noise_density", res);
  const auto gr = kalibr_value(*noise, "gyroscope", 'K', "gyroscope_random_walk", res);
  std::string intrinsics;
  try {
    intrinsics = kalibr_intrinsics(calibrations(run, o, res), res);
  } catch (const std::runtime_error& e) {  // the noise model stands alone unless a source was asked for
    if (o.from != "auto") throw;
    res.warnings.push_back(std::string("kalibr: no intrinsics written: ") + e.what());
  }
  const RunResults& id = run.identity;
  std::ostringstream f;
  f << fmt::format("# Kalibr IMU noise model (imu.yaml), written by Stend from {}/{}\n", run.dir.filename().string(), noise->file);
  f << fmt::format("# sensor: {} {} serial '{}'; Allan analysis of {} samples\n", id.vendor, id.model, id.serial,
                   noise->fit.noise->samples);
  f << "# Accelerometers\n";
  f << fmt::format("accelerometer_noise_density: {}  # [m/s^2/sqrt(Hz)] {}\n", g17(an.first), an.second);
  f << fmt::format("accelerometer_random_walk: {}  # [m/s^3/sqrt(Hz)] {}\n", g17(ar.first), ar.second);
  f << "# Gyroscopes\n";
  f << fmt::format("gyroscope_noise_density: {}  # [rad/s/sqrt(Hz)] {}\n", g17(gn.first), gn.second);
  f << fmt::format("gyroscope_random_walk: {}  # [rad/s^2/sqrt(Hz)] {}\n", g17(gr.first), gr.second);
  f << fmt::format("rostopic: {}\n", o.rostopic);
  f << fmt::format("update_rate: {}  # [Hz]\n", g17(noise->fit.noise->rate_hz));
  f << intrinsics;
  write_file_atomic(out, f.str());
  res.files.push_back(out);
  return res;
}

}  // namespace stend::reporting::detail
