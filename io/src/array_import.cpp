// Named arrays made a recording (import_arrays in arrays.hpp): the names the import options give
// (or the conventional ones, when none are given) found in the inputs, each sensor read a block at
// a time, converted by its own scale (counts with an LSB, or a unit) and joined to the others —
// row by row when their lengths agree, on their times when each has one, else refused.
#include "arrays.hpp"

#include "import_common.hpp"

#include <stend/io/timestamps.hpp>
#include <stend/physics/units.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

namespace stend::io::detail {

namespace fs = std::filesystem;

namespace {

// Rows read per block [samples].
constexpr std::size_t kBlockRows = std::size_t{1} << 14;
// Sensors without times are joined row by row only when the shorter holds at least this fraction
// of the longer's rows (a logger that stopped one sensor a little later); more differing lengths
// mean differing rates, which rows alone cannot join.
constexpr double kMinRowRatioByIndex = 0.9;

// One column of one array of one input.
struct ColumnRef {
  const ArrayFile* file = nullptr;
  ArrayInfo array;
  std::size_t col = 0;
  std::string label() const {
    return array.cols == 1 ? "'" + array.name + "'" : "'" + array.name + ":" + std::to_string(col) + "'";
  }
};

std::string shape(const ArrayInfo& a) {
  return std::to_string(a.rows) + "x" + std::to_string(a.cols) + " " + a.type;
}

// "file: a (100x3 float64), b (100x1 int16); file2: …" — what the inputs hold, for errors.
std::string inventory(const std::vector<const ArrayFile*>& files) {
  std::string out;
  for (const ArrayFile* f : files) {
    std::string list;
    for (const ArrayInfo& a : f->arrays()) list += (list.empty() ? "" : ", ") + a.name + " (" + shape(a) + ")";
    out += (out.empty() ? "" : "; ") + f->file().filename().string() + ": " + (list.empty() ? "no numeric arrays" : list);
  }
  return out;
}

std::optional<std::pair<const ArrayFile*, ArrayInfo>> find_array(const std::vector<const ArrayFile*>& files,
                                                                   const std::string& name) {
  for (const ArrayFile* f : files)
    for (const ArrayInfo& a : f->arrays())
      if (a.name == name) return std::make_pair(f, a);
  return std::nullopt;
}

// "A" or "A:k" (column k, 0-based) of an array, or a bare index: column k of the inputs' only
// array, or the k-th array when each is one column (raw records' fields). `whole` accepts an array
// of several columns named alone (a triad's N×3 / N×4 array).
std::vector<ColumnRef> resolve(const std::vector<const ArrayFile*>& files, const CsvColumn& c, const std::string& role,
                               bool whole) {
  auto fail = [&](const std::string& why) -> std::vector<ColumnRef> {
    throw ImportError(files.front()->file(), 0, role + ": " + why + "; the inputs hold " + inventory(files));
  };
  if (c.index >= 0) {
    std::vector<std::pair<const ArrayFile*, ArrayInfo>> all;
    for (const ArrayFile* f : files)
      for (const ArrayInfo& a : f->arrays()) all.emplace_back(f, a);
    const auto k = static_cast<std::size_t>(c.index);
    if (all.size() == 1 && k < all[0].second.cols) return {{all[0].first, all[0].second, k}};
    if (std::all_of(all.begin(), all.end(), [](const auto& p) { return p.second.cols == 1; }) && k < all.size())
      return {{all[k].first, all[k].second, 0}};
    return fail("no column " + std::to_string(k) + " (an index names a column of the only array, or the k-th of "
                "one-column arrays)");
  }
  if (auto found = find_array(files, c.name)) {
    const auto& [f, a] = *found;
    if (a.cols == 0 || a.rows == 0) return fail("'" + c.name + "' is " + shape(a) + ": it holds no values");
    if (a.cols == 1) return {{f, a, 0}};
    if (!whole) return fail("'" + c.name + "' is " + shape(a) + "; name one column as " + c.name + ":K (0-based)");
    std::vector<ColumnRef> cols;
    for (std::size_t k = 0; k < a.cols; ++k) cols.push_back({f, a, k});
    return cols;
  }
  const auto colon = c.name.rfind(':');
  if (colon != std::string::npos) {
    std::size_t k = 0;
    const std::string digits = c.name.substr(colon + 1);
    const auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), k);
    if (ec == std::errc() && p == digits.data() + digits.size() && !digits.empty()) {
      if (auto found = find_array(files, c.name.substr(0, colon))) {
        if (k < found->second.cols) return {{found->first, found->second, k}};
        return fail("'" + found->second.name + "' has " + std::to_string(found->second.cols) + " columns, no column " +
                    std::to_string(k));
      }
    }
  }
  return fail("no array named '" + c.name + "'");
}

