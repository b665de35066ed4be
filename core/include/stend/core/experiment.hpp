// The experiment model: what a researcher writes in experiment YAML, parsed and validated.
// Everything the runner needs is resolved here (defaults filled, units converted where the key
// names a non-SI unit, repeats and sweeps expanded), and every element remembers where in the
// file it came from so later checks (against the limits plugins declare) can point at it.
#pragma once

#include <stend/core/clock.hpp>
#include <stend/errors.hpp>
#include <stend/sdk.hpp>

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

namespace stend {

// Something the plugin host knows about a plugin, enough to validate its configuration.
class PluginCatalogue {
 public:
  virtual ~PluginCatalogue() = default;
  // nullptr when no plugin of that name was loaded.
  virtual const stend_plugin_info* find(const std::string& name) const = 0;
  virtual std::vector<std::string> names() const = 0;  // for "did you mean"
  // Why a plugin file that would provide `name` was not loaded ("" when there is none).
  virtual std::string why_not_loaded(const std::string& /*name*/) const { return {}; }
};

// Validates a plugin `config:` mapping against the plugin's schema and fills defaults.
// `node` may be null/undefined (all defaults). Errors name file:line:column of the offending key
// or value, what was expected (type, unit, range, choices) and suggest the closest known key.
Params params_from_yaml(const YAML::Node& node, const stend_plugin_info& plugin,
                        const std::string& file, const std::string& key_path);

namespace yaml {
// Emits validated plugin parameters as a mapping, in the order of the plugin's schema (keys the
// schema does not name follow in alphabetical order); `plugin` may be null.
void emit_params(YAML::Emitter& out, const Params& params, const stend_plugin_info* plugin);
}  // namespace yaml

struct PluginInstance {
  std::string plugin;  // plugin name
  Params params;       // validated config
  SourceLocation where;
};

struct FixtureDecl : PluginInstance {
  std::string id;  // unique within the bench, referenced by procedure steps
  std::string on;  // id of the fixture it stands on; "" = the bench base
};

struct GravitySpec {
  std::optional<double> value_mps2;  // explicit local g, if given
  double latitude_deg = 0.0;
  double height_m = 0.0;
  double resolved_mps2 = 0.0;  // value_mps2 or normal gravity at latitude/height
  bool stated = false;         // the file has bench.gravity (else the defaults above)
  // The latitude is known: stated, and not replaced by a measured value_mps2.
  bool latitude_known() const { return stated && !value_mps2; }
};

struct AxisTarget {
  std::string axis;  // fixture axis name
  double value = 0;  // axis unit (deg for tables)
};

struct Orientation {
  std::vector<AxisTarget> targets;
  SourceLocation where;
};

struct Step {
  // The first six are commanded by the bench; the observed kinds (faces, turns, rate legs, still)
  // describe what somebody else did to the sensor: Stend finds them in a recording (stend import
  // --experiment, stend/alignment/align.hpp) and never commands them.
  enum class Kind { kSetTemperature, kOrientations, kRates, kRecord, kWait, kSetVibration, kFaces, kTurns, kRateLegs, kStill };
  Kind kind = Kind::kRecord;
  SourceLocation where;
  std::string label;     // optional `label:`; default the kind name
  int repeat_index = 0;  // which pass of an enclosing `repeat` (0 when none)
  std::string fixture;   // fixture id the step commands ("" for record/wait)

  // set_temperature
  double setpoint_c = 25.0, tolerance_c = 0.5, hold_s = 60.0, timeout_s = 3600.0;
  bool record_settling = true;  // record sensor samples while settling
  // orientations (expanded from list / grid / sweep)
  std::vector<Orientation> orientations;
  // rates: one axis of a table turning at each rate in turn
  std::string axis;
  std::vector<double> rates;  // axis unit per second (deg/s)
  // orientations, rates, record, wait
  double dwell_s = 0.0;   // settle time after the fixture reports settled, not recorded as data
  double record_s = 0.0;  // recording time per orientation / rate; the duration_s of record and wait
  // set_vibration
  double amplitude_g = 0.0, frequency_hz = 0.0;  // direction is the shaker's own config

