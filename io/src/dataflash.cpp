// ArduPilot DataFlash (.BIN) reader (ArduPilot LogStructure.h; pymavlink DFReader is the reference
// reader).
#include <stend/io/logs.hpp>
#include <stend/physics/units.hpp>

#include "import_common.hpp"

#include <algorithm>
#include <deque>
#include <map>
#include <optional>
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
  std::size_t defined_at = 0;        // byte offset of the FMT message
  std::string problem;               // why the format cannot be decoded (empty = it can)
};

// An FMT message at `pos`.
DfFormat read_fmt(const BinaryFile& f, std::size_t pos) {
  f.need(pos, kFmtLength, "an FMT message");
  DfFormat fmt;
  fmt.type = *f.at(pos + 3);
  fmt.length = *f.at(pos + 4);
  fmt.name = fixed_string(f.at(pos + 5), 4);
  fmt.format = fixed_string(f.at(pos + 9), 16);
  const std::string columns = fixed_string(f.at(pos + 25), 64);
  for (auto c : split(columns, ',')) fmt.columns.emplace_back(c);
  fmt.defined_at = pos;
  std::size_t offset = kHeaderBytes;
  for (char c : fmt.format) {
    const TypeChar* t = type_char(c);
    if (!t) {
      fmt.problem = std::string("format char '") + c + "' in '" + fmt.format +
                    "' is not a DataFlash type (expected one of a b B h H i I f d n N Z c C e E L M q Q)";
      return fmt;
    }
    fmt.offsets.push_back(offset);
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

struct DfRecord {
  const DfFormat* fmt;
  std::size_t offset;       // of the message header
  std::size_t lost_before;  // resyncs before it
};

struct DfLog {
  std::deque<DfFormat> formats;                     // every FMT in file order (stable addresses)
  std::map<std::uint8_t, const DfFormat*> by_type;  // the latest FMT of each type
  std::map<std::string, std::vector<DfRecord>> records;  // of the wanted messages, by name
  std::map<std::string, std::size_t> counts;        // every message, by name
  std::size_t resyncs = 0, skipped_bytes = 0;
};

// Offset of the next message header A3 95 at or after `from` (f.size() when none).
std::size_t next_header(const BinaryFile& f, std::size_t from) {
  const std::uint8_t head[2] = {kHead1, kHead2};
  const std::uint8_t* begin = f.at(0);
  const std::uint8_t* end = begin + f.size();
  return static_cast<std::size_t>(std::search(begin + std::min(from, f.size()), end, head, head + 2) - begin);
}

// Reads every message: FMT messages define the types; a byte run that is not a message of a
// defined type is skipped up to the next header (as DFReader does) and counted.
DfLog read_dataflash(const BinaryFile& f) {
  f.need(0, kHeaderBytes, "the first message header");
  if (*f.at(0) != kHead1 || *f.at(1) != kHead2) {
    f.fail(0, "not a DataFlash log (expected the message header bytes A3 95)");
  }
  DfLog log;
  std::size_t pos = 0;
  while (pos < f.size()) {
    f.need(pos, kHeaderBytes, "a message header (A3 95 <type>)");
    const std::uint8_t type = *f.at(pos + 2);
    const bool header_ok = *f.at(pos) == kHead1 && *f.at(pos + 1) == kHead2;
    if (header_ok && type == kFmtType) {
      log.formats.push_back(read_fmt(f, pos));
      ++log.counts["FMT"];
      log.by_type[log.formats.back().type] = &log.formats.back();
      pos += kFmtLength;
      continue;
    }
    const auto it = header_ok ? log.by_type.find(type) : log.by_type.end();
    if (it == log.by_type.end()) {
      const std::size_t next = next_header(f, pos + 1);
      if (next == f.size()) {
        f.fail(pos, header_ok ? "message type " + std::to_string(type) + " has no FMT, and no message header follows"
                              : "expected a message header A3 95, and none follows");
      }
      log.skipped_bytes += next - pos;
      ++log.resyncs;
      pos = next;
      continue;
    }
    const DfFormat& fmt = *it->second;
    if (fmt.length < kHeaderBytes) f.fail(fmt.defined_at, "FMT for '" + fmt.name + "' gives a length below 3");
    f.need(pos, fmt.length, "a '" + fmt.name + "' message");
    ++log.counts[fmt.name];
    if (wanted(fmt.name)) {
      if (!fmt.problem.empty()) f.fail(fmt.defined_at, "FMT for '" + fmt.name + "': " + fmt.problem);
      log.records[fmt.name].push_back({&fmt, pos, log.resyncs});
    }
    pos += fmt.length;
  }
  return log;
}

std::optional<std::size_t> column(const DfFormat& fmt, const std::string& name) {
  const auto it = std::find(fmt.columns.begin(), fmt.columns.end(), name);
  if (it == fmt.columns.end()) return std::nullopt;
  return static_cast<std::size_t>(it - fmt.columns.begin());
}

// Column index by name; fails naming the format's columns when absent.
std::size_t required_column(const BinaryFile& f, const DfFormat& fmt, const std::string& name) {
  const auto c = column(fmt, name);
  if (!c) {
    std::string columns;
    for (const auto& n : fmt.columns) columns += (columns.empty() ? "" : ",") + n;
    f.fail(fmt.defined_at, "FMT for '" + fmt.name + "' has no column '" + name + "' (columns: " + columns + ")");
  }
  return *c;
}

// Numeric value of column c of the message at `msg`, with the type's own scale (c, e, L...). The
// message is in the file (read_dataflash checked its length) and its FMT adds up to that length.
double value(const BinaryFile& f, const DfFormat& fmt, std::size_t msg, std::size_t c) {
  const TypeChar& t = *type_char(fmt.format[c]);
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

std::string text(const BinaryFile& f, const DfFormat& fmt, std::size_t msg, std::size_t c) {
  return fixed_string(f.at(msg + fmt.offsets[c]), type_char(fmt.format[c])->size);
}

// ---------------------------------------------------------------------------------------------
// Units (FMTU: FmtType, UnitIds, MultIds; UNIT: Id, Label; MULT: Id, Mult)

struct DfUnits {
  std::map<char, std::string> labels;  // UNIT
  std::map<char, double> mults;        // MULT
  std::map<std::uint8_t, std::pair<std::string, std::string>> by_type;  // FMTU: unit ids, mult ids
};

DfUnits read_units(const BinaryFile& f, const DfLog& log) {
  DfUnits u;
  auto each = [&](const std::string& name, auto fn) {
    const auto it = log.records.find(name);
    if (it == log.records.end()) return;
    for (const DfRecord& r : it->second) fn(*r.fmt, r.offset);
  };
  each("UNIT", [&](const DfFormat& fmt, std::size_t m) {
    u.labels[static_cast<char>(value(f, fmt, m, required_column(f, fmt, "Id")))] = text(f, fmt, m, required_column(f, fmt, "Label"));
  });
  each("MULT", [&](const DfFormat& fmt, std::size_t m) {
    u.mults[static_cast<char>(value(f, fmt, m, required_column(f, fmt, "Id")))] = value(f, fmt, m, required_column(f, fmt, "Mult"));
  });
  each("FMTU", [&](const DfFormat& fmt, std::size_t m) {
    u.by_type[static_cast<std::uint8_t>(value(f, fmt, m, required_column(f, fmt, "FmtType")))] = {
        text(f, fmt, m, required_column(f, fmt, "UnitIds")), text(f, fmt, m, required_column(f, fmt, "MultIds"))};
  });
  return u;
}

// SI factor of column c of `fmt`: the FMTU multiplier (where the log defines it) times the unit
// conversion the expected units allow (deg/s → rad/s for the gyro). Fails on another unit.
double si_factor(const BinaryFile& f, const DfUnits& u, const DfFormat& fmt, std::size_t c,
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
  const TypeChar& t = *type_char(fmt.format[c]);
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
int instance_of(const BinaryFile& f, const DfFormat& fmt, std::size_t msg) {
  if (const auto c = column(fmt, "I")) return static_cast<int>(value(f, fmt, msg, *c));
  return fmt.name == "IMU" ? 0 : fmt.name[3] - '1';
}

std::map<int, std::vector<DfRecord>> imu_records_by_instance(const BinaryFile& f, const DfLog& log) {
  std::map<int, std::vector<DfRecord>> out;
  for (const char* name : {"IMU", "IMU2", "IMU3"}) {
    const auto it = log.records.find(name);
    if (it == log.records.end()) continue;
    for (const DfRecord& r : it->second) out[instance_of(f, *r.fmt, r.offset)].push_back(r);
  }
  for (auto& [inst, v] : out) {
    std::stable_sort(v.begin(), v.end(), [](const DfRecord& a, const DfRecord& b) { return a.offset < b.offset; });
  }
  return out;
}

// An IMU format's columns (T may be absent) and their SI factors, with the unit note.
struct ImuColumns {
  std::size_t time, gyr[3], acc[3];
  std::optional<std::size_t> temp;
  double gyr_factor = 1.0, acc_factor = 1.0, temp_factor = 1.0;
  std::string note;
};

ImuColumns imu_columns(const BinaryFile& f, const DfUnits& u, const DfFormat& fmt) {
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

// Identity: the vehicle firmware from the first MSG naming it ("ArduSub V4.1.0 (89639005)").
std::string firmware(const BinaryFile& f, const DfLog& log) {
  const auto it = log.records.find("MSG");
  if (it == log.records.end()) return {};
  for (const DfRecord& r : it->second) {
    const auto c = column(*r.fmt, "Message");
    if (!c) continue;
    const std::string m = text(f, *r.fmt, r.offset, *c);
    if (m.rfind("Ardu", 0) == 0) return m;
  }
  return {};
}

std::string describe_instances(const std::map<int, std::vector<DfRecord>>& by_instance) {
  std::string s;
  for (const auto& [inst, v] : by_instance) s += (s.empty() ? "" : ", ") + std::to_string(inst) + ": " + std::to_string(v.size());
  return s;
}

int choose_instance(const BinaryFile& f, const std::map<int, std::vector<DfRecord>>& by_instance, int wanted_instance) {
  if (by_instance.empty()) {
    f.fail(f.size(), "no IMU data: expected IMU (or IMU2/IMU3) messages defined by an FMT; the log has none");
  }
  if (wanted_instance >= 0) {
    if (!by_instance.count(wanted_instance)) {
      f.fail(f.size(), "no IMU instance " + std::to_string(wanted_instance) + " (messages per instance: " +
                           describe_instances(by_instance) + ")");
    }
    return wanted_instance;
  }
  int best = by_instance.begin()->first;
  for (const auto& [inst, v] : by_instance) {
    if (v.size() > by_instance.at(best).size()) best = inst;
  }
  return best;
}

}  // namespace

bool looks_like_dataflash(const fs::path& file) {
  const std::string head = file_prefix(file, kHeaderBytes);
  return head.size() == kHeaderBytes && static_cast<std::uint8_t>(head[0]) == kHead1 &&
         static_cast<std::uint8_t>(head[1]) == kHead2 && static_cast<std::uint8_t>(head[2]) == kFmtType;
}

Recording import_dataflash(const fs::path& file, const DataflashOptions& opt) {
  const BinaryFile f(file);
  const DfLog log = read_dataflash(f);
  const auto by_instance = imu_records_by_instance(f, log);
  const int instance = choose_instance(f, by_instance, opt.instance);
  const DfUnits units = read_units(f, log);
  Recording rec = new_recording(file, "dataflash");
  std::map<const DfFormat*, ImuColumns> columns;
  std::uint64_t t0_us = 0;
  bool has_temperature = true;
  std::size_t lost_gaps = 0;
  const std::vector<DfRecord>& records = by_instance.at(instance);
  for (std::size_t i = 0; i < records.size(); ++i) {
    const DfRecord& r = records[i];
    auto it = columns.find(r.fmt);
    if (it == columns.end()) it = columns.emplace(r.fmt, imu_columns(f, units, *r.fmt)).first;
    const ImuColumns& c = it->second;
    const auto t_us = static_cast<std::uint64_t>(value(f, *r.fmt, r.offset, c.time));
    if (i == 0) t0_us = t_us;
    ImuSample s;
    s.t_s = seconds_since_us(t0_us, t_us);
    for (int k = 0; k < 3; ++k) {
      s.gyro_radps[k] = value(f, *r.fmt, r.offset, c.gyr[k]) * c.gyr_factor;
      s.accel_mps2[k] = value(f, *r.fmt, r.offset, c.acc[k]) * c.acc_factor;
    }
    has_temperature = has_temperature && c.temp.has_value();
    if (c.temp) s.temperature_c = value(f, *r.fmt, r.offset, *c.temp) * c.temp_factor;
    if (i > 0 && r.lost_before != records[i - 1].lost_before) {
      s.flags |= kGapBefore;
      ++lost_gaps;
    }
    rec.samples.push_back(s);
  }
  const TimestampSummary ts = check_log_timestamps(rec.samples);
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = ts.rate_hz;
  info.has_gyro = true;
  info.has_temperature = has_temperature;
  const std::string fw = firmware(f, log);
  rec.header.identity.vendor = "ArduPilot";
  rec.header.identity.model = fw;
  rec.header.identity.who_am_i = "IMU instance " + std::to_string(instance);
  std::string unit_notes;
  for (const auto& [fmt, c] : columns) unit_notes += c.note;
  add_import_event(rec, "imported " + std::to_string(rec.samples.size()) + " samples from " + file.string() +
                            " (ArduPilot DataFlash; firmware '" + (fw.empty() ? "?" : fw) + "'; IMU instance " +
                            std::to_string(instance) + " (" +
                            (opt.instance >= 0 ? "as asked" : "the instance with the most messages") +
                            "; messages per instance: " + describe_instances(by_instance) + "); units: " + unit_notes +
                            (has_temperature ? "temperature from T" : "no temperature column") +
                            "; t = TimeUS [us] relative to the first sample; " + ts.describe() + "; " +
                            std::to_string(log.resyncs) + " resync(s) (" + std::to_string(log.skipped_bytes) +
                            " bytes skipped) flagged " + std::to_string(lost_gaps) + " gap(s))");
  return rec;
}

}  // namespace stend::io
