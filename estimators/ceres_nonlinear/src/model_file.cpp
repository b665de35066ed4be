#include <stend/ceres_nonlinear/model_file.hpp>
#include "parts.hpp"
#include <stend/physics/units.hpp>
#include <stend/yaml/reader.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>

namespace stend::ceres_nonlinear {
namespace {

std::vector<std::string> string_list(const yaml::MapReader& m, const std::string& key,
                                     const std::vector<std::string>& allowed) {
  const YAML::Node v = m.get(key);
  if (!v.IsSequence()) m.fail_value(key, "expected a list of names, e.g. [" + yaml::join(allowed) + "]");
  std::vector<std::string> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string s = yaml::as_string(v[i], m.file(), m.child_path(key) + fmt::format("[{}]", i));
    if (std::find(allowed.begin(), allowed.end(), s) == allowed.end())
      throw ExperimentError(yaml::location_of(v[i], m.file()), m.child_path(key),
                            "unknown name '" + s + "'",
                            yaml::join_sentences(yaml::did_you_mean(s, allowed), "Allowed: " + yaml::join(allowed)));
    out.push_back(s);
  }
  return out;
}

std::string choice(const yaml::MapReader& m, const std::string& key, const std::string& fallback,
                   const std::vector<std::string>& allowed) {
  const std::string s = m.string(key, fallback);
  if (std::find(allowed.begin(), allowed.end(), s) == allowed.end())
    m.fail_value(key, "expected one of " + yaml::join(allowed) + ", got '" + s + "'",
                 yaml::did_you_mean(s, allowed));
  return s;
}

double positive(const yaml::MapReader& m, const std::string& key, double fallback, const std::string& unit,
                bool allow_zero = false) {
  const double v = m.number(key, fallback, unit);
  if (!(allow_zero ? v >= 0.0 : v > 0.0))
    m.fail_value(key, std::string("must be ") + (allow_zero ? ">= 0" : "> 0") + (unit.empty() ? "" : " (" + unit + ")"));
  return v;
}

// Why the gyroscope procedure `method` cannot run on a recording without an accelerometer (`no_accel`
// the recording's absence, "" when it has one): every procedure but the rate table's reads the
// accelerometer (the gravity direction at each pose, the specific force of the g-sensitivity).
std::string gyro_needs_accel(const std::string& method, const std::string& no_accel) {
  if (no_accel.empty() || method == "rate_table" || method == "none") return {};
  return "'" + method + "' needs the accelerometer (the gravity direction at each pose), and " + no_accel +
         "; use gyroscope: rate_table with the table's truth";
}

// The gyroscope procedure the options name (not none or bias_only); the integration runs on the
// accelerometer's result.
CalibrationResult fit_gyroscope(const Recording& rec, const ModelFileOptions& o, const CalibrationResult& accel) {
  if (o.gyroscope == "rate_table") return calibrate_gyro_rate_table(rec, o.gyro);
  if (o.gyroscope == "turns") return calibrate_gyro_turns(rec, o.gyro, o.accelerometer != "none" && accel.ok() ? &accel : nullptr);
  if (o.gyroscope == "earth_rate") return calibrate_gyro_earth_rate(rec, o.gyro);
  return calibrate_gyro_integration(rec, accel, o.gyro);
}

}  // namespace

