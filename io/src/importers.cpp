#include <stend/csv.hpp>
#include <stend/files.hpp>
#include <stend/io/importers.hpp>
#include <stend/io/timestamps.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/table_chain.hpp>
#include <stend/physics/units.hpp>
#include <stend/version.hpp>
#include <stend/yaml_util.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <numbers>
#include <sstream>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "import_common.hpp"

// MATLAB files go through matio, when stend_core is built with it: core/CMakeLists.txt links
// PkgConfig::MATIO and defines STEND_HAVE_MATIO. Without it the .mat functions say so.
#if defined(STEND_HAVE_MATIO) && __has_include(<matio.h>)
#include <matio.h>
#include <zlib.h>
#define STEND_IMPORT_MATIO 1
#else
#define STEND_IMPORT_MATIO 0
#endif

namespace stend::io {

namespace fs = std::filesystem;

ImportError::ImportError(const fs::path& file, std::size_t line, const std::string& message)
    : InputError(file.string() + (line > 0 ? ":" + std::to_string(line) : std::string()) +
                 ": " + message),
      file_(file),
      line_(line) {}

ImportError::ImportError(const fs::path& file, ByteOffset offset, const std::string& message)
    : InputError(file.string() + ": byte " + std::to_string(offset.bytes) + ": " + message),
      file_(file),
      offset_(offset.bytes),
      where_("byte " + std::to_string(offset.bytes)) {}

ImportError::ImportError(const fs::path& file, const std::string& where, const std::string& message)
    : InputError(file.string() + ": " + where + ": " + message), file_(file), where_(where) {}

namespace {

using namespace detail;

// ---------------------------------------------------------------------------------------------
// Text helpers

std::string unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return std::string(s);
}

bool is_blank(std::string_view s) { return trim(s).empty(); }

// Whitespace, comma or semicolon separated (IMU-TK files come in all three).
std::vector<std::string_view> split_any(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  auto sep = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == ';'; };
  while (i < line.size()) {
    while (i < line.size() && sep(line[i])) ++i;
    if (i >= line.size()) break;
    std::size_t j = i;
    while (j < line.size() && !sep(line[j])) ++j;
    out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

double number(const LineReader& r, std::string_view field, const std::string& what) {
  double v = 0.0;
  if (!parse_double(field, v)) {
    r.fail("column '" + what + "': '" + excerpt(field) + "' is not a number");
  }
  return v;
}

std::int32_t to_counts(const LineReader& r, double v, const std::string& what) {
  if (!std::isfinite(v) || std::abs(v - std::round(v)) > 1e-6 || std::abs(v) > 2147483647.0) {
    r.fail("column '" + what + "': " + std::to_string(v) +
           " is not an integer count (set counts = false for values in physical units)");
  }
  return static_cast<std::int32_t>(std::lround(v));
}

Segment make_segment(int id, SegmentKind kind, const std::string& label, double t0,
                     double t1) {
  Segment s;
  s.id = id;
  s.step = id;
  s.kind = kind;
  s.label = label;
  s.t_start_s = t0;
  s.t_end_s = t1;
  s.settled = true;
  s.complete = true;
  return s;
}

// Truth snapshots (kTruthColumns) holding specific force f [m/s²] and zero rate over t0 … t1 [s]:
// at its start, middle and end (snapshots in time order; a time already passed is not repeated).
void add_held_truth(Recording& rec, double t0, double t1, const std::array<double, 3>& f) {
  rec.header.truth_columns = kTruthColumns;
  for (const double t : {t0, 0.5 * (t0 + t1), t1}) {
    if (!rec.truth_t.empty() && !(t > rec.truth_t.back())) continue;
    rec.truth_t.push_back(t);
    rec.truth.push_back({f[0], f[1], f[2], 0.0, 0.0, 0.0});
  }
}

// ---------------------------------------------------------------------------------------------
// IMU-TK helpers

// One line of an IMU-TK triad file: time [s] (× the time scale), the three values, its line.
struct TriadLine {
  double t = 0.0;
  std::array<double, 3> v{};
  std::size_t line = 0;
};

// The lines of an IMU-TK triad file one at a time ('#', '%' comments and blank lines skipped),
// each checked: four values, time not going back.
class TriadReader {
 public:
  TriadReader(const fs::path& file, double time_scale) : r_(file), time_scale_(time_scale) {}
  bool next(TriadLine& out) {
    std::string line;
    while (r_.next(line)) {
      std::string_view v = trim(line);
      if (v.empty() || v.front() == '#' || v.front() == '%') continue;
      const auto f = split_any(v);
      if (f.size() != 4) r_.fail("expected 4 values 't x y z', found " + std::to_string(f.size()));
      const double t = number(r_, f[0], "t") * time_scale_;
      if (count_ > 0 && t < prev_t_) {  // repeats are repaired from the rate afterwards
        r_.fail("timestamp " + fmt_g(t) + " s goes back (previous " + fmt_g(prev_t_) + " s)");
      }
      out.t = prev_t_ = t;
      for (std::size_t k = 0; k < 3; ++k) out.v[k] = number(r_, f[k + 1], k == 0 ? "x" : k == 1 ? "y" : "z");
      out.line = r_.line();
      ++count_;
      return true;
    }
    if (count_ == 0) throw ImportError(r_.file(), 0, "no samples (expected lines 't x y z')");
    return false;
  }
  const fs::path& file() const { return r_.file(); }

 private:
  LineReader r_;
  double time_scale_;
  double prev_t_ = 0.0;
  std::size_t count_ = 0;
};

void write_number(std::string& out, double v) {
  char buf[32];
  const auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, ec == std::errc() ? p : buf);
}

// Sensor description of a 16-bit accelerometer + gyroscope without temperature: rate [Hz], LSB
// sizes [m/s², rad/s per count] and the ±32768-count ranges.
void set_int16_sensor_info(double rate_hz, double acc_lsb, double gyr_lsb, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = rate_hz;
  info.accel_lsb_mps2 = acc_lsb;
  info.gyro_lsb_radps = gyr_lsb;
  info.accel_range_mps2 = 32768.0 * acc_lsb;
  info.gyro_range_radps = 32768.0 * gyr_lsb;
  info.has_gyro = true;
  info.has_temperature = false;
}

}  // namespace

// =============================================================================================
// (a) generic CSV

namespace {

// Column indices (0-based, −1 = absent) that a CSV mapping resolves to.
struct CsvColumns {
  std::vector<std::string> names;  // from the column-name line (empty without one)
  std::size_t names_line = 0;      // its line
  std::array<int, 3> acc{}, gyr{};
  bool has_gyro = false;
  int time = -1, temperature = -1;

  // Name of column idx for messages: its header name, else "#idx".
  std::string name(int idx) const {
    return idx >= 0 && static_cast<std::size_t>(idx) < names.size() ? names[static_cast<std::size_t>(idx)]
                                                                    : "#" + std::to_string(idx);
  }
  // Fields a data line must have.
  int needed() const { return std::max({time, temperature, acc[0], acc[1], acc[2], gyr[0], gyr[1], gyr[2]}) + 1; }
};

// Skips the mapping's header lines and reads the column-name line (when the mapping has one).
std::vector<std::string> read_csv_header(LineReader& r, const CsvMapping& map) {
  std::string line;
  for (std::size_t i = 0; i < map.skip_lines; ++i) {
    if (!r.next(line)) r.fail("file ends inside the " + std::to_string(map.skip_lines) + " header line(s) to skip");
  }
  std::vector<std::string> names;
  if (map.column_names) {
    bool got = false;
    while (!got && r.next(line)) got = !is_blank(line);
    if (!got) r.fail("no column-name line");
    for (auto f : split(line, map.delimiter)) names.push_back(unquote(f));
  }
  return names;
}

// Index of column c: given directly, or found by name among the header names (on line
// names_line); −1 when the mapping leaves c empty.
int resolve_column(const LineReader& r, const CsvMapping& map, const std::vector<std::string>& names,
                   std::size_t names_line, const CsvColumn& c, const std::string& role) {
  if (c.empty()) return -1;
  if (c.index >= 0) return c.index;
  if (!map.column_names) {
    throw ImportError(r.file(), 0, "column '" + c.name + "' (" + role +
                                       ") is given by name but the mapping has column_names = false");
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == c.name) return static_cast<int>(i);
  }
  std::string have;
  for (const auto& n : names) have += (have.empty() ? "" : ", ") + n;
  throw ImportError(r.file(), names_line, "no column named '" + c.name + "' (" + role +
                                              "); the columns are: " + have);
}

// The mapping's columns resolved against the header: all three accelerometer axes, all three
// gyroscope axes or none, and a time column or a fixed rate.
CsvColumns resolve_csv_columns(const LineReader& r, const CsvMapping& map, std::vector<std::string> names) {
  CsvColumns c;
  c.names = std::move(names);
  const std::size_t names_line = c.names_line = r.line();
  const char* axes[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    if (map.accel[k].empty()) {
      throw ImportError(r.file(), 0, std::string("the mapping has no accelerometer ") + axes[k] + " column");
    }
    c.acc[k] = resolve_column(r, map, c.names, names_line, map.accel[k], std::string("accel ") + axes[k]);
    c.gyr[k] = resolve_column(r, map, c.names, names_line, map.gyro[k], std::string("gyro ") + axes[k]);
    c.has_gyro = c.has_gyro || c.gyr[k] >= 0;
  }
  if (c.has_gyro && (c.gyr[0] < 0 || c.gyr[1] < 0 || c.gyr[2] < 0)) {
    throw ImportError(r.file(), 0, "the mapping names only some gyroscope columns (give x, y and z or none)");
  }
  c.time = resolve_column(r, map, c.names, names_line, map.time, "time");
  c.temperature = resolve_column(r, map, c.names, names_line, map.temperature, "temperature");
  if (c.time < 0 && !(map.rate_hz > 0.0)) {
    throw ImportError(r.file(), 0, "the mapping has neither a time column nor a rate_hz > 0");
  }
  return c;
}

