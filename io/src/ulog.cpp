// PX4 ULog reader (docs.px4.io "ULog File Format"; pyulog is the reference reader).
#include <stend/io/logs.hpp>

#include "import_common.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

constexpr std::uint8_t kUlogMagic[7] = {0x55, 0x4c, 0x6f, 0x67, 0x01, 0x12, 0x35};  // "ULog" 01 12 35
constexpr std::uint8_t kSyncMagic[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12};
constexpr std::size_t kHeaderBytes = 16;     // magic, version, start time [µs]
constexpr std::size_t kMessageHeader = 3;    // uint16 size, uint8 type
constexpr std::int32_t kRelativeTimestampInvalid = std::numeric_limits<std::int32_t>::max();

// ---------------------------------------------------------------------------------------------
// Formats (F messages)

enum class Basic { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kInt64, kUInt64, kFloat, kDouble, kBool, kChar, kNested };

struct BasicType {
  const char* name;
  Basic basic;
  std::size_t size;
};
constexpr BasicType kBasicTypes[] = {
    {"int8_t", Basic::kInt8, 1},   {"uint8_t", Basic::kUInt8, 1},   {"int16_t", Basic::kInt16, 2},
    {"uint16_t", Basic::kUInt16, 2}, {"int32_t", Basic::kInt32, 4}, {"uint32_t", Basic::kUInt32, 4},
    {"int64_t", Basic::kInt64, 8}, {"uint64_t", Basic::kUInt64, 8}, {"float", Basic::kFloat, 4},
    {"double", Basic::kDouble, 8}, {"bool", Basic::kBool, 1},       {"char", Basic::kChar, 1},
};

// The basic type named `name`, or nullptr (a nested format or unknown).
const BasicType* basic_type(const std::string& name) {
  const auto* it = std::find_if(std::begin(kBasicTypes), std::end(kBasicTypes),
                                [&](const BasicType& b) { return name == b.name; });
  return it == std::end(kBasicTypes) ? nullptr : it;
}

struct Field {
  std::string type;   // element type name as written ("float", "vehicle_attitude_s"...)
  std::string name;
  std::size_t count = 1;  // array length (1 for a scalar)
  Basic basic = Basic::kNested;
  std::size_t element_size = 0;
  std::size_t offset = 0;  // bytes from the start of the message data
};

struct Format {
  std::string name;
  std::vector<Field> fields;
  std::size_t size = 0;
  std::size_t defined_at = 0;  // byte offset of the F message
  bool resolved = false;
};

// "float[3] accelerometer_m_s2" → type, count, name.
Field parse_field(const BinaryFile& f, std::size_t at, const std::string& format, std::string_view text) {
  text = trim(text);
  const auto space = text.rfind(' ');
  if (space == std::string_view::npos) {
    f.fail(at, "format '" + format + "': field '" + std::string(text) + "' is not '<type> <name>'");
  }
  Field fld;
  fld.name = std::string(trim(text.substr(space + 1)));
  std::string_view type = trim(text.substr(0, space));
  if (const auto bracket = type.find('['); bracket != std::string_view::npos) {
    const auto close = type.find(']', bracket);
    double n = 0.0;
    if (close == std::string_view::npos || !parse_double(type.substr(bracket + 1, close - bracket - 1), n) ||
        !(n >= 1.0) || n != static_cast<double>(static_cast<std::size_t>(n))) {
      f.fail(at, "format '" + format + "': field '" + fld.name + "' has a bad array size in '" + std::string(type) + "'");
    }
    fld.count = static_cast<std::size_t>(n);
    type = type.substr(0, bracket);
  }
  fld.type = std::string(type);
  return fld;
}

// An F message body "name:type field;type field;...".
Format parse_format(const BinaryFile& f, std::size_t at, std::string_view body) {
  const auto colon = body.find(':');
  if (colon == std::string_view::npos) f.fail(at, "format definition without ':' (expected 'name:type field;...')");
  Format fmt;
  fmt.name = std::string(body.substr(0, colon));
  fmt.defined_at = at;
  for (auto part : split(body.substr(colon + 1), ';')) {
    if (!trim(part).empty()) fmt.fields.push_back(parse_field(f, at, fmt.name, part));
  }
  return fmt;
}