// A sensor as named: its columns (time first when it carries its own), rows, file values → SI.
struct Sensor {
  std::string role;                 // "accel", "gyro", "temperature", "time"
  std::vector<ColumnRef> values;    // 3 for a triad, 1 for temperature or time
  std::optional<ColumnRef> own_time;
  std::size_t rows = 0;
  std::string describe() const {
    std::string s = values.front().label();
    if (values.size() == 3 && values[0].array.name == values[2].array.name && values[0].array.cols >= 3)
      s = "'" + values[0].array.name + "'";
    else if (values.size() == 3)
      s = values[0].label() + "," + values[1].label() + "," + values[2].label();
    return s + (own_time ? " with its own time (column " + std::to_string(own_time->col) + ")" : "");
  }
};

// A triad: one array of 3 columns (x y z) or 4 ([t x y z]), or three single columns.
std::optional<Sensor> triad(const std::vector<const ArrayFile*>& files, const std::array<CsvColumn, 3>& cols,
                            const std::string& role) {
  if (cols[0].empty()) return std::nullopt;
  Sensor s;
  s.role = role;
  if (cols[1].empty()) {
    auto all = resolve(files, cols[0], role, true);
    if (all.size() == 4) {
      s.own_time = all[0];
      all.erase(all.begin());
    }
    if (all.size() != 3)
      throw ImportError(files.front()->file(), 0, role + ": '" + all[0].array.name + "' is " + shape(all[0].array) +
                                                      "; a triad is N x 3 (x y z) or N x 4 (t x y z), or name three "
                                                      "columns x,y,z");
    s.values = std::move(all);
  } else {
    for (const CsvColumn& c : cols) s.values.push_back(resolve(files, c, role, false).front());
  }
  s.rows = s.values[0].array.rows;
  for (const ColumnRef& r : s.values)
    if (r.array.rows != s.rows)
      throw ImportError(files.front()->file(), 0, role + ": " + s.values[0].label() + " has " + std::to_string(s.rows) +
                                                      " rows, " + r.label() + " " + std::to_string(r.array.rows));
  return s;
}

// A single column (time, temperature); a temperature array of 2 columns is [t T].
std::optional<Sensor> single(const std::vector<const ArrayFile*>& files, const CsvColumn& c, const std::string& role) {
  if (c.empty()) return std::nullopt;
  Sensor s;
  s.role = role;
  auto all = resolve(files, c, role, role == "temperature");
  if (all.size() == 2) {
    s.own_time = all[0];
    all.erase(all.begin());
  }
  if (all.size() != 1)
    throw ImportError(files.front()->file(), 0, role + ": '" + all[0].array.name + "' is " + shape(all[0].array) +
                                                    "; expected one column (or [t value])");
  s.values = std::move(all);
  s.rows = s.values[0].array.rows;
  return s;
}

// --- the conventional names, when the options name none ----------------------------------------

bool has_array(const std::vector<const ArrayFile*>& files, const std::string& name, std::size_t min_cols = 1) {
  const auto f = find_array(files, name);
  return f && f->second.cols >= min_cols;
}

std::array<CsvColumn, 3> guess_triad(const std::vector<const ArrayFile*>& files, std::initializer_list<const char*> whole,
                                     std::initializer_list<const char*> prefixes) {
  for (const char* w : whole)
    if (has_array(files, w, 3)) return {CsvColumn(w), {}, {}};
  for (const char* p : prefixes)
    for (const char* sep : {"_", ""}) {
      const std::string base = std::string(p) + sep;
      if (has_array(files, base + "x") && has_array(files, base + "y") && has_array(files, base + "z"))
        return {CsvColumn(base + "x"), CsvColumn(base + "y"), CsvColumn(base + "z")};
    }
  return {};
}

