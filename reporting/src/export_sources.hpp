// Internal to the exports (exports.hpp): what each format writes from — the run's results files
// read back through the estimator registry as typed results, the calibration of each instrument
// chosen by the rule of ExportOptions::from, the affine calibration of an instrument at a
// temperature, and the noise coefficients. Nothing here knows an estimator or a document's shape:
// the rule is written on the typed models (one model of the three axes with scale factors,
// axis-wise models, temperature models) and on the estimator's name where the user names one.
#pragma once

#include "stend/estimation/registry.hpp"
#include "stend/estimation/result.hpp"
#include "stend/reporting/exports.hpp"
#include "stend/reporting/results.hpp"

#include <Eigen/Core>

#include <array>
#include <memory>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace stend::reporting::detail {

inline constexpr const char* kAxisNames = "xyz";

// One results file of the run, read back through the registry.
struct RunResult {
  std::string file;  // its name in the run folder
  estimation::FitResult fit;
};

// What every export reads: the run's identity (run.json, experiment.yaml) and its results files.
struct RunData {
  std::filesystem::path dir;
  RunResults identity;              // vendor, model, serial, fingerprint (results.hpp)
  std::vector<RunResult> results;   // in file-name order
  const estimation::Registry* registry = nullptr;
  SensorInfo sensor;                // the recording's header: which instruments it holds

  // The first successful result with a noise analysis, nullptr when none.
  const RunResult* noise() const;
  // Why the run has nothing of `instrument` to export: "" when the recording has it, else "the
  // recording has no accelerometer (…)" (stend/recording/instruments.hpp).
  std::string absent(model::Instrument instrument) const;
};

// Reads the results files of the run `identity` describes (load_run_results): each registered
// estimator's (estimation::results_files_of) and any other "<its stem>*.json" in the folder, by
// name, and the recording's header. Throws InputError naming a file that is not JSON.
RunData read_run(RunResults identity, const estimation::Registry& registry);

// Per output axis of one instrument: the calibration (bias, scale, cross-axis at the reference
// temperature) and the temperature model, and the file each came from.
struct InstrumentModels {
  std::array<const estimation::InstrumentModel*, 3> calib{};  // nullptr: no model of the axis
  std::array<const estimation::InstrumentModel*, 3> temp{};   // temperature models
  std::array<std::string, 3> calib_source, temp_source;
  double reference_c = 25.0;
  double tmin = NAN, tmax = NAN;
  // Copies of the models above with what the fit did not determine set from the user's --assume
  // (calib and temp point into them once calibrations() has settled them).
  std::vector<std::shared_ptr<const estimation::InstrumentModel>> settled;
  bool has_calib() const;
  bool has_temp() const;
};

// The calibrations of both instruments [accelerometer, gyroscope] by the rule of
// ExportOptions::from (exports.hpp); what was used and what the user assumed go to res.notes.
// Refuses (InputError) an unknown source, a source named by --from that has none, (auto) a failed
// calibration when nothing else calibrates, or a parameter the fit did not determine that
// ExportOptions::assumed gives no value (estimation::settle_undetermined).
std::array<InstrumentModels, 2> calibrations(const RunData& run, const ExportOptions& o, ExportResult& res);

// One instrument's affine calibration at T [°C]: y = A·u + b + G·f (SI: m/s², rad/s). An axis no
// model fitted has an identity row and 0 bias (named in `unfitted`).
struct Triad {
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
  std::string unfitted;  // "x, y" or ""
};
Triad triad_at(const InstrumentModels& im, double temperature_c);
// The temperature of the calibrations: the temperature model's reference, 25 °C without one.
double reference_of(const InstrumentModels& im);
// Bias of axis k at T [°C] through the model (0 without one).
double offset_at(const estimation::InstrumentModel* m, int k, double temperature_c);
// Row k of the input matrix A at T [°C] through the model (the identity row without one).
Eigen::RowVector3d input_row(const estimation::InstrumentModel* m, int k, double temperature_c);

// One noise coefficient per axis of an instrument: "N", "K" or "B"; NaN where not identified.
Eigen::Vector3d noise_per_axis(const estimation::NoiseResult& noise, model::Instrument instrument, char symbol);

std::string g17(double v);  // %.17g
model::Instrument instrument_of(const char* name);  // "accelerometer" | "gyroscope"

}  // namespace stend::reporting::detail