// Field offsets and sizes of `name` and of the formats it nests (depth-first).
void resolve_format(const BinaryFile& f, std::map<std::string, Format>& formats, const std::string& name, int depth) {
  Format& fmt = formats.at(name);
  if (fmt.resolved) return;
  if (depth > 16) f.fail(fmt.defined_at, "format '" + name + "' nests formats more than 16 deep (a cycle?)");
  std::size_t offset = 0;
  for (Field& fld : fmt.fields) {
    if (const BasicType* basic = basic_type(fld.type)) {
      fld.basic = basic->basic;
      fld.element_size = basic->size;
    } else if (formats.count(fld.type)) {
      resolve_format(f, formats, fld.type, depth + 1);
      fld.element_size = formats.at(fld.type).size;
    } else {
      f.fail(fmt.defined_at, "format '" + name + "': field '" + fld.name + "' has type '" + fld.type +
                                 "', which is neither a ULog basic type (int8_t … uint64_t, float, double, bool, "
                                 "char) nor a format defined in the log");
    }
    fld.offset = offset;
    offset += fld.element_size * fld.count;
  }
  fmt.size = offset;
  fmt.resolved = true;
}

const Field* find_field(const Format& fmt, const std::string& name) {
  for (const auto& fld : fmt.fields) {
    if (fld.name == name) return &fld;
  }
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// The log: formats, subscriptions with the data of the topics an import reads, info messages

// The topics an IMU import reads; data of others is skipped.
const std::set<std::string> kImuTopics = {"sensor_accel", "sensor_gyro", "sensor_combined", "sensor_selection"};

struct DataRecord {
  std::size_t offset;      // of the message data (after msg_id)
  std::size_t size;
  std::size_t lost_before;  // dropouts and resyncs seen before it
};

struct Subscription {
  std::string topic;
  int instance = 0;
  std::vector<DataRecord> records;
};

struct UlogLog {
  std::map<std::string, Format> formats;
  std::map<std::uint16_t, Subscription> subscriptions;  // by msg_id
  std::map<std::string, std::string> info;              // I messages: key name → value as text
  std::size_t parameters = 0;
  std::size_t dropouts = 0, dropout_ms = 0;
  std::size_t resyncs = 0, skipped_bytes = 0;
  std::size_t lost = 0;  // dropouts + resyncs so far (marks data records)
  std::vector<std::uint64_t> appended_offsets;
};

// Value of a basic-typed element as text (info messages).
std::string value_text(const BinaryFile& f, std::size_t at, const Field& fld, std::size_t size) {
  if (fld.basic == Basic::kChar) return fixed_string(f.at(at), size);
  if (size < fld.element_size) return {};
  switch (fld.basic) {
    case Basic::kInt8: return std::to_string(f.get<std::int8_t>(at, "an info value"));
    case Basic::kUInt8: case Basic::kBool: return std::to_string(f.get<std::uint8_t>(at, "an info value"));
    case Basic::kInt16: return std::to_string(f.get<std::int16_t>(at, "an info value"));
    case Basic::kUInt16: return std::to_string(f.get<std::uint16_t>(at, "an info value"));
    case Basic::kInt32: return std::to_string(f.get<std::int32_t>(at, "an info value"));
    case Basic::kUInt32: return std::to_string(f.get<std::uint32_t>(at, "an info value"));
    case Basic::kInt64: return std::to_string(f.get<std::int64_t>(at, "an info value"));
    case Basic::kUInt64: return std::to_string(f.get<std::uint64_t>(at, "an info value"));
    case Basic::kFloat: return fmt_g(f.get<float>(at, "an info value"));
    case Basic::kDouble: return fmt_g(f.get<double>(at, "an info value"));
    default: return {};
  }
}

// I message: uint8 key_len, key "type name", value.
void read_info(const BinaryFile& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
  if (size < 1) f.fail(at, "info message without a key length");
  const std::size_t key_len = *f.at(body);
  if (1 + key_len > size) f.fail(at, "info message key (" + std::to_string(key_len) + " bytes) runs past the message");
  const Field key = parse_field(f, at, "info", fixed_string(f.at(body + 1), key_len));
  const BasicType* basic = basic_type(key.type);
  if (!basic) return;  // nested-type info: not needed
  Field typed = key;
  typed.basic = basic->basic;
  typed.element_size = basic->size;
  log.info[key.name] = value_text(f, body + 1 + key_len, typed, size - 1 - key_len);
}

// B message: incompatible flags this reader does not know stop it; appended-data offsets are kept.
void read_flag_bits(const BinaryFile& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
  if (size < 40) f.fail(at, "flag-bits message of " + std::to_string(size) + " bytes (expected 40)");
  const std::uint8_t incompat0 = *f.at(body + 8);
  for (std::size_t i = 0; i < 8; ++i) {
    const std::uint8_t bits = *f.at(body + 8 + i);
    if ((i == 0 && (bits & ~1u)) || (i > 0 && bits)) {
      f.fail(at, "unknown incompatible flag bits in byte " + std::to_string(i) + " (this reader knows only "
                 "DATA_APPENDED)");
    }
  }
  if (incompat0 & 1u) {
    for (std::size_t i = 0; i < 3; ++i) {
      const auto off = f.get<std::uint64_t>(body + 16 + 8 * i, "an appended-data offset");
      if (off > 0) log.appended_offsets.push_back(off);
    }
  }
}

// A message: uint8 multi_id, uint16 msg_id, topic name.
void read_subscription(const BinaryFile& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
  if (size < 3) f.fail(at, "subscription message of " + std::to_string(size) + " bytes (expected >= 3)");
  Subscription sub;
  sub.instance = *f.at(body);
  const auto id = f.get<std::uint16_t>(body + 1, "a subscription id");
  sub.topic = fixed_string(f.at(body + 3), size - 3);
  if (!log.formats.count(sub.topic)) {
    f.fail(at, "subscription to '" + sub.topic + "', which no format message defines");
  }
  log.subscriptions[id] = std::move(sub);
}

// D message: uint16 msg_id, data. Kept (as a position) for the IMU topics.
void read_data(const BinaryFile& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
  if (size < 2) f.fail(at, "data message of " + std::to_string(size) + " bytes (expected a msg_id)");
  const auto id = f.get<std::uint16_t>(body, "a data msg_id");
  const auto it = log.subscriptions.find(id);
  if (it == log.subscriptions.end()) return;  // pyulog too ignores data without a subscription
  if (kImuTopics.count(it->second.topic)) it->second.records.push_back({body + 2, size - 2, log.lost});
}

// Offset after the next sync marker at or after `from`, if any.
std::optional<std::size_t> next_sync(const BinaryFile& f, std::size_t from) {
  const std::uint8_t* begin = f.at(0);
  const std::uint8_t* end = begin + f.size();
  const auto* hit = std::search(begin + std::min(from, f.size()), end, std::begin(kSyncMagic), std::end(kSyncMagic));
  if (hit == end) return std::nullopt;
  return static_cast<std::size_t>(hit - begin) + sizeof kSyncMagic;
}

void check_header(const BinaryFile& f) {
  const std::size_t compared = std::min(f.size(), sizeof kUlogMagic);
  if (!std::equal(kUlogMagic, kUlogMagic + compared, f.at(0))) {
    f.fail(0, "not a ULog file (expected the magic bytes 55 4c 6f 67 01 12 35, \"ULog\"...)");
  }
  f.need(0, kHeaderBytes, "the ULog header");
}

// Reads every message after the header.
UlogLog read_ulog(const BinaryFile& f) {
  check_header(f);
  UlogLog log;
  std::size_t pos = kHeaderBytes;
  while (pos < f.size()) {
    const auto size = f.get<std::uint16_t>(pos, "a message header (uint16 size, uint8 type)");
    const auto type = static_cast<char>(f.get<std::uint8_t>(pos + 2, "a message header (uint16 size, uint8 type)"));
    const std::size_t end = pos + kMessageHeader + size;
    // A message cut by the start of appended data: the log continues there (pyulog does the same).
    const auto cut = std::find_if(log.appended_offsets.begin(), log.appended_offsets.end(),
                                  [&](std::uint64_t off) { return pos < off && end > off; });
    if (cut != log.appended_offsets.end()) {
      ++log.lost;
      pos = static_cast<std::size_t>(*cut);
      continue;
    }
    if (std::string_view("FIMPQBARDLCSO").find(type) == std::string_view::npos) {
      // Corrupt data: continue after the next sync marker, as pyulog does.
      const auto sync = next_sync(f, pos + 1);
      if (!sync) {
        f.fail(pos, "unknown message type " + fmt_hex(static_cast<std::uint8_t>(type), 2) +
                        " (expected one of F I M P Q B A R D L C S O) and no sync marker follows");
      }
      log.skipped_bytes += *sync - pos;
      ++log.resyncs;
      ++log.lost;
      pos = *sync;
      continue;
    }
    f.need(pos, kMessageHeader + size, std::string("a '") + type + "' message (3-byte header + " + std::to_string(size) + " bytes)");
    const std::size_t body = pos + kMessageHeader;
    switch (type) {
      case 'F': {
        Format fmt = parse_format(f, pos, fixed_string(f.at(body), size));
        log.formats[fmt.name] = std::move(fmt);
        break;
      }
      case 'I': read_info(f, pos, body, size, log); break;
      case 'B': read_flag_bits(f, pos, body, size, log); break;
      case 'A': read_subscription(f, pos, body, size, log); break;
      case 'D': read_data(f, pos, body, size, log); break;
      case 'P': ++log.parameters; break;
      case 'O':
        ++log.dropouts;
        ++log.lost;
        if (size >= 2) log.dropout_ms += f.get<std::uint16_t>(body, "a dropout duration");
        break;
      default: break;  // M Q R L C S: not needed
    }
    pos = end;
  }
  // Offsets of the formats the import decodes (their last definition, as pyulog keeps it).
  for (const auto& [id, sub] : log.subscriptions) {
    if (kImuTopics.count(sub.topic)) resolve_format(f, log.formats, sub.topic, 0);
  }
  return log;
}

}  // namespace

