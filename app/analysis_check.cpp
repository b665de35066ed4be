// The checks a run's fit will make, made by `stend validate` and `stend run` before the bench
// moves (commands.hpp: check_analysis): a run that cannot be analysed is refused up front.
#include "commands.hpp"

#include "stend/errors.hpp"
#include "stend/estimation/registry.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/processing/options.hpp"
#include "stend/yaml/reader.hpp"

#include <filesystem>

namespace stend::cli {

namespace {

// The experiment's processing: section read as the fit reads it from RUN/experiment.yaml
// (processing::resolve): unknown keys and bad values refused at file:line:col.
void check_processing_section(const YAML::Node& root, const std::string& file) {
  const YAML::Node section = root["processing"];
  if (!section || section.IsNull()) return;
  const yaml::MapReader reader(section, file, "processing", "'processing'", processing::kOptionKeys);
  processing::ProcessingOptions options;
  processing::read_options(reader, options);
}

// The model file estimation: model: names (relative to the experiment's folder, as `stend run`
// reads it): present, claimed by an estimator, and — for the linear fits — read whole.
void check_model_file(const YAML::Node& root, const std::string& file) {
  const YAML::Node estimation = root["estimation"];
  if (!estimation || !estimation.IsMap() || !estimation["model"]) return;
  const YAML::Node name = estimation["model"];
  std::filesystem::path model = name.as<std::string>();
  if (model.is_relative()) model = std::filesystem::path(file).parent_path() / model;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(model, ec))
    throw ExperimentError(yaml::location_of(name, file), "model",
                          "the model file '" + model.string() + "' does not exist (the run's fit would fail after "
                          "recording)",
                          "give a path relative to the experiment file, or an absolute one");
  const estimation::Registry registry = estimators::builtin();
  const estimation::EstimatorEntry& entry = registry.for_model(yaml::load_file(model.string(), "model file"), model.string());
  if (entry.linear_model) entry.linear_model(model.string());
}

}  // namespace

void check_analysis(const std::string& experiment_file) {
  const YAML::Node root = yaml::load_file(experiment_file, "experiment file");
  if (!root.IsMap()) return;  // the experiment reader has said what is wrong already
  check_processing_section(root, experiment_file);
  check_model_file(root, experiment_file);
}

}  // namespace stend::cli