// Data line `index` as a sample: time [s] (column × time_scale_s, or index / rate_hz), specific
// force [m/s²], rate [rad/s] and temperature [°C] scaled from the fields, plus the raw counts when
// the mapping reads counts.
ImuSample csv_sample(const LineReader& r, const std::vector<std::string_view>& f, const CsvMapping& map,
                     const CsvColumns& c, std::size_t index) {
  auto field = [&](int idx) { return number(r, f[static_cast<std::size_t>(idx)], c.name(idx)); };
  ImuSample s;
  s.t_s = c.time >= 0 ? field(c.time) * map.time_scale_s : static_cast<double>(index) / map.rate_hz;
  for (int k = 0; k < 3; ++k) {
    const double a = field(c.acc[k]);
    if (map.counts) s.accel_counts[k] = to_counts(r, a, c.name(c.acc[k]));
    s.accel_mps2[k] = (a - map.accel_offset_counts) * map.accel_scale;
    if (c.has_gyro) {
      const double g = field(c.gyr[k]);
      if (map.counts) s.gyro_counts[k] = to_counts(r, g, c.name(c.gyr[k]));
      s.gyro_radps[k] = (g - map.gyro_offset_counts) * map.gyro_scale;
    }
  }
  if (c.temperature >= 0) {
    const double v = field(c.temperature);
    if (map.counts && map.temperature_counts) s.temperature_counts = to_counts(r, v, c.name(c.temperature));
    s.temperature_c = v * map.temperature_scale + map.temperature_offset_c;
  }
  return s;
}

// Every data line as a sample (blank and comment lines skipped), passed to `out` in chunks; each
// line has as many fields as the column-name line (without one: as the first data line), and a time
// column must not go back (repeats are repaired afterwards). Returns the number of samples.
std::size_t read_csv_samples(LineReader& r, const CsvMapping& map, const CsvColumns& c, SampleSink& out) {
  const int needed = c.needed();
  std::size_t fields = c.names.size();
  std::string fields_from = "the column-name line (line " + std::to_string(c.names_line) + ")";
  std::vector<ImuSample> chunk;
  chunk.reserve(kDefaultChunkSamples);
  std::size_t count = 0;
  double prev_t = 0.0;
  std::string line;
  while (r.next(line)) {
    if (is_blank(line)) continue;
    if (!map.comment_prefix.empty() && trim(line).substr(0, map.comment_prefix.size()) == map.comment_prefix) {
      continue;
    }
    const auto f = split(line, map.delimiter);
    if (static_cast<int>(f.size()) < needed) {
      r.fail("expected at least " + std::to_string(needed) + " fields, found " + std::to_string(f.size()));
    }
    if (fields == 0) {
      fields = f.size();
      fields_from = "the first data line (line " + std::to_string(r.line()) + ")";
    }
    if (f.size() != fields) {
      r.fail("expected " + std::to_string(fields) + " fields as on " + fields_from + ", found " +
             std::to_string(f.size()));
    }
    const ImuSample s = csv_sample(r, f, map, c, count);
    if (c.time >= 0 && count > 0 && s.t_s < prev_t) {
      r.fail("time " + fmt_g(s.t_s) + " s goes back (previous " + fmt_g(prev_t) + " s)");
    }
    prev_t = s.t_s;
    ++count;
    chunk.push_back(s);
    if (chunk.size() == kDefaultChunkSamples) {
      out.add_samples(chunk.data(), chunk.size());
      chunk.clear();
    }
  }
  out.add_samples(chunk.data(), chunk.size());
  return count;
}

// Sensor description from the mapping: rate [Hz] (given, or from the median sample step),
// ranges, and the LSB sizes when the file holds counts.
void set_csv_sensor_info(const CsvMapping& map, const CsvColumns& c, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = map.rate_hz;  // 0: set by the timestamp repair
  info.has_gyro = c.has_gyro;
  info.has_temperature = c.temperature >= 0;
  info.accel_range_mps2 = map.accel_range_mps2;
  info.gyro_range_radps = map.gyro_range_radps;
  if (map.counts) {
    info.accel_lsb_mps2 = map.accel_scale;
    info.gyro_lsb_radps = c.has_gyro ? map.gyro_scale : 0.0;
    info.temperature_lsb_c = c.temperature >= 0 && map.temperature_counts ? map.temperature_scale : 0.0;
  }
  rec.header.identity = map.identity;
  rec.header.gravity_mps2 = map.gravity_mps2;
}

}  // namespace

void import_csv(const fs::path& file, const CsvMapping& map, Recording& rec, SampleSink& out) {
  LineReader r(file);
  const CsvColumns c = resolve_csv_columns(r, map, read_csv_header(r, map));
  rec = new_recording(file, "csv");
  set_csv_sensor_info(map, c, rec);
  std::size_t count = 0, gaps = 0;
  if (c.time >= 0) {
    TimestampRepairStream repair(rec, out, map.rate_hz);
    count = read_csv_samples(r, map, c, repair);
    if (count == 0) throw ImportError(file, 0, "no data lines");
    gaps = repair.finish().gaps;
  } else {
    count = read_csv_samples(r, map, c, out);
    if (count == 0) throw ImportError(file, 0, "no data lines");
  }
  add_import_event(rec, "imported " + std::to_string(count) + " samples from " +
                            file.string() + " (generic CSV; " +
                            (map.counts ? "counts" : "physical units") + ", accel scale " +
                            fmt_g(map.accel_scale) + " offset " + fmt_g(map.accel_offset_counts) + ", gyro scale " +
                            fmt_g(map.gyro_scale) + " offset " + fmt_g(map.gyro_offset_counts) +
                            (c.time >= 0 ? ", time column" : ", fixed rate " + fmt_g(map.rate_hz) + " Hz") +
                            (gaps ? ", " + std::to_string(gaps) + " gap(s) flagged" : "") + ")");
}

Recording import_csv(const fs::path& file, const CsvMapping& map) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_csv(file, map, rec, out); });
}

// =============================================================================================
// (b) imucal annotated session

