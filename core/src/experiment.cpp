// The experiment model: experiment YAML parsed, validated (stage 1: structure, types, units,
// plugin configs; stage 2: procedure against the fixtures' declared limits), and resolved.
// The format is documented in docs/experiment-format.md; keep the two in step.
#include <stend/core/experiment.hpp>
#include <stend/physics/geometry.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/yaml/reader.hpp>

#include <Eigen/LU>
#include <yaml-cpp/eventhandler.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <tuple>
#include <utility>

namespace stend {

namespace fs = std::filesystem;
using yaml::MapReader;
using yaml::format_number;

// ---------------------------------------------------------------------------------------------
// Stage 1

namespace {

constexpr std::size_t kMaxOrientationsPerStep = 100000;
constexpr std::size_t kMaxSteps = 100000;

const std::vector<std::string> kTopKeys = {"experiment", "bench",      "limits",  "procedure",
                                           "processing", "estimation", "outputs"};
// Each step kind: its YAML name and the keys its body may hold. `repeat` is a step kind of the
// file that expands into the others, so it has no Step::Kind.
struct StepKindSpec {
  Step::Kind kind;
  const char* name;
  std::vector<std::string> keys;
};
const std::vector<StepKindSpec> kStepKindSpecs = {
    {Step::Kind::kSetTemperature, "set_temperature",
     {"fixture", "setpoint_c", "tolerance_c", "hold_s", "timeout_s", "record", "label"}},
    {Step::Kind::kOrientations, "orientations",
     {"fixture", "sweep", "list", "grid", "dwell_s", "record_s", "label"}},
    {Step::Kind::kRates, "rates", {"fixture", "axis", "rates_dps", "dwell_s", "record_s", "label"}},
    {Step::Kind::kSetVibration, "set_vibration", {"fixture", "amplitude_g", "frequency_hz", "label"}},
    {Step::Kind::kRecord, "record", {"duration_s", "label"}},
    {Step::Kind::kWait, "wait", {"duration_s", "label"}},
};

// Every step kind name of the file, `repeat` last.
std::vector<std::string> step_kind_names() {
  std::vector<std::string> out;
  for (const auto& k : kStepKindSpecs) out.push_back(k.name);
  out.push_back("repeat");
  return out;
}
const std::vector<std::string> kStepKinds = step_kind_names();

const StepKindSpec* find_step_kind(const std::string& name) {
  for (const auto& k : kStepKindSpecs)
    if (name == k.name) return &k;
  return nullptr;
}

const char* kind_words(stend_plugin_kind k) {
  switch (k) {
    case STEND_KIND_SENSOR: return "sensor";
    case STEND_KIND_FIXTURE: return "fixture";
    case STEND_KIND_ESTIMATOR: return "estimator";
  }
  return "unknown-kind";
}

bool valid_experiment_name(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

bool valid_fixture_id(const std::string& s) {
  if (s.empty() || !(s[0] >= 'a' && s[0] <= 'z')) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

[[noreturn]] void fail(const SourceLocation& where, const std::string& path,
                       const std::string& message, const std::string& hint = {}) {
  throw ExperimentError(where, path, message, hint);
}

[[noreturn]] void syntax_error(const YAML::Mark& mark, const std::string& msg,
                               const std::string& file) {
  SourceLocation loc{file, 0, 0};
  if (mark.line >= 0 && mark.column >= 0) {
    loc.line = mark.line + 1;
    loc.column = mark.column + 1;
  }
  fail(loc, "", "YAML syntax error: " + msg,
       "check indentation (spaces, not tabs), brackets and quotes on this line and the one "
       "before");
}

std::string read_text_file(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec))
    fail({path, 0, 0}, "", "experiment file '" + path + "' does not exist",
         "check the path (relative paths are taken from the current folder)");
  if (fs::is_directory(path, ec))
    fail({path, 0, 0}, "", "'" + path + "' is a folder, not an experiment file",
         "give the path of the experiment's .yaml file");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    fail({path, 0, 0}, "",
         "cannot open experiment file '" + path + "': " + std::generic_category().message(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Where each YAML document of a text starts (its first node) and whether it is only a null,
// from yaml-cpp's event parser.
class DocumentStarts final : public YAML::EventHandler {
 public:
  struct Start {
    YAML::Mark mark;
    bool null;
  };
  std::vector<Start> starts;

  void OnDocumentStart(const YAML::Mark&) override { first_ = true; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& m, YAML::anchor_t) override { node(m, true); }
  void OnAlias(const YAML::Mark& m, YAML::anchor_t) override { node(m, false); }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t, const std::string&) override { node(m, false); }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(m, false);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(m, false);
  }
  void OnMapEnd() override {}

 private:
  void node(const YAML::Mark& m, bool null) {
    if (first_) starts.push_back({m, null});
    first_ = false;
  }
  bool first_ = false;
};

// The documents of an experiment file, walked with the event parser rather than YAML::LoadAll:
// yaml-cpp 0.7 (Debian 12) loops for ever there, allocating a null document per turn, when a
// document starts with a token no node starts with, e.g. a stray ',' (jbeder/yaml-cpp#1319). Two
// null documents in a row at the same place are the parser stuck on such a token: a syntax error
// there. The walk stops at the second document that holds something (an experiment is one).
std::vector<DocumentStarts::Start> document_starts(const std::string& text, const std::string& file) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentStarts docs;
  try {
    while (parser.HandleNextDocument(docs)) {
      const auto& s = docs.starts;
      const std::size_t n = s.size();
      if (n >= 2 && s[n - 1].null && s[n - 2].null && s[n - 1].mark.pos == s[n - 2].mark.pos) {
        const auto pos = static_cast<std::size_t>(std::max(0, s[n - 1].mark.pos));
        syntax_error(s[n - 1].mark,
                     pos < text.size() ? "unexpected '" + text.substr(pos, 1) + "': no YAML node starts with it"
                                       : "unexpected end of the text",
                     file);
      }
      if (std::count_if(s.begin(), s.end(), [](const auto& d) { return !d.null; }) >= 2) break;
    }
  } catch (const YAML::Exception& e) {
    syntax_error(e.mark, e.msg, file);
  }
  return docs.starts;
}

YAML::Node load_root(const std::string& text, const std::string& file) {
  std::vector<DocumentStarts::Start> docs = document_starts(text, file);
  while (docs.size() > 1 && docs.back().null) docs.pop_back();
  if (docs.empty() || docs[0].null)
    fail({file, 1, 1}, "", "the experiment file is empty",
         "an experiment has 'experiment:', 'bench:' and 'procedure:' sections; see "
         "docs/experiment-format.md");
  if (docs.size() > 1)
    fail({file, docs[1].mark.line + 1, docs[1].mark.column + 1}, "",
         "a second YAML document starts here; an experiment is a single document",
         "remove the '---' separator and merge the documents");
  YAML::Node root;
  try {
    root = YAML::Load(text);  // the first document
  } catch (const YAML::Exception& e) {
    syntax_error(e.mark, e.msg, file);
  }
  if (!root.IsMap())
    fail(yaml::location_of(root, file), "",
         "expected the experiment as a mapping with 'experiment:', 'bench:' and 'procedure:' "
         "sections, got " + yaml::describe(root));
  return root;
}


std::vector<std::string> resolve_plugin_paths(const YAML::Node& node, const std::string& file,
                                              const std::string& path) {
  std::vector<std::string> out;
  if (!node.IsDefined() || node.IsNull()) return out;
  if (!node.IsSequence())
    fail(yaml::location_of(node, file), path,
         "expected a list of folders for 'plugin_paths', got " + yaml::describe(node),
         "write plugin_paths: [./my_plugins]");
  const fs::path base = fs::path(file).parent_path();
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string epath = path + "[" + std::to_string(i) + "]";
    const std::string s = yaml::as_string(node[i], file, epath);
    if (s.empty())
      fail(yaml::location_of(node[i], file), epath, "a plugin path must not be empty");
    fs::path p(s);
    if (p.is_relative()) p = base / p;
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    if (ec) abs = p;
    abs = abs.lexically_normal();
    if (abs.has_relative_path() && abs.filename().empty()) abs = abs.parent_path();
    if (!fs::is_directory(abs, ec))
      fail(yaml::location_of(node[i], file), epath,
           "plugin path '" + s + "' (" + abs.string() + ") " + (fs::exists(abs, ec) ? "is not a folder" : "does not exist"),
           "plugin_paths lists folders holding stend_<name>.so files, relative to the experiment file's folder");
    out.push_back(abs.string());
  }
  return out;
}

// One step in the expansion, with how many times its source step is repeated per pass of the
// repeat that encloses this list (to number the passes of nested repeats through).
struct Expanded {
  Step step;
  std::int64_t multiplicity = 1;
};

class Parser {
 public:
  Parser(std::string file, const PluginCatalogue& catalogue)
      : file_(std::move(file)), cat_(catalogue) {}