ModelFileOptions options_from_yaml(const YAML::Node& root, const std::string& file) {
  ModelFileOptions o;
  const yaml::MapReader top(root, file, "", "model file", {"ceres_nonlinear"}, {"description", "name"});
  top.require("ceres_nonlinear", "the ceres_nonlinear estimator's options");
  std::vector<std::string> keys = {"accelerometer", "gyroscope", "segment_trim_s", "gravity_mps2", "loss",
                                   "loss_scale_mps2", "gyro_loss_scale_radps", "gyro_loss_scale_rad", "confidence",
                                   "max_iterations", "rank_tolerance", "max_std_error", estimation::kTolerancesKey, "fixed_cross_axis",
                                   "orientation_sigma_deg", "table_offsets", "table_fixture", "gyro_g_sensitivity",
                                   "turn_angle_sigma_deg", "rate_axis_sigma_deg", "g_sensitivity_sigma_dps_per_g"};
  keys.insert(keys.end(), processing::kOptionKeys.begin(), processing::kOptionKeys.end());
  const yaml::MapReader m(top.get("ceres_nonlinear"), file, "ceres_nonlinear", "ceres_nonlinear options", keys, {},
                          top.value_location("ceres_nonlinear"));
  o.accelerometer = choice(m, "accelerometer", o.accelerometer, {"unknown_orientations", "known_orientations", "none"});
  o.gyroscope = choice(m, "gyroscope", o.gyroscope, kGyroscopeMethods);
  if (o.accelerometer == "none" && (o.gyroscope == "integration" || o.gyroscope == "bias_only"))
    m.fail_value("gyroscope", "'" + o.gyroscope + "' needs the accelerometer calibration first (accelerometer: none)",
                 "use gyroscope: rate_table, or an accelerometer method");
  if (o.accelerometer == "none" && o.gyroscope == "none") m.fail_value("accelerometer", "nothing to fit: both are none");
  auto& a = o.accel;
  processing::read_options(m, a.processing);
  // segment_trim_s: dropped at each end of a segment — the rate table's, and the accelerometer
  // fits' on segments unless the file states their extraction.settle_s.
  auto& rate_table = o.gyro.processing;
  const std::string settle = "extraction.settle_s";
  if (m.has("segment_trim_s")) {
    rate_table.extraction.settle_s = positive(m, "segment_trim_s", 0.0, "in seconds", true);
    rate_table.stated.insert(settle);
  }
  if (a.processing.intervals == processing::IntervalSource::kSegments && a.processing.stated.count(settle) == 0) {
    a.processing.extraction.settle_s = rate_table.extraction.settle_s;
    if (rate_table.stated.count(settle) > 0) a.processing.stated.insert(settle);
  }
  if (m.has("gravity_mps2") && m.get("gravity_mps2").IsScalar() &&
      m.get("gravity_mps2").Scalar() == kRecordingOrStandardGravity)
    a.standard_gravity_fallback = true;
  else
    a.gravity_mps2 = positive(m, "gravity_mps2", 0.0, std::string("in m/s^2, or ") + kRecordingOrStandardGravity, true);
  a.loss = loss_from_name(choice(m, "loss", "none", {"none", "huber", "cauchy"}));
  o.gyro.loss = a.loss;
  a.loss_scale_mps2 = positive(m, "loss_scale_mps2", a.loss_scale_mps2, "in m/s^2");
  o.gyro.loss_scale_radps = positive(m, "gyro_loss_scale_radps", o.gyro.loss_scale_radps, "in rad/s");
  o.gyro.loss_scale_rad = positive(m, "gyro_loss_scale_rad", o.gyro.loss_scale_rad, "in rad");
  a.confidence = m.number("confidence", a.confidence, "");
  if (!(a.confidence > 0.0 && a.confidence < 1.0)) m.fail_value("confidence", "must be in (0, 1), e.g. 0.95");
  o.gyro.confidence = a.confidence;
  const std::int64_t it = m.integer("max_iterations", a.max_iterations);
  if (it < 1 || it > 100000) m.fail_value("max_iterations", "must be an integer in 1..100000");
  a.max_iterations = o.gyro.max_iterations = static_cast<int>(it);
  a.rank_tolerance = o.gyro.rank_tolerance = positive(m, "rank_tolerance", a.rank_tolerance, "(ratio of singular values)");
  if (m.has("max_std_error")) {
    positive(m, "max_std_error", 0.05, "(relative)");  // still checked, so a typo is still caught
    o.warnings.push_back(fmt::format(
        "{}: `max_std_error` is superseded and ignored: a converged fit on a non-singular design is always "
        "reported, each parameter with its standard error and a verdict against `tolerances:` "
        "(accel_bias_mg, gyro_bias_dps, scale_cross_ppm, g_sensitivity_dps_per_g, temperature_span_c)",
        m.key_location("max_std_error").str()));
  }
  estimation::read_tolerances(m, a.tolerances);
  o.gyro.tolerances = a.tolerances;
  if (m.has("fixed_cross_axis"))
    a.fixed_cross_axis = string_list(m, "fixed_cross_axis",
                                     {"cross_xy", "cross_xz", "cross_yx", "cross_yz", "cross_zx", "cross_zy"});
  a.orientation_sigma_deg = o.gyro.orientation_sigma_deg = positive(m, "orientation_sigma_deg", 0.0, "in degrees", true);
  if (m.has("table_offsets")) {
    a.table_offsets = string_list(m, "table_offsets", {"tilt", "rotation"});
    if (o.accelerometer != "known_orientations")
      m.fail_key("table_offsets", "table angle offsets are estimated only with accelerometer: known_orientations");
  }
  a.table_fixture = m.string("table_fixture", a.table_fixture);
  o.gyro.estimate_g_sensitivity = m.boolean("gyro_g_sensitivity", false);
  if (o.gyro.estimate_g_sensitivity && o.gyroscope == "earth_rate")
    m.fail_value("gyro_g_sensitivity", "earth_rate cannot estimate g-sensitivity: the vertical Earth rate and gravity "
                                       "flip together between up and down, so G_ii is the same combination as scale_i",
                 "set gyro_g_sensitivity: false (or use gyroscope: turns or rate_table)");
  if (m.has("turn_angle_sigma_deg")) {
    o.gyro.turn_angle_sigma_deg = positive(m, "turn_angle_sigma_deg", o.gyro.turn_angle_sigma_deg, "in degrees");
    if (o.gyroscope != "turns") m.fail_key("turn_angle_sigma_deg", "turn_angle_sigma_deg applies only with gyroscope: turns");
  }
  if (m.has("rate_axis_sigma_deg")) {
    o.gyro.rate_axis_sigma_deg = positive(m, "rate_axis_sigma_deg", 0.0, "in degrees", true);
    if (o.gyroscope != "rate_table") m.fail_key("rate_axis_sigma_deg", "rate_axis_sigma_deg applies only with gyroscope: rate_table");
  }
  if (m.has("g_sensitivity_sigma_dps_per_g")) {
    o.gyro.g_sensitivity_sigma_dps_per_g = positive(m, "g_sensitivity_sigma_dps_per_g", 0.0, "in (deg/s)/g", true);
    if (o.gyroscope != "earth_rate" && !(o.gyroscope == "rate_table" && o.gyro.rate_axis_sigma_deg > 0.0 &&
                                         !o.gyro.estimate_g_sensitivity))
      m.fail_key("g_sensitivity_sigma_dps_per_g",
                 "g_sensitivity_sigma_dps_per_g applies only with gyroscope: earth_rate, or rate_table with "
                 "rate_axis_sigma_deg > 0 and gyro_g_sensitivity: false (else the g-sensitivity is estimated, or "
                 "the weighting relative)");
  }
  a.estimate_gyro_bias = o.gyroscope == "bias_only";
  if (std::string why; !o.IsValid(&why))
    throw ExperimentError(top.value_location("ceres_nonlinear"), "ceres_nonlinear", why);
  return o;
}