namespace {

// The columns an imucal session must have, in the order of ImucalColumns::index.
constexpr const char* kImucalColumns[8] = {"part", "samples", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"};

// Positions of the required columns in the column-name line.
struct ImucalColumns {
  std::array<std::size_t, 8> index{};
  std::size_t count = 0;  // columns in the header
};

// One data line: sample index, part label, the six raw counts (acc xyz, gyr xyz), source line.
struct ImucalRow {
  std::int64_t index;
  std::string part;
  std::array<std::int32_t, 6> counts;
  std::size_t line;
};

// Reads the column-name line and finds the required columns in it.
ImucalColumns read_imucal_header(LineReader& r) {
  std::string line;
  if (!r.next(line)) throw ImportError(r.file(), 0, "empty file (expected the column-name line)");
  std::vector<std::string> names;
  for (auto f : split(line, ',')) names.push_back(unquote(f));
  ImucalColumns c;
  c.count = names.size();
  for (int k = 0; k < 8; ++k) {
    const auto it = std::find(names.begin(), names.end(), kImucalColumns[k]);
    if (it == names.end()) {
      r.fail(std::string("no column '") + kImucalColumns[k] +
             "' (expected part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z)");
    }
    c.index[static_cast<std::size_t>(k)] = static_cast<std::size_t>(it - names.begin());
  }
  return c;
}

// One data line's fields as a row: a non-empty part, a non-negative integer index, six counts.
ImucalRow imucal_row(const LineReader& r, const std::vector<std::string_view>& f, const ImucalColumns& c) {
  ImucalRow row;
  row.part = unquote(f[c.index[0]]);
  if (row.part.empty()) r.fail("empty 'part'");
  const double idx = number(r, f[c.index[1]], "samples");
  constexpr double kMaxIndex = 9007199254740992.0;  // 2^53: every integer up to it is exact in a double
  if (!(idx >= 0 && idx <= kMaxIndex) || idx != std::floor(idx)) {
    r.fail("'samples' must be a non-negative integer index (at most 2^53)");
  }
  row.index = static_cast<std::int64_t>(idx);
  for (std::size_t k = 0; k < 6; ++k) {
    row.counts[k] = to_counts(r, number(r, f[c.index[k + 2]], kImucalColumns[k + 2]), kImucalColumns[k + 2]);
  }
  row.line = r.line();
  return row;
}

// A run of data lines whose sample index increases from line to line: where its first line starts
// (file position, lines before it) and how many rows it holds. An imucal session is grouped by
// part, so its time order (the sample index) interleaves a few such runs.
struct ImucalRun {
  std::streampos pos;
  std::size_t lines_before = 0;
  std::size_t rows = 0;
};

// More runs would mean a file read through as many readers at once: such a file (its index going
// back at nearly every line) is refused with the advice to sort it.
constexpr std::size_t kMaxImucalRuns = 1024;

// "<axis>_p" (+axis up) or "<axis>_a" (+axis down) for axis x, y or z: a part with known specific
// force (truth).
bool imucal_held_part(const std::string& part) {
  return part.size() == 3 && part[0] >= 'x' && part[0] <= 'z' && part[1] == '_' && (part[2] == 'p' || part[2] == 'a');
}

// What the first pass finds: the runs, and whether a part gives truth.
struct ImucalScan {
  std::vector<ImucalRun> runs;
  bool truth = false;
};

// Checks every data line and finds the runs.
ImucalScan scan_imucal(LineReader& r, const ImucalColumns& c) {
  ImucalScan scan;
  std::vector<ImucalRun>& runs = scan.runs;
  std::string line;
  std::int64_t prev = 0;
  for (std::streampos pos = r.tell(); r.next(line); pos = r.tell()) {
    if (is_blank(line)) continue;
    const auto f = split(line, ',');
    if (f.size() != c.count) {
      r.fail("expected " + std::to_string(c.count) + " fields as on the column-name line, found " +
             std::to_string(f.size()));
    }
    const ImucalRow row = imucal_row(r, f, c);
    if (runs.empty() || row.index <= prev) {
      if (runs.size() == kMaxImucalRuns) {
        r.fail("the sample index goes back more than " + std::to_string(kMaxImucalRuns) +
               " times; sort the file by the 'samples' column");
      }
      runs.push_back({pos, r.line() - 1, 0});
    }
    ++runs.back().rows;
    prev = row.index;
    scan.truth = scan.truth || imucal_held_part(row.part);
  }
  if (runs.empty()) throw ImportError(r.file(), 0, "no data lines");
  return scan;
}

// The rows of every run merged in time order (by sample index; equal indices in file order), one
// reader per run; a repeated sample index is an error.
class ImucalRows {
 public:
  ImucalRows(const fs::path& file, const ImucalColumns& c, const std::vector<ImucalRun>& runs) : columns_(c) {
    for (const ImucalRun& run : runs) {
      Cursor& k = cursors_.emplace_back(Cursor{std::make_unique<LineReader>(file), run.rows, {}});
      k.reader->seek(run.pos, run.lines_before);
      advance(k);
    }
  }
  bool next(ImucalRow& out) {
    Cursor* best = nullptr;
    for (Cursor& k : cursors_)
      if (k.has_row() && (!best || k.row.index < best->row.index)) best = &k;
    if (!best) return false;
    out = best->row;
    if (emitted_ && out.index == last_.index) {
      throw ImportError(best->reader->file(), out.line, "sample index " + std::to_string(out.index) +
                                                         " also appears on line " + std::to_string(last_.line));
    }
    last_ = out;
    emitted_ = true;
    advance(*best);
    return true;
  }

 private:
  struct Cursor {
    std::unique_ptr<LineReader> reader;
    std::size_t rows_left;  // in its run, the current row included
    ImucalRow row;
    bool has_row() const { return rows_left > 0; }
  };
  void advance(Cursor& k) {
    if (k.row.line != 0 && --k.rows_left == 0) return;
    std::string line;
    while (k.reader->next(line)) {
      if (is_blank(line)) continue;
      k.row = imucal_row(*k.reader, split(line, ','), columns_);
      return;
    }
  }
  ImucalColumns columns_;
  std::vector<Cursor> cursors_;
  ImucalRow last_{};
  bool emitted_ = false;
};

// The sample of a row: t = index / rate [s], counts × LSB [m/s², rad/s].
ImuSample imucal_sample(const ImucalRow& row, const ImucalOptions& opt, double acc_lsb, double gyr_lsb) {
  ImuSample s;
  s.t_s = static_cast<double>(row.index) / opt.rate_hz;
  for (int k = 0; k < 3; ++k) {
    s.accel_counts[k] = row.counts[static_cast<std::size_t>(k)];
    s.gyro_counts[k] = row.counts[static_cast<std::size_t>(k + 3)];
    s.accel_mps2[k] = (s.accel_counts[k] - opt.accel_offset_counts) * acc_lsb;
    s.gyro_radps[k] = (s.gyro_counts[k] - opt.gyro_offset_counts) * gyr_lsb;
  }
  return s;
}

// One segment per contiguous run of a part in time order: "<axis>_rot" is a 360° rotation about
// the axis, any other part an orientation ("<axis>_p" = +axis up: f = +g along it, "<axis>_a" =
// +axis down: f = −g, both held as truth). Parts come sample by sample (add), finish() closes the
// last segment and counts the orientations.
class ImucalSegments {
 public:
  explicit ImucalSegments(double g_mps2) : g_mps2_(g_mps2) {}
  void add(const std::string& part, double t_s, Recording& rec) {
    if (open_ && part == part_) {
      t_end_ = t_s;
      return;
    }
    close(rec);
    open_ = true;
    part_ = part;
    t_start_ = t_end_ = t_s;
  }
  void finish(Recording& rec) {
    close(rec);
    for (std::size_t k : orientation_segments_) rec.segments[k].orientation_count = orientation_;
  }

 private:
  void close(Recording& rec) {
    if (!open_) return;
    const bool rotation = part_.size() > 4 && part_.compare(part_.size() - 4, 4, "_rot") == 0;
    Segment seg = make_segment(id_++, rotation ? SegmentKind::kRotation : SegmentKind::kOrientation, part_, t_start_,
                               t_end_);
    const std::string axis = part_.substr(0, 1);
    if (rotation) {
      seg.targets = "360 deg turn about " + axis;
    } else {
      seg.orientation = orientation_++;
      const bool up = part_.size() == 3 && part_[1] == '_' && part_[2] == 'p';
      const bool down = part_.size() == 3 && part_[1] == '_' && part_[2] == 'a';
      if (up || down) seg.targets = "+" + axis + (up ? " up" : " down");
      if (imucal_held_part(part_)) {
        std::array<double, 3> f{};
        f[static_cast<std::size_t>(part_[0] - 'x')] = up ? g_mps2_ : -g_mps2_;
        add_held_truth(rec, seg.t_start_s, seg.t_end_s, f);
      }
      orientation_segments_.push_back(rec.segments.size());
    }
    rec.segments.push_back(seg);
    open_ = false;
  }
  double g_mps2_;
  bool open_ = false;
  std::string part_;
  double t_start_ = 0.0, t_end_ = 0.0;
  int id_ = 0, orientation_ = 0;
  std::vector<std::size_t> orientation_segments_;
};

}  // namespace

void import_imucal_session(const fs::path& file, const ImucalOptions& opt, Recording& rec, SampleSink& out) {
  LineReader r(file);
  const ImucalColumns columns = read_imucal_header(r);
  const ImucalScan scan = scan_imucal(r, columns);
  rec = new_recording(file, "imucal");
  if (scan.truth) rec.header.truth_columns = kTruthColumns;  // before the samples: the run's layout
  const double acc_lsb = physics::kStandardGravity / opt.accel_lsb_per_g;
  const double gyr_lsb = physics::kDegPerSecond / opt.gyro_lsb_per_dps;
  set_int16_sensor_info(opt.rate_hz, acc_lsb, gyr_lsb, rec);
  rec.header.identity.model = "imucal example session";
  rec.header.gravity_mps2 = opt.gravity_mps2;

  ImucalRows rows(file, columns, scan.runs);
  ImucalSegments segments(opt.gravity_mps2);
  SampleChunker chunks(out);
  std::size_t gaps = 0;
  std::int64_t prev = 0;
  for (ImucalRow row; rows.next(row); prev = row.index) {
    ImuSample s = imucal_sample(row, opt, acc_lsb, gyr_lsb);
    if (chunks.count() > 0 && row.index != prev + 1) {  // a jump in the index
      s.flags |= kGapBefore;
      ++gaps;
    }
    segments.add(row.part, s.t_s, rec);
    chunks.add(s);
  }
  chunks.flush();
  segments.finish(rec);
  add_import_event(
      rec, "imported " + std::to_string(chunks.count()) + " samples from " + file.string() +
               " (imucal annotated session; rate " + fmt_g(opt.rate_hz) +
               " Hz; counts converted with the nominal " + fmt_g(opt.accel_lsb_per_g) +
               " LSB/g and " + fmt_g(opt.gyro_lsb_per_dps) +
               " LSB/(deg/s), which imucal's own calibration of this session (example_cal.json) "
               "matches within 3 % — SI values are uncalibrated approximations; gravity " +
               fmt_g(opt.gravity_mps2) + " m/s^2 is imucal's expected_g; truth from the annotations: "
               "<axis>_p = axis up (f = +g along it), <axis>_a = axis down (-g), rate 0" +
               (gaps ? "; " + std::to_string(gaps) + " gap(s) in the sample index" : "") + ")");
}

Recording import_imucal_session(const fs::path& file, const ImucalOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_imucal_session(file, opt, rec, out); });
}

// =============================================================================================
// (c) MPU-6050 multi-position session

namespace {

// The "key,value" header lines before the column names (values and their line numbers), and the
// column names with their line.
struct MpuHeader {
  std::map<std::string, double> values;
  std::map<std::string, std::size_t> lines;
  std::vector<std::string> names;
  std::size_t names_line = 0;
};

MpuHeader read_mpu_header(LineReader& r) {
  MpuHeader h;
  std::string line;
  while (r.next(line)) {
    if (is_blank(line)) continue;
    const auto f = split(line, ',');
    double v = 0.0;
    if (f.size() == 2 && !parse_double(f[0], v)) {
      if (!parse_double(f[1], v)) r.fail("header value '" + excerpt(f[1]) + "' is not a number");
      h.values[unquote(f[0])] = v;
      h.lines[unquote(f[0])] = r.line();
      continue;
    }
    for (auto n : f) h.names.push_back(unquote(n));
    break;
  }
  if (h.names.empty()) throw ImportError(r.file(), r.line(), "no column-name line (expected ax,ay,az,gx,gy,gz)");
  h.names_line = r.line();
  return h;
}

constexpr const char* kMpuColumns[6] = {"ax", "ay", "az", "gx", "gy", "gz"};

// Positions of ax..gz among the column names.
std::array<std::size_t, 6> mpu_columns(const fs::path& file, const MpuHeader& h) {
  std::array<std::size_t, 6> col{};
  for (std::size_t k = 0; k < 6; ++k) {
    const auto it = std::find(h.names.begin(), h.names.end(), kMpuColumns[k]);
    if (it == h.names.end()) {
      throw ImportError(file, h.names_line, std::string("no column '") + kMpuColumns[k] +
                                                "' (expected ax,ay,az,gx,gy,gz after the header)");
    }
    col[k] = static_cast<std::size_t>(it - h.names.begin());
  }
  return col;
}

// Sample rate [Hz] from the header line "Fs,<Hz>".
double mpu_rate(const fs::path& file, const MpuHeader& h) {
  const auto fs_it = h.values.find("Fs");
  if (fs_it == h.values.end() || !(fs_it->second > 0.0)) {
    throw ImportError(file, fs_it == h.values.end() ? 1 : h.lines.at("Fs"),
                      "no sample rate: expected a header line 'Fs,<Hz>' with a positive rate");
  }
  return fs_it->second;
}

// Every data line as a sample at t = index / rate [s]; counts × LSB [m/s², rad/s]. Returns the
// number of samples.
std::size_t read_mpu_samples(LineReader& r, const std::array<std::size_t, 6>& col, std::size_t fields, double rate,
                             const Mpu6050MultiposOptions& opt, double acc_lsb, double gyr_lsb, SampleSink& out) {
  SampleChunker chunks(out);
  std::string line;
  while (r.next(line)) {
    if (is_blank(line)) continue;
    const auto f = split(line, ',');
    if (f.size() != fields) {
      r.fail("expected " + std::to_string(fields) + " fields as on the column-name line, found " +
             std::to_string(f.size()));
    }
    ImuSample s;
    s.t_s = static_cast<double>(chunks.count()) / rate;
    for (int k = 0; k < 3; ++k) {
      const auto ka = static_cast<std::size_t>(k), kg = static_cast<std::size_t>(k + 3);
      s.accel_counts[k] = to_counts(r, number(r, f[col[ka]], kMpuColumns[ka]), kMpuColumns[ka]);
      s.gyro_counts[k] = to_counts(r, number(r, f[col[kg]], kMpuColumns[kg]), kMpuColumns[kg]);
      s.accel_mps2[k] = (s.accel_counts[k] - opt.accel_offset_counts) * acc_lsb;
      s.gyro_radps[k] = (s.gyro_counts[k] - opt.gyro_offset_counts) * gyr_lsb;
    }
    chunks.add(s);
  }
  chunks.flush();
  return chunks.count();
}

// The still interval at the start ("Initialization time" [s] in the header) as an orientation
// segment, up to the last sample's time t_last_s at most.
void add_initialization_segment(const MpuHeader& h, double t_last_s, Recording& rec) {
  const auto init = h.values.find("Initialization time");
  if (init == h.values.end() || !(init->second > 0.0)) return;
  const double t_end = std::min(init->second, t_last_s);
  Segment seg = make_segment(0, SegmentKind::kOrientation, "initialization", 0.0, t_end);
  seg.orientation = 0;
  seg.targets = "held still (Initialization time " + fmt_g(init->second) + " s)";
  rec.segments.push_back(seg);
}

}  // namespace