bool looks_like_ulog(const fs::path& file) {
  const std::string head = file_prefix(file, sizeof kUlogMagic);
  return head.size() == sizeof kUlogMagic && std::equal(std::begin(kUlogMagic), std::end(kUlogMagic),
                                                         reinterpret_cast<const std::uint8_t*>(head.data()));
}

namespace {

// ---------------------------------------------------------------------------------------------
// From data records to IMU series

// One sensor's samples in file order: time [µs], vector (m/s² or rad/s), temperature [°C].
struct Series {
  std::string what;  // "sensor_accel instance 1"
  std::vector<std::uint64_t> t_us;
  std::vector<Eigen::Vector3d> v;
  std::vector<double> temperature_c;  // empty when the topic has none
  std::vector<std::size_t> lost_before;
  std::optional<std::uint32_t> device_id;
};

// Reads basic-typed fields of one data record, with bounds checks against the record.
class RecordView {
 public:
  RecordView(const BinaryFile& f, const Format& fmt, const DataRecord& r) : f_(f), fmt_(fmt), r_(r) {}

  double number(const std::string& name, std::size_t index = 0) const {
    const Field& fld = field(name, index);
    const std::uint8_t* p = f_.at(r_.offset + fld.offset + index * fld.element_size);  // checked by field()
    switch (fld.basic) {
      case Basic::kInt8: return load_le<std::int8_t>(p);
      case Basic::kUInt8: case Basic::kBool: case Basic::kChar: return load_le<std::uint8_t>(p);
      case Basic::kInt16: return load_le<std::int16_t>(p);
      case Basic::kUInt16: return load_le<std::uint16_t>(p);
      case Basic::kInt32: return load_le<std::int32_t>(p);
      case Basic::kUInt32: return load_le<std::uint32_t>(p);
      case Basic::kInt64: return static_cast<double>(load_le<std::int64_t>(p));
      case Basic::kUInt64: return static_cast<double>(load_le<std::uint64_t>(p));
      case Basic::kFloat: return static_cast<double>(load_le<float>(p));
      case Basic::kDouble: return load_le<double>(p);
      case Basic::kNested: break;
    }
    f_.fail(r_.offset, "field '" + name + "' of '" + fmt_.name + "' is a nested type, expected a number");
  }

