#include <stend/recording/csv.hpp>
#include <stend/recording/files.hpp>
#include <stend/io/importers.hpp>
#include <stend/io/timestamps.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/table_chain.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/version.hpp>
#include <stend/yaml/reader.hpp>

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


}  // namespace stend::io