  Experiment run(const std::string& text) {
    const YAML::Node root = load_root(text, file_);
    exp_.file = file_;
    const MapReader top(root, file_, "", "the experiment file", kTopKeys);
    top.require("experiment", "name, seed and clock of the experiment");
    experiment_section(top);
    top.require("bench", "the sensor under test and the fixtures it stands on");
    bench_section(top);
    limits_section(top);  // before the procedure, whose durations it bounds
    top.require("procedure", "the list of steps to run");
    procedure_section(top);
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
    exp_.clock = m.string("clock", "auto");
    const std::vector<std::string> clocks = {"auto", "simulated", "wall"};
    if (std::find(clocks.begin(), clocks.end(), exp_.clock) == clocks.end()) {
      m.fail_value("clock", "unknown clock '" + exp_.clock + "'",
                   yaml::join_sentences(yaml::did_you_mean(exp_.clock, clocks),
                                        "clock is one of: auto, simulated, wall"));
    }
    if (m.has("plugin_paths"))
      exp_.plugin_paths =
          resolve_plugin_paths(m.get("plugin_paths"), file_, m.child_path("plugin_paths"));
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

  // --- bench: --------------------------------------------------------------------------------
  void bench_section(const MapReader& top) {
    const MapReader m(top.get("bench"), file_, "bench", "the 'bench' section",
                      {"gravity", "base_heading_deg", "sensor", "fixtures", "mounting"}, {},
                      top.key_location("bench"));
    gravity(m);
    exp_.base_heading_deg = m.number("base_heading_deg", exp_.base_heading_deg, "in degrees");
    m.require("sensor", "the sensor under test: plugin and config");
    {
      const MapReader s(m.get("sensor"), file_, "bench.sensor", "the sensor", {"plugin", "config"},
                        {}, m.key_location("sensor"));
      exp_.sensor = instance(s, STEND_KIND_SENSOR);
    }
    fixtures(m);
    mounting(m);
  }

  void gravity(const MapReader& bench) {
    GravitySpec& g = exp_.gravity;
    const MapReader m(bench.get("gravity"), file_, "bench.gravity", "'gravity'",
                      {"latitude_deg", "height_m", "value_mps2"}, {"resolved_mps2"},
                      bench.key_location("gravity"));
    const std::string hint =
        "give either value_mps2 (measured local gravity) or latitude_deg and height_m (normal "
        "gravity is computed from them), not both";
    m.at_most_one_of({"value_mps2", "latitude_deg"}, hint);
    m.at_most_one_of({"value_mps2", "height_m"}, hint);
    if (m.has("value_mps2")) {
      const double v = m.number("value_mps2", 0.0, "in m/s^2");
      if (v < physics::kMinPlausibleGravity_mps2 || v > physics::kMaxPlausibleGravity_mps2)
        m.fail_value("value_mps2",
                     "local gravity " + format_number(v) + " m/s^2 is not plausible on the Earth's surface (" +
                         format_number(physics::kMinPlausibleGravity_mps2) + " .. " +
                         format_number(physics::kMaxPlausibleGravity_mps2) + " m/s^2)",
                     "value_mps2 is in m/s^2, e.g. 9.8154");
      g.value_mps2 = v;
      g.resolved_mps2 = v;
    } else {
      g.latitude_deg = m.number("latitude_deg", g.latitude_deg, "in degrees");
      if (g.latitude_deg < -90.0 || g.latitude_deg > 90.0)
        m.fail_value("latitude_deg",
                     "latitude " + format_number(g.latitude_deg) + " deg is outside [-90, 90]",
                     "latitude_deg is the geodetic latitude in degrees, north positive");
      g.height_m = m.number("height_m", g.height_m, "in metres");
      if (g.height_m < -500.0 || g.height_m > 10000.0)
        m.fail_value("height_m",
                     "height " + format_number(g.height_m) + " m is outside [-500, 10000]",
                     "height_m is the height above the ellipsoid in metres");
      g.resolved_mps2 = physics::normal_gravity(g.latitude_deg, g.height_m);
    }
    if (m.has("resolved_mps2")) {
      const double r = m.number("resolved_mps2", 0.0, "in m/s^2");
      if (std::abs(r - g.resolved_mps2) > 1e-6)
        m.fail_value("resolved_mps2",
                     "'resolved_mps2' is " + format_number(r) + " but the gravity given resolves to " +
                         format_number(g.resolved_mps2) + " m/s^2",
                     "resolved_mps2 is written by Stend; remove it, or set local gravity with "
                     "value_mps2");
    }
  }

  std::vector<std::string> names_of_kind(stend_plugin_kind kind) const {
    std::vector<std::string> out;
    for (const auto& n : cat_.names()) {
      const stend_plugin_info* info = cat_.find(n);
      if (info && info->kind == kind) out.push_back(n);
    }
    return out;
  }

  PluginInstance instance(const MapReader& m, stend_plugin_kind kind) {
    const std::string kw = kind_words(kind);
    m.require("plugin", "name of a " + kw + " plugin; `stend plugins` lists them");
    const std::string name = m.string("plugin", "");
    const stend_plugin_info* info = cat_.find(name);
    const std::vector<std::string> same_kind = names_of_kind(kind);
    if (!info) {
      const std::vector<std::string> all = cat_.names();
      std::string suggestion = yaml::did_you_mean(name, same_kind);
      if (suggestion.empty()) suggestion = yaml::did_you_mean(name, all);
      const std::string loaded =
          all.empty() ? "No plugins are loaded; check the plugin search path with `stend plugins`."
                      : "Loaded " + kw + " plugins: " +
                            (same_kind.empty() ? std::string("none") : yaml::join(same_kind)) +
                            " (all loaded: " + yaml::join(all) + ")";
      const std::string why = cat_.why_not_loaded(name);
      m.fail_value("plugin", "unknown plugin '" + name + "'" + (why.empty() ? "" : ": " + why),
                   yaml::join_sentences(suggestion, loaded));
    }
    if (info->kind != kind) {
      std::string hint = "Loaded " + kw + " plugins: " +
                         (same_kind.empty() ? std::string("none") : yaml::join(same_kind));
      m.fail_value("plugin",
                   "plugin '" + name + "' is " +
                       (info->kind == STEND_KIND_ESTIMATOR ? "an " : "a ") +
                       kind_words(info->kind) + " plugin, not a " + kw + " plugin",
                   hint);
    }
    PluginInstance p;
    p.plugin = name;
    p.where = m.location();
    YAML::Node config = m.get("config");
    if (config.IsDefined() && config.IsNull()) config = YAML::Node(YAML::NodeType::Undefined);
    try {
      p.params = params_from_yaml(config, *info, file_, m.child_path("config"));
    } catch (const ExperimentError& e) {
      if (e.where().line > 0) throw;
      throw ExperimentError(m.has("config") ? m.key_location("config") : m.key_location("plugin"),
                            e.key(), e.message(), e.hint());
    }
    return p;
  }

  void fixtures(const MapReader& bench) {
    if (!bench.has("fixtures")) return;
    const YAML::Node list = bench.get("fixtures");
    if (list.IsNull()) return;
    if (!list.IsSequence())
      bench.fail_value("fixtures", "expected a list of fixtures, got " + yaml::describe(list),
                       "each fixture is an item '- id: table' with 'plugin:' (and 'on:', "
                       "'config:') below it");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string path = "bench.fixtures[" + std::to_string(i) + "]";
      const MapReader f(list[i], file_, path, "a fixture declaration",
                        {"id", "plugin", "on", "config"});
      FixtureDecl d;
      d.id = fixture_id(f);
      d.on = fixture_support(f, d.id, list, i);
      PluginInstance inst = instance(f, STEND_KIND_FIXTURE);
      d.plugin = std::move(inst.plugin);
      d.params = std::move(inst.params);
      d.where = inst.where;
      fixture_ids_.push_back(d.id);
      exp_.fixtures.push_back(std::move(d));
    }
  }