void import_mpu6050_multipos(const fs::path& file, const Mpu6050MultiposOptions& opt, Recording& rec,
                             SampleSink& out) {
  LineReader r(file);
  const MpuHeader header = read_mpu_header(r);
  const std::array<std::size_t, 6> col = mpu_columns(file, header);
  const double rate = mpu_rate(file, header);
  rec = new_recording(file, "mpu6050_multipos");
  const double acc_lsb = physics::kStandardGravity / opt.accel_lsb_per_g;
  const double gyr_lsb = physics::kDegPerSecond / opt.gyro_lsb_per_dps;
  set_int16_sensor_info(rate, acc_lsb, gyr_lsb, rec);
  rec.header.identity.vendor = "InvenSense";
  rec.header.identity.model = "MPU-6050";
  rec.header.gravity_mps2 = opt.gravity_mps2;
  const std::size_t count = read_mpu_samples(r, col, header.names.size(), rate, opt, acc_lsb, gyr_lsb, out);
  if (count == 0) throw ImportError(file, 0, "no data lines after the column names");
  std::string hdr;
  for (const auto& [k, v] : header.values) hdr += (hdr.empty() ? "" : ", ") + k + " = " + fmt_g(v);
  add_initialization_segment(header, static_cast<double>(count - 1) / rate, rec);
  add_import_event(rec, "imported " + std::to_string(count) + " samples from " +
                            file.string() + " (MPU-6050 multi-position session; header: " + hdr +
                            "; counts converted with " + fmt_g(opt.accel_lsb_per_g) + " LSB/g (+-2 g) and " +
                            fmt_g(opt.gyro_lsb_per_dps) +
                            " LSB/(deg/s) (+-250 deg/s), 1 g = " + fmt_g(physics::kStandardGravity) + " m/s^2; no orientation "
                            "annotations beyond the initial still interval)");
}

Recording import_mpu6050_multipos(const fs::path& file, const Mpu6050MultiposOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_mpu6050_multipos(file, opt, rec, out); });
}

// =============================================================================================
// (d) IMU-TK

namespace {

// A value of a triad line as an integer count (counts = true).
std::int32_t triad_count(const TriadLine& l, double v, const fs::path& file) {
  if (!std::isfinite(v) || std::abs(v - std::round(v)) > 1e-6 || std::abs(v) > 2147483647.0) {
    throw ImportError(file, l.line, fmt_g(v) + " is not an integer count (counts = true)");
  }
  return static_cast<std::int32_t>(std::lround(v));
}

// What a first pass over a triad file finds: its lines (checked), time span [s] and median
// interval [s] (over the first kTimestampWindow lines, as the timestamp repair takes its rate).
struct TriadScan {
  std::size_t lines = 0;
  double t_first = 0.0, t_last = 0.0, median_dt = 0.0;
};

TriadScan scan_triad(const fs::path& file, double time_scale) {
  TriadReader in(file, time_scale);
  TriadScan scan;
  std::vector<ImuSample> window;  // the first lines' times, for median_interval
  for (TriadLine l; in.next(l); ++scan.lines) {
    if (scan.lines == 0) scan.t_first = l.t;
    scan.t_last = l.t;
    if (window.size() < kTimestampWindow) window.emplace_back().t_s = l.t;
  }
  scan.median_dt = median_interval(window);
  return scan;
}

// Whether the gyro lines have the accelerometer's timestamps (within tol [s]), read side by side.
bool same_times(const fs::path& acc_file, const fs::path& gyro_file, double time_scale, double tol) {
  TriadReader acc(acc_file, time_scale), gyr(gyro_file, time_scale);
  for (TriadLine a, g;;) {
    const bool more_a = acc.next(a), more_g = gyr.next(g);
    if (more_a != more_g) return false;
    if (!more_a) return true;
    if (std::abs(g.t - a.t) > tol) return false;
  }
}

// One sample per accelerometer line: time [s] and value × accel_scale [m/s²] (with the counts).
ImuSample accel_sample(const TriadLine& a, const fs::path& acc_file, const ImuTkOptions& opt) {
  ImuSample s;
  s.t_s = a.t;
  for (int k = 0; k < 3; ++k) {
    const double v = a.v[static_cast<std::size_t>(k)];
    if (opt.counts) s.accel_counts[k] = triad_count(a, v, acc_file);
    s.accel_mps2[k] = (v - opt.accel_offset_counts) * opt.accel_scale;
  }
  return s;
}

// Gyro values g (file units) into a sample: g × gyro_scale [rad/s], with the counts (`count` turns
// a value into one).
template <class Count>
void set_gyro(const std::array<double, 3>& g, const ImuTkOptions& opt, Count count, ImuSample& s) {
  for (int k = 0; k < 3; ++k) {
    const double v = g[static_cast<std::size_t>(k)];
    if (opt.counts) s.gyro_counts[k] = count(v);
    s.gyro_radps[k] = (v - opt.gyro_offset_counts) * opt.gyro_scale;
  }
}

// The gyro linearly interpolated at rising times t [s] from a two-line window sliding over the gyro
// file (counts are the rounded interpolated values).
class GyroInterpolator {
 public:
  GyroInterpolator(const fs::path& file, double time_scale) : in_(file, time_scale) {
    in_.next(a_);
    if (!in_.next(b_)) b_ = a_;
  }
  std::array<double, 3> at(double t) {
    while (b_.t < t && a_.line != b_.line) {
      a_ = b_;
      if (!in_.next(b_)) b_ = a_;  // past the last line: its value
    }
    const double span = b_.t - a_.t;
    const double u = span > 0.0 ? std::clamp((t - a_.t) / span, 0.0, 1.0) : 0.0;
    std::array<double, 3> g{};
    for (std::size_t k = 0; k < 3; ++k) g[k] = a_.v[k] + u * (b_.v[k] - a_.v[k]);
    return g;
  }

 private:
  TriadReader in_;
  TriadLine a_, b_;  // the lines around the last time asked for (the same line at the file's end)
};

// Sensor description: rate [Hz] (given, else left to the timestamp repair) and the
// LSB sizes when the files hold counts.
void set_imutk_sensor_info(const ImuTkOptions& opt, bool has_gyro, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = opt.rate_hz;  // 0: set by the timestamp repair
  info.has_gyro = has_gyro;
  info.has_temperature = false;
  if (opt.counts) {
    info.accel_lsb_mps2 = opt.accel_scale;
    info.gyro_lsb_radps = has_gyro ? opt.gyro_scale : 0.0;
  }
  rec.header.identity = opt.identity;
  rec.header.gravity_mps2 = opt.gravity_mps2;
}

}  // namespace

void import_imutk(const fs::path& acc_file, const fs::path& gyro_file, const ImuTkOptions& opt, Recording& rec,
                  SampleSink& out) {
  const TriadScan acc = scan_triad(acc_file, opt.time_scale_s);
  const bool has_gyro = !gyro_file.empty();
  const TriadScan gyr = has_gyro ? scan_triad(gyro_file, opt.time_scale_s) : TriadScan{};
  const double tol = opt.time_tolerance_s >= 0.0 ? opt.time_tolerance_s : 0.01 * acc.median_dt;
  const bool matched = has_gyro && acc.lines == gyr.lines && same_times(acc_file, gyro_file, opt.time_scale_s, tol);
  rec = new_recording(acc_file, "imutk");
  set_imutk_sensor_info(opt, has_gyro, rec);

  TimestampRepairStream repair(rec, out, opt.rate_hz);
  SampleChunker chunks(repair);
  TriadReader acc_in(acc_file, opt.time_scale_s);
  std::optional<TriadReader> gyr_matched;
  std::optional<GyroInterpolator> gyr_interpolated;
  if (matched) gyr_matched.emplace(gyro_file, opt.time_scale_s);
  if (has_gyro && !matched) gyr_interpolated.emplace(gyro_file, opt.time_scale_s);
  std::size_t dropped = 0;
  for (TriadLine a; acc_in.next(a);) {
    ImuSample s = accel_sample(a, acc_file, opt);
    if (gyr_matched) {
      TriadLine g;
      gyr_matched->next(g);
      set_gyro(g.v, opt, [&](double v) { return triad_count(g, v, gyro_file); }, s);
    } else if (gyr_interpolated) {
      if (s.t_s < gyr.t_first - tol || s.t_s > gyr.t_last + tol) {
        ++dropped;
        continue;
      }
      set_gyro(gyr_interpolated->at(s.t_s), opt, [](double v) { return static_cast<std::int32_t>(std::lround(v)); }, s);
    }
    chunks.add(s);
  }
  if (chunks.count() == 0) {
    throw ImportError(gyro_file, 0, "the gyro timestamps (" + fmt_g(gyr.t_first) + " … " + fmt_g(gyr.t_last) +
                                        " s) do not overlap the accelerometer's (" + fmt_g(acc.t_first) + " … " +
                                        fmt_g(acc.t_last) + " s); check time_scale_s");
  }
  chunks.flush();
  const std::size_t gaps = repair.finish().gaps;
  std::string merge_note;
  if (matched) merge_note = "gyro samples matched by timestamp";
  if (gyr_interpolated) {
    merge_note = "gyro linearly interpolated at the accelerometer times (the files' timestamps differ)" +
                 (dropped ? "; " + std::to_string(dropped) + " accelerometer sample(s) outside the gyro's time span dropped"
                          : std::string());
  }
  add_import_event(rec, "imported " + std::to_string(chunks.count()) + " samples from " +
                            acc_file.string() + (has_gyro ? " and " + gyro_file.string() : std::string()) +
                            " (IMU-TK text; time scale " + fmt_g(opt.time_scale_s) + " s/unit, " +
                            (opt.counts ? "counts" : "physical units") + ", accel scale " +
                            fmt_g(opt.accel_scale) + ", gyro scale " + fmt_g(opt.gyro_scale) +
                            (merge_note.empty() ? "" : "; " + merge_note) +
                            (gaps ? "; " + std::to_string(gaps) + " gap(s) flagged" : "") + ")");
}

