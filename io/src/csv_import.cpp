// The generic CSV importer (import_csv in stend/io/importers.hpp): columns mapped by name or index
// (CsvMapping, from the import options), values in physical units or counts with their LSB, time
// from a column or from the rate.
#include "import_common.hpp"

#include <stend/io/plausibility.hpp>
#include <stend/recording/instruments.hpp>
#include <stend/io/timestamps.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Column indices (0-based, −1 = absent) that a CSV mapping resolves to.
struct CsvColumns {
  std::vector<std::string> names;  // from the column-name line (empty without one)
  std::size_t names_line = 0;      // its line
  std::array<int, 3> acc{}, gyr{};
  bool has_accel = false, has_gyro = false;
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

// One instrument's x, y, z columns resolved: all three, or none (the log lacks the instrument:
// `present` false).
void resolve_triad(const LineReader& r, const CsvMapping& map, CsvColumns& c, const std::array<CsvColumn, 3>& mapped,
                   const std::string& role, std::array<int, 3>& out, bool& present) {
  const char* axes[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    out[k] = resolve_column(r, map, c.names, c.names_line, mapped[k], role + " " + axes[k]);
    present = present || out[k] >= 0;
  }
  if (present && (out[0] < 0 || out[1] < 0 || out[2] < 0))
    throw ImportError(r.file(), 0, "the mapping names only some " + role + " columns (give x, y and z or none)");
}

// The mapping's columns resolved against the header: the accelerometer's three axes, the
// gyroscope's three axes, or both (a log of one instrument holds the other's columns not at all),
// and a time column or a fixed rate.
CsvColumns resolve_csv_columns(const LineReader& r, const CsvMapping& map, std::vector<std::string> names) {
  CsvColumns c;
  c.names = std::move(names);
  const std::size_t names_line = c.names_line = r.line();
  for (const auto* triad : {&map.accel, &map.gyro})
    if (!(*triad)[0].empty() && (*triad)[1].empty())
      throw ImportError(r.file(), 0, "'" + (*triad)[0].name + "' alone names an array (N x 3), which .mat, .npy/.npz and "
                                     "records have; in text, name the three columns x,y,z");
  resolve_triad(r, map, c, map.accel, "accel", c.acc, c.has_accel);
  resolve_triad(r, map, c, map.gyro, "gyro", c.gyr, c.has_gyro);
  if (!c.has_accel && !c.has_gyro)
    throw ImportError(r.file(), 0, "the mapping has neither accelerometer nor gyroscope columns (give accel, gyro or both)");
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
  auto field = [&](int idx) {
    const std::string_view text = f[static_cast<std::size_t>(idx)];
    double v = 0.0;
    return parse_double(text, v) ? v : number(r, text, c.name(idx));  // number() fails naming the column
  };
  ImuSample s;
  s.t_s = c.time >= 0 ? field(c.time) * map.time_scale_s : static_cast<double>(index) / map.rate_hz;
  for (int k = 0; k < 3; ++k) {
    if (c.has_accel) {
      const double a = field(c.acc[k]);
      if (map.accel_counts) s.accel_counts[k] = to_counts(r, a, c.name(c.acc[k]));
      s.accel_mps2[k] = (a - map.accel_offset_counts) * map.accel_scale;
    }
    if (c.has_gyro) {
      const double g = field(c.gyr[k]);
      if (map.gyro_counts) s.gyro_counts[k] = to_counts(r, g, c.name(c.gyr[k]));
      s.gyro_radps[k] = (g - map.gyro_offset_counts) * map.gyro_scale;
    }
  }
  if (c.temperature >= 0) {
    const double v = field(c.temperature);
    if (map.accel_counts && map.temperature_counts) s.temperature_counts = to_counts(r, v, c.name(c.temperature));
    s.temperature_c = v * map.temperature_scale + map.temperature_offset_c;
  }
  return s;
}

// What is wrong with the sample of a data line (empty: nothing): sample_problem, or a time that
// goes back from prev_t [s] (repeats are repaired afterwards).
std::string line_problem(const ImuSample& s, const SensorInfo& info, const CsvColumns& c, std::size_t count,
                         double prev_t) {
  if (std::string why = sample_problem(s, info); !why.empty()) return why;
  if (c.time >= 0 && count > 0 && s.t_s < prev_t)
    return "time " + fmt_g(s.t_s) + " s goes back (previous " + fmt_g(prev_t) + " s)";
  return {};
}

// Every data line as a sample (blank and comment lines skipped), passed to `out` in chunks; each
// line has as many fields as the column-name line (without one: as the first data line); a bad line
// (line_problem, judged on the instruments `info` says the log has) goes to `bad`. Returns the
// number of samples.
std::size_t read_csv_samples(LineReader& r, const CsvMapping& map, const CsvColumns& c, const SensorInfo& info,
                             SampleSink& out, BadSamples& bad) {
  const int needed = c.needed();
  std::size_t fields = c.names.size();
  std::string fields_from = "the column-name line (line " + std::to_string(c.names_line) + ")";
  std::vector<ImuSample> chunk;
  chunk.reserve(kDefaultChunkSamples);
  std::size_t count = 0;
  double prev_t = 0.0;
  std::string line;
  std::vector<std::string_view> f;
  while (r.next(line)) {
    if (is_blank(line)) continue;
    if (!map.comment_prefix.empty() && trim(line).substr(0, map.comment_prefix.size()) == map.comment_prefix) {
      continue;
    }
    split(line, map.delimiter, f);
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
    ImuSample s = csv_sample(r, f, map, c, count);
    blank_absent(info, s);  // what the log lacks is NaN from the start
    if (const std::string why = line_problem(s, info, c, count, prev_t); !why.empty()) {
      bad.report(ImportError(r.file(), r.line(), why));
      continue;
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
  info.has_accel = c.has_accel;
  info.has_gyro = c.has_gyro;
  info.has_temperature = c.temperature >= 0;
  info.accel_range_mps2 = map.accel_range_mps2;
  info.gyro_range_radps = map.gyro_range_radps;
  if (map.accel_counts) {
    info.accel_lsb_mps2 = c.has_accel ? map.accel_scale : 0.0;
    info.temperature_lsb_c = c.temperature >= 0 && map.temperature_counts ? map.temperature_scale : 0.0;
  }
  if (map.gyro_counts) info.gyro_lsb_radps = c.has_gyro ? map.gyro_scale : 0.0;
  rec.header.identity = map.identity;
  rec.header.gravity_mps2 = map.gravity_mps2;
}

}  // namespace

bool CsvMapping::IsValid(std::string* error) const {
  if (!(time_scale_s > 0.0 && std::isfinite(time_scale_s))) return invalid(error, "time_scale_s must be > 0");
  if (!(rate_hz >= 0.0 && std::isfinite(rate_hz))) return invalid(error, "rate_hz must be >= 0 (0: from the timestamps)");
  for (double s : {accel_scale, gyro_scale, temperature_scale})
    if (!finite_nonzero(s)) return invalid(error, "the scales must be finite and not 0");
  for (double o : {accel_offset_counts, gyro_offset_counts, temperature_offset_c})
    if (!std::isfinite(o)) return invalid(error, "the offsets must be finite");
  if (!gravity_or_unknown(gravity_mps2)) return invalid(error, "gravity_mps2 must be >= 0 (0: unknown)");
  if (!(accel_range_mps2 >= 0.0 && gyro_range_radps >= 0.0)) return invalid(error, "the ranges must be >= 0 (0: unknown)");
  return true;
}

void import_csv(const fs::path& file, const CsvMapping& map, Recording& rec, SampleSink& out) {
  require_valid(map, "csv mapping");
  LineReader r(file);
  const CsvColumns c = resolve_csv_columns(r, map, read_csv_header(r, map));
  rec = new_recording(file, "csv");
  set_csv_sensor_info(map, c, rec);
  std::size_t count = 0, gaps = 0;
  BadSamples bad(map.drop_bad_samples);
  if (c.time >= 0) {
    TimestampRepairStream repair(rec, out, map.rate_hz);
    count = read_csv_samples(r, map, c, rec.header.info, repair, bad);
    if (count == 0) throw ImportError(file, 0, "no data lines");
    gaps = repair.finish().gaps;
  } else {
    count = read_csv_samples(r, map, c, rec.header.info, out, bad);
    if (count == 0) throw ImportError(file, 0, "no data lines");
  }
  if (bad.dropped() > 0) add_import_event(rec, bad.describe(), "warning");
  add_import_event(rec, "imported " + std::to_string(count) + " samples from " +
                            file.string() + " (generic CSV; " +
                            (c.has_accel ? "accel " + std::string(map.accel_counts ? "counts" : "physical units") +
                                               ", scale " + fmt_g(map.accel_scale) + " offset " +
                                               fmt_g(map.accel_offset_counts)
                                         : "no accelerometer") +
                            (c.has_gyro ? "; gyro " + std::string(map.gyro_counts ? "counts" : "physical units") +
                                              ", scale " + fmt_g(map.gyro_scale) + " offset " +
                                              fmt_g(map.gyro_offset_counts)
                                        : "; no gyroscope") +
                            (c.time >= 0 ? ", time column" : ", fixed rate " + fmt_g(map.rate_hz) + " Hz") +
                            (gaps ? ", " + std::to_string(gaps) + " gap(s) flagged" : "") + ")");
}

Recording import_csv(const fs::path& file, const CsvMapping& map) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_csv(file, map, rec, out); });
}

}  // namespace stend::io
