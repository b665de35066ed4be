// ArduPilot DataFlash (.BIN) reader (ArduPilot LogStructure.h; pymavlink DFReader is the reference
// reader).
#include <stend/io/logs.hpp>
#include <stend/physics/units.hpp>

#include "import_common.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
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

constexpr std::uint8_t kHead1 = 0xA3, kHead2 = 0x95;
constexpr std::uint8_t kFmtType = 0x80;
constexpr std::size_t kHeaderBytes = 3;    // A3 95 <type>
constexpr std::size_t kFmtLength = 89;     // header + Type B, Length B, Name n, Format N, Columns Z

// A DataFlash format character: bytes, how the value is stored, and the scale the type implies.
enum class Storage { kInt, kUInt, kFloat, kText, kArray };
struct TypeChar {
  char c;
  std::size_t size;
  Storage storage;
  double scale;
};
constexpr TypeChar kTypeChars[] = {
    {'a', 64, Storage::kArray, 1.0}, {'b', 1, Storage::kInt, 1.0},   {'B', 1, Storage::kUInt, 1.0},
    {'h', 2, Storage::kInt, 1.0},    {'H', 2, Storage::kUInt, 1.0},  {'i', 4, Storage::kInt, 1.0},
    {'I', 4, Storage::kUInt, 1.0},   {'f', 4, Storage::kFloat, 1.0}, {'d', 8, Storage::kFloat, 1.0},
    {'n', 4, Storage::kText, 1.0},   {'N', 16, Storage::kText, 1.0}, {'Z', 64, Storage::kText, 1.0},
    {'c', 2, Storage::kInt, 0.01},   {'C', 2, Storage::kUInt, 0.01}, {'e', 4, Storage::kInt, 0.01},
    {'E', 4, Storage::kUInt, 0.01},  {'L', 4, Storage::kInt, 1e-7},  {'M', 1, Storage::kUInt, 1.0},
    {'q', 8, Storage::kInt, 1.0},    {'Q', 8, Storage::kUInt, 1.0},
};

const TypeChar* type_char(char c) {
  const auto* it = std::find_if(std::begin(kTypeChars), std::end(kTypeChars), [c](const TypeChar& t) { return t.c == c; });
  return it == std::end(kTypeChars) ? nullptr : it;
}

struct DfFormat {
  std::uint8_t type = 0;
  std::size_t length = 0;  // whole message, header included
  std::string name, format;
  std::vector<std::string> columns;
  std::vector<std::size_t> offsets;  // of each column in the message, header included
  std::vector<const TypeChar*> types;  // of each column
  bool imu = false;                    // an IMU, IMU2 or IMU3 message
  std::optional<std::size_t> instance_column;  // its I column, if it has one
  std::size_t defined_at = 0;        // byte offset of the FMT message
  std::size_t index = 0;             // among the log's FMT messages, in file order
  std::string problem;               // why the format cannot be decoded (empty = it can)
};

// Column index by name, if the format has that column.
std::optional<std::size_t> column(const DfFormat& fmt, const std::string& name) {
  const auto it = std::find(fmt.columns.begin(), fmt.columns.end(), name);
  if (it == fmt.columns.end()) return std::nullopt;
  return static_cast<std::size_t>(it - fmt.columns.begin());
}

// Whether a message of this name is an IMU's (IMU, IMU2, IMU3).
bool is_imu(const std::string& name) { return name == "IMU" || name == "IMU2" || name == "IMU3"; }