ModelFileOptions load_model_file(const std::string& file) {
  return options_from_yaml(yaml::load_file(file, "model file"), file);
}

std::string describe_options(const ModelFileOptions& o) {
  const auto& a = o.accel;
  const auto& d = a.processing.detector;
  std::string s = "options:\n";
  const processing::IntervalSource source = a.processing.intervals;
  s += fmt::format("  accelerometer: {}, gyroscope: {}, intervals: {}\n", o.accelerometer, o.gyroscope,
                   processing::interval_source_name(source));
  auto or_auto = [](double v, const char* unit) { return v > 0.0 ? fmt::format("{} {}", v, unit) : std::string("auto"); };
  if (source != processing::IntervalSource::kSegments)
    s += fmt::format("  detector (auto: from the data, see the detection below): window {}, min duration {}, "
                     "threshold {}, multiplier {}, still start {}, trim {} s, max gyro {:.3g} deg/s after its bias\n",
                     or_auto(d.window_s, "s"), or_auto(d.min_duration_s, "s"),
                     or_auto(d.variance_threshold, "(m/s^2)^2"), or_auto(d.threshold_multiplier, ""),
                     or_auto(d.init_duration_s, "s"), d.trim_s, d.max_gyro_radps / physics::kDegPerSecond);
  else
    s += fmt::format("  segments trimmed by {} s at each end\n", a.processing.extraction.settle_s);
  s += fmt::format("  gravity: {}\n", a.gravity_mps2 > 0.0            ? fmt::format("{} m/s^2", a.gravity_mps2)
                                      : a.standard_gravity_fallback ? "the recording's, else standard (9.80665 m/s^2)"
                                                                    : "from the recording");
  s += fmt::format("  loss: {} (scale {} m/s^2, gyro {} rad/s, integration {} rad)\n", loss_name(a.loss),
                   a.loss_scale_mps2, o.gyro.loss_scale_radps, o.gyro.loss_scale_rad);
  const estimation::PrecisionTolerances& t = a.tolerances;
  s += fmt::format("  confidence {}, max iterations {}, rank tolerance {:g}\n", a.confidence, a.max_iterations,
                   a.rank_tolerance);
  s += fmt::format("  precision tolerances (1 sigma): bias {:g} mg, {:g} deg/s; scale, cross-axis {:g} ppm; "
                   "g-sensitivity {:g} (deg/s)/g\n",
                   t.accel_bias_mg, t.gyro_bias_dps, t.scale_cross_ppm, t.g_sensitivity_dps_per_g);
  for (const auto& w : o.warnings) s += "  warning: " + w + "\n";
  if (o.accelerometer == "unknown_orientations")
    s += fmt::format("  fixed cross-axis terms: {}\n", yaml::join(a.fixed_cross_axis));
  if (o.accelerometer == "known_orientations")
    s += fmt::format("  orientation sigma {} deg, table offsets: {} (fixture '{}')\n", a.orientation_sigma_deg,
                     a.table_offsets.empty() ? std::string("none") : yaml::join(a.table_offsets), a.table_fixture);
  if (o.gyroscope == "integration" || o.gyroscope == "rate_table" || o.gyroscope == "turns")
    s += fmt::format("  gyro g-sensitivity: {}\n", o.gyro.estimate_g_sensitivity ? "estimated" : "not modelled");
  if (o.gyroscope == "turns" || o.gyroscope == "earth_rate")
    s += fmt::format("  gyro stills: segments of kinds orientation and detected, trimmed by {} s at each end\n",
                     o.gyro.processing.extraction.settle_s);
  if (o.gyroscope == "turns")
    s += fmt::format("  turns: the recording's rotation segments with turn_*_deg truth, known to {} deg (1 sigma) in "
                     "angle and axis\n",
                     o.gyro.turn_angle_sigma_deg);
  if (o.gyroscope == "rate_table")
    s += o.gyro.rate_axis_sigma_deg > 0.0
             ? fmt::format("  rate axes known to {} deg (1 sigma): a-priori sigmas, the Earth rate's horizontal part "
                           "included; unmodelled g-sensitivity {} (deg/s)/g (1 sigma)\n",
                           o.gyro.rate_axis_sigma_deg, o.gyro.g_sensitivity_sigma_dps_per_g)
             : std::string("  rate axes exact (the truth's): relative weighting\n");
  if (o.gyroscope == "earth_rate")
    s += fmt::format("  positions placed to {} deg (1 sigma); unmodelled g-sensitivity {} (deg/s)/g (1 sigma)\n",
                     o.gyro.orientation_sigma_deg, o.gyro.g_sensitivity_sigma_dps_per_g);
  return s;
}

