// The experiment file read (stage 1): its sections in order — experiment:, bench: (see
// experiment_bench.cpp), limits:, procedure: (experiment_expand.cpp), processing:, estimation:,
// outputs: — and the resolved YAML made from the result. The format is documented in
// docs/experiment-format.md; keep the two in step.
#include "experiment_parse.hpp"

#include <algorithm>
#include <tuple>
#include <utility>

namespace stend {

namespace {

using yaml::MapReader;
using yaml::format_number;
using namespace detail;

const std::vector<std::string> kTopKeys = {"experiment", "bench",      "limits",  "procedure",
                                           "processing", "estimation", "outputs"};

bool valid_experiment_name(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

// Reads the sections of one experiment file into an Experiment.
class ExperimentReader {
 public:
  ExperimentReader(std::string file, const PluginCatalogue& catalogue)
      : file_(std::move(file)), cat_(catalogue) {}

  // The sections in the order later ones need earlier ones: the procedure's durations are bounded
  // by the limits, its fixtures declared by the bench.
  Experiment run(const std::string& text) {
    const YAML::Node root = load_root(text, file_);
    exp_.file = file_;
    const MapReader top(root, file_, "", "the experiment file", kTopKeys);
    top.require("experiment", "name, seed and clock of the experiment");
    experiment_section(top);
    top.require("bench", "the sensor under test and the fixtures it stands on");
    read_bench(top, cat_, exp_);
    limits_section(top);  // before the procedure, whose durations it bounds
    top.require("procedure", "the list of steps to run");
    exp_.procedure = read_procedure(top, exp_);
    exp_.processing = free_mapping(top, "processing");
    exp_.estimation = free_mapping(top, "estimation");
    outputs_section(top);
    return std::move(exp_);
  }

 private:
  // --- experiment: ---------------------------------------------------------------------------
  void experiment_section(const MapReader& top) {
    const MapReader m(top.get("experiment"), file_, "experiment", "the 'experiment' section",
                      {"name", "description", "seed", "clock", "plugin_paths"}, {},
                      top.key_location("experiment"));
    m.require("name", "letters, digits, '_', '.', '-'; names the run folders");
    exp_.name = m.string("name", "");
    if (!valid_experiment_name(exp_.name))
      m.fail_value("name",
                   "experiment name '" + exp_.name +
                       "' may only contain letters, digits, '_', '.' and '-'",
                   "e.g. name: paper_mpu6050_z");
    exp_.description = m.string("description", "");
    const std::int64_t seed = m.integer("seed", 1);
    if (seed < 0)
      m.fail_value("seed", "'seed' must be a non-negative integer, got " + std::to_string(seed));
    exp_.seed = static_cast<std::uint64_t>(seed);
    exp_.clock = clock(m, exp_.clock);
    if (m.has("plugin_paths"))
      exp_.plugin_paths =
          resolve_plugin_paths(m.get("plugin_paths"), file_, m.child_path("plugin_paths"));
  }

  // `clock`: auto, simulated or wall.
  static ClockKind clock(const MapReader& m, ClockKind fallback) {
    const std::string name = m.string("clock", to_string(fallback));
    const auto kind = clock_kind_from_string(name);
    if (!kind)
      m.fail_value("clock", "unknown clock '" + name + "'",
                   yaml::join_sentences(yaml::did_you_mean(name, clock_kind_names()),
                                        "clock is one of: " + yaml::join(clock_kind_names())));
    return *kind;
  }

  // --- limits: what one run may produce (RunLimits) -------------------------------------------
  void limits_section(const MapReader& top) {
    RunLimits& l = exp_.limits;
    l.where = SourceLocation{file_, 0, 0};
    if (!top.has("limits")) return;
    l.where = top.key_location("limits");
    const MapReader m(top.get("limits"), file_, "limits", "'limits'", {"max_run_time_s", "max_samples", "max_bytes"},
                      {}, l.where);
    for (auto [key, value, words] : {std::tuple<const char*, double*, const char*>{"max_run_time_s", &l.max_run_time_s, "in seconds"},
                                     {"max_samples", &l.max_samples, "sensor samples"},
                                     {"max_bytes", &l.max_bytes, "bytes"}}) {
      *value = m.number(key, *value, words);
      if (!(*value > 0)) m.fail_value(key, std::string("'") + key + "' must be greater than 0, got " + format_number(*value));
    }
  }

  // --- processing:, estimation:, outputs: ----------------------------------------------------
  static YAML::Node free_mapping(const MapReader& top, const std::string& key) {
    const YAML::Node n = top.get(key);
    if (!n.IsDefined() || n.IsNull()) return YAML::Node(YAML::NodeType::Map);
    if (!n.IsMap())
      top.fail_value(key, "expected a mapping for '" + key + "', got " + yaml::describe(n));
    return YAML::Clone(n);
  }

  void outputs_section(const MapReader& top) {
    const MapReader m(top.get("outputs"), file_, "outputs", "'outputs'", {"directory", "report"},
                      {}, top.key_location("outputs"));
    exp_.outputs.directory = m.string("directory", "runs");
    if (exp_.outputs.directory.empty())
      m.fail_value("directory", "'directory' must not be empty", "e.g. directory: runs");
    exp_.outputs.report = m.boolean("report", exp_.outputs.report);
  }

  std::string file_;
  const PluginCatalogue& cat_;
  Experiment exp_;
};

}  // namespace

Experiment parse_experiment(const std::string& yaml_text, const std::string& file,
                            const PluginCatalogue& catalogue) {
  Experiment exp = ExperimentReader(file, catalogue).run(yaml_text);
  exp.resolved_yaml = emit_resolved(exp, catalogue);
  return exp;
}

Experiment load_experiment(const std::string& path, const PluginCatalogue& catalogue) {
  return parse_experiment(read_text_file(path), path, catalogue);
}

}  // namespace stend
