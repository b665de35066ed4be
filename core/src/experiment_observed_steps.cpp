// The observed steps of a procedure — faces, turns, rate_legs, still — read from their YAML: what
// somebody did to the sensor by hand or on a fixture Stend does not drive, described so that a
// recording of it can be aligned to the steps (stend/alignment/align.hpp). Directions are sensor
// directions: "+x", "-z", "y" (= "+y"), "+x up", "-y down", or a vector [x, y, z] in the sensor frame.
#include "experiment_parse.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <regex>

namespace stend::detail {

using yaml::MapReader;
using yaml::format_number;

namespace {

constexpr const char* kDirectionHint =
    "a sensor direction is '+x', '-y', 'z' (= '+z'), with ' up' or ' down' for a face (e.g. '+x up'), or a "
    "vector in the sensor frame such as [0, 0.7071, 0.7071]";

// A vector node [x, y, z] (finite, not zero) as a unit vector.
Eigen::Vector3d unit_vector(const YAML::Node& node, const std::string& file, const std::string& path) {
  const std::vector<double> v = yaml::as_numbers(node, file, path, "in the sensor frame");
  if (v.size() != 3) fail(yaml::location_of(node, file), path, "a direction vector has 3 components, got " + std::to_string(v.size()), kDirectionHint);
  const Eigen::Vector3d d(v[0], v[1], v[2]);
  if (!(d.norm() > 1e-9)) fail(yaml::location_of(node, file), path, "the direction vector is zero", kDirectionHint);
  return d.normalized();
}

// A sensor direction: a vector node, or "[+-]?[xyz]" optionally followed by " up" / " down"
// (`face` allows them; " down" flips the direction so that the result always points up).
Eigen::Vector3d sensor_direction(const YAML::Node& node, const std::string& file, const std::string& path,
                                 bool face) {
  if (node.IsSequence()) return unit_vector(node, file, path);
  const std::string text = yaml::as_string(node, file, path);
  static const std::regex kPattern(R"(\s*([+-]?)\s*([xyzXYZ])\s*(up|down)?\s*)");
  std::smatch m;
  if (!std::regex_match(text, m, kPattern) || (!face && m[3].matched))
    fail(yaml::location_of(node, file), path, "'" + text + "' is not a sensor direction", kDirectionHint);
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  d[std::tolower(static_cast<unsigned char>(m[2].str()[0])) - 'x'] = m[1].str() == "-" ? -1.0 : 1.0;
  if (m[3].matched && m[3].str() == "down") d = -d;
  return d;
}

// within_s: [from, to] on the recording's clock [s].
void within(const MapReader& m, Step& s) {
  if (!m.has("within_s")) return;
  const std::vector<double> w = m.numbers("within_s", "in seconds");
  if (w.size() != 2 || !(w[0] < w[1]))
    m.fail_value("within_s", "'within_s' is [from, to] in seconds on the recording's clock, from < to",
                 "e.g. within_s: [0, 120]");
  s.within_from_s = w[0];
  s.within_to_s = w[1];
}

// record_s: the least time each face, leg or still is held [s]; 0 (default) leaves it to the alignment.
void least_time(const MapReader& m, Step& s) {
  s.record_s = m.number("record_s", 0.0, "in seconds");
  if (!(s.record_s >= 0.0)) m.fail_value("record_s", "'record_s' must not be negative, got " + format_number(s.record_s) + " s");
}

// count: at least 1.
int count(const MapReader& m, const std::string& what) {
  const std::int64_t n = m.integer("count", 1);
  if (n < 1 || n > static_cast<std::int64_t>(kMaxOrientationsPerStep))
    m.fail_value("count", "'count' (" + what + ") must be between 1 and " + std::to_string(kMaxOrientationsPerStep) +
                              ", got " + std::to_string(n));
  return static_cast<int>(n);
}

// axis: a sensor direction (no up / down).
Eigen::Vector3d axis(const MapReader& m) {
  m.require("axis", "the sensor axis of the rotation, e.g. '+x' or [0, 0, 1]");
  return sensor_direction(m.get("axis"), m.file(), m.child_path("axis"), false);
}

}  // namespace

// faces: the sensor direction up of each face, in the order held.
void faces_settings(const MapReader& m, Step& s) {
  m.require("list", "the faces in the order they were held, e.g. ['+x up', '-x up', '+y up']");
  const YAML::Node list = m.get("list");
  if (!list.IsSequence() || list.size() == 0)
    m.fail_value("list", "expected a non-empty list of faces for 'list', got " + yaml::describe(list),
                 "e.g. list: ['+z up', '-z up']");
  if (list.size() > kMaxOrientationsPerStep)
    m.fail_value("list", "more than " + std::to_string(kMaxOrientationsPerStep) + " faces in one step");
  for (std::size_t i = 0; i < list.size(); ++i)
    s.faces_up.push_back(sensor_direction(list[i], m.file(), m.child_path("list") + "[" + std::to_string(i) + "]", true));
  least_time(m, s);
  within(m, s);
}

// turns: `count` turns by angle_deg about a sensor axis, in a stated direction or either.
void turns_settings(const MapReader& m, Step& s) {
  s.sensor_axis = axis(m);
  m.require("angle_deg", "the angle of each turn in degrees, e.g. 360");
  s.angle_deg = m.number("angle_deg", 0.0, "in degrees");
  if (!(s.angle_deg > 0.0 && s.angle_deg <= 3600.0))
    m.fail_value("angle_deg", "'angle_deg' is the size of each turn, in (0, 3600] degrees, got " + format_number(s.angle_deg),
                 "give the direction with 'direction: positive | negative' (default: either, taken from the data)");
  const std::string dir = m.string("direction", "either");
  if (dir == "positive") s.direction = 1;
  else if (dir == "negative") s.direction = -1;
  else if (dir == "either") s.direction = 0;
  else
    m.fail_value("direction", "unknown direction '" + dir + "'",
                 "positive (right-handed about the axis), negative, or either (the sign is taken from the data)");
  s.count = count(m, "turns");
  within(m, s);
}

// rate_legs: constant rates [deg/s] about a sensor axis, in order; optionally the direction up.
void rate_legs_settings(const MapReader& m, Step& s) {
  s.sensor_axis = axis(m);
  m.require("rates_dps", "the rates of the legs in order, in degrees per second, e.g. [25, -25]");
  s.rates = m.numbers("rates_dps", "in degrees per second");
  if (s.rates.empty()) m.fail_value("rates_dps", "'rates_dps' is empty", "give at least one rate, e.g. [25, -25]");
  for (double r : s.rates)
    if (r == 0.0) m.fail_value("rates_dps", "a rate leg of 0 deg/s is a still: use a 'still' or 'faces' step");
  if (m.has("up")) s.up = sensor_direction(m.get("up"), m.file(), m.child_path("up"), true);
  least_time(m, s);
  within(m, s);
}

// still: `count` stills at orientations nobody stated; `count: all` every still left (at least one).
void still_settings(const MapReader& m, Step& s) {
  const YAML::Node n = m.get("count");
  s.count = n.IsScalar() && n.Scalar() == "all" ? 0 : count(m, "stills");
  least_time(m, s);
  within(m, s);
}

}  // namespace stend::detail