std::string options_json(const ModelFileOptions& o) {
  const auto& a = o.accel;
  const auto& d = a.processing.detector;
  nlohmann::json j = {
      {"accelerometer", o.accelerometer},
      {"gyroscope", o.gyroscope},
      {"intervals", processing::interval_source_name(a.processing.intervals)},
      {"detector",
       {{"window_s", d.window_s},
        {"min_duration_s", d.min_duration_s},
        {"variance_threshold_m2ps4", d.variance_threshold},
        {"threshold_multiplier", d.threshold_multiplier},
        {"init_duration_s", d.init_duration_s},
        {"trim_s", d.trim_s},
        {"max_gyro_dps", d.max_gyro_radps / physics::kDegPerSecond}}},
      {"segment_trim_s", o.gyro.processing.extraction.settle_s},
      {"gravity_mps2", a.standard_gravity_fallback && !(a.gravity_mps2 > 0.0) ? nlohmann::json(kRecordingOrStandardGravity)
                                                                               : nlohmann::json(a.gravity_mps2)},
      {"loss", loss_name(a.loss)},
      {"loss_scale_mps2", a.loss_scale_mps2},
      {"gyro_loss_scale_radps", o.gyro.loss_scale_radps},
      {"gyro_loss_scale_rad", o.gyro.loss_scale_rad},
      {"confidence", a.confidence},
      {"max_iterations", a.max_iterations},
      {"rank_tolerance", a.rank_tolerance},
      {"tolerances",
       {{"accel_bias_mg", a.tolerances.accel_bias_mg},
        {"gyro_bias_dps", a.tolerances.gyro_bias_dps},
        {"scale_cross_ppm", a.tolerances.scale_cross_ppm},
        {"g_sensitivity_dps_per_g", a.tolerances.g_sensitivity_dps_per_g},
        {"temperature_span_c", a.tolerances.temperature_span_c}}},
      {"warnings", o.warnings},
      {"fixed_cross_axis", a.fixed_cross_axis},
      {"orientation_sigma_deg", a.orientation_sigma_deg},
      {"table_offsets", a.table_offsets},
      {"table_fixture", a.table_fixture},
      {"gyro_g_sensitivity", o.gyro.estimate_g_sensitivity},
      {"turn_angle_sigma_deg", o.gyro.turn_angle_sigma_deg},
      {"rate_axis_sigma_deg", o.gyro.rate_axis_sigma_deg},
      {"g_sensitivity_sigma_dps_per_g", o.gyro.g_sensitivity_sigma_dps_per_g}};
  return j.dump();
}