  std::uint64_t timestamp(const std::string& name) const {
    const Field& fld = field(name, 0);
    if (fld.basic != Basic::kUInt64) {
      f_.fail(fmt_.defined_at, "field '" + name + "' of '" + fmt_.name + "' is " + fld.type + ", expected uint64_t [us]");
    }
    return load_le<std::uint64_t>(f_.at(r_.offset + fld.offset));  // checked by field()
  }

 private:
  const Field& field(const std::string& name, std::size_t index) const {
    const Field* fld = find_field(fmt_, name);
    if (!fld || index >= fld->count) {
      f_.fail(fmt_.defined_at, "format '" + fmt_.name + "' has no field '" + name + "'" +
                                   (index ? "[" + std::to_string(index) + "]" : std::string()));
    }
    if (fld->offset + (index + 1) * fld->element_size > r_.size) {
      f_.fail(r_.offset, "'" + fmt_.name + "' data of " + std::to_string(r_.size) + " bytes ends before field '" +
                             name + "' (bytes " + std::to_string(fld->offset) + "…" +
                             std::to_string(fld->offset + (index + 1) * fld->element_size) + ")");
    }
    return *fld;
  }

  const BinaryFile& f_;
  const Format& fmt_;
  const DataRecord& r_;
};

std::vector<const Subscription*> subscriptions_of(const UlogLog& log, const std::string& topic, int instance) {
  std::vector<const Subscription*> out;
  for (const auto& [id, sub] : log.subscriptions) {
    if (sub.topic == topic && sub.instance == instance) out.push_back(&sub);
  }
  return out;
}

// sensor_accel / sensor_gyro instance: x y z, temperature, time timestamp_sample (else timestamp).
Series sensor_series(const BinaryFile& f, const UlogLog& log, const std::string& topic, int instance) {
  Series s;
  s.what = topic + " instance " + std::to_string(instance);
  const Format& fmt = log.formats.at(topic);
  const bool has_sample_time = find_field(fmt, "timestamp_sample") != nullptr;
  const bool has_temperature = find_field(fmt, "temperature") != nullptr;
  for (const Subscription* sub : subscriptions_of(log, topic, instance)) {
    for (const DataRecord& r : sub->records) {
      const RecordView v(f, fmt, r);
      s.t_us.push_back(v.timestamp(has_sample_time ? "timestamp_sample" : "timestamp"));
      s.v.emplace_back(v.number("x"), v.number("y"), v.number("z"));
      if (has_temperature) s.temperature_c.push_back(v.number("temperature"));
      s.lost_before.push_back(r.lost_before);
      if (!s.device_id && find_field(fmt, "device_id")) s.device_id = static_cast<std::uint32_t>(v.number("device_id"));
    }
  }
  return s;
}

// sensor_combined instance: accelerometer_m_s2 at timestamp + accelerometer_timestamp_relative
// (records marked invalid skipped), gyro_rad at timestamp.
std::pair<Series, Series> combined_series(const BinaryFile& f, const UlogLog& log, int instance) {
  Series acc, gyr;
  acc.what = "sensor_combined instance " + std::to_string(instance) + " accelerometer_m_s2";
  gyr.what = "sensor_combined instance " + std::to_string(instance) + " gyro_rad";
  const Format& fmt = log.formats.at("sensor_combined");
  for (const Subscription* sub : subscriptions_of(log, "sensor_combined", instance)) {
    for (const DataRecord& r : sub->records) {
      const RecordView v(f, fmt, r);
      const std::uint64_t t = v.timestamp("timestamp");
      gyr.t_us.push_back(t);
      gyr.v.emplace_back(v.number("gyro_rad", 0), v.number("gyro_rad", 1), v.number("gyro_rad", 2));
      gyr.lost_before.push_back(r.lost_before);
      const double rel = v.number("accelerometer_timestamp_relative");
      if (rel == kRelativeTimestampInvalid) continue;
      acc.t_us.push_back(static_cast<std::uint64_t>(static_cast<std::int64_t>(t) + static_cast<std::int64_t>(rel)));
      acc.v.emplace_back(v.number("accelerometer_m_s2", 0), v.number("accelerometer_m_s2", 1),
                         v.number("accelerometer_m_s2", 2));
      acc.lost_before.push_back(r.lost_before);
    }
  }
  return {std::move(acc), std::move(gyr)};
}

// Number of data records per instance of a topic.
std::map<int, std::size_t> instance_counts(const UlogLog& log, const std::string& topic) {
  std::map<int, std::size_t> out;
  for (const auto& [id, sub] : log.subscriptions) {
    if (sub.topic == topic) out[sub.instance] += sub.records.size();
  }
  return out;
}

std::string describe_counts(const std::string& topic, const std::map<int, std::size_t>& counts) {
  std::string s;
  for (const auto& [inst, n] : counts) {
    s += (s.empty() ? "" : ", ") + topic + " instance " + std::to_string(inst) + ": " + std::to_string(n);
  }
  return s.empty() ? topic + ": none" : s;
}

// The instance asked for (it must exist), else the one with the most records.
int choose_instance(const std::map<int, std::size_t>& counts, int wanted) {
  if (wanted >= 0) return counts.count(wanted) ? wanted : -1;
  int best = -1;
  std::size_t most = 0;
  for (const auto& [inst, n] : counts) {
    if (n > most) best = inst, most = n;
  }
  return best;
}

// What an import reads: the accelerometer and gyro series and why they were chosen.
struct UlogChoice {
  Series acc, gyr;
  Series temperature;  // when acc has none: a sensor_accel of the same device (time-ordered)
  std::string why;
  std::string temperature_note;
};

// sensor_combined: the devices sensor_selection names (its first message) as the accel's and
// gyro's device ids, and the temperature of the sensor_accel instance with that device id.
void add_selected_devices(const BinaryFile& f, const UlogLog& log, UlogChoice& c) {
  const auto sel = std::find_if(log.subscriptions.begin(), log.subscriptions.end(), [](const auto& s) {
    return s.second.topic == "sensor_selection" && !s.second.records.empty();
  });
  const Format* fmt = sel == log.subscriptions.end() ? nullptr : &log.formats.at("sensor_selection");
  if (!fmt || !find_field(*fmt, "accel_device_id") || !find_field(*fmt, "gyro_device_id")) {
    c.temperature_note = "no temperature (sensor_combined has none, and no sensor_selection names its devices)";
    return;
  }
  const RecordView v(f, *fmt, sel->second.records.front());
  c.acc.device_id = static_cast<std::uint32_t>(v.number("accel_device_id"));
  c.gyr.device_id = static_cast<std::uint32_t>(v.number("gyro_device_id"));
  for (const auto& [inst, n] : instance_counts(log, "sensor_accel")) {
    Series t = sensor_series(f, log, "sensor_accel", inst);
    if (t.device_id == c.acc.device_id && !t.temperature_c.empty()) {
      c.temperature_note = "temperature interpolated from " + t.what + " (the device sensor_selection names)";
      c.temperature = std::move(t);
      return;
    }
  }
  c.temperature_note = "no temperature (no sensor_accel of the selected device " + fmt_hex(*c.acc.device_id, 8) + ")";
}

UlogChoice choose_series(const BinaryFile& f, const UlogLog& log, const UlogOptions& opt) {
  const auto accel = instance_counts(log, "sensor_accel");
  const auto gyro = instance_counts(log, "sensor_gyro");
  const auto combined = instance_counts(log, "sensor_combined");
  const std::string available = describe_counts("sensor_accel", accel) + "; " + describe_counts("sensor_gyro", gyro) +
                                "; " + describe_counts("sensor_combined", combined);
  const int ag = choose_instance(accel, opt.instance);
  const int cb = choose_instance(combined, opt.instance);
  const std::size_t ag_n = ag >= 0 && gyro.count(ag) && gyro.at(ag) > 0 ? accel.at(ag) : 0;
  const std::size_t cb_n = cb >= 0 ? combined.at(cb) : 0;
  bool use_ag = false;
  std::string why;
  switch (opt.source) {
    case UlogSource::kSensorAccelGyro: use_ag = true; why = "topics as asked"; break;
    case UlogSource::kSensorCombined: use_ag = false; why = "topic as asked"; break;
    case UlogSource::kAuto:
      use_ag = ag_n > 0 && 2 * ag_n >= cb_n;
      why = use_ag ? "it holds at least half as many samples as sensor_combined"
                   : "sensor_accel + sensor_gyro hold fewer than half as many samples (logged sparsely)";
      break;
  }
  const std::string which = opt.instance >= 0 ? "instance " + std::to_string(opt.instance) + " as asked"
                                              : "the instance with the most samples";
  if ((use_ag && ag_n == 0) || (!use_ag && cb_n == 0)) {
    f.fail(f.size(), std::string("no IMU data: expected ") +
                         (use_ag ? "sensor_accel and sensor_gyro" : opt.source == UlogSource::kAuto
                                                                         ? "sensor_accel + sensor_gyro or sensor_combined"
                                                                         : "sensor_combined") +
                         " data (" + which + "); the log has " + available);
  }
  UlogChoice c;
  if (use_ag) {
    c.acc = sensor_series(f, log, "sensor_accel", ag);
    c.gyr = sensor_series(f, log, "sensor_gyro", ag);
  } else {
    std::tie(c.acc, c.gyr) = combined_series(f, log, cb);
    add_selected_devices(f, log, c);
  }
  c.why = "IMU from " + std::string(use_ag ? "sensor_accel + sensor_gyro" : "sensor_combined") + " instance " +
          std::to_string(use_ag ? ag : cb) + " (" + which + "; " + why + "); available: " + available;
  return c;
}

// A series' times [s, relative to t0_us] and values in time order, for interpolation.
template <class V>
struct Ordered {
  std::vector<double> t;
  std::vector<V> v;
};
template <class V>
Ordered<V> in_time_order(const std::vector<std::uint64_t>& t_us, const std::vector<V>& v, std::uint64_t t0_us) {
  std::vector<std::size_t> order(t_us.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return t_us[a] < t_us[b]; });
  Ordered<V> out;
  for (std::size_t i : order) {
    out.t.push_back(seconds_since_us(t0_us, t_us[i]));
    out.v.push_back(v[i]);
  }
  return out;
}

