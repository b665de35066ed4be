// temp_poly: bias and scale versus temperature (the paper's k_t, k_tt and higher orders), built on
// the batch least-squares estimator (stend/batch_lsq/batch_lsq.hpp) and the error-model vocabulary
// (stend/model/terms.hpp: bias_temperature, scale_temperature) — no term formula is written here.
//
//   1. static points from the recording (estimation::extract_static_points), each with its die temperature;
//   2. points grouped into temperature levels (gap > level_tolerance_c starts a new level), and in
//      time order into visits; a visit approached from a colder level is on the heating leg, from a
//      warmer one on the cooling leg (the first visit's direction is unknown). All legs are fitted;
//   3. refusal when the span or the number of levels cannot support the requested order;
//   4. per output axis (the axes are decoupled in this model), candidate orders m = 0..max_order
//      (m = 0: no temperature terms; m ≥ 1: bias_temperature and scale_temperature of order m)
//      are fitted with batch_lsq::fit_points and scored by BIC and by leave-one-temperature-out
//      cross-validation; the order is chosen by `selection` ("bic", "cv" or "fixed");
//   5. hysteresis: at each level visited on both legs, mean residual (chosen fit) on the cooling
//      leg minus that on the heating leg, with a standard error and interval.
// See estimators/temp_poly/README.md for the method, the options and the JSON schema.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <limits>
#include <string>
#include <vector>

#include "stend/batch_lsq/batch_lsq.hpp"
#include "stend/estimation/model_spec.hpp"
#include "stend/recording/recording.hpp"

namespace stend::temp_poly {

inline constexpr const char* kSchema = "stend.temp_poly/1";
inline constexpr const char* kEstimatorName = "temp_poly";
inline constexpr const char* kEstimatorVersion = "0.1.0";

struct TempPolyOptions {
  model::Instrument instrument = model::Instrument::kAccelerometer;
  std::vector<int> axes = {0, 1, 2};
  std::string selection = "bic";  // "bic" | "cv" | "fixed"
  int max_order = 3;              // highest candidate order for "bic" / "cv" (1..6)
  int order = 2;                  // the order for "fixed" (0..6)
  double reference_c = 25.0;      // T0 of the temperature terms [degC]
  double min_span_c = 20.0;       // refuse a temperature span below this [degC]
  double level_tolerance_c = 2.0; // points closer than this (sorted) share a temperature level
  // Fit the constant scale factor. False for a gyroscope on static positions: its only input there,
  // the Earth rate, is too small to determine a scale factor (examples/temp_poly_gyroscope.yaml).
  bool scale = true;
  bool bias_temperature = true;   // fit bias_temperature (k_t of the zero offset)
  bool scale_temperature = true;  // fit scale_temperature (the paper's k_t, k_tt on A_i)
  bool cross_axis = false;        // add the temperature-independent cross_axis term
  double confidence = 0.95;
  estimation::PrecisionTolerances tolerances;  // of each parameter's verdict (model file `tolerances:`)
  // Static intervals and extraction (the processing stage's keys and defaults).
  processing::ProcessingOptions processing;