CsvColumn guess_single(const std::vector<const ArrayFile*>& files, std::initializer_list<const char*> names) {
  for (const char* n : names)
    if (has_array(files, n)) return CsvColumn(n);
  return {};
}

// The options with the conventional names filled in where the options name no sensor at all.
ImportOptions with_conventional_names(const std::vector<const ArrayFile*>& files, ImportOptions o) {
  if (!o.accel[0].empty() || !o.gyro[0].empty()) return o;
  o.accel = guess_triad(files, {"acc", "accel", "accelerometer", "acc_xyz", "A_xyz"},
                        {"acc", "accel", "accelerometer", "a"});
  o.gyro = guess_triad(files, {"gyro", "gyr", "gyroscope", "gyro_xyz", "W_xyz", "omega"},
                       {"gyro", "gyr", "gyroscope", "g", "w"});
  if (o.time.empty()) o.time = guess_single(files, {"t", "time", "timestamp", "timestamps", "t_s"});
  if (o.temperature.empty()) o.temperature = guess_single(files, {"temp", "temperature", "temp_c", "temperature_c"});
  if (o.accel[0].empty() && o.gyro[0].empty())
    throw ImportError(files.front()->file(), 0,
                      "no accelerometer or gyroscope under the usual names; name them with --accel and --gyro "
                      "(an N x 3 array, or three columns x,y,z). The inputs hold " + inventory(files));
  return o;
}

// --- reading ------------------------------------------------------------------------------------

// A sensor's columns (its own time first) read a block at a time: each array it draws on opened
// once, its rows read into a buffer and the columns picked from it.
class SensorReader {
 public:
  explicit SensorReader(const Sensor& s) {
    if (s.own_time) add(*s.own_time);
    for (const ColumnRef& r : s.values) add(r);
  }
  // The next n rows: n × width() values, row after row.
  const std::vector<double>& read(std::size_t n) {
    for (auto& [key, a] : open_) {
      a.buf.resize(n * a.series->cols);
      a.series->read(n, a.buf.data());
    }
    out_.resize(n * picks_.size());
    for (std::size_t j = 0; j < picks_.size(); ++j) {
      const Open& a = *picks_[j].first;
      const std::size_t col = picks_[j].second, w = a.series->cols;
      for (std::size_t i = 0; i < n; ++i) out_[i * picks_.size() + j] = a.buf[i * w + col];
    }
    return out_;
  }
  std::size_t width() const { return picks_.size(); }

 private:
  struct Open {
    std::unique_ptr<ArraySeries> series;
    std::vector<double> buf;
  };
  void add(const ColumnRef& r) {
    auto& a = open_[{r.file, r.array.name}];
    if (!a.series) a.series = r.file->open(r.array.name);
    picks_.emplace_back(&a, r.col);
  }
  std::map<std::pair<const ArrayFile*, std::string>, Open> open_;
  std::vector<std::pair<const Open*, std::size_t>> picks_;
  std::vector<double> out_;
};

// A sensor read along its own time and interpolated linearly at the lead's times [s].
class TimedSensor {
 public:
  TimedSensor(const Sensor& s, double time_scale_s, const fs::path& file)
      : reader_(s), rows_(s.rows), scale_(time_scale_s), file_(file), name_(s.describe()) {}
  // The values at t [s] into out (width − 1 of them); false when t is outside the sensor's times.
  bool at(double t, double* out) {
    while (have_next() && next_t() <= t) advance();
    if (!have_prev_ || !have_next() || t < prev_t_) return have_prev_ && t == prev_t_ && copy_prev(out);
    const double w = (t - prev_t_) / (next_t() - prev_t_);
    const std::size_t m = reader_.width();
    for (std::size_t j = 1; j < m; ++j)
      out[j - 1] = prev_[j] + w * (block_[pos_ * m + j] - prev_[j]);
    return true;
  }