constexpr double kTimestampUnitS = 1e-6;     // interpolation tolerance at the ends: one timestamp unit
constexpr double kTemperatureHoldS = 2.0;    // a sparse temperature is held this long past its ends

// Temperature [°C] at the samples from another topic's sparse series, linearly interpolated; none
// at all (has_temperature false) unless it covers every sample. Returns the note.
std::string add_interpolated_temperature(const UlogChoice& c, Recording& rec) {
  const Ordered<double> temp = in_time_order(c.temperature.t_us, c.temperature.temperature_c, c.acc.t_us.front());
  for (auto& s : rec.samples) {
    if (!interpolate_at(temp.t, temp.v, s.t_s, kTemperatureHoldS, s.temperature_c)) {
      for (auto& x : rec.samples) x.temperature_c = 0.0;
      return "no temperature (" + c.temperature.what + " does not cover the samples within " +
             fmt_g(kTemperatureHoldS) + " s)";
    }
  }
  rec.header.info.has_temperature = true;
  return c.temperature_note + ", held at its end values up to " + fmt_g(kTemperatureHoldS) + " s beyond";
}

// Samples at the accelerometer times [s from the first sample]: accel [m/s²], temperature [°C],
// gyro [rad/s] as logged at the same time or linearly interpolated; a dropout or resync before a
// sample flags a gap. Accelerometer samples outside the gyro's time span are dropped. Sets
// has_temperature; returns the merge note.
std::string merge_series(const BinaryFile& f, const UlogChoice& c, Recording& rec) {
  if (c.acc.t_us.empty() || c.gyr.t_us.empty()) {
    f.fail(f.size(), "no IMU data: " + c.acc.what + " has " + std::to_string(c.acc.t_us.size()) + " samples, " +
                         c.gyr.what + " " + std::to_string(c.gyr.t_us.size()));
  }
  const bool same_times = c.acc.t_us == c.gyr.t_us;
  const std::uint64_t t0 = c.acc.t_us.front();
  const Ordered<Eigen::Vector3d> gyro = in_time_order(c.gyr.t_us, c.gyr.v, t0);
  std::size_t dropped = 0;
  for (std::size_t i = 0; i < c.acc.t_us.size(); ++i) {
    ImuSample s;
    s.t_s = seconds_since_us(t0, c.acc.t_us[i]);
    s.accel_mps2 = c.acc.v[i];
    if (!c.acc.temperature_c.empty()) s.temperature_c = c.acc.temperature_c[i];
    if (same_times) {
      s.gyro_radps = c.gyr.v[i];
    } else if (!interpolate_at(gyro.t, gyro.v, s.t_s, kTimestampUnitS, s.gyro_radps)) {
      ++dropped;
      continue;
    }
    if (i > 0 && c.acc.lost_before[i] != c.acc.lost_before[i - 1]) s.flags |= kGapBefore;
    rec.samples.push_back(s);
  }
  if (rec.samples.empty()) {
    f.fail(f.size(), "the gyro's timestamps do not overlap the accelerometer's (" + c.acc.what + ", " + c.gyr.what + ")");
  }
  std::string note = same_times ? "gyro logged at the accelerometer times"
                                : "gyro linearly interpolated at the accelerometer times" +
                                      (dropped ? " (" + std::to_string(dropped) +
                                                     " accelerometer sample(s) outside the gyro's time span dropped)"
                                               : std::string());
  rec.header.info.has_temperature = !c.acc.temperature_c.empty();
  if (rec.header.info.has_temperature) return note + "; temperature from " + c.acc.what;
  if (c.temperature.t_us.empty()) return note + "; " + c.temperature_note;
  return note + "; " + add_interpolated_temperature(c, rec);
}

