// Shared analysis helpers of the `stend` program: open a recording or dataset, fit a model file.
#include "commands.hpp"

#include "stend/allan/allan.hpp"
#include "stend/batch_lsq/batch_lsq.hpp"
#include "stend/ceres_nonlinear/model_file.hpp"
#include "stend/plugin_host.hpp"
#include "stend/io/importers.hpp"
#include "stend/temp_poly/temp_poly.hpp"

#include <fmt/format.h>

#include <fstream>
#include <iostream>
#include <sstream>

namespace stend::cli {

// A recording from a run folder, or a dataset file through its importer:
//   --format run|imucal|mpu6050_multipos|mat|imutk (imutk: "ACC_FILE,GYRO_FILE"), or auto.
stend::Recording open_recording(const std::string& input, std::string format) {
  namespace fs = std::filesystem;
  if (format.empty() || format == "auto") {
    if (fs::is_directory(input)) format = "run";
    else if (fs::path(input).extension() == ".mat") format = "mat";
    else {
      std::ifstream in(input);
      std::string first;
      std::getline(in, first);
      if (first.rfind("part,samples", 0) == 0) format = "imucal";
      else if (first.rfind("Fs,", 0) == 0) format = "mpu6050_multipos";
      else
        throw std::runtime_error(input + ": cannot tell the format; give --format run|imucal|mpu6050_multipos|mat|imutk");
    }
  }
  if (format == "run") return stend::Recording::open(input);
  if (format == "imucal") return stend::io::import_imucal_session(input);
  if (format == "mpu6050_multipos") return stend::io::import_mpu6050_multipos(input);
  if (format == "mat") return stend::io::import_mat(input);
  if (format == "imutk") {
    const auto comma = input.find(',');
    if (comma == std::string::npos) throw std::runtime_error("--format imutk takes ACC_FILE,GYRO_FILE");
    return stend::io::import_imutk(input.substr(0, comma), input.substr(comma + 1));
  }
  throw std::runtime_error("unknown format '" + format + "'");
}

// Which estimator a model file is for: `allan` (top-level `allan:` mapping), `temp_poly`
// (temperature-model options: `selection:` / `max_order:`), otherwise `batch_lsq`.
std::string estimator_of(const YAML::Node& root) {
  if (root.IsMap() && root["allan"]) return "allan";
  if (root.IsMap() && root["ceres_nonlinear"]) return "ceres_nonlinear";
  if (root.IsMap() && (root["selection"] || root["max_order"])) return "temp_poly";
  return "batch_lsq";
}

// Fits the model to a recording, prints the report and writes the results JSON (+ a text copy)
// into `out_dir`. Returns false when the fit failed (it says why, with no numbers).
bool fit_recording(const stend::Recording& rec, const std::string& model_file, const std::filesystem::path& out_dir,
                   const std::string& json_out, std::string estimator) {
  const YAML::Node root = YAML::LoadFile(model_file);
  if (estimator == "auto") estimator = estimator_of(root);
  std::ostringstream text;
  std::filesystem::path json = json_out;
  bool ok = true;
  std::string json_text;
  if (estimator == "temp_poly") {
    const stend::temp_poly::TempPolyResult r =
        stend::temp_poly::fit_temperature_model(rec, stend::temp_poly::load_options(model_file));
    stend::temp_poly::print_report(text, r);
    json_text = stend::temp_poly::to_json(r);
    ok = r.ok;
    if (json.empty()) json = out_dir / "temp_poly.json";
  } else if (estimator == "allan") {
    const stend::allan::AllanReport report =
        stend::allan::analyze_recording(rec, stend::allan::options_from_yaml(root["allan"], model_file));
    stend::allan::write_summary_table(text, report);
    std::ostringstream j;
    stend::allan::write_json(j, report);
    json_text = j.str();
    if (json.empty()) json = out_dir / "allan.json";
  } else if (estimator == "ceres_nonlinear") {
    const auto f = stend::ceres_nonlinear::fit_model_file(rec, stend::ceres_nonlinear::load_model_file(model_file));
    text << f.text;
    json_text = f.json;
    ok = f.ok;
    if (json.empty()) json = out_dir / "ceres.json";
  } else if (estimator != "batch_lsq") {
    // Not built in: an estimator plugin of that name on the search path (out-of-tree estimators).
    stend::PluginHost host;
    host.scan(stend::PluginHost::default_search_path());
    const stend_plugin_info* info = host.find(estimator);
    if (info == nullptr || info->kind != STEND_KIND_ESTIMATOR)
      throw std::runtime_error("no estimator '" + estimator + "': not built in (batch_lsq, temp_poly, allan, "
                               "ceres_nonlinear) and no estimator plugin of that name on the search path "
                               "(`stend plugins` lists what is found; STEND_PLUGIN_PATH adds a folder)");
    auto plugin = host.create_estimator(estimator, stend::Params{});
    stend::EstimatorRequest request;
    request.recording = &rec;
    request.input = rec.dir.string();
    request.model_file = model_file;
    request.output_dir = out_dir.string();
    const stend::EstimatorResult r = plugin->fit(request);
    text << r.text;
    if (!r.ok) text << estimator << ": FAILED — " << r.message << "\n";
    json_text = r.json;
    ok = r.ok;
    if (json.empty()) json = out_dir / (r.json_name.empty() ? estimator + ".json" : r.json_name);
  } else {
    const stend::batch_lsq::FitResult fit =
        stend::batch_lsq::fit_recording(rec, stend::batch_lsq::load_model_spec(model_file));
    stend::batch_lsq::print_table(text, fit);
    json_text = stend::batch_lsq::to_json(fit);
    ok = fit.ok;
    if (json.empty()) json = out_dir / "fit.json";
  }
  std::cout << text.str();
  std::ofstream(json) << json_text << "\n";
  std::filesystem::path txt = json;
  std::ofstream(txt.replace_extension(".txt")) << text.str();
  fmt::print("results:    {}\n", json.string());
  return ok;
}


}  // namespace stend::cli