  // A fixture's `id`: well-formed, not "base", not declared before.
  std::string fixture_id(const MapReader& f) const {
    f.require("id", "[a-z][a-z0-9_]*, referenced by procedure steps");
    const std::string id = f.string("id", "");
    if (!valid_fixture_id(id))
      f.fail_value("id",
                   "fixture id '" + id +
                       "' must start with a lowercase letter and contain only a-z, 0-9 and '_'",
                   "e.g. id: table");
    if (id == "base")
      f.fail_value("id", "'base' is reserved for the bench base; choose another fixture id");
    for (const auto& earlier : exp_.fixtures)
      if (earlier.id == id)
        f.fail_value("id",
                     "duplicate fixture id '" + id + "' (first declared at line " +
                         std::to_string(earlier.where.line) + ")",
                     "fixture ids must be unique within the bench");
    return id;
  }

  // What fixture `id` (item i of `list`) stands on: an earlier fixture, or "" for the base.
  std::string fixture_support(const MapReader& f, const std::string& id, const YAML::Node& list,
                              std::size_t i) const {
    if (!f.has("on")) return {};
    const std::string on = f.string("on", "");
    if (on == "base") return {};
    if (std::find(fixture_ids_.begin(), fixture_ids_.end(), on) != fixture_ids_.end()) return on;
    bool later = false;
    for (std::size_t j = i + 1; j < list.size(); ++j)
      if (list[j].IsMap() && list[j]["id"].IsDefined() && list[j]["id"].IsScalar() && list[j]["id"].Scalar() == on) later = true;
    if (later || on == id)
      f.fail_value("on",
                   on == id ? "fixture '" + id + "' cannot stand on itself"
                            : "fixture '" + id + "' stands on '" + on + "', which is declared later",
                   "declare fixtures from the base up: a fixture can only stand on 'base' or on a "
                   "fixture declared before it");
    std::vector<std::string> ids = fixture_ids_;
    ids.insert(ids.begin(), "base");
    f.fail_value("on", "unknown fixture '" + on + "' in 'on'",
                 yaml::join_sentences(yaml::did_you_mean(on, ids),
                                      "'on' is 'base' or an earlier fixture: " + yaml::join(ids)));
  }

  void mounting(const MapReader& bench) {
    const MapReader m(bench.get("mounting"), file_, "bench.mounting", "'mounting'",
                      {"on", "rpy_deg", "matrix"}, {}, bench.key_location("mounting"));
    m.at_most_one_of({"rpy_deg", "matrix"},
                     "give the mounting rotation either as rpy_deg: [roll, pitch, yaw] or as a "
                     "3x3 matrix, not both");
    exp_.mounted_on = mounted_on(m);
    if (m.has("rpy_deg")) {
      const std::vector<double> rpy = m.numbers("rpy_deg", "in degrees");
      if (rpy.size() != 3)
        m.fail_value("rpy_deg",
                     "expected [roll, pitch, yaw] in degrees for 'rpy_deg', got " +
                         std::to_string(rpy.size()) + " numbers");
      exp_.R_sensor_from_mount = physics::from_rpy_deg(rpy[0], rpy[1], rpy[2]);
    }
    if (m.has("matrix")) exp_.R_sensor_from_mount = mounting_matrix(m);
  }

  // What carries the sensor: `on`, else the last fixture declared, else "base".
  std::string mounted_on(const MapReader& m) const {
    if (!m.has("on")) return fixture_ids_.empty() ? std::string("base") : fixture_ids_.back();
    const std::string on = m.string("on", "");
    if (on == "base") return on;
    if (std::find(fixture_ids_.begin(), fixture_ids_.end(), on) == fixture_ids_.end()) {
      std::vector<std::string> ids = fixture_ids_;
      ids.insert(ids.begin(), "base");
      m.fail_value("on", "unknown fixture '" + on + "' in mounting 'on'",
                   yaml::join_sentences(yaml::did_you_mean(on, ids),
                                        "The sensor is mounted on 'base' or a declared "
                                        "fixture: " + yaml::join(ids)));
    }
    return on;
  }

