// run.json both ways: the header written as JSON, and read back with every field checked.
// Format: docs/recording-format.md.
#include "run_json.hpp"
#include "store_files.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <optional>
#include <string_view>
#include <utility>

namespace stend::detail {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

ojson header_json(const RecordingHeader& h) {
  ojson j;
  j["format_version"] = kRecordingFormatVersion;
  j["status"] = to_string(h.status);
  j["experiment_name"] = h.experiment_name;
  j["experiment_file"] = h.experiment_file;
  j["stend_version"] = h.stend_version;
  j["start_time_utc"] = h.start_time_utc;
  j["clock"] = h.clock;
  j["seed"] = h.seed;
  j["gravity_mps2"] = h.gravity_mps2;
  j["latitude_deg"] = h.latitude_deg;
  j["height_m"] = h.height_m;
  j["mounting_R_sensor_from_mount"] = h.mounting_R;
  ojson identity;
  identity["vendor"] = h.identity.vendor;
  identity["model"] = h.identity.model;
  identity["serial"] = h.identity.serial;
  identity["who_am_i"] = h.identity.who_am_i;
  ojson info;
  info["output_rate_hz"] = h.info.output_rate_hz;
  info["accel_range_mps2"] = h.info.accel_range_mps2;
  info["gyro_range_radps"] = h.info.gyro_range_radps;
  info["accel_lsb_mps2"] = h.info.accel_lsb_mps2;
  info["gyro_lsb_radps"] = h.info.gyro_lsb_radps;
  info["temperature_lsb_c"] = h.info.temperature_lsb_c;
  info["has_gyro"] = h.info.has_gyro;
  info["has_temperature"] = h.info.has_temperature;
  info["has_accel"] = h.info.has_accel;
  j["sensor"] = {{"identity", identity}, {"info", info}};
  ojson plugins = ojson::array();
  for (const auto& p : h.plugins) {
    plugins.push_back({{"role", p.role}, {"name", p.name}, {"version", p.version}, {"file", p.file},
                       {"origin", p.origin}, {"hash", p.hash}});
  }
  j["plugins"] = plugins;
  j["truth_columns"] = h.truth_columns;
  return j;
}

std::string dump_json(const ojson& j) {
  return j.dump(2, ' ', false, ojson::error_handler_t::replace) + "\n";
}

namespace {

// Typed access to run.json with errors that name the key.
class JsonFields {
 public:
  JsonFields(const nlohmann::json& j, fs::path file) : j_(j), file_(std::move(file)) {}

  const nlohmann::json* find(const nlohmann::json& obj, const char* key) const {
    auto it = obj.find(key);
    return it == obj.end() ? nullptr : &*it;
  }
  [[noreturn]] void bad(const std::string& key, const char* expected) const {
    throw InputError(
        fmt::format("{}: key '{}' should be {}", file_.string(), key, expected));
  }
  void str(const nlohmann::json& obj, const char* key, const std::string& path,
           std::string& out) const {
    if (const auto* v = find(obj, key)) {
      if (!v->is_string()) bad(path, "a string");
      out = v->get<std::string>();
    }
  }
  void num(const nlohmann::json& obj, const char* key, const std::string& path, double& out) const {
    if (const auto* v = find(obj, key)) {
      if (v->is_null()) {
        out = std::numeric_limits<double>::quiet_NaN();  // JSON has no NaN; written as null
      } else if (v->is_number()) {
        out = v->get<double>();
      } else {
        bad(path, "a number (or null for NaN)");
      }
    }
  }
  void boolean(const nlohmann::json& obj, const char* key, const std::string& path,
               bool& out) const {
    if (const auto* v = find(obj, key)) {
      if (!v->is_boolean()) bad(path, "true or false");
      out = v->get<bool>();
    }
  }
  const nlohmann::json& root() const { return j_; }

 private:
  const nlohmann::json& j_;
  fs::path file_;
};

// run.json's text as JSON; a syntax error names the file and line.
nlohmann::json parse_run_json(const fs::path& file, const std::string& text) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    const std::size_t upto = std::min<std::size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
    const auto line =
        1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(upto), '\n'));
    fail_at(file, line, fmt::format("invalid JSON ({})", e.what()));
  } catch (const nlohmann::json::exception& e) {  // e.g. a number out of range
    throw InputError(fmt::format("{}: invalid JSON ({})", file.string(), e.what()));
  }
}

// format_version (refused outside 1..kRecordingFormatVersion) and status.
void read_version_and_status(const nlohmann::json& j, const JsonFields& f, const fs::path& file,
                             RecordingHeader& h) {
  const auto* ver = f.find(j, "format_version");
  if (!ver || !ver->is_number_integer()) f.bad("format_version", "an integer (required)");
  const auto version = ver->get<std::int64_t>();
  if (version < 1 || version > kRecordingFormatVersion) {
    throw InputError(fmt::format(
        "{}: format_version {} is not readable by this Stend (reads 1..{}); {}", file.string(),
        version, kRecordingFormatVersion,
        version > kRecordingFormatVersion ? "upgrade Stend" : "the file is damaged"));
  }
  const auto* st = f.find(j, "status");
  const auto status = st && st->is_string() ? run_status_from_string(st->get<std::string>()) : std::nullopt;
  if (!status) f.bad("status", "one of running, complete, interrupted, failed (required)");
  h.status = *status;
}

