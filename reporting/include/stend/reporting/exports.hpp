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
// The run's results files are read back through the estimator registry as typed results
// (stend/estimation/result.hpp): the calibration (bias, scale, cross-axis, g-sensitivity) comes
// from their instrument models by the rule of ExportOptions::from (with the built-in estimators:
// ceres.json, fit.json of batch_lsq, temp_poly*.json), the noise from their noise analysis
// (allan.json); which was used is in ExportResult::notes. A source that is absent or failed is
// refused (stend::InputError naming it). Values the fit could not identify, and what the target
// format cannot hold, are listed in ExportResult::warnings — never silently.
#pragma once

#include <stend/estimation/assumption.hpp>
#include <stend/estimation/registry.hpp>

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
  // Calibration source, per instrument: "auto" — one model of the three axes that estimated the
  // scale factors (a full calibration: Ceres), else the axis-wise models (batch_lsq's fit.json),
  // then the temperature models at their reference temperature, axis by axis (temp_poly), else a
  // model of the three axes without scale factors (a Ceres bias-only gyro result); or the name of
  // an estimator (or the one name it begins: "ceres" for ceres_nonlinear): that estimator's models
  // only. Temperature models always come from the first temperature model of the instrument (one
  // per instrument: temp_poly.json, temp_poly-gyroscope.json), noise from the noise analysis.
  std::string from = "auto";
  // csv: copy the readable part of a damaged run (else a damaged run is refused).
  bool accept_damaged = false;
  // Values for the parameters the fit did not determine (`--assume bias_x=0`): without one, a
  // calibration with such a parameter is refused, as `stend apply` refuses it.
  std::vector<estimation::Assumption> assumed = {};

  // A ROS topic named, px4_instance 0..3, px4_device_id ≥ 0, a source named (export_run resolves the
  // name against the registry: calibration_source).
  bool IsValid(std::string* error = nullptr) const;
};

struct ExportResult {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> warnings;  // what is exported as 0 / identity, or cannot be represented
  std::vector<std::string> notes;     // which result each value came from, and format conventions
};

// The estimator ExportOptions::from names: nullptr for "auto", else the registry's entry of that
// name or the only one whose name begins with it ("ceres" → ceres_nonlinear). Throws
// stend::InputError naming the estimators for anything else.
const estimation::EstimatorEntry* calibration_source(const estimation::Registry& registry, const std::string& from);

// Formats known to export_run.
const std::vector<std::string>& export_formats();

// Writes `format` for the run folder, its results read through `registry` (the program passes
// stend::estimators::builtin()). `out`: a file (json, kalibr, matlab, px4) or a path prefix
// (imutk: <out>_acc.calib, <out>_gyro.calib); empty → RUN/export/<default name>. Throws
// stend::InputError saying what is missing (e.g. "no allan.json: run stend fit … first").
ExportResult export_run(const std::filesystem::path& run_dir, const std::string& format, std::filesystem::path out,
                        const estimation::Registry& registry, const ExportOptions& options = {});

}  // namespace stend::reporting
