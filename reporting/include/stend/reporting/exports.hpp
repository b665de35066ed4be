// Exports of a run's results into other tools' formats (`stend export RUN --to FORMAT`):
//   kalibr  Kalibr IMU yaml (imu.yaml): noise densities and random walks from allan.json (the worst
//           axis of each sensor), rostopic, update_rate; with an accelerometer and a gyroscope
//           calibration also Kalibr's scale-misalignment intrinsics (M, A, C_gyro_i)
//   matlab  stend_params.mat (MAT 5): structs `accelparams` and `gyroparams` with the fields of
//           MATLAB's accelparams / gyroparams objects (noise per axis), plus `stend_info`
//   imutk   IMU-TK CalibratedTriad files imutk_acc.calib / imutk_gyro.calib: misalignment T (3×3),
//           scale K (3×3), bias B (3), so that x_calibrated = T·K·(x_raw − B) in SI units
//   px4     PX4 parameters (QGroundControl .params file): thermal calibration TC_A0_* / TC_G0_*
//           where the run has a temperature model, else the static CAL_ACC0_* / CAL_GYRO0_*
//   json    the results JSON, schema stend.results/1 (docs/reports.md)
// The calibration (bias, scale, cross-axis, g-sensitivity) comes from ceres.json, fit.json
// (batch_lsq) or temp_poly*.json by the rule of ExportOptions::from; which was used is in
// ExportResult::notes. A source that is absent or failed is refused (std::runtime_error naming it).
// Values the fit could not identify, and what the target format cannot hold, are listed in
// ExportResult::warnings — never silently.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace stend::estimation {
class Registry;
}

namespace stend::reporting {

struct ExportOptions {
  std::string rostopic = "/imu0";  // Kalibr
  int px4_instance = 0;            // TC_A<n> / TC_G<n>
  int px4_device_id = 0;           // TC_A0_ID / CAL_ACC0_ID: the sensor's PX4 device id (0: fill in on the vehicle)
  // Calibration source: "auto" (Ceres when it estimated the instrument's scale factors, else
  // fit.json then temp_poly.json axis by axis, else a Ceres bias-only result) | "ceres" |
  // "batch_lsq" | "temp_poly". Temperature models always come from temp_poly*.json (one per
  // instrument), noise from allan.json.
  std::string from = "auto";
  // csv: copy the readable part of a damaged run (else a damaged run is refused).
  bool accept_damaged = false;
};

struct ExportResult {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> warnings;  // what is exported as 0 / identity, or cannot be represented
  std::vector<std::string> notes;     // which result each value came from, and format conventions
};

// Formats known to export_run.
const std::vector<std::string>& export_formats();

// Writes `format` for the run folder. `out`: a file (json, kalibr, matlab, px4) or a path prefix
// (imutk: <out>_acc.calib, <out>_gyro.calib); empty → RUN/export/<default name>. Throws
// std::runtime_error saying what is missing (e.g. "no allan.json: run stend fit … first").
ExportResult export_run(const std::filesystem::path& run_dir, const std::string& format, std::filesystem::path out,
                        const estimation::Registry& registry, const ExportOptions& options = {});

}  // namespace stend::reporting