// An FMT message at `pos`.
DfFormat read_fmt(const BinaryReader& f, std::size_t pos) {
  f.need(pos, kFmtLength, "an FMT message");
  DfFormat fmt;
  fmt.type = *f.at(pos + 3);
  fmt.length = *f.at(pos + 4);
  fmt.name = fixed_string(f.at(pos + 5), 4);
  fmt.format = fixed_string(f.at(pos + 9), 16);
  const std::string columns = fixed_string(f.at(pos + 25), 64);
  for (auto c : split(columns, ',')) fmt.columns.emplace_back(c);
  fmt.defined_at = pos;
  fmt.imu = is_imu(fmt.name);
  fmt.instance_column = column(fmt, "I");
  std::size_t offset = kHeaderBytes;
  for (char c : fmt.format) {
    const TypeChar* t = type_char(c);
    if (!t) {
      fmt.problem = std::string("format char '") + c + "' in '" + fmt.format +
                    "' is not a DataFlash type (expected one of a b B h H i I f d n N Z c C e E L M q Q)";
      return fmt;
    }
    fmt.offsets.push_back(offset);
    fmt.types.push_back(t);
    offset += t->size;
  }
  if (offset != fmt.length) {
    fmt.problem = "format '" + fmt.format + "' adds up to " + std::to_string(offset) + " bytes, the FMT says " +
                  std::to_string(fmt.length);
  } else if (fmt.columns.size() != fmt.format.size()) {
    fmt.problem = std::to_string(fmt.columns.size()) + " column names for the " + std::to_string(fmt.format.size()) +
                  " fields of '" + fmt.format + "'";
  }
  return fmt;
}

// The messages an IMU import reads, by their format's name.
bool wanted(const std::string& name) {
  return name == "IMU" || name == "IMU2" || name == "IMU3" || name == "FMTU" || name == "UNIT" || name == "MULT" ||
         name == "MSG";
}

// The formats a walk through the log has defined so far.
struct DfFormats {
  std::deque<DfFormat> all;                         // every FMT in file order (stable addresses)
  std::map<std::uint8_t, const DfFormat*> by_type;  // the latest FMT of each type
};

// Where a log cut short (a power loss, a crash: the common end of a vehicle's log) ends inside a
// message: every whole message before it is read, and the cut is said.
struct DfCut {
  std::size_t offset = 0;  // of the message the file ends in
  std::size_t bytes = 0;   // of it that are in the file
  std::string what;        // "a 'IMU' message", "a message header", "an FMT message"
  bool found() const { return !what.empty(); }
  std::string describe(std::size_t file_size) const {
    return "the log is cut short at byte " + std::to_string(file_size) + ", inside " + what + " that starts at byte " +
           std::to_string(offset) + ": its " + std::to_string(bytes) +
           " byte(s) are dropped; every whole message before it is read (a log cut by a power loss or a crash)";
  }
};

struct DfMessage {
  const DfFormat* fmt;  // nullptr for an FMT message (its definition is formats.all.back())
  std::size_t offset;   // of the message header
};

// The message at `pos` (advancing `pos` past it, the message whole in the reader's buffer), false
// at the end of the file. FMT messages define the types; a byte run that is not a message of a
// defined type is skipped up to the next header (as DFReader does) and counted in `resyncs` and
// `skipped_bytes`.
bool next_message(const BinaryReader& f, std::size_t& pos, DfFormats& formats, std::size_t& resyncs,
                  std::size_t& skipped_bytes, DfMessage& m, DfCut& cut) {
  constexpr std::uint8_t kHead[2] = {kHead1, kHead2};
  // `what` names the cut-off part, built only when there is a cut (this runs once per message).
  const auto ends_inside = [&](std::size_t length, const auto& what) {
    if (pos + length <= f.size()) return false;
    cut = DfCut{pos, f.size() - pos, what()};
    pos = f.size();
    return true;
  };
  while (pos < f.size()) {
    if (ends_inside(kHeaderBytes, [] { return std::string("a message header"); })) return false;
    f.need(pos, kHeaderBytes, "a message header (A3 95 <type>)");
    const std::uint8_t type = *f.at(pos + 2);
    const bool header_ok = *f.at(pos) == kHead1 && *f.at(pos + 1) == kHead2;
    if (header_ok && type == kFmtType && ends_inside(kFmtLength, [] { return std::string("an FMT message"); }))
      return false;
    if (header_ok && type == kFmtType) {
      formats.all.push_back(read_fmt(f, pos));
      formats.all.back().index = formats.all.size() - 1;
      formats.by_type[formats.all.back().type] = &formats.all.back();
      m = DfMessage{nullptr, pos};
      pos += kFmtLength;
      return true;
    }
    const auto it = header_ok ? formats.by_type.find(type) : formats.by_type.end();
    if (it == formats.by_type.end()) {
      const auto next = f.find(pos + 1, kHead, 2);
      if (!next) {
        f.fail(pos, header_ok ? "message type " + std::to_string(type) + " has no FMT, and no message header follows"
                              : "expected a message header A3 95, and none follows");
      }
      skipped_bytes += *next - pos;
      ++resyncs;
      pos = *next;
      continue;
    }
    const DfFormat& fmt = *it->second;
    if (fmt.length < kHeaderBytes) f.fail(fmt.defined_at, "FMT for '" + fmt.name + "' gives a length below 3");
    const auto what = [&fmt] { return "a '" + fmt.name + "' message"; };
    if (ends_inside(fmt.length, what)) return false;
    f.need(pos, fmt.length, what);
    m = DfMessage{&fmt, pos};
    pos += fmt.length;
    return true;
  }
  return false;
}

