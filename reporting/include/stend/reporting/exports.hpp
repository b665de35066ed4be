// Exports of a run's results into other tools' formats (`stend export RUN --to FORMAT`):
//   kalibr  Kalibr IMU yaml (imu.yaml) from allan.json: noise densities, random walks, rostopic,
//           update_rate
//   matlab  stend_params.mat (MAT 5): structs `accelparams` and `gyroparams` with the fields of
//           MATLAB's accelparams / gyroparams objects, plus `stend_info`
//   imutk   IMU-TK CalibratedTriad files imutk_acc.calib / imutk_gyro.calib: misalignment T (3×3),
//           scale K (3×3), bias B (3), so that x_calibrated = T·K·(x_raw − B) in SI units
//   px4     PX4 thermal-calibration parameters (QGroundControl .params file): TC_A0_* / TC_G0_*
//           offset polynomials X0…X3 about TREF, TMIN, TMAX, TC_A_ENABLE / TC_G_ENABLE
//   json    the results JSON, schema stend.results/1 (docs/reports.md)
// Values the fit could not identify are exported as 0 (or the format's neutral value) and listed
// in ExportResult::warnings — never silently.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace stend::reporting {

struct ExportOptions {
  std::string rostopic = "/imu0";  // Kalibr
  int px4_instance = 0;            // TC_A<n> / TC_G<n>
  int px4_device_id = 0;           // TC_A0_ID: the sensor's PX4 device id (0: fill in on the vehicle)
};

struct ExportResult {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> warnings;
};

// Formats known to export_run.
const std::vector<std::string>& export_formats();

// Writes `format` for the run folder. `out`: a file (json, kalibr, matlab, px4) or a path prefix
// (imutk: <out>_acc.calib, <out>_gyro.calib); empty → RUN/export/<default name>. Throws
// std::runtime_error saying what is missing (e.g. "no allan.json: run stend fit … first").
ExportResult export_run(const std::filesystem::path& run_dir, const std::string& format, std::filesystem::path out,
                        const ExportOptions& options = {});

}  // namespace stend::reporting
