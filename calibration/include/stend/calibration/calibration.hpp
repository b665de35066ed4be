// A fitted calibration as a correction: read back from any estimator's results through the
// estimator registry (its typed result, stend/estimation/result.hpp) and applied to a recording
// through the inverse of the error model (ErrorModel::correct, written beside measure in
// stend/model/terms.hpp).
//
// The correction is built from the result's instrument models (each the vocabulary's terms, θ and
// what the fit identified), whichever estimator fitted them: an instrument part that failed is not
// applied, and an axis whose fit failed is left uncalibrated (both named in `notes`). A parameter
// the estimator holds at 0 where 0 is exact (ParameterEstimate::zero_is_exact: a frame convention,
// an order the selection left out, an axis outside the fit) is applied as 0. A parameter the fit
// did not determine — not identifiable, aliased, or held at 0 where 0 is a guess — is refused
// unless the user states its value (an Assumption), which is then recorded (`assumed`, and the
// event write_calibrated writes).
//
// Applying: accelerometer first, u_a = correct_a(y_a; T); then the gyroscope with the calibrated
// specific force for its g-sensitivity, u_g = correct_g(y_g; f = u_a, T). T is each sample's
// temperature [degC] (required when the model has temperature terms). Counts stay the raw ones;
// the SI columns are calibrated.
#pragma once

#include <stend/estimation/assumption.hpp>
#include <stend/estimation/registry.hpp>
#include <stend/estimation/result.hpp>
#include <stend/model/terms.hpp>
#include <stend/recording/recording.hpp>

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace stend::calibration {

// One instrument's correction.
struct InstrumentCalibration {
  model::ErrorModel model;
  std::vector<double> theta;                              // model.size() values applied; empty: not calibrated
  std::vector<estimation::ParameterEstimate> parameters;  // as fitted, vocabulary names, one per θ entry
  std::vector<int> axes = {0, 1, 2};  // the output axes it calibrates (the others pass as recorded)
  bool present() const { return !theta.empty(); }
  // The fitted parameter of that name, or nullptr.
  const estimation::ParameterEstimate* find(const std::string& name) const;
  // Standard error of a parameter [its unit]; 0 when the fit did not estimate it.
  double std_error(const std::string& name) const;
};

// A value the user states for a parameter the fit did not determine (`stend apply --assume
// bias_x=0`): the one definition, shared with the exports (stend/estimation/assumption.hpp).
using estimation::Assumption;
using estimation::parse_assumptions;

struct Calibration {
  std::string source;     // the results file
  std::string estimator;  // the estimator that fitted it ("batch_lsq", "ceres_nonlinear", …)
  InstrumentCalibration accel, gyro;
  double gravity_mps2 = 0.0;  // the fit's local gravity when it states one, else 0
  // Temperature range the fit saw [degC] (a temperature model), NaN when not stated.
  double valid_min_c = NAN, valid_max_c = NAN;
  std::vector<std::string> notes;  // parts that failed, axes left uncalibrated
  // The values the user stated for parameters the fit did not determine, one line each:
  // "accelerometer bias_x = 0 m/s^2 (not identifiable: …)".
  std::vector<std::string> assumed;

  bool needs_temperature() const;
  // "ceres_nonlinear calibration from FILE: accelerometer (bias, scale, cross_axis), gyroscope (…)".
  void print(std::ostream& os) const;
};

// The correction of a typed result (read from `source`), with the values `assumed` for parameters
// the fit did not determine. Throws stend::InputError naming `source` when the result holds no
// accelerometer or gyroscope model, every part of it failed, a parameter the fit did not
// determine has no assumed value (each such parameter named, with why), or an assumption names no
// such parameter.
Calibration calibration_from(const estimation::FitResult& result, const std::string& source,
                             const std::vector<Assumption>& assumed = {});
// Reads a results file through the registry (the entry of the estimator that wrote it) and
// builds its correction. Throws stend::InputError naming the file when it cannot be read, is not a
// results document, or cannot be applied (calibration_from).
Calibration load_calibration(const std::filesystem::path& results_file, const estimation::Registry& registry,
                             const std::vector<Assumption>& assumed = {});

// Samples with a calibration applied as they are read (the instruments `cal` holds; the other one
// as recorded), a chunk at a time. A read throws stend::InputError when the model needs the
// temperature and a sample has none.
class CalibratedSamples final : public SampleSource {
 public:
  CalibratedSamples(std::shared_ptr<const SampleSource> raw, const Calibration& cal, std::string name);
  std::uint64_t size() const override { return raw_->size(); }
  void read(std::uint64_t first, std::size_t count, ImuSample* out) const override;

 private:
  std::shared_ptr<const SampleSource> raw_;
  const Calibration& cal_;
  std::string name_;  // the raw recording, for errors
};

// The recording with every sample corrected as it is read (CalibratedSamples over raw's samples:
// valid while `raw` and `cal` live). Throws stend::InputError when the model needs the
// temperature and a sample has none.
Recording apply_calibration(const Recording& raw, const Calibration& cal);

// Writes `calibrated` as a new run folder `out_dir` (which must not exist): samples, truth,
// segments, the recording's events, and an event naming the calibration applied. Throws
// stend::InputError when `out_dir` exists.
void write_calibrated(const Recording& calibrated, const Calibration& cal, const std::filesystem::path& out_dir);

}  // namespace stend::calibration