 private:
  bool have_next() {
    if (pos_ < in_block_) return true;
    if (read_ >= rows_) return false;
    const std::size_t n = std::min(kBlockRows, rows_ - read_);
    block_ = reader_.read(n);
    in_block_ = n;
    pos_ = 0;
    read_ += n;
    return true;
  }
  double next_t() const { return block_[pos_ * reader_.width()] * scale_; }
  void advance() {
    const std::size_t m = reader_.width();
    const double t = next_t();
    if (have_prev_ && t < prev_t_)
      throw ImportError(file_, 0, name_ + ": its time goes back at row " + std::to_string(read_ - in_block_ + pos_ + 1));
    prev_.assign(block_.begin() + static_cast<std::ptrdiff_t>(pos_ * m),
                 block_.begin() + static_cast<std::ptrdiff_t>((pos_ + 1) * m));
    prev_t_ = t;
    have_prev_ = true;
    ++pos_;
  }
  bool copy_prev(double* out) const {
    std::copy(prev_.begin() + 1, prev_.end(), out);
    return true;
  }
  SensorReader reader_;
  std::size_t rows_, read_ = 0, in_block_ = 0, pos_ = 0;
  double scale_;
  fs::path file_;
  std::string name_;
  std::vector<double> block_, prev_;
  double prev_t_ = 0.0;
  bool have_prev_ = false;
};

// How each sensor reaches the samples.
enum class Join { kByRow, kByTime };

struct Plan {
  std::optional<Sensor> time, accel, gyro, temperature;
  std::size_t rows = 0;          // samples
  bool lead_time_own = false;    // the samples' times are the lead's own (N×4)
  Join gyro_join = Join::kByRow, temperature_join = Join::kByRow;
  std::string what;              // what was done, for the import event
  // The sensor whose rows are the samples: the accelerometer, else the gyroscope.
  const Sensor& lead() const { return accel ? *accel : *gyro; }
};

bool timed(const Sensor& s) { return s.own_time.has_value(); }

// How `s` joins the lead: row by row when it has the lead's rows (or nearly, without times to join
// on), on its own times when both have times.
Join choose_join(const fs::path& file, Plan& p, const Sensor& s, bool lead_has_time) {
  if (s.rows == p.lead().rows && !timed(s)) return Join::kByRow;
  if (timed(s) && lead_has_time) {
    p.what += "; " + s.role + " joined on its own time (linear interpolation at the " + p.lead().role + "'s times)";
    return Join::kByTime;
  }
  if (timed(s) && s.rows == p.lead().rows) return Join::kByRow;
  const double ratio = static_cast<double>(std::min(s.rows, p.lead().rows)) / static_cast<double>(std::max(s.rows, p.lead().rows));
  if (ratio < kMinRowRatioByIndex)
    throw ImportError(file, 0, s.role + " " + s.describe() + " has " + std::to_string(s.rows) + " rows and the " +
                                   p.lead().role + " " + std::to_string(p.lead().rows) +
                                   ": without a time for each, sensors of such different lengths cannot be joined "
                                   "row by row (their rates differ?). Give each its time: an N x 4 [t x y z] array, "
                                   "or --time for the samples and [t value] for the other");
  p.what += "; " + s.role + " joined row by row to the " + p.lead().role + " (" + std::to_string(s.rows) + " vs " +
            std::to_string(p.lead().rows) + " rows: the longer cut to the shorter)";
  p.rows = std::min(p.rows, s.rows);
  return Join::kByRow;
}