// Column index by name; fails naming the format's columns when absent.
std::size_t required_column(const BinaryReader& f, const DfFormat& fmt, const std::string& name) {
  const auto c = column(fmt, name);
  if (!c) {
    std::string columns;
    for (const auto& n : fmt.columns) columns += (columns.empty() ? "" : ",") + n;
    f.fail(fmt.defined_at, "FMT for '" + fmt.name + "' has no column '" + name + "' (columns: " + columns + ")");
  }
  return *c;
}

// Numeric value of column c of the message at `msg`, with the type's own scale (c, e, L...). The
// message is in the reader's buffer (next_message brought it whole) and its FMT adds up to that length.
double value(const BinaryReader& f, const DfFormat& fmt, std::size_t msg, std::size_t c) {
  const TypeChar& t = *fmt.types[c];
  const std::uint8_t* p = f.at(msg + fmt.offsets[c]);
  double v = 0.0;
  switch (t.storage) {
    case Storage::kInt:
      v = t.size == 1   ? load_le<std::int8_t>(p)
          : t.size == 2 ? load_le<std::int16_t>(p)
          : t.size == 4 ? load_le<std::int32_t>(p)
                        : static_cast<double>(load_le<std::int64_t>(p));
      break;
    case Storage::kUInt:
      v = t.size == 1   ? load_le<std::uint8_t>(p)
          : t.size == 2 ? load_le<std::uint16_t>(p)
          : t.size == 4 ? load_le<std::uint32_t>(p)
                        : static_cast<double>(load_le<std::uint64_t>(p));
      break;
    case Storage::kFloat: v = t.size == 4 ? static_cast<double>(load_le<float>(p)) : load_le<double>(p); break;
    case Storage::kText:
    case Storage::kArray:
      f.fail(msg, "column '" + fmt.columns[c] + "' of a '" + fmt.name + "' message is not a number (format char '" +
                      std::string(1, t.c) + "')");
  }
  return v * t.scale;
}

std::string text(const BinaryReader& f, const DfFormat& fmt, std::size_t msg, std::size_t c) {
  return fixed_string(f.at(msg + fmt.offsets[c]), fmt.types[c]->size);
}

// ---------------------------------------------------------------------------------------------
// Units (FMTU: FmtType, UnitIds, MultIds; UNIT: Id, Label; MULT: Id, Mult)

struct DfUnits {
  std::map<char, std::string> labels;  // UNIT
  std::map<char, double> mults;        // MULT
  std::map<std::uint8_t, std::pair<std::string, std::string>> by_type;  // FMTU: unit ids, mult ids
};

// Column c of message `msg` as an integer of type T; fails naming the column and its value when
// the message holds something else there (a damaged or mis-declared message).
template <class T>
T integer_value(const BinaryReader& f, const DfFormat& fmt, std::size_t msg, std::size_t c) {
  const double v = value(f, fmt, msg, c);
  const double lo = static_cast<double>(std::numeric_limits<T>::min());
  const double end = static_cast<double>(std::numeric_limits<T>::max()) + 1.0;  // exact: a power of two
  if (!(v >= lo && v < end) || v != std::floor(v)) {
    f.fail(msg, "'" + fmt.name + "." + fmt.columns[c] + "' is " + fmt_g(v) + ", not an integer in [" + fmt_g(lo) +
                    ", " + fmt_g(end) + ")");
  }
  return static_cast<T>(v);
}