  // `matrix`: 3 rows of 3 numbers, a proper rotation (orthonormal to 1e-6, determinant +1).
  Eigen::Matrix3d mounting_matrix(const MapReader& m) const {
    const YAML::Node node = m.get("matrix");
    const std::string path = m.child_path("matrix");
    const std::string hint = "write matrix: [[1, 0, 0], [0, 1, 0], [0, 0, 1]] (rows)";
    if (!node.IsSequence() || node.size() != 3)
      m.fail_value("matrix", "expected a 3x3 rotation matrix (3 rows of 3 numbers), got " +
                                 (node.IsSequence() ? std::to_string(node.size()) + " rows"
                                                    : yaml::describe(node)),
                   hint);
    Eigen::Matrix3d R;
    for (std::size_t r = 0; r < 3; ++r) {
      const std::string rpath = path + "[" + std::to_string(r) + "]";
      const std::vector<double> row = yaml::as_numbers(node[r], file_, rpath, "");
      if (row.size() != 3)
        fail(yaml::location_of(node[r], file_), rpath,
             "row " + std::to_string(r + 1) + " of the mounting matrix has " +
                 std::to_string(row.size()) + " numbers, expected 3",
             hint);
      for (std::size_t c = 0; c < 3; ++c)
        R(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = row[c];
    }
    const double dev = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (dev > 1e-6)
      m.fail_value("matrix",
                   "the mounting matrix is not a rotation: its rows are not orthonormal "
                   "(largest deviation of R^T R from identity is " + format_number(dev) + ")",
                   "give a proper rotation (orthonormal to 1e-6, determinant +1), or use "
                   "rpy_deg: [roll, pitch, yaw]");
    if (R.determinant() < 0)
      m.fail_value("matrix", "the mounting matrix is a reflection (determinant -1), not a rotation",
                   "sensor frames are right-handed; negate one row, or use rpy_deg");
    return R;
  }

  // --- procedure: ----------------------------------------------------------------------------
  void procedure_section(const MapReader& top) {
    const YAML::Node list = top.get("procedure");
    const std::string hint = "add at least one step, e.g. '- record: {duration_s: 60}'";
    if (list.IsNull()) top.fail_key("procedure", "the procedure is empty", hint);
    if (!list.IsSequence())
      top.fail_value("procedure", "expected a list of steps for 'procedure', got " +
                                      yaml::describe(list),
                     "each step is an item like '- record: {duration_s: 60}'");
    if (list.size() == 0) top.fail_value("procedure", "the procedure is empty", hint);
    std::vector<Expanded> steps = step_list(list, "procedure", false);
    exp_.procedure.reserve(steps.size());
    for (auto& e : steps) exp_.procedure.push_back(std::move(e.step));
  }

  std::vector<Expanded> step_list(const YAML::Node& list, const std::string& path,
                                  bool inside_repeat) {
    std::vector<Expanded> out;
    for (std::size_t i = 0; i < list.size(); ++i)
      step(list[i], path + "[" + std::to_string(i) + "]", inside_repeat, out);
    return out;
  }

  // One item of a step list: a one-key mapping naming its kind. A repeat appends its expansion.
  void step(const YAML::Node& item, const std::string& path, bool inside_repeat,
            std::vector<Expanded>& out) {
    const YAML::Node key = step_kind_key(item, path);
    const YAML::Node body = item.begin()->second;
    const std::string kind = key.Scalar();
    const SourceLocation where = yaml::location_of(key, file_);
    const std::string spath = path + "." + kind;
    if (kind == "repeat") {
      repeat(body, spath, where, out);
      return;
    }
    const StepKindSpec& spec = *find_step_kind(kind);
    const MapReader m(body, file_, spath, "the " + kind + " step", spec.keys, {"repeat_index"}, where);
    Step s;
    s.kind = spec.kind;
    s.where = where;
    label_and_repeat_index(m, kind, inside_repeat, s);
    step_settings(m, s);
    if (out.size() >= kMaxSteps)
      fail(where, spath, "the procedure expands into more than " + std::to_string(kMaxSteps) +
                             " steps");
    out.push_back({std::move(s), 1});
  }

  // The key naming a step's kind; fails unless the item is a one-key mapping of a known kind.
  YAML::Node step_kind_key(const YAML::Node& item, const std::string& path) const {
    const std::string kinds_hint = "Step kinds: " + yaml::join(kStepKinds);
    if (!item.IsDefined() || item.IsNull())
      fail(yaml::location_of(item, file_), path,
           "expected a step (a one-key mapping naming its kind), got nothing: " + path +
               " is a '-' with nothing after it (reported where the next item starts)",
           "write e.g. '- record: {duration_s: 60}', or remove the empty '-'. " + kinds_hint);
    if (!item.IsMap())
      fail(yaml::location_of(item, file_), path,
           "expected a step (a one-key mapping naming its kind), got " + yaml::describe(item),
           "write e.g. '- record: {duration_s: 60}'. " + kinds_hint);
    if (item.size() != 1) {
      auto it = item.begin();
      const std::string first = it->first.IsScalar() ? it->first.Scalar() : "?";
      ++it;
      const std::string second = it->first.IsScalar() ? it->first.Scalar() : "?";
      fail(yaml::location_of(it->first, file_), path,
           "a step names exactly one kind, but this one has keys '" + first + "' and '" + second +
               "'",
           "indent the step's settings under its kind (deeper than '" + first +
               ":'), or start a new step with '-'");
    }
    const YAML::Node key = item.begin()->first;
    const std::string kind = key.IsScalar() ? key.Scalar() : std::string{};
    if (std::find(kStepKinds.begin(), kStepKinds.end(), kind) == kStepKinds.end())
      fail(yaml::location_of(key, file_), path, "unknown step kind '" + kind + "'",
           yaml::join_sentences(yaml::did_you_mean(kind, kStepKinds), kinds_hint));
    return key;
  }

  // `label` (default the kind's name) and `repeat_index` (only outside a repeat, which numbers
  // its passes itself).
  static void label_and_repeat_index(const MapReader& m, const std::string& kind, bool inside_repeat,
                                     Step& s) {
    s.label = m.string("label", kind);
    if (s.label.empty()) m.fail_value("label", "'label' must not be empty");
    if (!m.has("repeat_index")) return;
    if (inside_repeat)
      m.fail_key("repeat_index", "'repeat_index' is numbered by the enclosing repeat; remove it here");
    const std::int64_t r = m.integer("repeat_index", 0);
    if (r < 0 || r > static_cast<std::int64_t>(kMaxSteps))
      m.fail_value("repeat_index", "'repeat_index' must be between 0 and " +
                                       std::to_string(kMaxSteps) + ", got " + std::to_string(r));
    s.repeat_index = static_cast<int>(r);
  }

  // The settings of a step of kind s.kind, read from its body.
  void step_settings(const MapReader& m, Step& s) {
    switch (s.kind) {
      case Step::Kind::kSetTemperature: set_temperature_settings(m, s); break;
      case Step::Kind::kOrientations: orientations_settings(m, s); break;
      case Step::Kind::kRates: rates_settings(m, s); break;
      case Step::Kind::kSetVibration: set_vibration_settings(m, s); break;
      case Step::Kind::kRecord:
        m.require("duration_s", "seconds to record");
        s.record_s = positive(m, "duration_s", s.record_s, "in seconds", "s");
        break;
      case Step::Kind::kWait:
        m.require("duration_s", "seconds to wait without recording");
        s.dwell_s = positive(m, "duration_s", s.dwell_s, "in seconds", "s");
        break;
    }
  }

  // set_temperature: chamber setpoint and tolerance [degC], hold and timeout [s].
  void set_temperature_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.require("setpoint_c", "chamber air temperature to reach, in degrees Celsius");
    s.setpoint_c = m.number("setpoint_c", s.setpoint_c, "in degrees Celsius");
    if (s.setpoint_c < -273.15)
      m.fail_value("setpoint_c", "setpoint " + format_number(s.setpoint_c) +
                                     " degC is below absolute zero");
    s.tolerance_c = positive(m, "tolerance_c", s.tolerance_c, "in degrees Celsius", "degC");
    s.hold_s = non_negative(m, "hold_s", s.hold_s);
    s.timeout_s = positive(m, "timeout_s", s.timeout_s, "in seconds", "s");
    s.record_settling = m.boolean("record", s.record_settling);
  }

  // orientations: one of sweep, list or grid [deg], then dwell and record times [s].
  void orientations_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.exactly_one_of({"sweep", "list", "grid"});
    if (m.has("sweep")) sweep(m, s);
    if (m.has("list")) orientation_list(m, s);
    if (m.has("grid")) grid(m, s);
    s.dwell_s = non_negative(m, "dwell_s", s.dwell_s);
    m.require("record_s", "seconds of data recorded at each orientation");
    s.record_s = positive(m, "record_s", s.record_s, "in seconds", "s");
  }