Recording import_imutk(const fs::path& acc_file, const fs::path& gyro_file, const ImuTkOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_imutk(acc_file, gyro_file, opt, rec, out); });
}

void export_imutk(const Recording& rec, const fs::path& acc_file, const fs::path& gyro_file,
                  bool counts) {
  auto write = [&](const fs::path& file, bool gyro) {
    std::string out;
    out.reserve(rec.samples.size() * 80);
    for (const auto& s : rec.samples) {
      write_number(out, s.t_s);
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        if (counts) {
          out += std::to_string(gyro ? s.gyro_counts[k] : s.accel_counts[k]);
        } else {
          write_number(out, gyro ? s.gyro_radps[k] : s.accel_mps2[k]);
        }
      }
      out += '\n';
    }
    write_file_atomic(file, out);
  };
  write(acc_file, false);
  if (!gyro_file.empty()) write(gyro_file, true);
}

// =============================================================================================
// (f) table of static means

namespace {

// Which columns of a static table hold the known input and the measured means (−1 = absent).
struct TableColumns {
  int angle = -1;
  std::array<int, 3> force{-1, -1, -1}, measured{-1, -1, -1};
};

TableColumns table_columns(const LineReader& r, const std::vector<std::string>& names) {
  TableColumns c;
  auto find = [&](const std::string& n) {
    const auto it = std::find(names.begin(), names.end(), n);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
  };
  c.angle = find("angle_deg");
  bool any = false;
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string axis(1, static_cast<char>('x' + k));
    c.force[k] = find("f_" + axis + "_mps2");
    c.measured[k] = find("a_" + axis + "_mps2");
    any = any || c.measured[k] >= 0;
  }
  const bool force = c.force[0] >= 0 && c.force[1] >= 0 && c.force[2] >= 0;
  if (!any) r.fail("no measured column: expected a_x_mps2, a_y_mps2 and/or a_z_mps2");
  if ((c.angle >= 0) == force)
    r.fail("expected the known input as either angle_deg or f_x_mps2,f_y_mps2,f_z_mps2 (exactly one of them)");
  return c;
}

}  // namespace

Recording import_static_table(const fs::path& file, double gravity_mps2) {
  LineReader r(file);
  std::string line;
  std::vector<std::string> names;
  while (names.empty() && r.next(line)) {
    if (is_blank(line) || trim(line).front() == '#') continue;
    for (auto f : split(line, ',')) names.push_back(unquote(f));
  }
  if (names.empty()) throw ImportError(file, 0, "no column-name line");
  const TableColumns c = table_columns(r, names);
  Recording rec = new_recording(file, "static_table");
  rec.header.gravity_mps2 = gravity_mps2;
  const double g = rec.header.gravity_or_standard_mps2();
  const auto per_row = static_cast<std::size_t>(kStaticTableHold_s * kStaticTableRate_hz);
  while (r.next(line)) {
    if (is_blank(line) || trim(line).front() == '#') continue;
    const auto f = split(line, ',');
    if (f.size() != names.size()) {
      r.fail("expected " + std::to_string(names.size()) + " fields, found " + std::to_string(f.size()));
    }
    std::array<double, 3> force{};
    std::string label;
    if (c.angle >= 0) {
      const double delta = number(r, f[static_cast<std::size_t>(c.angle)], "angle_deg");
      const Eigen::Vector3d fv = physics::gravity_specific_force(physics::paper_table(0.0, delta * physics::kDegToRad), g);
      force = {fv.x(), fv.y(), fv.z()};
      label = fmt_g(delta) + " deg";
    } else {
      for (std::size_t k = 0; k < 3; ++k) force[k] = number(r, f[static_cast<std::size_t>(c.force[k])], names[static_cast<std::size_t>(c.force[k])]);
      label = "row " + std::to_string(rec.segments.size() + 1);
    }
    ImuSample s;
    for (std::size_t k = 0; k < 3; ++k) {
      s.accel_mps2[static_cast<int>(k)] = c.measured[k] >= 0 ? number(r, f[static_cast<std::size_t>(c.measured[k])], names[static_cast<std::size_t>(c.measured[k])])
                                                            : std::numeric_limits<double>::quiet_NaN();
    }
    const double t0 = static_cast<double>(rec.samples.size()) / kStaticTableRate_hz;
    for (std::size_t i = 0; i < per_row; ++i) {
      s.t_s = static_cast<double>(rec.samples.size()) / kStaticTableRate_hz;
      rec.samples.push_back(s);
    }
    const int id = static_cast<int>(rec.segments.size());
    Segment seg = make_segment(id, SegmentKind::kOrientation, label, t0, rec.samples.back().t_s);
    seg.orientation = id;
    rec.segments.push_back(seg);
    add_held_truth(rec, seg.t_start_s, seg.t_end_s, force);
  }
  if (rec.segments.empty()) throw ImportError(file, 0, "no data rows after the column names");
  for (auto& seg : rec.segments) seg.orientation_count = static_cast<int>(rec.segments.size());
  rec.header.info.output_rate_hz = kStaticTableRate_hz;
  rec.header.info.has_gyro = false;
  add_import_event(rec, "imported " + std::to_string(rec.segments.size()) + " static means from " + file.string() +
                            " (table of static means; each row held as an orientation segment of " +
                            fmt_g(kStaticTableHold_s) + " s at " + fmt_g(kStaticTableRate_hz) +
                            " Hz repeating the mean, so sample statistics carry no noise information; " +
                            (c.angle >= 0 ? "known input from angle_deg: f = g*[-sin d, 0, cos d], the paper's table with tilt h = 0, g = " +
                                                fmt_g(g) + " m/s^2" + (gravity_mps2 > 0.0 ? "" : " (standard gravity: the table does not state g)")
                                          : std::string("known input from f_x_mps2, f_y_mps2, f_z_mps2")) +
                            "; axes without a measured column read NaN)");
  return rec;
}

// =============================================================================================
// (e) MATLAB .mat

#if STEND_IMPORT_MATIO

bool mat_supported() { return true; }

namespace {

struct MatFileCloser {
  void operator()(mat_t* m) const {
    if (m) Mat_Close(m);
  }
};
struct MatVarFree {
  void operator()(matvar_t* v) const {
    if (v) Mat_VarFree(v);
  }
};
using MatFile = std::unique_ptr<mat_t, MatFileCloser>;
using MatVar = std::unique_ptr<matvar_t, MatVarFree>;

// Numeric content of a variable as doubles (column-major), with its dims.
bool numeric(const matvar_t* v, std::vector<double>& out, std::size_t& rows, std::size_t& cols) {
  if (!v || v->isComplex || v->rank != 2 || !v->data) return false;
  rows = v->dims[0];
  cols = v->dims[1];
  const std::size_t n = rows * cols;
  out.resize(n);
  auto copy = [&](auto* p) {
    for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(p[i]);
  };
  switch (v->class_type) {
    case MAT_C_DOUBLE: copy(static_cast<const double*>(v->data)); return true;
    case MAT_C_SINGLE: copy(static_cast<const float*>(v->data)); return true;
    case MAT_C_INT8: copy(static_cast<const std::int8_t*>(v->data)); return true;
    case MAT_C_UINT8: copy(static_cast<const std::uint8_t*>(v->data)); return true;
    case MAT_C_INT16: copy(static_cast<const std::int16_t*>(v->data)); return true;
    case MAT_C_UINT16: copy(static_cast<const std::uint16_t*>(v->data)); return true;
    case MAT_C_INT32: copy(static_cast<const std::int32_t*>(v->data)); return true;
    case MAT_C_UINT32: copy(static_cast<const std::uint32_t*>(v->data)); return true;
    case MAT_C_INT64: copy(static_cast<const std::int64_t*>(v->data)); return true;
    case MAT_C_UINT64: copy(static_cast<const std::uint64_t*>(v->data)); return true;
    default: return false;
  }
}

std::string text(const matvar_t* v) {
  if (!v || v->class_type != MAT_C_CHAR || !v->data) return {};
  std::size_t n = 1;
  for (int i = 0; i < v->rank; ++i) n *= v->dims[i];
  std::string s;
  if (v->data_size == 2 || v->data_type == MAT_T_UINT16 || v->data_type == MAT_T_UTF16) {
    const auto* p = static_cast<const std::uint16_t*>(v->data);
    for (std::size_t i = 0; i < n; ++i) s += p[i] < 128 ? static_cast<char>(p[i]) : '?';
  } else {
    const auto* p = static_cast<const char*>(v->data);
    s.assign(p, n);
  }
  return s;
}

// The bytes of one top-level element, as stored or inflated from a compressed one (whose
// inflated bytes start with the matrix's own tag), read forwards; at most what it holds.
class MatElementBytes {
 public:
  MatElementBytes(std::ifstream& in, std::uint64_t pos, std::uint32_t bytes, bool compressed)
      : in_(in), next_(pos + 8), left_(bytes), compressed_(compressed) {
    if (compressed_ && inflateInit(&z_) != Z_OK) throw std::bad_alloc();
  }
  ~MatElementBytes() {
    if (compressed_) inflateEnd(&z_);
  }
  MatElementBytes(const MatElementBytes&) = delete;
  MatElementBytes& operator=(const MatElementBytes&) = delete;