  // Observed steps. Directions are unit vectors in the sensor frame.
  std::vector<Eigen::Vector3d> faces_up;  // faces: the sensor direction pointing up, one per face
  Eigen::Vector3d sensor_axis = Eigen::Vector3d::Zero();  // turns, rate_legs: the rotation axis
  std::optional<Eigen::Vector3d> up;  // rate_legs: the sensor direction up during the legs, if stated
  double angle_deg = 0.0;  // turns: the angle of each turn, a magnitude [deg]
  int direction = 0;       // turns: +1 positive about sensor_axis, −1 negative, 0 either (from the data)
  int count = 1;           // turns, still: how many (still: 0 = every still left, `count: all`)
  // faces, rate_legs, still: record_s above is the least time each face, leg or still is held [s]
  // (0: the alignment's own minimum). Any observed step: the window of the recording's clock its
  // stretches are looked for in [s], from `within_s: [from, to]`; the whole recording by default.
  double within_from_s = -std::numeric_limits<double>::infinity();
  double within_to_s = std::numeric_limits<double>::infinity();
};

// Whether the bench commands steps of this kind (false: an observed step).
bool step_is_commanded(Step::Kind kind);

// The kind's name in the experiment file: "set_temperature", "orientations", "rates", …
const char* step_kind_name(Step::Kind kind);

// Bounds on what one run may produce, each written once here. A single duration beyond
// max_run_time_s is refused while the file is read; the whole run's expected figures
// (estimate_run in runner.hpp) are checked before it starts. The experiment's `limits:` block
// overrides them (docs/experiment-format.md).
struct RunLimits {
  double max_run_time_s = 30.0 * 86400.0;  // 30 days of run time
  double max_samples = 1e10;               // sensor samples written
  double max_bytes = 1e12;                 // 1 TB written into the run folder
  SourceLocation where;                    // the `limits:` block; the file when absent
};

struct Outputs {
  std::string directory = "runs";  // run folders are created inside, relative to the CWD
  bool report = true;
};

struct Experiment {
  std::string file;         // path as given
  std::string name;         // [A-Za-z0-9_.-]+
  std::string description;
  std::uint64_t seed = 1;   // seeds every simulated noise source
  ClockKind clock = ClockKind::kAuto;
  std::vector<std::string> plugin_paths;  // resolved relative to the experiment file

  GravitySpec gravity;
  double base_heading_deg = 0.0;  // azimuth of the bench base x axis from east, for Earth rate
  PluginInstance sensor;  // plugin "" when the file only describes a procedure (no bench to run)
  std::vector<FixtureDecl> fixtures;  // in stacking order: each stands on an earlier one or base
  std::string mounted_on;  // fixture id carrying the sensor, or "base"; default the last fixture declared
  Eigen::Matrix3d R_sensor_from_mount = Eigen::Matrix3d::Identity();  // mounting rotation

  RunLimits limits;
  std::vector<Step> procedure;  // repeats expanded

  YAML::Node processing;  // consumed by processing / estimators (validated there)
  YAML::Node estimation;
  Outputs outputs;

  std::string resolved_yaml;  // the whole experiment, defaults filled in, as YAML text
};

// Stage 1: read the file, check structure, types, units and plugin configs (against the
// catalogue's schemas). Throws ExperimentError for the first problem found.
Experiment load_experiment(const std::string& path, const PluginCatalogue& catalogue);
// Same from text (`file` is the name used in messages).
Experiment parse_experiment(const std::string& yaml_text, const std::string& file,
                            const PluginCatalogue& catalogue);

// Reads only `experiment.plugin_paths` (resolved like load_experiment does), so a host can add
// them to its search path before loading plugins and validating the whole file. Throws
// ExperimentError for an unreadable file, a YAML syntax error or a malformed plugin_paths.
std::vector<std::string> experiment_plugin_paths(const std::string& path);

// Stage 2: with the plugin objects created, check the procedure against the limits the fixtures
// declare (axis names exist, targets within range, rates within max_rate, setpoints within the
// chamber's range, step fixture ids exist and have the right role). `fixtures[i]` belongs to
// exp.fixtures[i].
void validate_against_bench(const Experiment& exp, const std::vector<const Fixture*>& fixtures);
// Before any plugin is created: the experiment can run on a bench — it names a sensor and has no
// observed step (those are aligned to an imported recording instead). Throws ExperimentError.
void require_runnable(const Experiment& exp);

}  // namespace stend
