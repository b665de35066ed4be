// The structure of a PX4 ULog file (docs.px4.io "ULog File Format"; pyulog is the reference
// reader): its formats, subscriptions and info messages read in a first pass over the message
// headers (ulog_log.cpp); the data records are read later, one at a time (ulog.cpp). Internal to
// stend_io.
#pragma once

#include "import_common.hpp"

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace stend::io::detail {

inline constexpr std::size_t kUlogHeaderBytes = 16;  // magic, version, start time [µs]
inline constexpr std::int32_t kRelativeTimestampInvalid = std::numeric_limits<std::int32_t>::max();

// ---------------------------------------------------------------------------------------------
// Formats (F messages)

enum class Basic { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kInt64, kUInt64, kFloat, kDouble, kBool, kChar, kNested };

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

// The field of `fmt` called `name`, or nullptr.
const Field* find_field(const Format& fmt, std::string_view name);

// ---------------------------------------------------------------------------------------------
// The log: formats, subscriptions with the number of data messages of each, info messages.

struct DataRecord {
  std::size_t offset;  // of the message data (after msg_id)
  std::size_t size;
};

struct Subscription {
  std::string topic;
  int instance = 0;
  bool imu = false;                       // a topic an IMU import reads (its data counted)
  std::size_t records = 0;                // data messages
  std::optional<DataRecord> first;        // the first of them
};

// What a walk through the messages has lost so far: each dropout, resync and message cut by
// appended data marks the data after it.
struct Losses {
  std::size_t lost = 0;  // dropouts + resyncs + cut messages
  std::size_t resyncs = 0, skipped_bytes = 0;
  // Where the file ends inside a message (a log cut by a power loss or a crash): every whole
  // message before it is read; empty `cut_what` when the file ends on a message boundary.
  std::size_t cut_at = 0, cut_bytes = 0;
  std::string cut_what;
  std::string describe_cut(std::size_t file_size) const {
    return "the log is cut short at byte " + std::to_string(file_size) + ", inside " + cut_what +
           " that starts at byte " + std::to_string(cut_at) + ": its " + std::to_string(cut_bytes) +
           " byte(s) are dropped; every whole message before it is read (a log cut by a power loss or a crash)";
  }
};

struct UlogLog {
  std::map<std::string, Format> formats;
  std::map<std::uint16_t, Subscription> subscriptions;  // by msg_id
  std::map<std::string, std::string> info;              // I messages: key name → value as text
  std::size_t parameters = 0;
  std::size_t dropouts = 0, dropout_ms = 0;
  Losses losses;
  bool flag_bits_read = false;
  std::vector<std::uint64_t> appended_offsets;  // ascending, at most 3
};

// One message: type, offsets of its header and body, body size. In the reader's buffer whole.
struct Message {
  char type;
  std::size_t at, body, size;
};

// The message at `pos` after the header (advancing `pos` past it), false at the end of the file.
// A message cut by the start of appended data is lost (the log continues there), corrupt bytes are
// skipped to the next sync marker (both as pyulog reads them); these and dropouts count in `losses`.
bool next_message(const BinaryReader& f, const std::vector<std::uint64_t>& appended_offsets, std::size_t& pos,
                  Losses& losses, Message& m);

// The first pass: every message's header; definitions, info and parameters read, data messages of
// the IMU topics counted.
UlogLog read_ulog(const BinaryReader& f);

}  // namespace stend::io::detail
