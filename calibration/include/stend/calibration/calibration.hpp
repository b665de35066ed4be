// A fitted calibration as a correction: read back from any estimator's results document and
// applied to a recording through the inverse of the error model (ErrorModel::correct, written
// beside measure in stend/model/terms.hpp).
//
// Results documents read (each fit's parameters carry the vocabulary's names):
//   - batch_lsq ("stend.fit/1"): one instrument, `model` and `parameters`;
//   - temp_poly: one instrument, one "stend.fit/1" document per axis (`axes[].fit`), the
//     temperature polynomials' reference temperature `reference_c` and `valid_range_c`;
//   - ceres_nonlinear: `accelerometer` and `gyroscope` parts (each with its own "ok"), the gyro
//     bias alone (`gyro_bias_x/y/z`) when the gyroscope was bias_only.
// The model applied is built from the parameter names present (bias_x → bias, gsens_xy →
// g_sensitivity, bias_tc2_z → bias_temperature of order ≥ 2, …); a parameter of the model the fit
// did not identify is applied as 0 and named in `notes`.
//
// Applying: accelerometer first, u_a = correct_a(y_a; T); then the gyroscope with the calibrated
// specific force for its g-sensitivity, u_g = correct_g(y_g; f = u_a, T). T is each sample's
// temperature [degC] (required when the model has temperature terms). Counts stay the raw ones;
// the SI columns are calibrated.
#pragma once

#include <stend/estimation/model_spec.hpp>
#include <stend/estimation/summary.hpp>
#include <stend/model/terms.hpp>
#include <stend/recording/recording.hpp>

#include <nlohmann/json_fwd.hpp>

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace stend::calibration {

// One instrument's correction.
struct InstrumentCalibration {
  model::ErrorModel model;
  std::vector<double> theta;                           // model.size() values; empty: not calibrated
  std::vector<estimation::ParameterEstimate> parameters;  // as fitted, vocabulary names
  bool present() const { return !theta.empty(); }
  // The fitted parameter of that name, or nullptr.
  const estimation::ParameterEstimate* find(const std::string& name) const;
  // Standard error of a parameter [its unit]; 0 when the fit did not estimate it.
  double std_error(const std::string& name) const;
};

struct Calibration {
  std::string source;     // the results file
  std::string estimator;  // "batch_lsq", "temp_poly", "ceres_nonlinear", …
  InstrumentCalibration accel, gyro;
  double gravity_mps2 = 0.0;  // the fit's local gravity when it states one, else 0
  // Temperature range the fit saw [degC] (temp_poly), NaN when not stated.
  double valid_min_c = NAN, valid_max_c = NAN;
  std::vector<std::string> notes;  // parameters applied as 0, parts that failed

  bool needs_temperature() const;
  // "ceres_nonlinear calibration from FILE: accelerometer (bias, scale, cross_axis), gyroscope (…)".
  void print(std::ostream& os) const;
};

// Reads a results document. Throws std::runtime_error naming `source` when the document is not
// a results document, its fit failed, or it holds no calibration of either instrument.
Calibration calibration_from_json(const nlohmann::json& doc, const std::string& source);
Calibration load_calibration(const std::filesystem::path& results_file);

// The model whose parameters are `names` (any the vocabulary's terms own), the temperature
// polynomials at the highest order named and reference `reference_c` [degC].
model::ErrorModel model_from_names(model::Instrument instrument, const std::vector<std::string>& names,
                                   double reference_c);

// Samples with a calibration applied as they are read (the instruments `cal` holds; the other one
// as recorded), a chunk at a time. A read throws std::runtime_error when the model needs the
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
// valid while `raw` and `cal` live). Throws std::runtime_error when the model needs the
// temperature and a sample has none.
Recording apply_calibration(const Recording& raw, const Calibration& cal);

// Writes `calibrated` as a new run folder `out_dir` (which must not exist): samples, truth,
// segments, the recording's events, and an event naming the calibration applied.
void write_calibrated(const Recording& calibrated, const Calibration& cal, const std::filesystem::path& out_dir);

}  // namespace stend::calibration