// A UNIT, MULT or FMTU message into `u` (a later one of the same id replaces an earlier one).
void read_unit(const BinaryReader& f, const DfFormat& fmt, std::size_t m, DfUnits& u) {
  if (fmt.name == "UNIT") {
    u.labels[integer_value<char>(f, fmt, m, required_column(f, fmt, "Id"))] = text(f, fmt, m, required_column(f, fmt, "Label"));
  } else if (fmt.name == "MULT") {
    u.mults[integer_value<char>(f, fmt, m, required_column(f, fmt, "Id"))] = value(f, fmt, m, required_column(f, fmt, "Mult"));
  } else if (fmt.name == "FMTU") {
    u.by_type[integer_value<std::uint8_t>(f, fmt, m, required_column(f, fmt, "FmtType"))] = {
        text(f, fmt, m, required_column(f, fmt, "UnitIds")), text(f, fmt, m, required_column(f, fmt, "MultIds"))};
  }
}

// SI factor of column c of `fmt`: the FMTU multiplier (where the log defines it) times the unit
// conversion the expected units allow (deg/s → rad/s for the gyro). Fails on another unit.
double si_factor(const BinaryReader& f, const DfUnits& u, const DfFormat& fmt, std::size_t c,
                 const std::vector<std::string>& accepted, std::string& note) {
  const auto it = u.by_type.find(fmt.type);
  if (it == u.by_type.end() || c >= it->second.first.size()) {
    note += fmt.columns[c] + " assumed " + accepted.front() + " (no FMTU); ";
    return 1.0;
  }
  const char unit_id = it->second.first[c];
  const auto label = u.labels.find(unit_id);
  const std::string unit = label == u.labels.end() ? std::string(1, unit_id) : label->second;
  if (std::find(accepted.begin(), accepted.end(), unit) == accepted.end()) {
    std::string list;
    for (const auto& a : accepted) list += (list.empty() ? "" : " or ") + a;
    f.fail(fmt.defined_at, "'" + fmt.name + "' column " + fmt.columns[c] + " is in '" + unit + "' (FMTU), expected " + list);
  }
  double factor = unit == "deg/s" ? physics::kDegPerSecond : 1.0;
  const TypeChar& t = *fmt.types[c];
  const char mult_id = c < it->second.second.size() ? it->second.second[c] : '-';
  const auto mult = u.mults.find(mult_id);
  // '-' and '?' mean "no multiplier"; the c/C/e/E/L types carry their own scale.
  if (mult != u.mults.end() && mult->second != 0.0 && mult_id != '-' && mult_id != '?' && t.scale == 1.0) {
    factor *= mult->second;
  }
  note += fmt.columns[c] + " " + unit + (factor != 1.0 ? " x " + fmt_g(factor) : "") + "; ";
  return factor;
}

// ---------------------------------------------------------------------------------------------
// IMU messages

// One IMU message's instance: its I column, else the message name (IMU, IMU2, IMU3 → 0, 1, 2).
int instance_of(const BinaryReader& f, const DfFormat& fmt, std::size_t msg) {
  if (fmt.instance_column) return integer_value<int>(f, fmt, msg, *fmt.instance_column);
  return fmt.name == "IMU" ? 0 : fmt.name[3] - '1';
}


// An IMU format's columns (T may be absent) and their SI factors, with the unit note.
struct ImuColumns {
  std::size_t time, gyr[3], acc[3];
  std::optional<std::size_t> temp;
  double gyr_factor = 1.0, acc_factor = 1.0, temp_factor = 1.0;
  std::string note;
};

ImuColumns imu_columns(const BinaryReader& f, const DfUnits& u, const DfFormat& fmt) {
  ImuColumns c{};
  c.time = required_column(f, fmt, "TimeUS");
  const char* axes = "XYZ";
  for (int k = 0; k < 3; ++k) {
    c.gyr[k] = required_column(f, fmt, std::string("Gyr") + axes[k]);
    c.acc[k] = required_column(f, fmt, std::string("Acc") + axes[k]);
  }
  c.temp = column(fmt, "T");
  c.gyr_factor = si_factor(f, u, fmt, c.gyr[0], {"rad/s", "deg/s"}, c.note);
  c.acc_factor = si_factor(f, u, fmt, c.acc[0], {"m/s/s"}, c.note);
  if (c.temp) c.temp_factor = si_factor(f, u, fmt, *c.temp, {"degC"}, c.note);
  return c;
}