  // rates: the turning axis, its rates [deg/s], then dwell and record times [s].
  void rates_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.require("axis", "name of the table axis that turns, e.g. angle");
    s.axis = m.string("axis", "");
    if (s.axis.empty()) m.fail_value("axis", "'axis' must not be empty");
    m.require("rates_dps", "list of rates in degrees per second");
    s.rates = m.numbers("rates_dps", "in degrees per second");
    if (s.rates.empty())
      m.fail_value("rates_dps", "'rates_dps' is empty", "give at least one rate, e.g. [-100, 100]");
    s.dwell_s = non_negative(m, "dwell_s", s.dwell_s);
    m.require("record_s", "seconds of data recorded at each rate");
    s.record_s = positive(m, "record_s", s.record_s, "in seconds", "s");
  }

  // set_vibration: amplitude [g] (0 turns vibration off) and frequency [Hz].
  void set_vibration_settings(const MapReader& m, Step& s) {
    s.fixture = step_fixture(m);
    m.require("amplitude_g", "vibration amplitude in g; 0 turns vibration off");
    s.amplitude_g = m.number("amplitude_g", s.amplitude_g, "in g");
    if (s.amplitude_g < 0)
      m.fail_value("amplitude_g",
                   "'amplitude_g' must not be negative, got " + format_number(s.amplitude_g) + " g",
                   "amplitudes are in g; 0 turns vibration off");
    if (s.amplitude_g > 0) m.require("frequency_hz", "vibration frequency in hertz");
    if (m.has("frequency_hz")) s.frequency_hz = positive(m, "frequency_hz", s.frequency_hz, "in hertz", "Hz");
  }

  void repeat(const YAML::Node& body, const std::string& path, const SourceLocation& where,
              std::vector<Expanded>& out) {
    const MapReader m(body, file_, path, "the repeat step", {"count", "steps", "label"}, {}, where);
    m.require("count", "how many times to run the steps, at least 1");
    m.require("steps", "the list of steps to repeat");
    const std::int64_t count = m.integer("count", 1);
    if (count < 1)
      m.fail_value("count", "repeat count must be at least 1, got " + std::to_string(count));
    if (m.has("label") && m.string("label", "").empty())
      m.fail_value("label", "'label' must not be empty");
    const YAML::Node list = m.get("steps");
    if (list.IsNull() || (list.IsSequence() && list.size() == 0))
      m.fail_value("steps", "the repeat has no steps", "list the steps to repeat under 'steps:'");
    if (!list.IsSequence())
      m.fail_value("steps", "expected a list of steps for 'steps', got " + yaml::describe(list));
    const std::vector<Expanded> inner = step_list(list, m.child_path("steps"), true);
    if (static_cast<double>(inner.size()) * static_cast<double>(count) +
            static_cast<double>(out.size()) >
        static_cast<double>(kMaxSteps))
      m.fail_value("count", "the repeat expands into more than " + std::to_string(kMaxSteps) +
                                " steps");
    for (std::int64_t pass = 0; pass < count; ++pass) {
      for (const Expanded& e : inner) {
        Expanded x = e;
        x.step.repeat_index =
            static_cast<int>(pass * e.multiplicity + static_cast<std::int64_t>(e.step.repeat_index));
        x.multiplicity = e.multiplicity * count;
        out.push_back(std::move(x));
      }
    }
  }

  std::string step_fixture(const MapReader& m) {
    m.require("fixture", "id of a fixture declared under bench.fixtures");
    const std::string id = m.string("fixture", "");
    if (std::find(fixture_ids_.begin(), fixture_ids_.end(), id) == fixture_ids_.end()) {
      m.fail_value("fixture", "unknown fixture '" + id + "'",
                   yaml::join_sentences(yaml::did_you_mean(id, fixture_ids_),
                                        fixture_ids_.empty()
                                            ? "No fixtures are declared under bench.fixtures."
                                            : "Declared fixtures: " + yaml::join(fixture_ids_)));
    }
    return id;
  }

  // A duration [s] ≥ 0, at most the run-time limit.
  double non_negative(const MapReader& m, const std::string& key, double fallback) const {
    const double v = m.number(key, fallback, "in seconds");
    if (v < 0)
      m.fail_value(key, "'" + key + "' must not be negative, got " + format_number(v) + " s",
                   "durations are in seconds");
    within_run_time(m, key, v);
    return v;
  }

  // A value > 0; a duration (unit "s") also at most the run-time limit.
  double positive(const MapReader& m, const std::string& key, double fallback, const std::string& unit_words,
                  const std::string& unit) const {
    const double v = m.number(key, fallback, unit_words);
    if (m.has(key) && !(v > 0))
      m.fail_value(key,
                   "'" + key + "' must be greater than 0, got " + format_number(v) + " " + unit);
    if (unit == "s") within_run_time(m, key, v);
    return v;
  }

  // One duration longer than the whole run may be is refused where it is written.
  void within_run_time(const MapReader& m, const std::string& key, double v) const {
    const double limit = exp_.limits.max_run_time_s;
    if (m.has(key) && v > limit)
      m.fail_value(key,
                   "'" + key + "' is " + format_number(v) + " s, more than the run-time limit of " +
                       format_number(limit) + " s (" + format_number(limit / 86400.0) + " days)",
                   "durations are in seconds; raise limits.max_run_time_s if a run this long is meant");
  }

  // "<axis>_deg" -> "<axis>"
  std::string axis_of_key(const YAML::Node& key, const std::string& path) const {
    if (!key.IsScalar())
      fail(yaml::location_of(key, file_), path,
           "orientation keys are '<axis>_deg' names, got " + yaml::describe(key));
    const std::string k = key.Scalar();
    const std::string suffix = "_deg";
    if (k.size() > suffix.size() && k.compare(k.size() - suffix.size(), suffix.size(), suffix) == 0)
      return k.substr(0, k.size() - suffix.size());
    std::string axis = k;
    const auto us = axis.rfind('_');
    if (us != std::string::npos && us > 0 && axis.size() - us <= 5) axis = axis.substr(0, us);
    fail(yaml::location_of(key, file_), path + "." + k,
         "orientation key '" + k + "' has no '_deg' unit",
         "did you mean '" + axis + "_deg'? angles are in degrees; keys are <axis>_deg, e.g. angle_deg");
  }

  void sweep(const MapReader& step_map, Step& s) {
    const MapReader m(step_map.get("sweep"), file_, step_map.child_path("sweep"), "'sweep'",
                      {"axis", "from_deg", "to_deg", "step_deg"}, {},
                      step_map.key_location("sweep"));
    m.require("axis", "name of the table axis to sweep, e.g. angle");
    m.require("from_deg", "first angle, in degrees");
    m.require("to_deg", "last angle, in degrees (included when it lies on the grid)");
    m.require("step_deg", "angle increment, in degrees");
    const std::string axis = m.string("axis", "");
    if (axis.empty()) m.fail_value("axis", "'axis' must not be empty");
    const double from = m.number("from_deg", 0.0, "in degrees");
    const double to = m.number("to_deg", 0.0, "in degrees");
    const double step = m.number("step_deg", 0.0, "in degrees");
    if (step == 0.0)
      m.fail_value("step_deg", "'step_deg' must not be 0",
                   "give the angle increment in degrees, e.g. step_deg: 2");
    if ((to - from) * step < 0)
      m.fail_value("step_deg",
                   "step_deg " + format_number(step) + " moves away from to_deg (the sweep goes from " +
                       format_number(from) + " to " + format_number(to) + " deg)",
                   "use step_deg: " + format_number(-step));
    const double span = (to - from) / step;  // >= 0
    if (span + 1 > static_cast<double>(kMaxOrientationsPerStep))
      m.fail_value("step_deg", "the sweep gives more than " +
                                   std::to_string(kMaxOrientationsPerStep) + " orientations");
    const auto n = static_cast<std::size_t>(std::floor(span + 1e-9 * std::max(1.0, span))) + 1;
    for (std::size_t i = 0; i < n; ++i) {
      double v = from + static_cast<double>(i) * step;
      if (i + 1 == n && std::abs(v - to) <= 1e-6 * std::abs(step)) v = to;
      Orientation o;
      o.where = m.location();
      o.targets.push_back({axis, v});
      s.orientations.push_back(std::move(o));
    }
  }

  void orientation_list(const MapReader& step_map, Step& s) {
    const YAML::Node list = step_map.get("list");
    const std::string path = step_map.child_path("list");
    const std::string hint = "write list: [{angle_deg: 0}, {angle_deg: 90, tilt_deg: 10}]";
    if (!list.IsSequence())
      step_map.fail_value("list", "expected a list of orientations for 'list', got " +
                                      yaml::describe(list),
                          hint);
    if (list.size() == 0) step_map.fail_value("list", "the orientation list is empty", hint);
    if (list.size() > kMaxOrientationsPerStep)
      step_map.fail_value("list", "more than " + std::to_string(kMaxOrientationsPerStep) +
                                      " orientations in one step");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const YAML::Node entry = list[i];
      const std::string epath = path + "[" + std::to_string(i) + "]";
      if (!entry.IsMap() || entry.size() == 0)
        fail(yaml::location_of(entry, file_), epath,
             "expected an orientation (a mapping of <axis>_deg to angles), got " +
                 yaml::describe(entry),
             hint);
      Orientation o;
      o.where = yaml::location_of(entry, file_);
      for (auto it = entry.begin(); it != entry.end(); ++it) {
        const std::string axis = axis_of_key(it->first, epath);
        for (const auto& t : o.targets)
          if (t.axis == axis)
            fail(yaml::location_of(it->first, file_), epath + "." + it->first.Scalar(),
                 "axis '" + axis + "' is given twice in this orientation");
        const std::string kpath = epath + "." + it->first.Scalar();
        if (it->second.IsNull())
          fail(yaml::location_of(it->first, file_), kpath,
               "expected a number in degrees for '" + it->first.Scalar() + "', got nothing");
        o.targets.push_back({axis, yaml::as_number(it->second, file_, kpath, "in degrees")});
      }
      s.orientations.push_back(std::move(o));
    }
  }

  void grid(const MapReader& step_map, Step& s) {
    const YAML::Node g = step_map.get("grid");
    const std::string path = step_map.child_path("grid");
    const std::string hint = "write grid: {angle_deg: [0, 90, 180], tilt_deg: [0, 45]}";
    if (!g.IsMap() || g.size() == 0)
      step_map.fail_value("grid", "expected a mapping of <axis>_deg to lists of angles for 'grid', got " +
                                      yaml::describe(g),
                          hint);
    std::vector<std::pair<std::string, std::vector<double>>> axes;
    double total = 1;
    for (auto it = g.begin(); it != g.end(); ++it) {
      const std::string axis = axis_of_key(it->first, path);
      const std::string kpath = path + "." + it->first.Scalar();
      for (const auto& a : axes)
        if (a.first == axis)
          fail(yaml::location_of(it->first, file_), kpath,
               "axis '" + axis + "' is given twice in the grid");
      if (it->second.IsNull())
        fail(yaml::location_of(it->first, file_), kpath,
             "expected a list of angles in degrees for '" + it->first.Scalar() + "', got nothing",
             hint);
      std::vector<double> values = yaml::as_numbers(it->second, file_, kpath, "in degrees");
      if (values.empty())
        fail(yaml::location_of(it->second, file_), kpath,
             "the grid gives no angles for '" + it->first.Scalar() + "'", hint);
      total *= static_cast<double>(values.size());
      axes.emplace_back(axis, std::move(values));
    }
    if (total > static_cast<double>(kMaxOrientationsPerStep))
      step_map.fail_value("grid", "the grid gives more than " +
                                      std::to_string(kMaxOrientationsPerStep) + " orientations");
    const SourceLocation where = step_map.value_location("grid");
    std::vector<std::vector<AxisTarget>> combos(1);
    for (const auto& [axis, values] : axes) {
      std::vector<std::vector<AxisTarget>> next;
      next.reserve(combos.size() * values.size());
      for (const auto& c : combos) {
        for (double v : values) {
          auto x = c;
          x.push_back({axis, v});
          next.push_back(std::move(x));
        }
      }
      combos = std::move(next);
    }
    for (auto& c : combos) {
      Orientation o;
      o.where = where;
      o.targets = std::move(c);
      s.orientations.push_back(std::move(o));
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
  std::vector<std::string> fixture_ids_;
};

// ---------------------------------------------------------------------------------------------
// Resolved YAML

void emit_step(YAML::Emitter& out, const Step& s) {
  const auto num = [&](const char* key, double v) { out << YAML::Key << key << YAML::Value << format_number(v); };
  const auto fixture = [&] {
    out << YAML::Key << "fixture" << YAML::Value;
    yaml::emit_string(out, s.fixture);
  };
  out << YAML::BeginMap << YAML::Key << step_kind_name(s.kind) << YAML::Value << YAML::BeginMap;
  switch (s.kind) {
    case Step::Kind::kSetTemperature:
      fixture();
      num("setpoint_c", s.setpoint_c);
      num("tolerance_c", s.tolerance_c);
      num("hold_s", s.hold_s);
      num("timeout_s", s.timeout_s);
      out << YAML::Key << "record" << YAML::Value << s.record_settling;
      break;
    case Step::Kind::kOrientations:
      fixture();
      out << YAML::Key << "list" << YAML::Value << YAML::BeginSeq;
      for (const auto& o : s.orientations) {
        out << YAML::Flow << YAML::BeginMap;
        for (const auto& t : o.targets)
          out << YAML::Key << (t.axis + "_deg") << YAML::Value << format_number(t.value);
        out << YAML::EndMap;
      }
      out << YAML::EndSeq;
      num("dwell_s", s.dwell_s);
      num("record_s", s.record_s);
      break;
    case Step::Kind::kRates:
      fixture();
      out << YAML::Key << "axis" << YAML::Value;
      yaml::emit_string(out, s.axis);
      out << YAML::Key << "rates_dps" << YAML::Value << YAML::Flow << YAML::BeginSeq;
      for (double r : s.rates) out << format_number(r);
      out << YAML::EndSeq;
      num("dwell_s", s.dwell_s);
      num("record_s", s.record_s);
      break;
    case Step::Kind::kSetVibration:
      fixture();
      num("amplitude_g", s.amplitude_g);
      if (s.amplitude_g > 0 || s.frequency_hz > 0) num("frequency_hz", s.frequency_hz);
      break;
    case Step::Kind::kRecord:
      num("duration_s", s.record_s);
      break;
    case Step::Kind::kWait:
      num("duration_s", s.dwell_s);
      break;
  }
  out << YAML::Key << "label" << YAML::Value;
  yaml::emit_string(out, s.label);
  if (s.repeat_index != 0) out << YAML::Key << "repeat_index" << YAML::Value << s.repeat_index;
  out << YAML::EndMap << YAML::EndMap;
}

void emit_instance(YAML::Emitter& out, const PluginInstance& p, const PluginCatalogue& cat) {
  out << YAML::Key << "plugin" << YAML::Value;
  yaml::emit_string(out, p.plugin);
  out << YAML::Key << "config" << YAML::Value;
  yaml::emit_params(out, p.params, cat.find(p.plugin));
}

// experiment: name, description, seed, clock, plugin paths.
void emit_experiment_section(YAML::Emitter& out, const Experiment& e) {
  out << YAML::Key << "experiment" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value;
  yaml::emit_string(out, e.name);
  out << YAML::Key << "description" << YAML::Value;
  yaml::emit_string(out, e.description);
  out << YAML::Key << "seed" << YAML::Value << e.seed;
  out << YAML::Key << "clock" << YAML::Value << e.clock;
  out << YAML::Key << "plugin_paths" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const auto& p : e.plugin_paths) yaml::emit_string(out, p);
  out << YAML::EndSeq << YAML::EndMap;
}