// Names, clock, seed, site (gravity [m/s²], latitude [deg], height [m]) and mounting.
void read_run_fields(const nlohmann::json& j, const JsonFields& f, RecordingHeader& h) {
  f.str(j, "experiment_name", "experiment_name", h.experiment_name);
  f.str(j, "experiment_file", "experiment_file", h.experiment_file);
  f.str(j, "stend_version", "stend_version", h.stend_version);
  f.str(j, "start_time_utc", "start_time_utc", h.start_time_utc);
  f.str(j, "clock", "clock", h.clock);
  if (const auto* v = f.find(j, "seed")) {
    if (!v->is_number_unsigned() && !(v->is_number_integer() && v->get<std::int64_t>() >= 0)) {
      f.bad("seed", "a non-negative integer");
    }
    h.seed = v->get<std::uint64_t>();
  }
  f.num(j, "gravity_mps2", "gravity_mps2", h.gravity_mps2);
  f.num(j, "latitude_deg", "latitude_deg", h.latitude_deg);
  f.num(j, "height_m", "height_m", h.height_m);
  if (const auto* v = f.find(j, "mounting_R_sensor_from_mount")) {
    if (!v->is_array() || (v->size() != 0 && v->size() != 9)) {
      f.bad("mounting_R_sensor_from_mount", "an array of 9 numbers (row-major)");
    }
    h.mounting_R.clear();
    for (const auto& x : *v) {
      if (x.is_null()) {
        h.mounting_R.push_back(std::numeric_limits<double>::quiet_NaN());
      } else if (x.is_number()) {
        h.mounting_R.push_back(x.get<double>());
      } else {
        f.bad("mounting_R_sensor_from_mount", "an array of 9 numbers (row-major)");
      }
    }
  }
}

// "sensor": identity and info (rate [Hz], ranges and LSB sizes in SI, what it measures).
void read_sensor(const nlohmann::json& j, const JsonFields& f, RecordingHeader& h) {
  const auto* sensor = f.find(j, "sensor");
  if (!sensor) return;
  if (!sensor->is_object()) f.bad("sensor", "an object");
  if (const auto* id = f.find(*sensor, "identity")) {
    if (!id->is_object()) f.bad("sensor.identity", "an object");
    f.str(*id, "vendor", "sensor.identity.vendor", h.identity.vendor);
    f.str(*id, "model", "sensor.identity.model", h.identity.model);
    f.str(*id, "serial", "sensor.identity.serial", h.identity.serial);
    f.str(*id, "who_am_i", "sensor.identity.who_am_i", h.identity.who_am_i);
  }
  if (const auto* info = f.find(*sensor, "info")) {
    if (!info->is_object()) f.bad("sensor.info", "an object");
    f.num(*info, "output_rate_hz", "sensor.info.output_rate_hz", h.info.output_rate_hz);
    f.num(*info, "accel_range_mps2", "sensor.info.accel_range_mps2", h.info.accel_range_mps2);
    f.num(*info, "gyro_range_radps", "sensor.info.gyro_range_radps", h.info.gyro_range_radps);
    f.num(*info, "accel_lsb_mps2", "sensor.info.accel_lsb_mps2", h.info.accel_lsb_mps2);
    f.num(*info, "gyro_lsb_radps", "sensor.info.gyro_lsb_radps", h.info.gyro_lsb_radps);
    f.num(*info, "temperature_lsb_c", "sensor.info.temperature_lsb_c", h.info.temperature_lsb_c);
    f.boolean(*info, "has_gyro", "sensor.info.has_gyro", h.info.has_gyro);
    f.boolean(*info, "has_temperature", "sensor.info.has_temperature", h.info.has_temperature);
    f.boolean(*info, "has_accel", "sensor.info.has_accel", h.info.has_accel);  // absent before it: true
  }
}

// "plugins" (role, name, version, file of each) and "truth_columns".
void read_plugins_and_truth_columns(const nlohmann::json& j, const JsonFields& f, RecordingHeader& h) {
  if (const auto* plugins = f.find(j, "plugins")) {
    if (!plugins->is_array()) f.bad("plugins", "an array");
    h.plugins.clear();
    for (std::size_t i = 0; i < plugins->size(); ++i) {
      const auto& p = (*plugins)[i];
      const std::string path = fmt::format("plugins[{}]", i);
      if (!p.is_object()) f.bad(path, "an object");
      PluginUse u;
      f.str(p, "role", path + ".role", u.role);
      f.str(p, "name", path + ".name", u.name);
      f.str(p, "version", path + ".version", u.version);
      f.str(p, "file", path + ".file", u.file);
      if (p.contains("origin")) f.str(p, "origin", path + ".origin", u.origin);  // absent before they were recorded
      if (p.contains("hash")) f.str(p, "hash", path + ".hash", u.hash);
      h.plugins.push_back(std::move(u));
    }
  }
  if (const auto* cols = f.find(j, "truth_columns")) {
    if (!cols->is_array()) f.bad("truth_columns", "an array of strings");
    h.truth_columns.clear();
    for (const auto& c : *cols) {
      if (!c.is_string()) f.bad("truth_columns", "an array of strings");
      h.truth_columns.push_back(c.get<std::string>());
    }
  }
}

}  // namespace

nlohmann::json read_run_json(const fs::path& file, const std::string& text, RecordingHeader& h) {
  const nlohmann::json j = parse_run_json(file, text);
  if (!j.is_object()) fail_at(file, 1, "expected a JSON object");
  const JsonFields f(j, file);
  read_version_and_status(j, f, file, h);
  read_run_fields(j, f, h);
  read_sensor(j, f, h);
  read_plugins_and_truth_columns(j, f, h);
  return j;
}

}  // namespace stend::detail
