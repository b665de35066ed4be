// One instrument's fitted error model, typed: what `stend apply` applies, what the exports write
// and what the reports plot, whichever estimator fitted it. The model is the vocabulary's
// (stend/model/terms.hpp, the only place term formulas live); this type only holds the fitted
// numbers and what they cover, and evaluates the model through ErrorModel::measure / regressor.
//
// θ has one entry per parameter of `model`, in the model's order:
//   - the estimate, when the data identified it;
//   - NaN, when the fit did not identify it (`parameters[i].identifiable` false);
//   - 0, when the estimator holds it by its convention (`parameters[i].held`, `reason` says why:
//     a frame convention, a temperature order the selection did not choose, an axis not fitted).
#pragma once

#include <stend/estimation/summary.hpp>
#include <stend/model/terms.hpp>
#include <stend/sdk.hpp>  // SensorInfo

#include <Eigen/Core>

#include <cmath>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

namespace stend::estimation {

// How a model covers the sensor's three output axes.
enum class Coverage {
  kTriad,  // the three axes as one model, their frame included (e.g. a Ceres calibration)
  kAxes,   // the listed output axes, each row fitted on its own data (batch_lsq, temp_poly)
};

// An output axis the fit was asked for and could not fit.
struct AxisFailure {
  int axis = 0;  // 0 x, 1 y, 2 z
  std::string message;
};

struct InstrumentModel {
  FitStatus status = FitStatus::kFailed;  // of this instrument's part of the fit
  std::string message;                    // why it failed ("" when it did not)
  model::ErrorModel model;                // the instrument and the terms
  std::vector<double> theta;              // model.size() entries (see the top of this file)
  std::vector<ParameterEstimate> parameters;  // one per θ entry, the vocabulary's names
  double confidence = NAN;                // of the parameters' intervals
  Eigen::MatrixXd covariance;  // over θ (model.size()²), 0 in the rows and columns of θ not estimated
  Coverage coverage = Coverage::kTriad;
  std::vector<int> axes = {0, 1, 2};      // the output axes the fit covered
  std::vector<AxisFailure> failed_axes;   // axes asked for whose fit failed (not in `axes`)
  double reference_c = NAN;               // T0 of the temperature polynomials [degC]; NaN: none
  // The temperature range the fit saw [degC], when the estimator states it (a temperature model
  // is valid there); NaN otherwise.
  double min_temperature_c = NAN, max_temperature_c = NAN;
  double gravity_mps2 = NAN;              // the local gravity the fit used, when it states one
  // What anyone applying or exporting this model is told (e.g. which parameters a frame
  // convention holds at 0), one sentence each.
  std::vector<std::string> notes;

  model::Instrument instrument() const { return model.instrument; }
  bool ok() const { return status == FitStatus::kOk; }
  bool covers(int axis) const;
  bool has(model::TermKind kind) const { return model.find(kind) >= 0; }
  // Whether the estimator states the temperature range its model holds over.
  bool states_temperature_range() const { return std::isfinite(min_temperature_c) && std::isfinite(max_temperature_c); }
  const ParameterEstimate* find(const std::string& name) const;  // nullptr when absent
  // Standard error of a parameter [its unit]; 0 when the fit did not estimate it.
  double std_error(const std::string& name) const;
  // Whether the fit determined θ entry i: identified, or held at 0 where 0 is exact
  // (ParameterEstimate::zero_is_exact). Not: not identified (NaN: not identifiable, aliased), or
  // held at 0 where 0 is a guess. What `stend apply` refuses and the exports warn about.
  bool determined(std::size_t i) const;
  // Names of the θ entries the fit did not determine, in θ order.
  std::vector<std::string> not_identified() const;
  // θ with what the fit did not identify as 0: the values `stend apply` and the exports use
  // (each names the parameters it sets to 0).
  std::vector<double> applied_theta() const;

  // Output axis k of the model's contribution y_k − u_k at input u and temperature T [degC]
  // (applied_theta; for an accelerometer the specific force is u), minus the same at `minus_u`
  // when given; and its standard error from `covariance` (the gradient is the regressor row).
  std::pair<double, double> contribution(int k, const model::Vec3<double>& u, double temperature_c,
                                         const model::Vec3<double>* minus_u = nullptr) const;

  // "accelerometer: bias, scale (axes x y z as one triad; ok)", then the parameter table and the
  // notes.
  void print(std::ostream& os) const;
  // Same status, model, coverage and axes; numbers within |a − b| ≤ abs_tol + rel_tol·max(|a|, |b|)
  // (NaN matches NaN).
  bool equals(const InstrumentModel& other, double rel_tol = 1e-9, double abs_tol = 0.0) const;
};
// Why `instrument` cannot be fitted on a recording whose sensor `info` describes: "" when the
// recording has it (stend/recording/instruments.hpp: has_instrument). Either can be absent: the
// gyroscope of an accelerometer-only log (SensorInfo::has_gyro false: a CSV without gyro columns),
// the accelerometer of a gyro-only one (has_accel false): "the recording has no accelerometer (its
// source holds no accelerometer data)".
std::string why_absent(const SensorInfo& info, model::Instrument instrument);
// Why a model with `temperature_terms` (the terms that read the temperature, by name) cannot be
// fitted on a recording whose sensor `info` describes: "" when it has none or the recording has a
// temperature (SensorInfo::has_temperature). No coefficient is ever fitted against a temperature
// that was not measured.
std::string why_no_temperature(const SensorInfo& info, const std::vector<std::string>& temperature_terms);
// The model of an instrument absent from the recording: kNotApplicable, `why` its message, no
// parameters (nothing was fitted).
InstrumentModel not_applicable(model::ErrorModel model, const std::string& why);

std::ostream& operator<<(std::ostream& os, const InstrumentModel& m);  // = print

}  // namespace stend::estimation