// gravity: as given (value, or latitude and height), and resolved [m/s²].
void emit_gravity(YAML::Emitter& out, const GravitySpec& g) {
  out << YAML::Key << "gravity" << YAML::Value << YAML::Flow << YAML::BeginMap;
  if (g.value_mps2) {
    out << YAML::Key << "value_mps2" << YAML::Value << format_number(*g.value_mps2);
  } else {
    out << YAML::Key << "latitude_deg" << YAML::Value << format_number(g.latitude_deg);
    out << YAML::Key << "height_m" << YAML::Value << format_number(g.height_m);
  }
  out << YAML::Key << "resolved_mps2" << YAML::Value << format_number(g.resolved_mps2);
  out << YAML::EndMap;
}

// fixtures: each with its id, what it stands on and its plugin config.
void emit_fixtures(YAML::Emitter& out, const Experiment& e, const PluginCatalogue& cat) {
  out << YAML::Key << "fixtures" << YAML::Value;
  if (e.fixtures.empty()) out << YAML::Flow;
  out << YAML::BeginSeq;
  for (const auto& f : e.fixtures) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << f.id;
    out << YAML::Key << "on" << YAML::Value << (f.on.empty() ? std::string("base") : f.on);
    emit_instance(out, f, cat);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

// mounting: what the sensor is on, and the rotation as a 3x3 matrix (rows).
void emit_mounting(YAML::Emitter& out, const Experiment& e) {
  out << YAML::Key << "mounting" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "on" << YAML::Value
      << (e.mounted_on.empty() ? std::string("base") : e.mounted_on);
  out << YAML::Key << "matrix" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int r = 0; r < 3; ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (int c = 0; c < 3; ++c) out << format_number(e.R_sensor_from_mount(r, c));
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq << YAML::EndMap;
}

void emit_bench_section(YAML::Emitter& out, const Experiment& e, const PluginCatalogue& cat) {
  out << YAML::Key << "bench" << YAML::Value << YAML::BeginMap;
  emit_gravity(out, e.gravity);
  out << YAML::Key << "base_heading_deg" << YAML::Value << format_number(e.base_heading_deg);
  out << YAML::Key << "sensor" << YAML::Value << YAML::BeginMap;
  emit_instance(out, e.sensor, cat);
  out << YAML::EndMap;
  emit_fixtures(out, e, cat);
  emit_mounting(out, e);
  out << YAML::EndMap;
}

// processing:, estimation: as given ({} when absent); outputs:.
void emit_later_sections(YAML::Emitter& out, const Experiment& e) {
  for (const auto& [key, node] : {std::pair<const char*, const YAML::Node*>{"processing", &e.processing},
                                   {"estimation", &e.estimation}}) {
    out << YAML::Key << key << YAML::Value;
    if (!node->IsDefined() || node->IsNull() || node->size() == 0)
      out << YAML::Flow << YAML::BeginMap << YAML::EndMap;
    else
      out << *node;
  }
  out << YAML::Key << "limits" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "max_run_time_s" << YAML::Value << e.limits.max_run_time_s;
  out << YAML::Key << "max_samples" << YAML::Value << e.limits.max_samples;
  out << YAML::Key << "max_bytes" << YAML::Value << e.limits.max_bytes;
  out << YAML::EndMap;
  out << YAML::Key << "outputs" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "directory" << YAML::Value;
  yaml::emit_string(out, e.outputs.directory);
  out << YAML::Key << "report" << YAML::Value << e.outputs.report;
  out << YAML::EndMap;
}

std::string emit_resolved(const Experiment& e, const PluginCatalogue& cat) {
  YAML::Emitter out;
  out << YAML::Comment("Resolved by Stend: defaults filled in, repeats and sweeps expanded");
  out << YAML::BeginMap;
  emit_experiment_section(out, e);
  emit_bench_section(out, e, cat);
  out << YAML::Key << "procedure" << YAML::Value << YAML::BeginSeq;
  for (const auto& s : e.procedure) emit_step(out, s);
  out << YAML::EndSeq;
  emit_later_sections(out, e);
  out << YAML::EndMap;
  if (!out.good()) throw std::logic_error("experiment: cannot emit resolved YAML: " + out.GetLastError());
  return std::string(out.c_str()) + "\n";
}

}  // namespace

