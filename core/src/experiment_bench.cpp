// The experiment's bench: section: local gravity, the sensor and the fixtures it stands on (each a
// plugin whose config is checked against the plugin's schema), and the sensor's mounting.
#include "experiment_parse.hpp"

#include <stend/physics/geometry.hpp>
#include <stend/physics/gravity.hpp>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <utility>

namespace stend::detail {

using yaml::MapReader;
using yaml::format_number;

namespace {

const char* kind_words(stend_plugin_kind k) {
  switch (k) {
    case STEND_KIND_SENSOR: return "sensor";
    case STEND_KIND_FIXTURE: return "fixture";
    case STEND_KIND_ESTIMATOR: return "estimator";
  }
  return "unknown-kind";
}

bool valid_fixture_id(const std::string& s) {
  if (s.empty() || !(s[0] >= 'a' && s[0] <= 'z')) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

// Reads the bench section into an experiment; the fixtures declared so far are what later ones
// and the mounting may stand on.
class BenchReader {
 public:
  BenchReader(const std::string& file, const PluginCatalogue& catalogue, Experiment& exp)
      : file_(file), cat_(catalogue), exp_(exp) {}

  // bench: gravity, base heading [deg], sensor, fixtures, mounting.
  void read(const MapReader& top) {
    const MapReader m(top.get("bench"), file_, "bench", "the 'bench' section",
                      {"gravity", "base_heading_deg", "sensor", "fixtures", "mounting"}, {},
                      top.key_location("bench"));
    gravity(m);
    exp_.base_heading_deg = m.number("base_heading_deg", exp_.base_heading_deg, "in degrees");
    if (m.has("sensor")) {  // absent: the file describes a procedure only (require_runnable)
      const MapReader s(m.get("sensor"), file_, "bench.sensor", "the sensor", {"plugin", "config"},
                        {}, m.key_location("sensor"));
      exp_.sensor = instance(s, STEND_KIND_SENSOR);
    }
    fixtures(m);
    mounting(m);
  }

 private:
  // gravity: a measured value_mps2, or normal gravity at latitude_deg and height_m [m/s²];
  // resolved_mps2, as Stend writes it back, must agree.
  void gravity(const MapReader& bench) {
    GravitySpec& g = exp_.gravity;
    g.stated = bench.has("gravity");
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

  // The loaded plugins of one kind.
  std::vector<std::string> names_of_kind(stend_plugin_kind kind) const {
    std::vector<std::string> out;
    for (const auto& n : cat_.names()) {
      const stend_plugin_info* info = cat_.find(n);
      if (info && info->kind == kind) out.push_back(n);
    }
    return out;
  }

  // `plugin` (a loaded plugin of `kind`) and its `config`, checked against the plugin's schema.
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

  // fixtures: each with its id, what it stands on and its plugin, in stacking order.
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

  // mounting: what carries the sensor and the rotation R_sensor_from_mount (rpy_deg or matrix).
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

  const std::string& file_;
  const PluginCatalogue& cat_;
  Experiment& exp_;
  std::vector<std::string> fixture_ids_;
};

}  // namespace

void read_bench(const MapReader& top, const PluginCatalogue& catalogue, Experiment& exp) {
  BenchReader(exp.file, catalogue, exp).read(top);
}

std::vector<std::string> fixture_ids(const Experiment& exp) {
  std::vector<std::string> ids;
  for (const auto& f : exp.fixtures) ids.push_back(f.id);
  return ids;
}

}  // namespace stend::detail