  // n bytes into out (nullptr: skipped); false when the element (or its zlib stream) ends first.
  bool read(char* out, std::uint64_t n) {
    if (!out && !compressed_) {  // skipping stored bytes: no need to read them
      if (n > left_) return false;
      next_ += n;
      left_ -= n;
      return true;
    }
    char scratch[4096];
    while (n > 0) {
      const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(n, sizeof scratch));
      char* to = out ? out : scratch;
      const std::size_t got = compressed_ ? inflate_into(to, want) : read_stored(to, want);
      if (got == 0) return false;
      n -= got;
      if (out) out += got;
    }
    return true;
  }

 private:
  std::size_t read_stored(char* to, std::size_t want) {
    const std::size_t take = static_cast<std::size_t>(std::min<std::uint64_t>(want, left_));
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(next_));
    in_.read(to, static_cast<std::streamsize>(take));
    const auto got = static_cast<std::size_t>(std::max<std::streamsize>(0, in_.gcount()));
    next_ += got;
    left_ -= got;
    return got;
  }
  std::size_t inflate_into(char* to, std::size_t want) {
    z_.next_out = reinterpret_cast<Bytef*>(to);
    z_.avail_out = static_cast<uInt>(want);
    while (z_.avail_out > 0 && !ended_) {
      if (z_.avail_in == 0) {
        const std::size_t got = read_stored(in_buf_, sizeof in_buf_);
        if (got == 0) break;
        z_.next_in = reinterpret_cast<Bytef*>(in_buf_);
        z_.avail_in = static_cast<uInt>(got);
      }
      const int rc = inflate(&z_, Z_NO_FLUSH);
      if (rc == Z_STREAM_END) ended_ = true;
      else if (rc != Z_OK) break;  // a damaged stream: matio reports it
    }
    return want - z_.avail_out;
  }

  std::ifstream& in_;
  std::uint64_t next_, left_;
  bool compressed_;
  bool ended_ = false;
  z_stream z_{};
  char in_buf_[4096];
};

// Walks the matrix in a MAT v5 element the way matio's Mat_GetDir and Mat_VarReadInfo do (array
// flags, dimensions, name; for structs and objects the field names and each field's matrix, for
// cells each element's), and refuses any length they would allocate before checking: a
// subelement or nested matrix longer than what is left of its parent, dimensions beyond 256,
// nesting beyond 32 levels (damaged tags declared gigabytes, and matio asked for them).
template <class U32>
class MatMatrixWalk {
 public:
  MatMatrixWalk(const fs::path& file, std::uint64_t pos, MatElementBytes& bytes, const U32& u32)
      : file_(file), pos_(pos), bytes_(bytes), u32_(u32) {}

  // The top-level matrix: its own tag first (inflated, for a compressed element).
  void top(bool compressed, std::uint32_t declared) {
    std::uint64_t left = declared;
    if (compressed) {
      char tag[8];
      if (!bytes_.read(tag, 8) || u32_(tag) != kMiMatrix) return;  // matio says what is wrong
      left = u32_(tag + 4);
    }
    matrix(left, 0);
  }

 private:
  static constexpr std::uint32_t kMiMatrix = 14;
  static constexpr std::uint64_t kMaxDimensionBytes = 256 * 4;
  static constexpr int kMaxDepth = 32;
  enum : std::uint32_t { kCell = 1, kStruct = 2, kObject = 3 };

  [[noreturn]] void fail(int depth, const std::string& what) const {
    const std::string which =
        depth == 0 ? "the matrix in this element" : "a matrix nested " + std::to_string(depth) + " deep in this element";
    throw ImportError(file_, ByteOffset{pos_}, which + " " + what + " (damaged .mat)");
  }

  // One subelement inside the `left` bytes of its matrix: its tag, then its data (into `keep`, or
  // skipped); `max` bounds its length. False when the element ends first (matio reports it).
  bool subelement(std::uint64_t& left, int depth, const char* what, std::uint64_t max, std::string* keep = nullptr) {
    char tag[8];
    if (left < 8 || !bytes_.read(tag, 8)) return false;
    left -= 8;
    const std::uint32_t type = u32_(tag);
    if ((type >> 16) != 0) {  // a small data element: its length in the upper half, its data in the tag
      if (keep) keep->assign(tag + 4, std::min<std::uint32_t>(type >> 16, 4));
      return true;
    }
    const std::uint64_t n = u32_(tag + 4), padded = n + (8 - n % 8) % 8;
    if (n > max) fail(depth, "declares " + std::to_string(n) + " bytes of " + what);
    if (padded > left)
      fail(depth, "declares " + std::to_string(n) + " bytes of " + what + " where " + std::to_string(left) + " are left");
    left -= padded;
    if (!keep) return bytes_.read(nullptr, padded);
    keep->resize(static_cast<std::size_t>(n));
    return bytes_.read(keep->data(), n) && bytes_.read(nullptr, padded - n);
  }

  // The matrix whose `left` bytes follow (its tag read); returns with the stream wherever the
  // walk stopped inside it.
  void matrix(std::uint64_t& left, int depth) {
    if (depth > kMaxDepth) fail(depth, "is nested deeper than " + std::to_string(kMaxDepth) + " levels");
    constexpr std::uint64_t kAny = ~std::uint64_t{0};
    std::string flags;
    if (!subelement(left, depth, "array flags", kAny, &flags) || flags.size() < 4) return;
    if (!subelement(left, depth, "dimensions (at most 256 dimensions of 4 bytes)", kMaxDimensionBytes)) return;
    if (!subelement(left, depth, "name", kAny)) return;
    const std::uint32_t cls = u32_(flags.data()) & 0xff;
    if (cls == kObject && !subelement(left, depth, "class name", kAny)) return;
    if (cls == kStruct || cls == kObject) {
      if (!subelement(left, depth, "field name length", kAny) || !subelement(left, depth, "field names", kAny)) return;
    } else if (cls != kCell) {
      return;  // numeric, char, sparse, logical: data follows, which matio sizes from the dimensions
    }
    while (left >= 8) {  // the fields or cell elements, each a matrix
      char tag[8];
      if (!bytes_.read(tag, 8)) return;
      left -= 8;
      std::uint64_t n = u32_(tag + 4);
      if (u32_(tag) != kMiMatrix)
        fail(depth, "holds an element of data type " + std::to_string(u32_(tag)) + " where a matrix (14) is expected");
      if (n > left) fail(depth, "holds a matrix of " + std::to_string(n) + " bytes where " + std::to_string(left) + " are left");
      left -= n;
      matrix(n, depth + 1);
      if (!bytes_.read(nullptr, n)) return;  // the rest of the nested matrix (its data)
    }
  }

  const fs::path& file_;
  std::uint64_t pos_;
  MatElementBytes& bytes_;
  const U32& u32_;
};

// Refuses a MAT v5 file whose top-level elements (8-byte tag: uint32 data type, uint32 byte
// count) are not matrices or compressed matrices lying inside the file, or whose matrices declare
// lengths matio would allocate unchecked (MatMatrixWalk), before matio reads it. v7.3 files
// (HDF5, version 0x0200) are left to matio.
void check_mat5_elements(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string header(128, '\0');
  if (!in.read(header.data(), 128)) return;  // matio says why it cannot open it
  const bool swap = header[126] == 'M' && header[127] == 'I';
  const auto u32 = [swap](const char* p) {
    std::uint8_t b[4];
    std::memcpy(b, p, 4);
    if (swap) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
    return static_cast<std::uint32_t>(b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24);
  };
  const std::uint32_t version = swap ? static_cast<std::uint8_t>(header[124]) << 8 | static_cast<std::uint8_t>(header[125])
                                     : static_cast<std::uint8_t>(header[125]) << 8 | static_cast<std::uint8_t>(header[124]);
  if (version != 0x0100) return;
  constexpr std::uint32_t kMiMatrix = 14, kMiCompressed = 15;
  const std::uint64_t size = fs::file_size(file);
  struct Element {
    std::uint64_t pos;
    bool compressed;
    std::uint32_t bytes;
  };
  std::vector<Element> elements;  // all inside the file, then each one's dimensions
  for (std::uint64_t pos = 128; pos + 8 <= size;) {
    char tag[8];
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(tag, 8);
    const std::uint32_t type = u32(tag), bytes = u32(tag + 4);
    if ((type != kMiMatrix && type != kMiCompressed) || bytes > size - pos - 8) {
      throw ImportError(file, ByteOffset{pos},
                        "a top-level element of data type " + std::to_string(type) + " declares " +
                            std::to_string(bytes) + " bytes; expected a matrix (14) or compressed matrix (15) "
                            "inside the file, which ends at byte " + std::to_string(size) + " (damaged or truncated .mat)");
    }
    elements.push_back({pos, type == kMiCompressed, bytes});
    pos += 8 + bytes + (type == kMiMatrix ? (8 - bytes % 8) % 8 : 0);
  }
  for (const auto& e : elements) {
    MatElementBytes bytes(in, e.pos, e.bytes, e.compressed);
    MatMatrixWalk(file, e.pos, bytes, u32).top(e.compressed, e.bytes);
  }
}