Plan make_plan(const std::vector<const ArrayFile*>& files, const ImportOptions& o) {
  Plan p;
  const fs::path& file = files.front()->file();
  p.accel = triad(files, o.accel, "accel");
  p.gyro = triad(files, o.gyro, "gyro");
  p.temperature = single(files, o.temperature, "temperature");
  p.time = single(files, o.time, "time");
  if (!p.accel && !p.gyro)
    throw ImportError(file, 0, "no accelerometer or gyroscope named (--accel, --gyro: an N x 3 array or three columns "
                               "x,y,z); the inputs hold " + inventory(files));
  p.rows = p.lead().rows;
  if (p.time && p.time->rows != p.rows)
    throw ImportError(file, 0, "time " + p.time->describe() + " has " + std::to_string(p.time->rows) + " rows, the " +
                                   p.lead().role + " " + std::to_string(p.rows));
  p.lead_time_own = !p.time && timed(p.lead());
  const bool lead_has_time = p.time || p.lead_time_own;
  if (!lead_has_time && !(o.rate_hz > 0.0))
    throw ImportError(file, 0, "no time: name one (--time, or an N x 4 [t x y z] array) or give the rate (--rate-hz)");
  p.what = p.time ? "time " + p.time->describe()
                  : p.lead_time_own ? "time from the " + p.lead().role + "'s own column"
                                    : "time i / " + fmt_g(o.rate_hz) + " Hz";
  if (p.accel && p.gyro) p.gyro_join = choose_join(file, p, *p.gyro, lead_has_time);
  if (p.temperature) p.temperature_join = choose_join(file, p, *p.temperature, lead_has_time);
  return p;
}

// File values → SI for a triad: counts (kept as counts too) or a unit.
void set_triad(const double* v, const ValueScale& scale, std::int32_t counts[3], Eigen::Vector3d& si) {
  for (int k = 0; k < 3; ++k) {
    if (scale.counts()) {
      const double c = std::round(v[k]);
      if (std::abs(c) < 2147483647.0) counts[k] = static_cast<std::int32_t>(c);
      si[k] = (v[k] - scale.offset) * scale.lsb;
    } else {
      si[k] = v[k] * scale.unit;
    }
  }
}

// Reads the plan's sensors a block at a time into samples, handed to `out`. Returns how many;
// *outside counts lead rows dropped because a sensor joined on time had no value at their time.
std::size_t stream_samples(const Plan& p, const ImportOptions& o, const fs::path& file, SampleSink& out,
                           std::size_t* outside) {
  SensorReader lead(p.lead());
  std::optional<SensorReader> time, gyro_rows, temp_rows;
  std::optional<TimedSensor> gyro_t, temp_t;
  if (p.time) time.emplace(*p.time);
  if (p.accel && p.gyro) {  // a gyroscope without an accelerometer is the lead
    if (p.gyro_join == Join::kByRow) gyro_rows.emplace(*p.gyro);
    else gyro_t.emplace(*p.gyro, o.time_scale_s, file);
  }
  if (p.temperature) {
    if (p.temperature_join == Join::kByRow) temp_rows.emplace(*p.temperature);
    else temp_t.emplace(*p.temperature, o.time_scale_s, file);
  }
  const std::size_t lw = lead.width(), gw = gyro_rows ? (timed(*p.gyro) ? 4 : 3) : 0;
  const std::size_t tw = p.temperature ? (timed(*p.temperature) ? 2 : 1) : 0;
  std::vector<ImuSample> block;
  std::size_t n_out = 0;
  double g[3], temp[1];
  for (std::size_t first = 0; first < p.rows; first += kBlockRows) {
    const std::size_t k = std::min(kBlockRows, p.rows - first);
    const std::vector<double>& a = lead.read(k);
    const std::vector<double>* tv = time ? &time->read(k) : nullptr;
    const std::vector<double>* gv = gyro_rows ? &gyro_rows->read(k) : nullptr;
    const std::vector<double>* temps = temp_rows ? &temp_rows->read(k) : nullptr;
    block.clear();
    for (std::size_t j = 0; j < k; ++j) {
      ImuSample s;
      const double* row = a.data() + j * lw;
      s.t_s = tv ? (*tv)[j] * o.time_scale_s
                 : p.lead_time_own ? row[0] * o.time_scale_s : static_cast<double>(first + j) / o.rate_hz;
      if (!p.accel) {
        set_triad(row + (lw - 3), o.gyro_value, s.gyro_counts, s.gyro_radps);
      } else {
        set_triad(row + (lw - 3), o.accel_value, s.accel_counts, s.accel_mps2);
      }
      if (gv) {
        set_triad(gv->data() + j * gw + (gw - 3), o.gyro_value, s.gyro_counts, s.gyro_radps);
      } else if (gyro_t) {
        if (!gyro_t->at(s.t_s, g)) {
          ++*outside;
          continue;
        }
        set_triad(g, o.gyro_value, s.gyro_counts, s.gyro_radps);
      }
      if (temps) {
        s.temperature_c = (*temps)[j * tw + (tw - 1)] * o.temperature_scale + o.temperature_offset_c;
      } else if (temp_t) {
        if (!temp_t->at(s.t_s, temp)) {
          ++*outside;
          continue;
        }
        s.temperature_c = temp[0] * o.temperature_scale + o.temperature_offset_c;
      }
      block.push_back(s);
    }
    out.add_samples(block.data(), block.size());
    n_out += block.size();
  }
  return n_out;
}