const char* step_kind_name(Step::Kind kind) {
  for (const auto& k : kStepKindSpecs)
    if (k.kind == kind) return k.name;
  return "?";
}

Experiment parse_experiment(const std::string& yaml_text, const std::string& file,
                            const PluginCatalogue& catalogue) {
  Parser parser(file, catalogue);
  Experiment exp = parser.run(yaml_text);
  exp.resolved_yaml = emit_resolved(exp, catalogue);
  return exp;
}

Experiment load_experiment(const std::string& path, const PluginCatalogue& catalogue) {
  return parse_experiment(read_text_file(path), path, catalogue);
}

std::vector<std::string> experiment_plugin_paths(const std::string& path) {
  const YAML::Node root = load_root(read_text_file(path), path);
  const YAML::Node section = root["experiment"];
  if (!section.IsDefined() || !section.IsMap()) return {};
  for (auto it = section.begin(); it != section.end(); ++it)
    if (it->first.IsScalar() && it->first.Scalar() == "plugin_paths")
      return resolve_plugin_paths(it->second, path, "experiment.plugin_paths");
  return {};
}

// ---------------------------------------------------------------------------------------------
// Stage 2

namespace {

const char* role_words(FixtureRole r) {
  switch (r) {
    case FixtureRole::kTable: return "table";
    case FixtureRole::kChamber: return "chamber";
    case FixtureRole::kStimulus: return "vibration stimulus";
  }
  return "?";
}

std::string range_text(const AxisSpec& a) {
  return "[" + format_number(a.min) + ", " + format_number(a.max) + "] " + a.unit;
}

// The fixture objects match the declarations one to one, in order.
void check_fixture_objects(const Experiment& exp, const std::vector<const Fixture*>& fixtures) {
  if (fixtures.size() != exp.fixtures.size())
    throw std::invalid_argument("validate_against_bench: " + std::to_string(fixtures.size()) +
                                " fixture objects for " + std::to_string(exp.fixtures.size()) +
                                " declared fixtures");
  for (std::size_t i = 0; i < fixtures.size(); ++i)
    if (!fixtures[i])
      throw std::invalid_argument("validate_against_bench: no object for fixture '" +
                                  exp.fixtures[i].id + "'");
}

// What the fixtures declare: each one's role and axes, in declaration order.
struct BenchDeclared {
  std::vector<FixtureRole> roles;
  std::vector<std::vector<AxisSpec>> axes;
};

// The fixture one procedure step commands, with the lookups its checks need; every failure
// names the step, the fixture and what it declares.
class StepFixture {
 public:
  StepFixture(const Experiment& exp, const BenchDeclared& bench, const Step& s, std::size_t si)
      : exp_(exp), bench_(bench), step_(s), path_("procedure[" + std::to_string(si) + "]"),
        kind_(step_kind_name(s.kind)) {
    while (fi_ < exp.fixtures.size() && exp.fixtures[fi_].id != s.fixture) ++fi_;
    if (fi_ == exp.fixtures.size())
      fail(s.where, path_ + ".fixture", "unknown fixture '" + s.fixture + "'");
    const FixtureDecl& decl = exp.fixtures[fi_];
    name_ = "fixture '" + decl.id + "' (plugin " + decl.plugin + ")";
  }