// The variables of the file (top level or one struct's fields), by name.
class MatSource {
 public:
  MatSource(const fs::path& file, const std::string& struct_name) : file_(file) {
    check_mat5_elements(file);
    mat_.reset(Mat_Open(file.c_str(), MAT_ACC_RDONLY));
    if (!mat_) throw ImportError(file, 0, "matio cannot open it as a MATLAB file (missing, or not a .mat)");
    std::size_t n = 0;
    char** dir = Mat_GetDir(mat_.get(), &n);
    if (!dir) throw ImportError(file, 0, "matio cannot list its variables");
    std::vector<std::string> names(dir, dir + n);
    for (const auto& nm : names) check_declared_size(nm);
    if (!struct_name.empty()) {
      root_.reset(Mat_VarRead(mat_.get(), struct_name.c_str()));
      if (!root_ || root_->class_type != MAT_C_STRUCT) {
        throw ImportError(file, 0, "no struct variable named '" + struct_name + "'");
      }
      return;
    }
    for (const auto& nm : names) {
      MatVar v(Mat_VarRead(mat_.get(), nm.c_str()));
      if (!v) continue;
      top_[nm] = std::move(v);
    }
    bool has_acc = top_.count("acc") || top_.count("accel") || top_.count("accelerometer") ||
                   top_.count("acc_counts");
    if (!has_acc) {
      for (auto& [nm, v] : top_) {
        if (v->class_type == MAT_C_STRUCT) {
          root_ = std::move(v);
          top_.clear();
          break;
        }
      }
    }
  }
  // Refuses a variable whose header declares more data than the file can hold (compressed
  // variables: zlib's largest expansion, about 1032:1) before matio allocates it.
  void check_declared_size(const std::string& name) const {
    MatVar info(Mat_VarReadInfo(mat_.get(), name.c_str()));
    if (!info) return;  // unreadable: Mat_VarRead says so, or skips it
    const double file_bytes = static_cast<double>(fs::file_size(file_));
    const double declared = static_cast<double>(Mat_VarGetSize(info.get()));
    constexpr double kMaxExpansion = 1032.0;
    if (declared > kMaxExpansion * file_bytes + 4096.0) {
      throw ImportError(file_, 0, "variable '" + name + "' declares " + std::to_string(Mat_VarGetSize(info.get())) +
                                      " bytes of data, more than a file of " + std::to_string(fs::file_size(file_)) +
                                      " bytes can hold (damaged header?)");
    }
  }

  const matvar_t* get(std::initializer_list<const char*> names) const {
    for (const char* n : names) {
      if (root_) {
        matvar_t* f = Mat_VarGetStructFieldByName(root_.get(), n, 0);
        if (f) return f;
      } else {
        auto it = top_.find(n);
        if (it != top_.end()) return it->second.get();
      }
    }
    return nullptr;
  }
  const fs::path& file() const { return file_; }

 private:
  fs::path file_;
  MatFile mat_;
  MatVar root_;
  std::map<std::string, MatVar> top_;
};

// N×3 or 3×N → rows of 3 (returns false when absent).
bool triad(const MatSource& src, std::initializer_list<const char*> names, std::vector<std::array<double, 3>>& out,
           std::string& which) {
  const matvar_t* v = src.get(names);
  if (!v) return false;
  which = v->name ? v->name : *names.begin();
  std::vector<double> d;
  std::size_t r = 0, c = 0;
  if (!numeric(v, d, r, c)) throw ImportError(src.file(), 0, "'" + which + "' is not a real numeric matrix");
  if (c == 3) {
    out.resize(r);
    for (std::size_t i = 0; i < r; ++i) out[i] = {d[i], d[i + r], d[i + 2 * r]};
  } else if (r == 3) {
    out.resize(c);
    for (std::size_t i = 0; i < c; ++i) out[i] = {d[3 * i], d[3 * i + 1], d[3 * i + 2]};
  } else {
    throw ImportError(src.file(), 0, "'" + which + "' is " + std::to_string(r) + "x" + std::to_string(c) +
                                         ", expected N x 3");
  }
  return true;
}

bool vector_of(const MatSource& src, std::initializer_list<const char*> names, std::vector<double>& out,
               std::string& which) {
  const matvar_t* v = src.get(names);
  if (!v) return false;
  which = v->name ? v->name : *names.begin();
  std::size_t r = 0, c = 0;
  if (!numeric(v, out, r, c) || (r != 1 && c != 1)) {
    throw ImportError(src.file(), 0, "'" + which + "' is not a real numeric vector");
  }
  return true;
}

MatVar make_double(const char* name, std::size_t rows, std::size_t cols, const double* data) {
  std::size_t dims[2] = {rows, cols};
  return MatVar(Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, const_cast<double*>(data), 0));
}
MatVar make_int32(const char* name, std::size_t rows, std::size_t cols, const std::int32_t* data) {
  std::size_t dims[2] = {rows, cols};
  return MatVar(Mat_VarCreate(name, MAT_C_INT32, MAT_T_INT32, 2, dims, const_cast<std::int32_t*>(data), 0));
}
MatVar make_text(const char* name, const std::string& s) {
  std::size_t dims[2] = {1, s.size()};
  return MatVar(Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UINT8, 2, dims, const_cast<char*>(s.data()), 0));
}

// The variables an import looks for, as found (names as in the file, empty when absent).
struct MatData {
  std::vector<std::array<double, 3>> acc, gyr, acc_counts, gyr_counts;
  std::string acc_name, gyr_name, acc_counts_name, gyr_counts_name, t_name, fs_name, temp_name, lsb_name;
  bool have_acc = false, have_acc_counts = false, have_gyr = false, have_gyr_counts = false;
  std::vector<double> t, rate_v, temp, acc_lsb_v, gyr_lsb_v;
  bool have_t = false, have_fs = false, have_temp = false, have_acc_lsb = false, have_gyr_lsb = false;

  std::size_t rows() const { return have_acc ? acc.size() : acc_counts.size(); }
  bool fixed_rate() const { return have_fs && rate_v.size() == 1 && rate_v[0] > 0.0; }
  double acc_lsb() const { return have_acc_lsb && !acc_lsb_v.empty() ? acc_lsb_v[0] : 0.0; }
  double gyr_lsb() const { return have_gyr_lsb && !gyr_lsb_v.empty() ? gyr_lsb_v[0] : 0.0; }
  bool has_gyro() const { return have_gyr || (have_gyr_counts && gyr_lsb() > 0.0); }
};

// Finds the variables (or struct fields) under their accepted names.
MatData read_mat_data(const MatSource& src) {
  MatData m;
  m.have_acc = triad(src, {"acc", "accel", "accelerometer"}, m.acc, m.acc_name);
  m.have_acc_counts = triad(src, {"acc_counts"}, m.acc_counts, m.acc_counts_name);
  m.have_gyr = triad(src, {"gyro", "gyr", "gyroscope"}, m.gyr, m.gyr_name);
  m.have_gyr_counts = triad(src, {"gyro_counts", "gyr_counts"}, m.gyr_counts, m.gyr_counts_name);
  m.have_t = vector_of(src, {"t", "time", "timestamp"}, m.t, m.t_name);
  m.have_fs = vector_of(src, {"fs", "rate_hz", "rate"}, m.rate_v, m.fs_name);
  m.have_temp = vector_of(src, {"temp", "temperature"}, m.temp, m.temp_name);
  m.have_acc_lsb = vector_of(src, {"acc_lsb"}, m.acc_lsb_v, m.lsb_name);
  m.have_gyr_lsb = vector_of(src, {"gyro_lsb", "gyr_lsb"}, m.gyr_lsb_v, m.lsb_name);
  return m;
}

// An accelerometer (SI or counts with LSB), every series as long as it, and a time or a rate.
void check_mat_data(const fs::path& file, const MatData& m) {
  if (!m.have_acc && !(m.have_acc_counts && m.have_acc_lsb)) {
    throw ImportError(file, 0, "no accelerometer: expected a variable/field 'acc' (N x 3, m/s^2), or "
                               "'acc_counts' with 'acc_lsb'");
  }
  const std::size_t n = m.rows();
  auto check_len = [&](std::size_t len, const std::string& name) {
    if (len != n) {
      throw ImportError(file, 0, "'" + name + "' has " + std::to_string(len) + " rows, the accelerometer " +
                                     std::to_string(n));
    }
  };
  if (m.have_acc_counts) check_len(m.acc_counts.size(), m.acc_counts_name);
  if (m.have_gyr) check_len(m.gyr.size(), m.gyr_name);
  if (m.have_gyr_counts) check_len(m.gyr_counts.size(), m.gyr_counts_name);
  if (m.have_temp) check_len(m.temp.size(), m.temp_name);
  if (m.have_t) check_len(m.t.size(), m.t_name);
  if (!m.have_t && !m.fixed_rate()) {
    throw ImportError(file, 0, "no time: expected 't' (N-vector, s) or a positive scalar 'fs' (Hz)");
  }
}

// Row i as a sample: time [s] (t × time_scale_s, or i / fs), acceleration [m/s²] and rate [rad/s]
// (SI × scale, or counts × LSB), counts, temperature [°C].
ImuSample mat_sample(const MatData& m, std::size_t i, const MatOptions& opt) {
  ImuSample s;
  s.t_s = m.have_t ? m.t[i] * opt.time_scale_s : static_cast<double>(i) / m.rate_v[0];
  const bool has_gyro = m.has_gyro();
  for (int k = 0; k < 3; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    if (m.have_acc_counts) s.accel_counts[k] = static_cast<std::int32_t>(std::lround(m.acc_counts[i][uk]));
    s.accel_mps2[k] = m.have_acc ? m.acc[i][uk] * opt.accel_scale : m.acc_counts[i][uk] * m.acc_lsb();
    if (m.have_gyr_counts) s.gyro_counts[k] = static_cast<std::int32_t>(std::lround(m.gyr_counts[i][uk]));
    if (m.have_gyr) {
      s.gyro_radps[k] = m.gyr[i][uk] * opt.gyro_scale;
    } else if (has_gyro) {
      s.gyro_radps[k] = m.gyr_counts[i][uk] * m.gyr_lsb();
    }
  }
  if (m.have_temp) s.temperature_c = m.temp[i];
  return s;
}

