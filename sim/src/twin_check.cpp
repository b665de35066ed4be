// A fit of a twin log against its planted truth. See stend/sim/twin_check.hpp.
#include <stend/sim/twin_check.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace stend::sim {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double number_or_nan(const nlohmann::json& v) { return v.is_number() ? v.get<double>() : kNaN; }

}  // namespace

double ParameterCheck::z() const { return estimated && std_error > 0.0 ? (value - planted) / std_error : kNaN; }

bool ParameterCheck::covered_within(double factor) const {
  if (!estimated) return false;
  return planted >= value - factor * (value - lower) && planted <= value + factor * (upper - value);
}

std::vector<ParameterCheck> check_against_truth(const std::string& results_json, const PlantedTruth& truth) {
  const auto doc = nlohmann::json::parse(results_json);
  if (!doc.contains("parameters") || !doc["parameters"].is_array())
    throw std::runtime_error("the results document has no parameters list");
  const bool convention = doc.contains("options") && doc["options"].value("accelerometer", "") == "unknown_orientations";
  const PlantedTruth t = convention ? truth.in_accel_frame_convention() : truth;
  std::vector<ParameterCheck> out;
  for (const auto& p : doc["parameters"]) {
    const std::string name = p.value("name", "");
    const auto it = t.parameters.find(name);
    if (it == t.parameters.end()) continue;
    ParameterCheck c;
    c.name = name;
    c.planted = it->second;
    c.value = number_or_nan(p["value"]);
    c.std_error = number_or_nan(p["std_error"]);
    c.lower = p.contains("interval") ? number_or_nan(p["interval"][0]) : kNaN;
    c.upper = p.contains("interval") ? number_or_nan(p["interval"][1]) : kNaN;
    c.held = p.value("fixed", false);
    c.verdict = p.value("verdict", "");
    c.reason = p.value("reason", "");
    c.estimated = !c.held && std::isfinite(c.value) && std::isfinite(c.lower) && std::isfinite(c.upper);
    c.covered = c.estimated && c.lower <= c.planted && c.planted <= c.upper;
    out.push_back(c);
  }
  return out;
}

}  // namespace stend::sim
