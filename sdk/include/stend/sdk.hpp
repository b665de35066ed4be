// Stend plugin SDK — the C++ interfaces a plugin implements and the host drives.
//
// Header-only; depends on Eigen only. Units are SI throughout (m/s^2, rad/s, degC, s) unless a
// name says otherwise (`_deg`, `_c`). Frames:
//   local  — the bench base frame, right-handed, z up (the paper's ξ0 η0 ζ); gravity is −g·z.
//   top    — a fixture's moving platform frame; for a stack, each fixture's base is the top of
//            the one it stands on.
//   sensor — axes as printed on the sensor package.
// Rotation matrices are passive (frame transforms): v_top = R_top_from_base · v_base.
#pragma once

#include <stend/errors.hpp>
#include <stend/plugin_abi.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <type_traits>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace stend {

// A value that is not known (a missing temperature, a parameter the data did not identify): never
// a default presented as a result. The one definition; code in namespace stend uses it unqualified.
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A sensor, fixture or estimator made by a plugin's factory, deleted through the plugin's own
// deleter (the plugin host hands these out).
template <class T>
using PluginPtr = std::unique_ptr<T, std::function<void(T*)>>;

// ---------------------------------------------------------------------------------------------
// Validated configuration handed to a plugin's create(). Every key of the plugin's schema is
// present (defaults filled in by the host), with the declared type.
class Params {
 public:
  using Matrix = std::vector<std::vector<double>>;
  using Value = std::variant<double, std::int64_t, bool, std::string, std::vector<double>, Matrix>;

  void set(const std::string& key, Value v) { values_[key] = std::move(v); }
  bool has(const std::string& key) const { return values_.count(key) != 0; }
  const std::map<std::string, Value>& values() const { return values_; }