ModelFileFit fit_model_file(const Recording& rec, const ModelFileOptions& options) {
  if (std::string why; !options.IsValid(&why)) throw InputError("ceres_nonlinear options: " + why);
  ModelFileOptions o = options;
  o.accel.processing = processing::resolve(o.accel.processing, rec);
  o.gyro.processing = processing::resolve(o.gyro.processing, rec);
  ModelFileFit f;
  const std::string no_gyro = estimation::why_absent(rec.header.info, model::Instrument::kGyroscope);
  const std::string no_accel = estimation::why_absent(rec.header.info, model::Instrument::kAccelerometer);
  if (!no_gyro.empty()) o.accel.estimate_gyro_bias = false;  // bias_only: no gyroscope to average
  std::string text = describe_options(o);
  std::vector<std::string> failures;
  if (o.accelerometer != "none" && !no_accel.empty()) {
    f.accel = detail::not_applicable_part(accelerometer_model(), no_accel);
    f.has_accel = true;
    text += "\n" + f.accel.report();
  } else if (o.accelerometer != "none") {
    f.accel = o.accelerometer == "known_orientations" ? calibrate_accelerometer_known_orientations(rec, o.accel)
                                                      : calibrate_accelerometer_unknown_orientations(rec, o.accel);
    f.has_accel = true;
    text += "\n" + f.accel.report();
    if (!f.accel.ok()) failures.push_back("accelerometer: " + f.accel.message);
  }
  const std::string gyro_absent = !no_gyro.empty() ? no_gyro : gyro_needs_accel(o.gyroscope, no_accel);
  if (o.gyroscope != "none" && !gyro_absent.empty()) {
    f.gyro = detail::not_applicable_part(gyroscope_model(o.gyro.estimate_g_sensitivity), gyro_absent);
    f.has_gyro = true;
    text += "\n" + f.gyro.report();
  } else if (o.gyroscope != "none" && o.gyroscope != "bias_only") {
    f.gyro = fit_gyroscope(rec, o, f.accel);
    f.has_gyro = true;
    text += "\n" + f.gyro.report();
    if (!f.gyro.ok()) failures.push_back("gyroscope: " + f.gyro.message);
  }
  for (const auto& s : failures) f.message += (f.message.empty() ? "" : "; ") + s;
  detail::conclude(f);
  text += "\n" + detail::status_line(f);
  f.text = text;
  f.document = results_document(o, f);
  return f;
}

}  // namespace stend::ceres_nonlinear
