// Shared analysis helpers of the `stend` program: open a recording or dataset, fit a model file.
#include "commands.hpp"

#include "stend/estimators/builtin.hpp"
#include "stend/io/importers.hpp"
#include "stend/plugin_host.hpp"

#include <fmt/format.h>

#include <fstream>
#include <iostream>

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

namespace {

// The estimator `name` (or the one the model file is written for, with "auto"): built in, or an
// estimator plugin on the search path. `host` keeps a plugin loaded while it is used.
const estimation::EstimatorEntry& resolve_estimator(const estimation::Registry& registry, PluginHost& host,
                                                    estimation::Registry& with_plugins, const std::string& name,
                                                    const std::string& model_file) {
  if (name == "auto") return registry.for_model(YAML::LoadFile(model_file), model_file);
  if (const auto* e = registry.find(name)) return *e;
  host.scan(PluginHost::default_search_path());
  with_plugins = registry;
  with_plugins.add_plugins(host);
  if (const auto* e = with_plugins.find(name)) return *e;
  throw std::runtime_error("no estimator '" + name + "': not built in (" + registry.names() +
                           ") and no estimator plugin of that name on the search path "
                           "(`stend plugins` lists what is found; STEND_PLUGIN_PATH adds a folder)");
}

}  // namespace

void write_results(std::filesystem::path json, const std::string& document, const std::string& text) {
  if (json.empty()) {
    fmt::print("results:    not written (the input is not a run folder; --json FILE writes them)\n");
    return;
  }
  std::ofstream(json) << document << "\n";
  std::filesystem::path txt = json;
  std::ofstream(txt.replace_extension(".txt")) << text;
  fmt::print("results:    {}\n", json.string());
}

bool fit_recording(const stend::Recording& rec, const std::string& model_file, const std::filesystem::path& out_dir,
                   const std::string& json_out, const std::string& estimator) {
  const estimation::Registry registry = estimators::builtin();
  PluginHost host;
  estimation::Registry with_plugins;
  const estimation::EstimatorEntry& entry = resolve_estimator(registry, host, with_plugins, estimator, model_file);
  EstimatorRequest request;
  request.recording = &rec;
  request.input = rec.dir.string();
  request.model_file = model_file;
  request.output_dir = out_dir.string();
  const EstimatorResult r = entry.create()->fit(request);
  std::string text = r.text;
  if (!r.ok && !r.message.empty() && text.find(r.message) == std::string::npos)
    text += entry.name + ": FAILED — " + r.message + "\n";
  std::filesystem::path json = json_out;
  if (json.empty() && !out_dir.empty()) json = out_dir / (r.json_name.empty() ? entry.results_file : r.json_name);
  std::cout << text;
  write_results(json, r.json, text);
  return r.ok;
}

}  // namespace stend::cli
