// `stend apply CAL INPUT [-o CALIBRATED] [--assume NAME=VALUE,…] [--validate] [--expect-rotation x:90]
// [--rebias-from-start S]` — a fitted calibration applied to a recording (run folder or dataset
// file), written as a new run folder of calibrated samples, and validated on it when asked
// (stend/calibration/*.hpp). A calibration with parameters the fit did not determine is refused
// (exit 2) unless --assume states their values.
#include "commands.hpp"

#include "stend/calibration/calibration.hpp"
#include "stend/calibration/validation.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/physics/gravity.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <iostream>
#include <sstream>

namespace stend::cli {

namespace fs = std::filesystem;

fs::path calibration_results_file(const fs::path& cal, const estimation::Registry& registry) {
  if (!fs::is_directory(cal)) return cal;
  std::vector<fs::path> found;
  for (const auto& e : registry.entries())
    if (!e.results_file.empty() && fs::is_regular_file(cal / e.results_file)) found.push_back(cal / e.results_file);
  if (found.size() == 1) return found.front();
  std::string names;
  for (const auto& f : found) names += (names.empty() ? "" : ", ") + f.string();
  throw std::invalid_argument(cal.string() + (found.empty() ? ": no estimator results in this run folder (run `stend fit` first)"
                                                            : ": several results in this run folder (" + names +
                                                                  "); name the one to apply"));
}

calibration::Calibration load_stated_calibration(const std::string& cal, const std::vector<std::string>& assumptions) {
  const estimation::Registry registry = estimators::builtin();
  std::vector<calibration::Assumption> assumed;
  for (const auto& text : assumptions)
    for (auto& v : calibration::parse_assumptions(text)) assumed.push_back(std::move(v));
  return calibration::load_calibration(calibration_results_file(cal, registry), registry, assumed);
}

namespace {

// Warns on stderr when the recording's temperatures leave the range the calibration was fitted over.
void warn_outside_temperatures(const Recording& raw, const calibration::Calibration& cal) {
  if (!cal.needs_temperature() || !std::isfinite(cal.valid_min_c) || raw.sample_count() == 0) return;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;  // [degC]
  for_each_chunk(raw.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t) {
    for (std::size_t k = 0; k < n; ++k) {
      lo = std::min(lo, c[k].temperature_c);
      hi = std::max(hi, c[k].temperature_c);
    }
  });
  if (lo < cal.valid_min_c || hi > cal.valid_max_c)
    fmt::print(stderr, "warning: the recording spans {:.1f}..{:.1f} degC, outside the fit's {:.1f}..{:.1f} degC\n",
               lo, hi, cal.valid_min_c, cal.valid_max_c);
}

}  // namespace

Outcome run_apply(const ApplyArgs& a) {
  const calibration::Calibration cal = load_stated_calibration(a.cal, a.assumptions);
  const bool validating = a.validate || !a.rotations.empty() || a.options.rebias_from_start_s > 0.0;
  if (a.output.empty() && !validating)
    throw Refusal(ExitCode::kUsage,
                  "stend apply: nothing to do: give -o CALIBRATED to write the calibrated recording, and/or --validate");
  calibration::ValidationOptions options = a.options;
  for (const auto& r : a.rotations) options.rotations.push_back(calibration::parse_expected_rotation(r));
  calibration::check_applicable(cal, options);  // before reading the recording or writing anything
  cal.print(human_stream());
  const RunFolderLock lock = lock_run(a.data.is_run() ? a.data.inputs[0] : std::string());
  const Recording raw = a.data.open();
  warn_outside_temperatures(raw, cal);
  const Recording calibrated = calibration::apply_calibration(raw, cal);
  // docs/schemas/apply.schema.json
  nlohmann::json doc = {{"calibrated", nullptr}, {"assumed", cal.assumed}, {"validation", nullptr}};
  if (!a.output.empty()) {
    calibration::write_calibrated(calibrated, cal, a.output);
    fmt::print(human(), "calibrated: {} ({} samples)\n", a.output, calibrated.sample_count());
    doc["calibrated"] = a.output;
  }
  if (!validating) return {ExitCode::kOk, doc};
  const calibration::ValidationReport report = calibration::validate(raw, calibrated, cal, options);
  std::ostringstream text;
  report.print(text);
  human_stream() << "\n" << text.str();
  fs::path json = a.json;
  if (json.empty() && !a.output.empty()) json = fs::path(a.output) / "validation.json";
  const std::string document = report.to_json();
  write_results(json, document, text.str());
  doc["validation"] = {{"ok", report.ok},
                       {"verdict", calibration::to_string(report.verdict())},
                       {"results_file", json.empty() ? nlohmann::json(nullptr) : nlohmann::json(json.string())},
                       {"document", nlohmann::json::parse(document, nullptr, false)}};
  return {report.ok ? ExitCode::kOk : ExitCode::kFitFailed, doc};
}

void add_apply_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("apply", "Apply a fitted calibration to a recording (run folder or dataset file) and "
                                          "validate it there: static |a| - g, integrated turns");
  static ApplyArgs a;
  sub->add_option("calibration", a.cal,
                  "Results of a fit: ceres.json, fit.json, temp_poly.json, or the run folder that holds one")
      ->required();
  a.data.add_to(sub);  // the recording to calibrate: run folder or dataset file, as for `stend fit`
  a.data.add_accept_damaged(sub);
  sub->add_option("-o,--output", a.output, "New run folder for the calibrated recording");
  sub->add_option("--assume", a.assumptions, kAssumeHelp);
  sub->add_flag("--validate", a.validate,
                "Validate on the input (a recording the calibration was not fitted to): each check PASS, FAIL or NOT "
                "CHECKED against its limit; exit 3 unless it passes");
  sub->add_option("--expect-rotation", a.rotations,
                  "AXIS:DEGREES, e.g. x:90: turns between still intervals to integrate and compare (repeatable)");
  sub->add_option("--rebias-from-start", a.options.rebias_from_start_s,
                  "Re-estimate the gyro bias from the first S seconds (they must be still)")
      ->check(above(0));
  sub->add_option("--gravity", a.options.gravity_mps2, "Local gravity [m/s^2] (default: the recording's)")
      ->check(within(physics::kMinPlausibleGravity_mps2, physics::kMaxPlausibleGravity_mps2));
  sub->add_option("--confidence", a.options.confidence, "Level of the turns' intervals (default 0.95)")
      ->check(strictly_within(0, 1));
  sub->add_option("--validation-out", a.json,
                  "Where to write the validation results (default CALIBRATED/validation.json; with no -o, only here)");
  add_json_flag(sub, "what was written and the validation's outcome");
  out.push_back({sub, [] {
                   const Outcome o = run_apply(a);
                   print_json(o.doc);
                   return o.code;
                 }});
}

}  // namespace stend::cli
