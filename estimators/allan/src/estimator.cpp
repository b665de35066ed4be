// allan as an Estimator and its registry entry (see stend/allan/estimator.hpp).
#include "stend/allan/estimator.hpp"
#include "report_section.hpp"

#include "stend/allan/allan.hpp"
#include "stend/allan/deviation_report.hpp"
#include "stend/estimation/result_io.hpp"
#include "stend/yaml/reader.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace stend::allan {

AllanEstimator::AllanEstimator(const Params& p) : config_(require_valid(fields().read(p), kEstimatorName)) {}

const stend::fields::Table<estimation::EstimatorConfig>& AllanEstimator::fields() {
  static const stend::fields::Table<estimation::EstimatorConfig> table(
      kEstimatorName, estimation::estimator_fields(), {kResultsFile});
  return table;
}

namespace {

constexpr double kConfidence = 0.95;
constexpr double kNormalQuantile = 1.959963984540054;  // two-sided 95 %

// N, K and B of one channel's noise model: value ± the fit's 1 σ, a normal 95 % interval.
estimation::ParameterEstimate coefficient(const nlohmann::json& k, const std::string& name) {
  estimation::ParameterEstimate p;
  p.name = name;
  p.unit = k.value("unit", "");
  p.identifiable = k.value("identified", false);
  if (!p.identifiable) {
    const auto ub = k.find("upper_bound");
    p.reason = ub != k.end() && ub->is_number()
                   ? fmt::format("not identified; upper bound {:.4g} {}", ub->get<double>(), p.unit)
                   : "not identified";
    return p;
  }
  p.value = k.value("value", std::numeric_limits<double>::quiet_NaN());
  p.std_error = k.value("sigma", std::numeric_limits<double>::quiet_NaN());
  p.lower = p.value - kNormalQuantile * p.std_error;
  p.upper = p.value + kNormalQuantile * p.std_error;
  return p;
}

estimation::FitSummary summarize(const nlohmann::json& doc) {
  estimation::FitSummary s = estimation::summary_from_json(doc);
  if (!doc.contains("status")) s.status = estimation::FitStatus::kOk;  // documents before "status": always ran
  s.parameters.clear();
  s.confidence = kConfidence;
  for (const auto& ch : doc.value("channels", nlohmann::json::array())) {
    const std::string c = ch.value("channel", "");
    if (!ch.contains("model") || !ch["model"].is_object()) continue;
    const nlohmann::json& m = ch["model"];
    if (!m.value("ok", false)) {  // the others' numbers stand; this channel's failure is said
      s.message += c + ": " + m.value("message", "") + "; ";
      continue;
    }
    for (const char* symbol : {"N", "K", "B", "G", "Tc"})
      if (m.contains(symbol)) s.parameters.push_back(coefficient(m[symbol], std::string(symbol) + "_" + c));
  }
  return s;
}

// The instrument and output axis of a channel ("ax" … "gz"); nullopt for another channel.
std::optional<std::pair<model::Instrument, int>> channel_axis(const nlohmann::json& ch) {
  const std::string instrument = ch.value("instrument", "");
  const std::string name = ch.value("channel", "");
  const auto axis = name.empty() ? std::string::npos : std::string("xyz").find(name.back());
  if (axis == std::string::npos) return std::nullopt;
  if (instrument == to_string(Instrument::kAccelerometer)) return std::pair{model::Instrument::kAccelerometer, static_cast<int>(axis)};
  if (instrument == to_string(Instrument::kGyroscope)) return std::pair{model::Instrument::kGyroscope, static_cast<int>(axis)};
  return std::nullopt;
}

double number_or_nan(const nlohmann::json& j, const char* key) {
  return j.is_object() && j.contains(key) && j[key].is_number() ? j[key].get<double>() : kNaN;
}

// What stands for a sensor's density when none of its axes identified it: the Kalibr block's
// number (the largest slope read-off, else the largest upper bound); nothing when an axis did.
estimation::UnidentifiedDensity stand_in(const nlohmann::json& kalibr, const std::string& key, bool any_identified) {
  estimation::UnidentifiedDensity d;
  if (any_identified) return d;
  d.value = number_or_nan(kalibr, key.c_str());
  d.upper_bound = kalibr.value(key + "_is_upper_bound", false);
  return d;
}

// N, K and B of every accelerometer and gyroscope channel whose model was fitted, and each
// sensor's stand-ins.
estimation::NoiseResult noise_of(const nlohmann::json& doc) {
  estimation::NoiseResult n;
  n.rate_hz = number_or_nan(doc, "rate_hz");
  n.samples = doc.value("samples", std::uint64_t{0});
  for (const auto& ch : doc.value("channels", nlohmann::json::array())) {
    const auto where = channel_axis(ch);
    const nlohmann::json m = ch.value("model", nlohmann::json::object());
    if (!where || !m.value("ok", false)) continue;
    estimation::ChannelNoise c;
    c.channel = ch.value("channel", "");
    std::tie(c.instrument, c.axis) = *where;
    c.white_noise = coefficient(m.value("N", nlohmann::json::object()), "N_" + c.channel);
    c.random_walk = coefficient(m.value("K", nlohmann::json::object()), "K_" + c.channel);
    c.bias_instability = coefficient(m.value("B", nlohmann::json::object()), "B_" + c.channel);
    n.channels.push_back(c);
  }
  const nlohmann::json kalibr = doc.value("kalibr", nlohmann::json::object());
  for (const auto inst : {model::Instrument::kAccelerometer, model::Instrument::kGyroscope}) {
    const std::string prefix = inst == model::Instrument::kAccelerometer ? "accelerometer" : "gyroscope";
    bool white = false, walk = false;
    for (const auto& c : n.channels)
      if (c.instrument == inst) {
        white = white || c.white_noise.identifiable;
        walk = walk || c.random_walk.identifiable;
      }
    n.sensor(inst).white_noise = stand_in(kalibr, prefix + "_noise_density", white);
    n.sensor(inst).random_walk = stand_in(kalibr, prefix + "_random_walk", walk);
  }
  return n;
}

}  // namespace