  const std::string& path() const { return path_; }
  const std::string& name() const { return name_; }

  // Fails unless the fixture has the role the step needs.
  void need_role(FixtureRole want) const {
    const FixtureRole role = bench_.roles[fi_];
    if (role == want) return;
    std::vector<std::string> fitting;
    for (std::size_t j = 0; j < bench_.roles.size(); ++j)
      if (bench_.roles[j] == want) fitting.push_back(exp_.fixtures[j].id);
    fail(step_.where, path_ + ".fixture",
         std::string("step '") + kind_ + "' needs a " + role_words(want) + ", but " + name_ +
             " is a " + role_words(role),
         fitting.empty() ? std::string("no ") + role_words(want) + " is declared on this bench"
                         : std::string("declared ") + role_words(want) + "s: " + yaml::join(fitting));
  }

  // The axis called `name`, which must be in `unit`.
  const AxisSpec& axis(const std::string& name, const std::string& unit, const SourceLocation& where) const {
    for (const auto& a : axes()) {
      if (a.name != name) continue;
      if (a.unit != unit)
        fail(where, path_,
             "axis '" + name + "' of " + name_ + " is in '" + a.unit + "', but step '" + kind_ +
                 "' gives it in '" + unit + "'",
             "this step can only command axes in " + unit + "; axes of the fixture: " + axis_list());
      return a;
    }
    std::vector<std::string> names;
    for (const auto& a : axes()) names.push_back(a.name);
    fail(where, path_, name_ + " has no axis '" + name + "'",
         yaml::join_sentences(yaml::did_you_mean(name, names),
                              "Its axes: " + (axes().empty() ? std::string("none") : axis_list())));
  }

  // The axis in `unit` (the one called `preferred` when there are several).
  const AxisSpec& unit_axis(const std::string& preferred, const std::string& unit,
                            const std::string& what) const {
    for (const auto& a : axes())
      if (a.name == preferred && a.unit == unit) return a;
    for (const auto& a : axes())
      if (a.unit == unit) return a;
    fail(step_.where, path_, name_ + " declares no " + what + " axis (unit " + unit + ")",
         "its axes: " + (axes().empty() ? std::string("none") : axis_list()));
  }

 private:
  const std::vector<AxisSpec>& axes() const { return bench_.axes[fi_]; }
  std::string axis_list() const {
    std::vector<std::string> out;
    for (const auto& a : axes()) out.push_back(a.name + " (" + a.unit + ")");
    return yaml::join(out);
  }

  const Experiment& exp_;
  const BenchDeclared& bench_;
  const Step& step_;
  std::string path_;
  const char* kind_;
  std::size_t fi_ = 0;
  std::string name_;
};

// orientations: a table, every target angle [deg] within its axis' limits.
void check_orientations(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kTable);
  for (const auto& o : s.orientations) {
    for (const auto& t : o.targets) {
      const AxisSpec& a = fx.axis(t.axis, "deg", o.where);
      if (t.value < a.min || t.value > a.max)
        fail(o.where, fx.path(),
             t.axis + "_deg = " + format_number(t.value) + " is beyond the limits of axis '" +
                 a.name + "' of " + fx.name() + ": " + range_text(a),
             "keep orientations within the range the fixture declares");
    }
  }
}

// rates: a table axis in rate mode, every |rate| [deg/s] within its maximum.
void check_rates(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kTable);
  const AxisSpec& a = fx.axis(s.axis, "deg", s.where);
  if (!a.supports_rate)
    fail(s.where, fx.path(), "axis '" + a.name + "' of " + fx.name() + " cannot turn at a commanded rate",
         "rates need an axis that supports rate mode; use orientations for this axis");
  for (double r : s.rates)
    if (std::abs(r) > a.max_rate)
      fail(s.where, fx.path(),
           "rate " + format_number(r) + " deg/s exceeds the maximum rate " +
               format_number(a.max_rate) + " deg/s of axis '" + a.name + "' of " + fx.name(),
           "keep |rate| <= " + format_number(a.max_rate) + " deg/s");
}

// set_temperature: a chamber whose temperature axis [degC] holds the setpoint.
void check_temperature(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kChamber);
  const AxisSpec& a = fx.unit_axis("temperature", "degC", "temperature");
  if (s.setpoint_c < a.min || s.setpoint_c > a.max)
    fail(s.where, fx.path(),
         "setpoint " + format_number(s.setpoint_c) + " degC is outside the range of " + fx.name() +
             ": " + range_text(a),
         "choose a setpoint the chamber can reach");
}

// set_vibration: a stimulus whose amplitude [g] and (when vibrating) frequency [Hz] axes hold
// the step's values.
void check_vibration(const Step& s, const StepFixture& fx) {
  fx.need_role(FixtureRole::kStimulus);
  const AxisSpec& amp = fx.unit_axis("amplitude", "g", "amplitude");
  if (s.amplitude_g < amp.min || s.amplitude_g > amp.max)
    fail(s.where, fx.path(),
         "vibration amplitude " + format_number(s.amplitude_g) + " g is outside the range of " +
             fx.name() + ": " + range_text(amp));
  if (s.amplitude_g > 0 || s.frequency_hz > 0) {
    const AxisSpec& fr = fx.unit_axis("frequency", "Hz", "frequency");
    if (s.frequency_hz < fr.min || s.frequency_hz > fr.max)
      fail(s.where, fx.path(),
           "vibration frequency " + format_number(s.frequency_hz) + " Hz is outside the range of " +
               fx.name() + ": " + range_text(fr));
  }
}

}  // namespace

void validate_against_bench(const Experiment& exp, const std::vector<const Fixture*>& fixtures) {
  check_fixture_objects(exp, fixtures);
  BenchDeclared bench;
  for (const Fixture* f : fixtures) {
    bench.roles.push_back(f->role());
    bench.axes.push_back(f->axes());
  }
  for (std::size_t si = 0; si < exp.procedure.size(); ++si) {
    const Step& s = exp.procedure[si];
    if (s.fixture.empty()) continue;
    const StepFixture fx(exp, bench, s, si);
    switch (s.kind) {
      case Step::Kind::kOrientations: check_orientations(s, fx); break;
      case Step::Kind::kRates: check_rates(s, fx); break;
      case Step::Kind::kSetTemperature: check_temperature(s, fx); break;
      case Step::Kind::kSetVibration: check_vibration(s, fx); break;
      case Step::Kind::kRecord:
      case Step::Kind::kWait: break;
    }
  }
}

}  // namespace stend