  double number(const std::string& key) const {
    const Value& v = at(key);
    if (auto* d = std::get_if<double>(&v)) return *d;
    if (auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
    throw std::runtime_error("parameter '" + key + "' is not a number");
  }
  std::int64_t integer(const std::string& key) const { return get<std::int64_t>(key); }
  bool boolean(const std::string& key) const { return get<bool>(key); }
  const std::string& string(const std::string& key) const { return get<std::string>(key); }
  const std::vector<double>& numbers(const std::string& key) const {
    return get<std::vector<double>>(key);
  }
  Eigen::Vector3d vec3(const std::string& key) const {
    const auto& v = numbers(key);
    if (v.size() != 3) throw std::runtime_error("parameter '" + key + "' is not a 3-vector");
    return {v[0], v[1], v[2]};
  }
  const Matrix& matrix(const std::string& key) const { return get<Matrix>(key); }
  Eigen::Matrix3d mat3(const std::string& key) const {
    const Matrix& m = matrix(key);
    Eigen::Matrix3d out;
    if (m.size() != 3) throw std::runtime_error("parameter '" + key + "' is not 3x3");
    for (int r = 0; r < 3; ++r) {
      if (m[r].size() != 3) throw std::runtime_error("parameter '" + key + "' is not 3x3");
      for (int c = 0; c < 3; ++c) out(r, c) = m[r][c];
    }
    return out;
  }

 private:
  const Value& at(const std::string& key) const {
    auto it = values_.find(key);
    if (it == values_.end()) throw std::runtime_error("missing parameter '" + key + "'");
    return it->second;
  }
  template <class T>
  const T& get(const std::string& key) const {
    const Value& v = at(key);
    if (auto* p = std::get_if<T>(&v)) return *p;
    throw std::runtime_error("parameter '" + key + "' has the wrong type");
  }
  std::map<std::string, Value> values_;
};

// ---------------------------------------------------------------------------------------------
// What the bench physically applies to the sensor at one instant: the truth a simulated sensor
// turns into readings and a recording stores beside the readings.
struct BenchTruth {
  double t_s = 0.0;                                           // run clock
  Eigen::Matrix3d R_sensor_from_local = Eigen::Matrix3d::Identity();
  Eigen::Vector3d specific_force_mps2 = Eigen::Vector3d::Zero();  // sensor frame, ideal accel
  Eigen::Vector3d angular_rate_radps = Eigen::Vector3d::Zero();   // sensor frame, ideal gyro
  double air_temperature_c = 25.0;  // chamber air (or room) temperature
  double die_temperature_c = 25.0;  // sensor die temperature (lags the air)
};

// Source of truth at any time inside the interval the runner is currently advancing.
class TruthSource {
 public:
  virtual ~TruthSource() = default;
  virtual BenchTruth at(double t_s) const = 0;
};

// ---------------------------------------------------------------------------------------------
// Sensors

struct SensorIdentity {
  std::string vendor;    // "InvenSense"
  std::string model;     // "MPU-6050"
  std::string serial;    // unit serial, or "" when the part has none
  std::string who_am_i;  // identity register as read, e.g. "0x68"
};

struct SensorInfo {
  double output_rate_hz = 0.0;
  double accel_range_mps2 = 0.0;   // full scale, ±
  double gyro_range_radps = 0.0;   // full scale, ±
  double accel_lsb_mps2 = 0.0;     // one count
  double gyro_lsb_radps = 0.0;     // one count
  double temperature_lsb_c = 0.0;  // one count
  // Which instruments the sensor has. An absent one's SI values are NaN and its counts 0 in every
  // sample; nothing reads them as data (stend/recording/instruments.hpp says which are present).
  bool has_gyro = true;
  bool has_temperature = true;
  bool has_accel = true;
};

enum SampleFlags : std::uint32_t {
  kAccelSaturated = 1u << 0,
  kGyroSaturated = 1u << 1,
  kGapBefore = 1u << 2,  // samples were lost between this and the previous sample
};

struct ImuSample {
  double t_s = 0.0;  // sample time on the run clock
  std::int32_t accel_counts[3] = {0, 0, 0};
  std::int32_t gyro_counts[3] = {0, 0, 0};
  std::int32_t temperature_counts = 0;
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();  // counts converted to SI
  Eigen::Vector3d gyro_radps = Eigen::Vector3d::Zero();
  double temperature_c = 0.0;
  std::uint32_t flags = 0;  // SampleFlags
};

class Sensor {
 public:
  virtual ~Sensor() = default;
  virtual SensorIdentity identity() const = 0;
  virtual SensorInfo info() const = 0;
  // Start producing samples; the first sample time is > t0_s.
  virtual void start(double t0_s) = 0;
  // Append every sample with time in (previous call's t_s, t_s]. A simulated sensor evaluates
  // `truth` at its sample instants; a real sensor reads what the device produced and ignores it.
  // Throws std::runtime_error on a device fault (samples already appended stay valid).
  virtual void acquire(double t_s, const TruthSource& truth, std::vector<ImuSample>& out) = 0;
  virtual void stop() {}
};

// ---------------------------------------------------------------------------------------------
// Fixtures: tables, chambers, vibration stimuli. Each exposes named axes the procedure commands.

enum class FixtureRole { kTable, kChamber, kStimulus };
enum class CommandMode { kPosition, kRate, kSetpoint };

struct AxisSpec {
  std::string name;   // "angle", "tilt", "temperature", "amplitude"
  std::string unit;   // unit of positions/setpoints: "deg", "degC", "g", "Hz"
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  double max_rate = std::numeric_limits<double>::infinity();  // unit per second; rate commands beyond it are refused
  bool supports_rate = false;
};

// Kinematic state of a fixture's top relative to its base at one instant.
struct Pose {
  Eigen::Matrix3d R_top_from_base = Eigen::Matrix3d::Identity();
  Eigen::Vector3d omega_top_radps = Eigen::Vector3d::Zero();  // top w.r.t. base, in top frame
  Eigen::Vector3d accel_top_mps2 = Eigen::Vector3d::Zero();   // linear accel of the mounting
                                                              // point w.r.t. base, top frame
};

class Fixture {
 public:
  virtual ~Fixture() = default;
  virtual FixtureRole role() const = 0;
  virtual std::vector<AxisSpec> axes() const = 0;
  // Command one axis (index into axes()). Values are in the axis unit (rates: unit/s).
  // Throws std::invalid_argument when out of the declared limits.
  virtual void command(std::size_t axis, CommandMode mode, double value) = 0;
  // Advance to run time t_s: a simulated fixture integrates its dynamics, a real one polls.
  virtual void advance(double t_s) = 0;
  virtual double measured(std::size_t axis) const = 0;   // last measured value, axis unit
  virtual double commanded(std::size_t axis) const = 0;  // last command, axis unit
  // True once every axis has reached its command and stayed within the fixture's settle
  // tolerance for its settle time.
  virtual bool settled() const = 0;
  // Pose at any t in the interval of the last advance() (tables, shakers). Default: rigid.
  virtual Pose pose(double /*t_s*/) const { return {}; }
  // Chambers: air temperature and the temperature of the module they hold (degC).
  virtual bool thermal(double /*t_s*/, double& /*air_c*/, double& /*die_c*/) const { return false; }
  // Extra measured quantities recorded as bench truth, e.g. {"heater_pwm", 120}. The names (with
  // their unit in the name) must be the same on every call; values are the latest.
  virtual void telemetry(std::vector<std::pair<std::string, double>>& /*out*/) const {}
  // Bring the fixture to rest / heater and cooler off and check it where the device allows (read
  // the command back, ask for errors). Returns "" when done and checked, else what failed (the
  // runner records it as an error). Must not throw.
  virtual std::string safe_state() noexcept = 0;
  // The sensor samples the runner just received (run clock), e.g. for a manual fixture that
  // waits until the operator's placement is still. Default: ignored.
  virtual void observe(const ImuSample* /*samples*/, std::size_t /*count*/) {}
};

// Thrown by Fixture::advance() when the link to the device failed but the fixture
// itself is in a known, safe condition (time-out, garbled reply, peer gone): the runner records
// an event with the text, marks the recording's truth as a gap, keeps the sensor running and tries
// again on the next period, for up to RunOptions::fixture_outage_s. Any other exception from a
// fixture (a runaway chamber, a limit hit) ends the run at once.
class __attribute__((visibility("default"))) FixtureLinkFault : public IoError {
 public:
  using IoError::IoError;
};

// ---------------------------------------------------------------------------------------------
// Estimators: fit a model to a recording. The host (`stend fit --estimator NAME`) opens the run
// folder or dataset and hands the recording over; an estimator plugin links stend_core for the
// Recording type (stend/recording/recording.hpp) and parses its own section of the model YAML.
struct Recording;  // stend/recording/recording.hpp

struct EstimatorRequest {
  const Recording* recording = nullptr;  // the opened recording (never null when fit() is called)
  std::string input;                     // where it came from (run folder or dataset file)
  std::string model_file;                // the model YAML (path); errors name file:line:col
  std::string output_dir;                // where the host writes the results (run folder or cwd)
};

// What an estimator plugin gives back: its results document as JSON, which the host writes as it
// is and reads back as the typed result (stend/estimation/result.hpp) with the generic reader
// (stend/estimation/result_io.hpp). So that the reports, the results database, `stend compare`,
// `stend apply` and `stend export` can use it, the document carries
//   - the summary fields (stend/estimation/summary.hpp): "estimator": {"name", "version"},
//     "status": "ok" | "failed", "message", "confidence", "parameters": [{"name", "unit", "value",
//     "std_error", "interval", "identifiable", "verdict", "reason"}, …];
//   - for a fitted error model, a `stend.fit/1`-shaped "model" section (estimators/batch_lsq/
//     README.md): {"instrument": "accelerometer" | "gyroscope", "axes": ["x", …], "terms":
//     [{"kind": "bias"}, …]}, its parameters named as the vocabulary names them (bias_x, scale_z,
//     …; stend/model/terms.hpp) and optionally "correlation" over them — then `stend apply` applies
//     it and the exports write it.
// `ok` and `message` are the plugin's word on its success whatever the document says; a failed fit
// may leave `json` empty (the host then writes the summary fields). Built-in estimators return
// their typed result through their registry entry instead (stend/estimation/registry.hpp).
struct EstimatorResult {
  bool ok = false;           // false: the fit failed; `message` says why and no numbers are given
  std::string message;
  std::string json;          // results with a versioned "schema" field (see above)
  std::string text;          // the report table (parameter, value, unit, std error, interval, …)
  std::string json_name;     // default results file name, e.g. "ceres.json"
};

class Estimator {
 public:
  virtual ~Estimator() = default;
  // Throws stend::ExperimentError (bad model file) or std::exception (unreadable input); a fit
  // that ran but failed returns ok = false.
  virtual EstimatorResult fit(const EstimatorRequest& request) = 0;
};

namespace detail {
// The host receives the interface pointer (Sensor*, Fixture*, Estimator*) as void*, so the
// plugin converts to the interface before erasing the type and deletes through it.
template <class T>
using InterfaceOf = std::conditional_t<
    std::is_base_of_v<Sensor, T>, Sensor,
    std::conditional_t<std::is_base_of_v<Fixture, T>, Fixture, Estimator>>;

// The schema STEND_DEFINE_PLUGIN hands to the host: a hand-written `const stend_param_spec[]`
// array, or a field table (stend/fields.hpp) — anything with specs() and size().
template <std::size_t N>
constexpr const stend_param_spec* schema_data(const stend_param_spec (&specs)[N]) {
  return specs;
}
template <std::size_t N>
constexpr std::size_t schema_size(const stend_param_spec (&)[N]) {
  return N;
}
template <class Table>
auto schema_data(const Table& table) -> decltype(table.specs()) {
  return table.specs();
}
template <class Table>
auto schema_size(const Table& table) -> decltype(table.size()) {
  return table.size();
}

}  // namespace detail

}  // namespace stend

