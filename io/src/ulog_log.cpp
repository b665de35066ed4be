// The first pass over a PX4 ULog file (ulog_log.hpp): header, formats, info and parameters,
// subscriptions and their data messages counted; dropouts, appended data and resyncs accounted.
#include "ulog_log.hpp"

#include <stend/io/logs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <string_view>

namespace stend::io {
namespace detail {

namespace {

constexpr std::uint8_t kUlogMagic[7] = {0x55, 0x4c, 0x6f, 0x67, 0x01, 0x12, 0x35};  // "ULog" 01 12 35
constexpr std::uint8_t kSyncMagic[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12};
constexpr std::size_t kMessageHeader = 3;    // uint16 size, uint8 type

// ---------------------------------------------------------------------------------------------
// Formats (F messages)

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

// "float[3] accelerometer_m_s2" → type, count, name.
Field parse_field(const BinaryReader& f, std::size_t at, const std::string& format, std::string_view text) {
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
    // A message is at most 65535 bytes (its uint16 size), so no array is longer; bounded before the
    // integer cast, which a larger value would make undefined (the fuzz target found 3.7e78).
    constexpr double kMaxArray = 65535.0;
    if (close == std::string_view::npos || !parse_double(type.substr(bracket + 1, close - bracket - 1), n) ||
        !(n >= 1.0 && n <= kMaxArray) || n != std::floor(n)) {
      f.fail(at, "format '" + format + "': field '" + fld.name + "' has a bad array size in '" + std::string(type) + "'");
    }
    fld.count = static_cast<std::size_t>(n);
    type = type.substr(0, bracket);
  }
  fld.type = std::string(type);
  return fld;
}

// An F message body "name:type field;type field;...".
Format parse_format(const BinaryReader& f, std::size_t at, std::string_view body) {
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
void resolve_format(const BinaryReader& f, std::map<std::string, Format>& formats, const std::string& name, int depth) {
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

// ---------------------------------------------------------------------------------------------
// The log's messages

// The topics an IMU import reads; data of others is skipped.
const std::set<std::string> kImuTopics = {"sensor_accel", "sensor_gyro", "sensor_combined", "sensor_selection"};

// Value of a basic-typed element as text (info messages).
std::string value_text(const BinaryReader& f, std::size_t at, const Field& fld, std::size_t size) {
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
    case Basic::kFloat: return fmt_g(static_cast<double>(f.get<float>(at, "an info value")));
    case Basic::kDouble: return fmt_g(f.get<double>(at, "an info value"));
    default: return {};
  }
}

// I message: uint8 key_len, key "type name", value.
void read_info(const BinaryReader& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
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
// The first flag-bits message only (the format puts one right after the header; pyulog reads no
// other): a crafted log of many would otherwise list appended-data offsets without bound, each
// checked against every message.
void read_flag_bits(const BinaryReader& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
  if (log.flag_bits_read) return;
  log.flag_bits_read = true;
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
    std::sort(log.appended_offsets.begin(), log.appended_offsets.end());  // a message is cut at the first
  }
}

// A message: uint8 multi_id, uint16 msg_id, topic name.
void read_subscription(const BinaryReader& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
  if (size < 3) f.fail(at, "subscription message of " + std::to_string(size) + " bytes (expected >= 3)");
  Subscription sub;
  sub.instance = *f.at(body);
  const auto id = f.get<std::uint16_t>(body + 1, "a subscription id");
  sub.topic = fixed_string(f.at(body + 3), size - 3);
  sub.imu = kImuTopics.count(sub.topic) > 0;
  if (!log.formats.count(sub.topic)) {
    f.fail(at, "subscription to '" + sub.topic + "', which no format message defines");
  }
  log.subscriptions[id] = std::move(sub);
}

// D message: uint16 msg_id, data. Counted (and the first kept as a position) for the IMU topics.
void read_data(const BinaryReader& f, std::size_t at, std::size_t body, std::size_t size, UlogLog& log) {
  if (size < 2) f.fail(at, "data message of " + std::to_string(size) + " bytes (expected a msg_id)");
  const auto id = f.get<std::uint16_t>(body, "a data msg_id");
  const auto it = log.subscriptions.find(id);
  if (it == log.subscriptions.end()) return;  // pyulog too ignores data without a subscription
  Subscription& sub = it->second;
  if (!sub.imu) return;
  if (!sub.first) sub.first = DataRecord{body + 2, size - 2};
  ++sub.records;
}

void check_header(const BinaryReader& f) {
  f.need(0, std::min(f.size(), sizeof kUlogMagic), "the ULog magic");
  const std::size_t compared = std::min(f.size(), sizeof kUlogMagic);
  if (!std::equal(kUlogMagic, kUlogMagic + compared, f.at(0))) {
    f.fail(0, "not a ULog file (expected the magic bytes 55 4c 6f 67 01 12 35, \"ULog\"...)");
  }
  f.need(0, kUlogHeaderBytes, "the ULog header");
}

// One of the message types F I M P Q B A R D L C S O.
bool known_type(char type) {
  switch (type) {
    case 'F': case 'I': case 'M': case 'P': case 'Q': case 'B': case 'A': case 'R': case 'D': case 'L': case 'C':
    case 'S': case 'O': return true;
    default: return false;
  }
}

}  // namespace

const Field* find_field(const Format& fmt, std::string_view name) {
  for (const auto& fld : fmt.fields) {
    if (fld.name == name) return &fld;
  }
  return nullptr;
}

bool next_message(const BinaryReader& f, const std::vector<std::uint64_t>& appended_offsets, std::size_t& pos,
                  Losses& losses, Message& m) {
  // `what` names the cut-off part, built only when there is a cut (this runs once per message).
  const auto ends_inside = [&](std::size_t length, const auto& what) {
    if (pos + length <= f.size()) return false;
    losses.cut_at = pos;
    losses.cut_bytes = f.size() - pos;
    losses.cut_what = what();
    pos = f.size();
    return true;
  };
  while (pos < f.size()) {
    if (ends_inside(kMessageHeader, [] { return std::string("a message header"); })) return false;
    const auto size = f.get<std::uint16_t>(pos, "a message header (uint16 size, uint8 type)");
    const auto type = static_cast<char>(f.get<std::uint8_t>(pos + 2, "a message header (uint16 size, uint8 type)"));
    const std::size_t end = pos + kMessageHeader + size;
    const auto cut = std::find_if(appended_offsets.begin(), appended_offsets.end(),
                                  [&](std::uint64_t off) { return pos < off && end > off; });
    if (cut != appended_offsets.end()) {
      ++losses.lost;
      pos = static_cast<std::size_t>(*cut);
      continue;
    }
    if (!known_type(type)) {
      const auto sync = f.find(pos + 1, kSyncMagic, sizeof kSyncMagic);
      if (!sync) {
        f.fail(pos, "unknown message type " + fmt_hex(static_cast<std::uint8_t>(type), 2) +
                        " (expected one of F I M P Q B A R D L C S O) and no sync marker follows");
      }
      losses.skipped_bytes += *sync + sizeof kSyncMagic - pos;
      ++losses.resyncs;
      ++losses.lost;
      pos = *sync + sizeof kSyncMagic;
      continue;
    }
    if (ends_inside(kMessageHeader + size, [type] { return std::string("a '") + type + "' message"; })) return false;
    f.need(pos, kMessageHeader + size, [type, size] {
      return std::string("a '") + type + "' message (3-byte header + " + std::to_string(size) + " bytes)";
    });
    m = Message{type, pos, pos + kMessageHeader, size};
    if (type == 'O') ++losses.lost;
    pos = end;
    return true;
  }
  return false;
}

UlogLog read_ulog(const BinaryReader& f) {
  check_header(f);
  UlogLog log;
  std::size_t pos = kUlogHeaderBytes;
  Message m{};
  while (next_message(f, log.appended_offsets, pos, log.losses, m)) {
    switch (m.type) {
      case 'F': {
        Format fmt = parse_format(f, m.at, fixed_string(f.at(m.body), m.size));
        log.formats[fmt.name] = std::move(fmt);
        break;
      }
      case 'I': read_info(f, m.at, m.body, m.size, log); break;
      case 'B': read_flag_bits(f, m.at, m.body, m.size, log); break;
      case 'A': read_subscription(f, m.at, m.body, m.size, log); break;
      case 'D': read_data(f, m.at, m.body, m.size, log); break;
      case 'P': ++log.parameters; break;
      case 'O':
        ++log.dropouts;
        if (m.size >= 2) log.dropout_ms += f.get<std::uint16_t>(m.body, "a dropout duration");
        break;
      default: break;  // M Q R L C S: not needed
    }
  }
  // Offsets of the formats the import decodes (their last definition, as pyulog keeps it).
  for (const auto& [id, sub] : log.subscriptions) {
    if (kImuTopics.count(sub.topic)) resolve_format(f, log.formats, sub.topic, 0);
  }
  return log;
}

}  // namespace detail

namespace fs = std::filesystem;
using namespace detail;

bool looks_like_ulog(const fs::path& file) {
  const std::string head = file_prefix(file, sizeof kUlogMagic);
  return head.size() == sizeof kUlogMagic && std::equal(std::begin(kUlogMagic), std::end(kUlogMagic),
                                                         reinterpret_cast<const std::uint8_t*>(head.data()));
}

}  // namespace stend::io