std::string scale_text(const ValueScale& v, bool accel) {
  if (v.counts())
    return "counts of " + fmt_g(v.lsb) + (accel ? " m/s^2" : " rad/s") + (v.offset != 0.0 ? " from " + fmt_g(v.offset) : "");
  if (accel) return v.unit == physics::kStandardGravity ? "g" : v.unit == 1.0 ? "m/s^2" : fmt_g(v.unit) + " m/s^2 per unit";
  return v.unit == physics::kDegPerSecond ? "deg/s" : v.unit == 1.0 ? "rad/s" : fmt_g(v.unit) + " rad/s per unit";
}

void set_sensor_info(const Plan& p, const ImportOptions& o, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = o.rate_hz;  // 0: set by the timestamp repair
  info.has_accel = p.accel.has_value();
  info.has_gyro = p.gyro.has_value();
  info.has_temperature = p.temperature.has_value();
  info.accel_lsb_mps2 = p.accel && o.accel_value.counts() ? o.accel_value.lsb : 0.0;
  info.gyro_lsb_radps = p.gyro && o.gyro_value.counts() ? o.gyro_value.lsb : 0.0;
  rec.header.gravity_mps2 = o.gravity_mps2;
}

}  // namespace

void import_arrays(const std::vector<const ArrayFile*>& files, const ImportOptions& options, const std::string& format,
                   Recording& rec, SampleSink& out) {
  if (files.empty()) throw std::invalid_argument("import_arrays: no input");
  const fs::path& file = files.front()->file();
  const ImportOptions o = with_conventional_names(files, options);
  const Plan p = make_plan(files, o);
  rec = new_recording(file, format);
  set_sensor_info(p, o, rec);
  std::size_t n = 0, outside = 0, gaps = 0;
  const bool timed_samples = p.time || p.lead_time_own;
  if (timed_samples) {
    TimestampRepairStream repair(rec, out, o.rate_hz);
    n = stream_samples(p, o, file, repair, &outside);
    if (n == 0) throw ImportError(file, 0, "no samples (the sensors' times do not overlap?)");
    gaps = repair.finish().gaps;
  } else {
    n = stream_samples(p, o, file, out, &outside);
    if (n == 0) throw ImportError(file, 0, "no samples");
  }
  std::string layouts;
  for (const ArrayFile* f : files) {
    layouts += (layouts.empty() ? "" : "; ") + f->file().filename().string() + ": " + f->layout();
    if (const std::string d = f->damage(); !d.empty()) add_import_event(rec, f->file().filename().string() + ": " + d, "warning");
  }
  add_import_event(rec, "imported " + std::to_string(n) + " samples (" + layouts + "): " +
                            (p.accel ? "accel " + p.accel->describe() + " in " + scale_text(o.accel_value, true)
                                     : std::string("no accelerometer")) +
                            (p.gyro ? ", gyro " + p.gyro->describe() + " in " + scale_text(o.gyro_value, false) : ", no gyro") +
                            (p.temperature ? ", temperature " + p.temperature->describe() : "") + "; " + p.what +
                            (outside ? "; " + std::to_string(outside) + " sample(s) outside the joined sensors' times dropped" : "") +
                            (gaps ? "; " + std::to_string(gaps) + " gap(s) flagged" : ""));
}

}  // namespace stend::io::detail