estimation::FitResult read_results(const nlohmann::json& doc) {
  estimation::FitResult r;
  r.summary = summarize(doc);
  if (doc.contains("channels")) r.noise = noise_of(doc);
  r.document = doc;
  r.results_file = kResultsFile;
  return r;
}

namespace {

// The typed fit: allan.json written (with the deviations when the model file asks for them),
// then read back by read_results, so a fit and its results file give the same typed result.
estimation::FitResult fit_typed(const EstimatorRequest& req) {
  if (req.recording == nullptr) throw std::invalid_argument("allan: no recording given");
  const YAML::Node root = yaml::load_file(req.model_file, "model file");
  const AllanOptions options = options_from_yaml(root["allan"], req.model_file);
  const DeviationRequest deviations = deviations_from_yaml(root["allan"], req.model_file);
  const AllanReport report = analyze_recording(*req.recording, options);
  if (!report.not_still.empty())
    return estimation::failed_fit(kEstimatorName, kEstimatorVersion, "allan: " + report.not_still);
  if (report_failed(report)) {  // says which channel failed and why; no numbers
    std::string why;
    for (const auto& c : report.channels)
      if (!c.model.ok) why += (why.empty() ? "" : "; ") + c.curve.channel.name + ": " + c.model.message;
    return estimation::failed_fit(kEstimatorName, kEstimatorVersion,
                                   "allan: noise-model fit failed — " + (why.empty() ? std::string("no channel") : why));
  }
  std::ostringstream text, json;
  for (const auto& n : report.notes) text << "note: " << n << "\n";
  write_summary_table(text, report);
  write_json(json, report);
  nlohmann::json doc = nlohmann::json::parse(json.str());
  std::string document = json.str();
  if (!deviations.empty()) {
    const auto devs = recording_deviations(*req.recording, report, deviations, options);
    write_deviation_table(text, devs);
    add_deviations_json(doc, devs, deviations.tau);
    document = doc.dump(2);
  }
  estimation::FitResult r = read_results(doc);
  r.document_text = document;
  r.text = text.str();
  return r;
}

}  // namespace

EstimatorResult AllanEstimator::fit(const EstimatorRequest& req) {
  const estimation::FitResult r = fit_typed(req);
  return {r.ok(), r.summary.message, r.document_text, r.text, config_.results_file};
}

estimation::EstimatorEntry estimator_entry() {
  estimation::EstimatorEntry e;
  e.name = kEstimatorName;
  e.version = kEstimatorVersion;
  e.description = kDescription;
  e.results_file = kResultsFile;
  e.claims = [](const YAML::Node& root) { return root.IsMap() && root["allan"]; };
  e.create = [] { return PluginPtr<Estimator>(new AllanEstimator(), [](Estimator* p) { delete p; }); };
  e.fit = fit_typed;
  e.read = read_results;
  e.reads_truth = false;
  e.report = report_section;
  return e;
}

}  // namespace stend::allan