// Defines the plugin's entry point. Use once per plugin library:
//   STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "sim_imu", "0.1.0", "Simulated IMU", SCHEMA, MySensor)
// where SCHEMA is the plugin's field table (stend/fields.hpp: one declaration per parameter gives
// the schema and the reader; e.g. `my_fields()`) or a hand-written `const stend_param_spec[]`
// array, and MySensor has a constructor MySensor(const stend::Params&) that throws on bad input.
// The schema is read once, on the first call of the entry point, and must live as long as the
// library (static storage).
#define STEND_DEFINE_PLUGIN(KIND, NAME, VERSION, DESCRIPTION, SCHEMA, TYPE)                      \
  extern "C" __attribute__((visibility("default"))) const stend_plugin_info*                    \
  stend_plugin_entry(void) {                                                                    \
    static const stend_plugin_info info = {                                                     \
        STEND_PLUGIN_ABI_VERSION,                                                               \
        static_cast<uint32_t>(sizeof(stend_plugin_info)),                                       \
        KIND,                                                                                   \
        NAME,                                                                                   \
        VERSION,                                                                                \
        DESCRIPTION,                                                                            \
        stend::detail::schema_data(SCHEMA),                                                     \
        stend::detail::schema_size(SCHEMA),                                                     \
        [](const void* p, char* err, size_t n) -> void* {                                       \
          try {                                                                                 \
            using Interface = stend::detail::InterfaceOf<TYPE>;                                 \
            Interface* object = new TYPE(*static_cast<const stend::Params*>(p));                \
            return static_cast<void*>(object);                                                  \
          } catch (const std::exception& e) {                                                   \
            if (err && n) {                                                                     \
              std::snprintf(err, n, "%s", e.what());                                            \
            }                                                                                   \
            return nullptr;                                                                     \
          }                                                                                     \
        },                                                                                      \
        [](void* o) { delete static_cast<stend::detail::InterfaceOf<TYPE>*>(o); }};             \
    return &info;                                                                               \
  }