// Segments from a struct array 'segments' with fields kind, label, t_start_s, t_end_s [s].
void add_mat_segments(const MatSource& src, const fs::path& file, Recording& rec) {
  const matvar_t* segs = src.get({"segments"});
  if (!segs || segs->class_type != MAT_C_STRUCT) return;
  std::size_t count = 1;
  for (int d = 0; d < segs->rank; ++d) count *= segs->dims[d];
  auto* sv = const_cast<matvar_t*>(segs);
  for (std::size_t i = 0; i < count; ++i) {
    std::vector<double> a, b;
    std::size_t r = 0, c = 0;
    matvar_t* t0 = Mat_VarGetStructFieldByName(sv, "t_start_s", i);
    matvar_t* t1 = Mat_VarGetStructFieldByName(sv, "t_end_s", i);
    if (!numeric(t0, a, r, c) || a.size() != 1 || !numeric(t1, b, r, c) || b.size() != 1) {
      throw ImportError(file, 0, "segments(" + std::to_string(i + 1) +
                                     ") needs scalar fields t_start_s and t_end_s");
    }
    // kind: a segment kind's name; absent or empty means a static position ("orientation").
    const std::string kind_text = text(Mat_VarGetStructFieldByName(sv, "kind", i));
    const auto kind = kind_text.empty() ? SegmentKind::kOrientation : segment_kind_from_string(kind_text);
    if (!kind) {
      throw ImportError(file, 0, "segments(" + std::to_string(i + 1) + ").kind '" + kind_text +
                                     "' is not a segment kind (" + yaml::join(segment_kind_names()) + ")");
    }
    Segment seg = make_segment(static_cast<int>(i), *kind, text(Mat_VarGetStructFieldByName(sv, "label", i)), a[0], b[0]);
    rec.segments.push_back(seg);
  }
}

// Sensor description: rate [Hz] (fs, or from the median sample step), gyro, temperature, LSB sizes.
void set_mat_sensor_info(const MatData& m, const MatOptions& opt, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = m.fixed_rate() ? m.rate_v[0] : 0.0;  // 0: set by the timestamp repair
  info.has_gyro = m.has_gyro();
  info.has_temperature = m.have_temp;
  info.accel_lsb_mps2 = m.acc_lsb();
  info.gyro_lsb_radps = m.gyr_lsb();
  rec.header.identity = opt.identity;
  rec.header.gravity_mps2 = opt.gravity_mps2;
}

}  // namespace

Recording import_mat(const fs::path& file, const MatOptions& opt) {
  MatSource src(file, opt.struct_name);
  const MatData m = read_mat_data(src);
  check_mat_data(file, m);
  const std::size_t n = m.rows();
  Recording rec = new_recording(file, "mat");
  rec.samples.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    rec.samples[i] = mat_sample(m, i, opt);
    if (m.have_t && i > 0 && rec.samples[i].t_s < rec.samples[i - 1].t_s) {  // repeats are repaired below
      throw ImportError(file, 0, "'" + m.t_name + "' goes back at element " + std::to_string(i + 1));
    }
  }
  add_mat_segments(src, file, rec);
  set_mat_sensor_info(m, opt, rec);
  const bool has_gyro = m.has_gyro();
  const std::size_t gaps = m.have_t ? repair_timestamps(rec, m.fixed_rate() ? m.rate_v[0] : 0.0).gaps : 0;
  add_import_event(rec, "imported " + std::to_string(n) + " samples from " + file.string() +
                            " (MATLAB file" + (opt.struct_name.empty() ? "" : ", struct " + opt.struct_name) +
                            "; accel from '" + (m.have_acc ? m.acc_name : m.acc_counts_name) + "'" +
                            (has_gyro ? ", gyro from '" + (m.have_gyr ? m.gyr_name : m.gyr_counts_name) + "'" : ", no gyro") +
                            (m.have_t ? ", time '" + m.t_name + "'" : ", rate '" + m.fs_name + "'") +
                            (gaps ? "; " + std::to_string(gaps) + " gap(s) flagged" : "") + ")");
  return rec;
}

namespace {

// The samples as column-major N x 1 / N x 3 arrays: time [s], acceleration [m/s²], rate [rad/s],
// their counts, temperature [°C].
struct MatColumns {
  std::vector<double> t, acc, gyr, temp;
  std::vector<std::int32_t> acc_c, gyr_c;
};

MatColumns mat_columns(const Recording& rec) {
  const std::size_t n = rec.samples.size();
  MatColumns m{std::vector<double>(n), std::vector<double>(3 * n), std::vector<double>(3 * n), std::vector<double>(n),
               std::vector<std::int32_t>(3 * n), std::vector<std::int32_t>(3 * n)};
  for (std::size_t i = 0; i < n; ++i) {
    const ImuSample& s = rec.samples[i];
    m.t[i] = s.t_s;
    m.temp[i] = s.temperature_c;
    for (std::size_t k = 0; k < 3; ++k) {
      const int ik = static_cast<int>(k);
      m.acc[i + k * n] = s.accel_mps2[ik];
      m.gyr[i + k * n] = s.gyro_radps[ik];
      m.acc_c[i + k * n] = s.accel_counts[k];
      m.gyr_c[i + k * n] = s.gyro_counts[k];
    }
  }
  return m;
}

// The segments as a struct array with fields kind, label, t_start_s, t_end_s [s].
MatVar segments_struct(const Recording& rec, const fs::path& file) {
  const char* segment_fields[] = {"kind", "label", "t_start_s", "t_end_s", nullptr};
  std::size_t dims[2] = {rec.segments.size(), 1};
  MatVar s(Mat_VarCreateStruct2("segments", 2, dims, segment_fields));
  if (!s) throw ImportError(file, 0, "matio failed to create 'segments'");
  for (std::size_t i = 0; i < rec.segments.size(); ++i) {
    const Segment& seg = rec.segments[i];
    Mat_VarSetStructFieldByName(s.get(), "kind", i, make_text("kind", to_string(seg.kind)).release());
    Mat_VarSetStructFieldByName(s.get(), "label", i, make_text("label", seg.label).release());
    Mat_VarSetStructFieldByName(s.get(), "t_start_s", i, make_double("t_start_s", 1, 1, &seg.t_start_s).release());
    Mat_VarSetStructFieldByName(s.get(), "t_end_s", i, make_double("t_end_s", 1, 1, &seg.t_end_s).release());
  }
  return s;
}

// Writes variables to a MAT file: at the top level each at once, or (struct_name given)
// collected and written as the fields of one struct by finish().
class MatWriter {
 public:
  MatWriter(mat_t* mat, const fs::path& file, const std::string& struct_name)
      : mat_(mat), file_(file), struct_name_(struct_name) {}

  void write(MatVar v, const char* what) {
    if (!v) throw ImportError(file_, 0, std::string("matio failed to create '") + what + "'");
    if (!struct_name_.empty()) {
      fields_.emplace_back(what, std::move(v));
      return;
    }
    if (Mat_VarWrite(mat_, v.get(), MAT_COMPRESSION_NONE) != 0) {
      throw ImportError(file_, 0, std::string("matio failed to write '") + what + "'");
    }
  }

  void finish() {
    if (struct_name_.empty()) return;
    std::vector<const char*> names;
    for (const auto& f : fields_) names.push_back(f.first.c_str());
    names.push_back(nullptr);
    std::size_t dims[2] = {1, 1};
    MatVar root(Mat_VarCreateStruct2(struct_name_.c_str(), 2, dims, names.data()));
    if (!root) throw ImportError(file_, 0, "matio failed to create struct '" + struct_name_ + "'");
    for (auto& f : fields_) Mat_VarSetStructFieldByName(root.get(), f.first.c_str(), 0, f.second.release());
    if (Mat_VarWrite(mat_, root.get(), MAT_COMPRESSION_NONE) != 0) {
      throw ImportError(file_, 0, "matio failed to write struct '" + struct_name_ + "'");
    }
  }

 private:
  mat_t* mat_;
  fs::path file_;
  std::string struct_name_;
  std::vector<std::pair<std::string, MatVar>> fields_;
};

}  // namespace

void export_mat(const Recording& rec, const fs::path& file, const std::string& struct_name) {
  MatFile mat(Mat_CreateVer(file.c_str(), nullptr, MAT_FT_MAT5));
  if (!mat) throw ImportError(file, 0, "matio cannot create it");
  const std::size_t n = rec.samples.size();
  const MatColumns c = mat_columns(rec);
  const double fs_hz = rec.header.info.output_rate_hz;
  const double acc_lsb = rec.header.info.accel_lsb_mps2, gyr_lsb = rec.header.info.gyro_lsb_radps;
  MatWriter w(mat.get(), file, struct_name);
  w.write(make_double("t", n, 1, c.t.data()), "t");
  w.write(make_double("fs", 1, 1, &fs_hz), "fs");
  w.write(make_double("acc", n, 3, c.acc.data()), "acc");
  w.write(make_int32("acc_counts", n, 3, c.acc_c.data()), "acc_counts");
  w.write(make_double("acc_lsb", 1, 1, &acc_lsb), "acc_lsb");
  if (rec.header.info.has_gyro) {
    w.write(make_double("gyro", n, 3, c.gyr.data()), "gyro");
    w.write(make_int32("gyro_counts", n, 3, c.gyr_c.data()), "gyro_counts");
    w.write(make_double("gyro_lsb", 1, 1, &gyr_lsb), "gyro_lsb");
  }
  if (rec.header.info.has_temperature) w.write(make_double("temp", n, 1, c.temp.data()), "temp");
  if (!rec.segments.empty()) w.write(segments_struct(rec, file), "segments");
  w.finish();
}

#else  // built without matio

namespace {
constexpr const char* kNoMatio =
    "MATLAB files need matio, and this stend_core was built without it (install libmatio-dev; "
    "io/CMakeLists.txt links PkgConfig::MATIO and defines STEND_HAVE_MATIO)";
}

bool mat_supported() { return false; }

Recording import_mat(const fs::path& file, const MatOptions&) { throw ImportError(file, 0, kNoMatio); }
void export_mat(const Recording&, const fs::path& file, const std::string&) {
  throw ImportError(file, 0, kNoMatio);
}

#endif

}  // namespace stend::io
