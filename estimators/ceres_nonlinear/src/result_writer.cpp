// ceres_nonlinear's one writer: a procedure's result as JSON (CalibrationResult::to_json) and the
// results document ceres.json (schema stend.ceres_nonlinear.results/1, README.md) of a model-file
// fit; read back by result_reader.cpp.
#include "report.hpp"

#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/physics/units.hpp>

#include <nlohmann/json.hpp>

#include <cmath>

namespace stend::ceres_nonlinear {

using namespace detail;

namespace {

using nlohmann::json;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json vec_deg(const Eigen::Vector3d& rad) {
  return {num(rad[0] * physics::kRadToDeg), num(rad[1] * physics::kRadToDeg), num(rad[2] * physics::kRadToDeg)};
}

nlohmann::json detection_json(const processing::DetectionSummary& d) {
  json scan = json::array();
  for (const auto& st : d.scan)
    scan.push_back({{"multiplier", st.multiplier}, {"intervals", st.intervals}, {"poses", st.poses},
                    {"quadric_rms_mps2", num(st.quadric_rms_mps2)}});
  json rejected = json::object();
  for (processing::Rejection r : processing::kAllRejections) rejected[processing::rejection_name(r)] = d.count(r);
  return {{"found", d.found},
          {"rate_hz", d.rate_hz},
          {"window_s", d.window_s},
          {"min_duration_s", d.min_duration_s},
          {"init_duration_s", d.init_duration_s},
          {"noise_variance_m2ps4", d.noise_variance},
          {"noise_source", d.noise_source},
          {"threshold_m2ps4", d.threshold},
          {"multiplier", d.multiplier},
          {"multiplier_choice", d.multiplier_choice},
          {"scan", scan},
          {"gyro_bias_dps", {d.gyro_bias_radps.x() / physics::kDegPerSecond, d.gyro_bias_radps.y() / physics::kDegPerSecond,
                             d.gyro_bias_radps.z() / physics::kDegPerSecond}},
          {"gyro_bias_source", d.gyro_bias_source},
          {"max_gyro_dps", d.max_gyro_radps / physics::kDegPerSecond},
          {"rejected", rejected}};
}

// The fit's degrees of freedom in the summary: the fewest of its fitted parts'; null when none was fitted.
json fewest_dof(const ModelFileFit& f) {
  json fewest = nullptr;
  for (const CalibrationResult* p : {f.has_accel ? &f.accel : nullptr, f.has_gyro ? &f.gyro : nullptr})
    if (p != nullptr && p->ok() && (fewest.is_null() || p->dof < fewest.get<int>())) fewest = p->dof;
  return fewest;
}

}  // namespace

std::string CalibrationResult::to_json() const {
  auto prm = [&](const estimation::ParameterEstimate& p) {
    return json{{"name", p.name}, {"unit", p.unit}, {"value", num(p.value)},
                {"std_error", num(p.std_error)}, {"ci95", {num(p.lower), num(p.upper)}},
                {"identifiable", p.identifiable}, {"verdict", estimation::to_string(p.judged())},
                {"tolerance", num(p.tolerance)}, {"fixed", p.held}, {"zero_is_exact", p.zero_is_exact},
                {"reason", p.reason}};
  };
  json j;
  j["ok"] = ok();
  j["status"] = estimation::to_string(status);
  j["message"] = message;
  const bool gyro = model.instrument == model::Instrument::kGyroscope;
  j["instrument"] = gyro ? "gyroscope" : "accelerometer";
  if (status == estimation::FitStatus::kNotApplicable) return j.dump(2);  // nothing was fitted
  j["method"] = method_name(method);
  j["gravity_mps2"] = gravity_mps2;
  j["observations"] = observations;
  j["estimated"] = estimated;
  j["dof"] = dof;
  j[whitened ? "sigma_whitened" : "sigma_mps2"] = num(sigma);
  const Rms& rms = reported_rms(*this);
  const AxisRms& axis = reported_axis_rms(*this);
  const std::string au = check_unit(method);
  const std::string rms_what = !gyro                          ? "rms_norm_"
                               : method == Method::kIntegration ? "rms_direction_"
                               : method == Method::kTurns       ? "rms_turn_"
                                                                : "rms_";
  j[rms_what + "before_" + au] = num(rms.before);
  j[rms_what + "after_" + au] = num(rms.after);
  const Eigen::Vector3d& rms_axis_before = axis.before;
  const Eigen::Vector3d& rms_axis_after = axis.after;
  j["rms_axis_before_" + au] = {num(rms_axis_before[0]), num(rms_axis_before[1]), num(rms_axis_before[2])};
  j["rms_axis_after_" + au] = {num(rms_axis_after[0]), num(rms_axis_after[1]), num(rms_axis_after[2])};
  if (!gyro) {
    j["rms_axis_before_mg"] = {num(rms_axis_before[0] / physics::kMilliG), num(rms_axis_before[1] / physics::kMilliG),
                               num(rms_axis_before[2] / physics::kMilliG)};
    j["rms_axis_after_mg"] = {num(rms_axis_after[0] / physics::kMilliG), num(rms_axis_after[1] / physics::kMilliG),
                              num(rms_axis_after[2] / physics::kMilliG)};
  }
  j["uncertainty"] = uncertainty;
  j["notes"] = notes;
  j["condition_number"] = num(condition_number);
  j["confidence_quantile"] = num(quantile);
  j["solver"] = solver_report;
  j["not_identifiable"] = not_identifiable;
  j["parameters"] = json::array();
  for (const auto& p : parameters) j["parameters"].push_back(prm(p));
  j["gyro_parameters"] = json::array();
  for (const auto& p : gyro_bias) j["gyro_parameters"].push_back(prm(p));
  if (detection) j["detection"] = detection_json(*detection);
  j["intervals"] = json::array();
  // Accelerometer: each interval's |ȳ| − g raw and |correct(ȳ)| − g calibrated [m/s^2].
  for (const auto& iv : intervals) {
    json e = {{"label", iv.segment.label}, {"t_start_s", iv.t_start_s}, {"t_end_s", iv.t_end_s}, {"samples", iv.samples_used}};
    if (!gyro) {
      e["norm_error_before_mps2"] = num(iv.accel.mean.norm() - gravity_mps2);
      e["norm_error_after_mps2"] = ok() ? num(correct(iv.accel.mean).norm() - gravity_mps2) : json(nullptr);
    }
    j["intervals"].push_back(e);
  }
  // Gyro integration: each move's gravity-direction mismatch raw and calibrated [rad].
  if (!moves.empty()) {
    j["moves"] = json::array();
    for (const auto& m : moves)
      j["moves"].push_back({{"t_end_s", m.t_end_s}, {"mismatch_before_rad", num(m.before_rad)},
                            {"mismatch_after_rad", num(m.after_rad)}});
  }
  // Turns: each turn's stated rotation and the reading integrated over it, raw and calibrated [deg].
  if (!turns.empty()) {
    j["turns"] = json::array();
    for (const TurnCheck& t : turns)
      j["turns"].push_back({{"label", t.label}, {"t_start_s", t.t_start_s}, {"t_end_s", t.t_end_s},
                            {"stated_deg", vec_deg(t.stated_rad)}, {"integrated_before_deg", vec_deg(t.before_rad)},
                            {"integrated_after_deg", vec_deg(t.after_rad)}});
  }
  return j.dump(2);
}


json results_document(const ModelFileOptions& o, const ModelFileFit& f) {
  json j;
  j["schema"] = kResultsSchema;
  j["estimator"] = {{"name", kEstimatorName}, {"version", kEstimatorVersion}};
  j["options"] = json::parse(options_json(o));
  if (f.has_accel) j["accelerometer"] = json::parse(f.accel.to_json());
  if (f.has_gyro) j["gyroscope"] = json::parse(f.gyro.to_json());
  // Flat parameter list in the shape report tools read (`stend.fit/1`-like): accel_* / gyro_*.
  j["confidence"] = o.accel.confidence;
  j["parameters"] = json::array();
  auto add = [&](const std::string& prefix, const estimation::ParameterEstimate& p) {
    const std::string name = p.name.rfind("table_offset", 0) == 0 || p.name.rfind("gyro_", 0) == 0 ? p.name : prefix + p.name;
    j["parameters"].push_back({{"name", name}, {"unit", p.unit}, {"value", num(p.value)}, {"std_error", num(p.std_error)},
                               {"interval", {num(p.lower), num(p.upper)}}, {"identifiable", p.identifiable},
                               {"verdict", estimation::to_string(p.judged())}, {"tolerance", num(p.tolerance)},
                               {"fixed", p.held}, {"zero_is_exact", p.zero_is_exact}, {"reason", p.reason}});
  };
  if (f.has_accel) {
    for (const auto& p : f.accel.parameters) add("accel_", p);
    for (const auto& p : f.accel.gyro_bias) add("", p);
  }
  if (f.has_gyro)
    for (const auto& p : f.gyro.parameters) add("gyro_", p);
  j["status"] = estimation::to_string(f.status);
  j["message"] = f.message;
  j["dof"] = fewest_dof(f);
  j["notes"] = f.notes;  // the parts not applicable, the accelerometer's check and remarks, the gyroscope's
  if (f.has_accel)
    for (const auto& n : f.accel.notes) j["notes"].push_back("accelerometer: " + n);
  if (f.has_gyro) {
    const bool a_priori = f.gyro.method == Method::kTurns || f.gyro.method == Method::kEarthRate;
    if (a_priori && f.gyro.ok())  // the intervals' source is not the usual σ² = RSS/(n − p): say so
      j["notes"].push_back("gyroscope (" + std::string(method_name(f.gyro.method)) + "): " + f.gyro.uncertainty);
    for (const auto& n : f.gyro.notes) j["notes"].push_back("gyroscope: " + n);
  }
  return j;
}

}  // namespace stend::ceres_nonlinear