// The vehicle firmware when `m` is a MSG naming it ("ArduSub V4.1.0 (89639005)"), else "".
std::string firmware(const BinaryReader& f, const DfFormat& fmt, std::size_t m) {
  if (fmt.name != "MSG") return {};
  const auto c = column(fmt, "Message");
  if (!c) return {};
  std::string message = text(f, fmt, m, *c);
  return message.rfind("Ardu", 0) == 0 ? message : std::string();
}

// One IMU instance as the first pass finds it.
struct DfInstance {
  std::size_t messages = 0;
  bool has_temperature = true;     // every message's format has a T column
  std::set<std::size_t> formats;   // indices of the formats of its messages
};

// What the first pass finds: the IMU instances, the units, the firmware (the first MSG naming it).
struct DfLog {
  DfFormats formats;
  std::map<int, DfInstance> imu;
  DfUnits units;
  std::string firmware;
  std::size_t resyncs = 0, skipped_bytes = 0;
  DfCut cut;  // where the file ends inside a message, if it does
};

// The first pass: every message's header; FMT, UNIT, MULT, FMTU and MSG read, IMU messages counted
// by instance. A format of the messages an import reads must be decodable.
DfLog read_dataflash(const BinaryReader& f) {
  f.need(0, kHeaderBytes, "the first message header");
  if (*f.at(0) != kHead1 || *f.at(1) != kHead2) {
    f.fail(0, "not a DataFlash log (expected the message header bytes A3 95)");
  }
  DfLog log;
  std::size_t pos = 0;
  DfMessage m{};
  while (next_message(f, pos, log.formats, log.resyncs, log.skipped_bytes, m, log.cut)) {
    if (!m.fmt || !wanted(m.fmt->name)) continue;
    const DfFormat& fmt = *m.fmt;
    if (!fmt.problem.empty()) f.fail(fmt.defined_at, "FMT for '" + fmt.name + "': " + fmt.problem);
    if (fmt.imu) {
      DfInstance& imu = log.imu[instance_of(f, fmt, m.offset)];
      ++imu.messages;
      imu.has_temperature = imu.has_temperature && column(fmt, "T").has_value();
      imu.formats.insert(fmt.index);
    } else if (fmt.name == "MSG") {
      if (log.firmware.empty()) log.firmware = firmware(f, fmt, m.offset);
    } else {
      read_unit(f, fmt, m.offset, log.units);
    }
  }
  return log;
}

std::string describe_instances(const std::map<int, DfInstance>& imu) {
  std::string s;
  for (const auto& [inst, v] : imu) s += (s.empty() ? "" : ", ") + std::to_string(inst) + ": " + std::to_string(v.messages);
  return s;
}

int choose_instance(const BinaryReader& f, const std::map<int, DfInstance>& imu, int wanted_instance) {
  if (imu.empty()) {
    f.fail(f.size(), "no IMU data: expected IMU (or IMU2/IMU3) messages defined by an FMT; the log has none");
  }
  if (wanted_instance >= 0) {
    if (!imu.count(wanted_instance)) {
      f.fail(f.size(), "no IMU instance " + std::to_string(wanted_instance) + " (messages per instance: " +
                           describe_instances(imu) + ")");
    }
    return wanted_instance;
  }
  int best = imu.begin()->first;
  for (const auto& [inst, v] : imu) {
    if (v.messages > imu.at(best).messages) best = inst;
  }
  return best;
}

}  // namespace

bool looks_like_dataflash(const fs::path& file) {
  const std::string head = file_prefix(file, kHeaderBytes);
  return head.size() == kHeaderBytes && static_cast<std::uint8_t>(head[0]) == kHead1 &&
         static_cast<std::uint8_t>(head[1]) == kHead2 && static_cast<std::uint8_t>(head[2]) == kFmtType;
}