  // A known selection, orders in range (max_order 1..6, order 0..6), axes 0..2, something that
  // depends on temperature, level_tolerance_c > 0, min_span_c ≥ 0, reference_c finite, confidence
  // in (0, 1), the tolerances and the processing options valid.
  bool IsValid(std::string* error = nullptr) const;
};

// One temperature level: the points whose die temperatures cluster together.
struct TemperatureLevel {
  double temperature_c = 0.0;  // mean die temperature of its points
  double min_c = 0.0, max_c = 0.0;
  int points = 0;
  int heating_points = 0, cooling_points = 0, unknown_points = 0;
};

enum class Leg { kUnknown, kHeating, kCooling };
const char* leg_name(Leg leg);  // "unknown" | "heating" | "cooling"

struct OrderScore {
  int order = 0;
  bool ok = false;        // fitted (BIC valid)
  std::string note;       // why not scored, or warnings
  int observations = 0;   // n
  int parameters = 0;     // rank of the fit
  double rss = std::numeric_limits<double>::quiet_NaN();
  double bic = std::numeric_limits<double>::quiet_NaN();  // n·ln(RSS/n) + rank·ln(n)
  bool cv_ok = false;
  double cv_mse = std::numeric_limits<double>::quiet_NaN();  // leave-one-temperature-out MSE
};

struct Hysteresis {
  int level = 0;               // index into TempPolyResult::levels
  double temperature_c = 0.0;
  int heating_points = 0, cooling_points = 0;
  // Cooling minus heating mean residual [instrument unit]; NaN when not computable.
  double value = std::numeric_limits<double>::quiet_NaN();
  double std_error = std::numeric_limits<double>::quiet_NaN();
  double lower = std::numeric_limits<double>::quiet_NaN(), upper = std::numeric_limits<double>::quiet_NaN();
  bool significant = false;    // the interval excludes 0
};

struct AxisResult {
  int axis = 0;
  estimation::FitStatus status = estimation::FitStatus::kFailed;
  std::string message;
  bool ok() const { return status == estimation::FitStatus::kOk; }
  int chosen_order = -1;
  std::vector<OrderScore> scores;  // candidate orders 0..max (or just the fixed one)
  batch_lsq::FitResult fit;        // the chosen order's fit (values, std errors, intervals,
                                   // identifiability, residuals)
  std::vector<Hysteresis> hysteresis;
  double max_abs_hysteresis = std::numeric_limits<double>::quiet_NaN();
};

struct TempPolyResult {
  estimation::FitStatus status = estimation::FitStatus::kFailed;
  std::string message;  // why it was refused / failed (empty on success)
  bool ok() const { return status == estimation::FitStatus::kOk; }
  TempPolyOptions options;
  std::string recording_dir, experiment_name;
  std::vector<std::string> notes;
  std::vector<processing::StaticPoint> points;
  std::vector<Leg> legs;      // per point
  std::vector<int> level_of;  // per point: index into levels
  std::vector<TemperatureLevel> levels;  // ascending temperature
  double reference_c = 25.0;
  double valid_min_c = std::numeric_limits<double>::quiet_NaN();
  double valid_max_c = std::numeric_limits<double>::quiet_NaN();
  std::vector<AxisResult> axes;
  std::string unit;  // "m/s^2" | "rad/s"

  const AxisResult& axis(int a) const;  // throws when the axis was not fitted
};

// The model spec of one candidate: bias, scale (+ cross_axis), bias/scale_temperature of `order`
// (none when order = 0), fitted axes {axis}.
estimation::ModelSpec candidate_spec(const TempPolyOptions& options, int order, int axis);

// Steps 2–5 on given points (synthetic, or extracted). Never throws for data problems.
TempPolyResult fit_temperature_points(const std::vector<processing::StaticPoint>& points,
                                      const TempPolyOptions& options);
// The whole procedure on a recording. Never throws for data problems.
TempPolyResult fit_temperature_model(const Recording& recording, const TempPolyOptions& options);

// Options from YAML (README.md "Options"); errors are stend::ExperimentError "FILE:LINE:COL: …".
TempPolyOptions parse_options(const std::string& yaml_text, const std::string& source_name = "<temp_poly>");
TempPolyOptions load_options(const std::filesystem::path& file);

// Text report (levels and legs, per-axis order table, coefficients, hysteresis, notes); a refused
// or failed fit prints the reason and no numbers.
void print_report(std::ostream& os, const TempPolyResult& r);
std::ostream& operator<<(std::ostream& os, const TempPolyResult& r);
// JSON of schema "stend.temp_poly/1"; each axis embeds its batch_lsq "stend.fit/1" document.
std::string to_json(const TempPolyResult& r, int indent = 2);

}  // namespace stend::temp_poly