std::string info_or(const UlogLog& log, const std::string& key, const std::string& fallback = {}) {
  const auto it = log.info.find(key);
  return it == log.info.end() ? fallback : it->second;
}

// Identity from the info messages: sys_name (vendor), ver_hw (model), sys_uuid (serial) and the
// PX4 device ids of the chosen sensors (who_am_i).
SensorIdentity ulog_identity(const UlogLog& log, const UlogChoice& c) {
  SensorIdentity id;
  id.vendor = info_or(log, "sys_name");
  id.model = info_or(log, "ver_hw");
  id.serial = info_or(log, "sys_uuid");
  if (c.acc.device_id) id.who_am_i = "accel device_id " + fmt_hex(*c.acc.device_id, 8);
  if (c.gyr.device_id) id.who_am_i += (id.who_am_i.empty() ? "" : ", ") + std::string("gyro device_id ") + fmt_hex(*c.gyr.device_id, 8);
  return id;
}

}  // namespace

Recording import_ulog(const fs::path& file, const UlogOptions& opt) {
  const BinaryFile f(file);
  const UlogLog log = read_ulog(f);
  const UlogChoice choice = choose_series(f, log, opt);
  Recording rec = new_recording(file, "ulog");
  const std::string merge = merge_series(f, choice, rec);
  std::size_t lost_gaps = 0;
  for (const auto& s : rec.samples) lost_gaps += (s.flags & kGapBefore) ? 1 : 0;
  const TimestampSummary ts = check_log_timestamps(rec.samples);
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = ts.rate_hz;
  info.has_gyro = true;
  rec.header.identity = ulog_identity(log, choice);
  add_import_event(
      rec, "imported " + std::to_string(rec.samples.size()) + " samples from " + file.string() + " (PX4 ULog; " +
               "sys_name '" + info_or(log, "sys_name", "?") + "', ver_hw '" + info_or(log, "ver_hw", "?") +
               "', ver_sw '" + info_or(log, "ver_sw", "?") + "'; " + choice.why + "; " + merge +
               "; values as logged: m/s^2, rad/s, degC" +
               "; t = " + (choice.acc.what.rfind("sensor_combined", 0) == 0 ? "timestamp + accelerometer_timestamp_relative"
                                                                            : "timestamp_sample") +
               " [us] relative to the first sample; " + ts.describe() + "; " + std::to_string(log.dropouts) +
               " dropout(s) (" + std::to_string(log.dropout_ms) + " ms) and " + std::to_string(log.resyncs) +
               " resync(s) (" + std::to_string(log.skipped_bytes) + " bytes skipped) flagged " +
               std::to_string(lost_gaps) + " gap(s); " + std::to_string(log.parameters) + " parameters not imported)");
  return rec;
}

}  // namespace stend::io