// Two passes over the file through a bounded buffer: the first reads every message header (the
// formats, units, firmware, and how many IMU messages each instance holds), the second decodes the
// chosen instance's IMU messages into samples.
bool DataflashOptions::IsValid(std::string* error) const {
  return instance >= -1 && instance <= 255
             ? true
             : invalid(error, "instance must be 0 … 255, or -1 (the instance with the most samples)");
}

void import_dataflash(const fs::path& file, const DataflashOptions& opt, Recording& rec, SampleSink& out) {
  require_valid(opt, "DataFlash options");
  const BinaryReader f(file);
  const DfLog log = read_dataflash(f);
  const int instance = choose_instance(f, log.imu, opt.instance);
  const DfInstance& imu = log.imu.at(instance);
  std::map<std::size_t, ImuColumns> columns;  // by format index
  std::string unit_notes;
  for (const std::size_t index : imu.formats) {
    const ImuColumns& c = columns.emplace(index, imu_columns(f, log.units, log.formats.all[index])).first->second;
    unit_notes += c.note;
  }
  rec = new_recording(file, "dataflash");
  SensorInfo& info = rec.header.info;
  info.has_gyro = true;
  info.has_temperature = imu.has_temperature;
  rec.header.identity.vendor = "ArduPilot";
  rec.header.identity.model = log.firmware;
  rec.header.identity.who_am_i = "IMU instance " + std::to_string(instance);
  LogTimestampStream times(rec, out);
  std::vector<ImuSample> chunk;
  chunk.reserve(kDefaultChunkSamples);
  std::uint64_t t0_us = 0;
  std::size_t count = 0, lost_gaps = 0, prev_resyncs = 0;
  DfFormats formats;
  std::size_t pos = 0, resyncs = 0, skipped_bytes = 0;
  DfMessage m{};
  DfCut cut;  // the first pass's, again
  while (next_message(f, pos, formats, resyncs, skipped_bytes, m, cut)) {
    if (!m.fmt || !m.fmt->imu || instance_of(f, *m.fmt, m.offset) != instance) continue;
    const DfFormat& fmt = *m.fmt;
    const ImuColumns& c = columns.at(fmt.index);
    const auto t_us = integer_value<std::uint64_t>(f, fmt, m.offset, c.time);
    if (count == 0) t0_us = t_us;
    ImuSample s;
    s.t_s = seconds_since_us(t0_us, t_us);
    for (int k = 0; k < 3; ++k) {
      s.gyro_radps[k] = value(f, fmt, m.offset, c.gyr[k]) * c.gyr_factor;
      s.accel_mps2[k] = value(f, fmt, m.offset, c.acc[k]) * c.acc_factor;
    }
    if (c.temp) s.temperature_c = value(f, fmt, m.offset, *c.temp) * c.temp_factor;
    if (count > 0 && resyncs != prev_resyncs) {
      s.flags |= kGapBefore;
      ++lost_gaps;
    }
    prev_resyncs = resyncs;
    ++count;
    chunk.push_back(s);
    if (chunk.size() == kDefaultChunkSamples) {
      times.add_samples(chunk.data(), chunk.size());
      chunk.clear();
    }
  }
  times.add_samples(chunk.data(), chunk.size());
  const TimestampSummary ts = times.finish();
  const std::string& fw = log.firmware;
  add_import_event(rec, "imported " + std::to_string(count) + " samples from " + file.string() +
                            " (ArduPilot DataFlash; firmware '" + (fw.empty() ? "?" : fw) + "'; IMU instance " +
                            std::to_string(instance) + " (" +
                            (opt.instance >= 0 ? "as asked" : "the instance with the most messages") +
                            "; messages per instance: " + describe_instances(log.imu) + "); units: " + unit_notes +
                            (imu.has_temperature ? "temperature from T" : "no temperature column") +
                            "; t = TimeUS [us] relative to the first sample; " + ts.describe() + "; " +
                            std::to_string(log.resyncs) + " resync(s) (" + std::to_string(log.skipped_bytes) +
                            " bytes skipped) flagged " + std::to_string(lost_gaps) + " gap(s))");
  if (log.cut.found()) add_import_event(rec, file.string() + ": " + log.cut.describe(f.size()), "warning");
}

Recording import_dataflash(const fs::path& file, const DataflashOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_dataflash(file, opt, rec, out); });
}

}  // namespace stend::io
