// A .mat file's variables made a recording (import_mat in stend/io/importers.hpp): an
// accelerometer in SI or counts with its LSB, optionally a gyroscope, time or a rate, temperature
// and a segments struct array, each found under its accepted names (mat_variables.cpp).
#include "mat_file.hpp"

#include "import_common.hpp"

#include <stend/io/timestamps.hpp>
#include <stend/yaml/reader.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

// matio is required (CMakeLists.txt): MATLAB files are always supported.
bool mat_supported() { return true; }

namespace {

// The variables an import looks for, as found (nullptr when absent): the series read as the
// samples are made, the scalars read whole.
struct MatData {
  std::unique_ptr<MatSeries> acc, gyr, acc_counts, gyr_counts, t, temp;
  std::string fs_name;
  std::vector<double> rate_v, acc_lsb_v, gyr_lsb_v;
  bool have_fs = false, have_acc_lsb = false, have_gyr_lsb = false;

  std::size_t rows() const { return acc ? acc->rows : acc_counts->rows; }
  bool fixed_rate() const { return have_fs && rate_v.size() == 1 && rate_v[0] > 0.0; }
  double acc_lsb() const { return have_acc_lsb && !acc_lsb_v.empty() ? acc_lsb_v[0] : 0.0; }
  double gyr_lsb() const { return have_gyr_lsb && !gyr_lsb_v.empty() ? gyr_lsb_v[0] : 0.0; }
  bool has_gyro() const { return gyr || (gyr_counts && gyr_lsb() > 0.0); }
};

// A scalar-like variable's values (at most kMaxScalar of them are kept: a longer one is no scalar).
bool small_values(const MatSource& src, std::initializer_list<const char*> names, std::vector<double>& out,
                  std::string* which = nullptr) {
  constexpr std::size_t kMaxScalar = 16;
  auto s = vector_of(src, names);
  if (!s) return false;
  if (which) *which = s->name;
  if (s->rows * s->cols <= kMaxScalar) out = s->all();
  else out.assign(2, 0.0);  // not one value
  return true;
}

// Finds the variables (or struct fields) under their accepted names.
MatData read_mat_data(const MatSource& src) {
  MatData m;
  m.acc = triad(src, {"acc", "accel", "accelerometer"});
  m.acc_counts = triad(src, {"acc_counts"});
  m.gyr = triad(src, {"gyro", "gyr", "gyroscope"});
  m.gyr_counts = triad(src, {"gyro_counts", "gyr_counts"});
  m.t = vector_of(src, {"t", "time", "timestamp"});
  m.have_fs = small_values(src, {"fs", "rate_hz", "rate"}, m.rate_v, &m.fs_name);
  m.temp = vector_of(src, {"temp", "temperature"});
  m.have_acc_lsb = small_values(src, {"acc_lsb"}, m.acc_lsb_v);
  m.have_gyr_lsb = small_values(src, {"gyro_lsb", "gyr_lsb"}, m.gyr_lsb_v);
  return m;
}

// An accelerometer (SI or counts with LSB), every series as long as it, and a time or a rate.
void check_mat_data(const MatSource& src, const MatData& m) {
  const fs::path& file = src.file();
  if (!m.acc && !(m.acc_counts && m.have_acc_lsb)) {
    std::string present;
    for (const auto& [name, v] : src.variables()) present += (present.empty() ? "" : ", ") + name;
    throw ImportError(file, 0, "no accelerometer under the usual names ('acc' N x 3 in m/s^2, or 'acc_counts' with "
                               "'acc_lsb'); the file holds: " + (present.empty() ? "no variables" : present) +
                               ". Name them: --accel NAME [--gyro NAME --time NAME | --rate-hz HZ] "
                               "(docs/log-importers.md, containers read by name)");
  }
  const std::size_t n = m.rows();
  for (const MatSeries* s : {m.acc_counts.get(), m.gyr.get(), m.gyr_counts.get(), m.temp.get(), m.t.get()}) {
    if (s && s->rows != n) {
      throw ImportError(file, 0, "'" + s->name + "' has " + std::to_string(s->rows) + " rows, the accelerometer " +
                                     std::to_string(n));
    }
  }
  if (!m.t && !m.fixed_rate()) {
    throw ImportError(file, 0, "no time: expected 't' (N-vector, s) or a positive scalar 'fs' (Hz)");
  }
}

// The samples in blocks: each series' next rows, then row i of the block as a sample — time [s]
// (t × time_scale_s, or i / fs), acceleration [m/s²] and rate [rad/s] (SI × scale, or counts ×
// LSB), counts, temperature [°C] — handed to `out`. Returns how many.
std::size_t stream_mat_samples(const fs::path& file, MatData& m, const MatOptions& opt, SampleSink& out) {
  constexpr std::size_t kBlock = 1 << 14;
  const std::size_t n = m.rows();
  const bool has_gyro = m.has_gyro();
  std::vector<double> acc, acc_c, gyr, gyr_c, t, temp;
  std::vector<ImuSample> block;
  double t_prev = -std::numeric_limits<double>::infinity();
  for (std::size_t first = 0; first < n; first += kBlock) {
    const std::size_t k = std::min(kBlock, n - first);
    auto take = [k](MatSeries* s, std::vector<double>& buf) {
      if (!s) return;
      buf.resize(k * s->cols);
      s->read(k, buf.data());
    };
    take(m.acc.get(), acc);
    take(m.acc_counts.get(), acc_c);
    take(m.gyr.get(), gyr);
    take(m.gyr_counts.get(), gyr_c);
    take(m.t.get(), t);
    take(m.temp.get(), temp);
    block.assign(k, ImuSample{});
    for (std::size_t j = 0; j < k; ++j) {
      ImuSample& s = block[j];
      const std::size_t i = first + j;
      s.t_s = m.t ? t[j] * opt.time_scale_s : static_cast<double>(i) / m.rate_v[0];
      if (m.t && s.t_s < t_prev) {  // repeats are repaired later
        throw ImportError(file, 0, "'" + m.t->name + "' goes back at element " + std::to_string(i + 1));
      }
      t_prev = s.t_s;
      for (std::size_t c = 0; c < 3; ++c) {
        const int ic = static_cast<int>(c);
        if (m.acc_counts) s.accel_counts[c] = static_cast<std::int32_t>(std::lround(acc_c[3 * j + c]));
        s.accel_mps2[ic] = m.acc ? acc[3 * j + c] * opt.accel_scale : acc_c[3 * j + c] * m.acc_lsb();
        if (m.gyr_counts) s.gyro_counts[c] = static_cast<std::int32_t>(std::lround(gyr_c[3 * j + c]));
        if (m.gyr) {
          s.gyro_radps[ic] = gyr[3 * j + c] * opt.gyro_scale;
        } else if (has_gyro) {
          s.gyro_radps[ic] = gyr_c[3 * j + c] * m.gyr_lsb();
        }
      }
      if (m.temp) s.temperature_c = temp[j];
    }
    out.add_samples(block.data(), block.size());
  }
  return n;
}

// Segments from a struct array 'segments' with fields kind, label, t_start_s, t_end_s [s].
void add_mat_segments(MatSource& src, const fs::path& file, Recording& rec) {
  const matvar_t* segs = src.segments();
  if (!segs) return;
  if (segs->class_type != MAT_C_STRUCT) {
    static constexpr const char* kClasses[] = {"empty",  "cell",   "struct", "object", "char",     "sparse",
                                               "double", "single", "int8",   "uint8",  "int16",    "uint16",
                                               "int32",  "uint32", "int64",  "uint64", "function", "object (opaque)"};
    const auto cls = static_cast<std::size_t>(segs->class_type);
    throw ImportError(file, 0, std::string("'segments' is a ") + (cls < std::size(kClasses) ? kClasses[cls] : "matrix") +
                                   " array; expected a struct array with fields kind, label, t_start_s, t_end_s [s]");
  }
  auto* sv = const_cast<matvar_t*>(segs);
  const std::size_t count = struct_elements(file, sv);
  for (std::size_t i = 0; i < count; ++i) {
    std::vector<double> a, b;
    std::size_t r = 0, c = 0;
    matvar_t* t0 = struct_field(file, sv, "t_start_s", i);
    matvar_t* t1 = struct_field(file, sv, "t_end_s", i);
    if (!numeric(t0, a, r, c) || a.size() != 1 || !numeric(t1, b, r, c) || b.size() != 1) {
      throw ImportError(file, 0, "segments(" + std::to_string(i + 1) +
                                     ") needs scalar fields t_start_s and t_end_s");
    }
    auto field_text = [&](const char* name) {
      const matvar_t* f = struct_field(file, sv, name, i);
      if (f && f->class_type != MAT_C_CHAR && declared_elements(f) != std::size_t{0})  // (MATLAB's [] for a field never set is fine)
        throw ImportError(file, 0, "segments(" + std::to_string(i + 1) + ")." + name + " is not text (a char array)");
      const auto t = text(f);
      if (!t) {
        throw ImportError(file, 0, "segments(" + std::to_string(i + 1) + ")." + name +
                                       " declares more characters than its data holds (damaged)");
      }
      return *t;
    };
    // kind: a segment kind's name; absent or empty means a static position ("orientation").
    const std::string kind_text = field_text("kind");
    const auto kind = kind_text.empty() ? SegmentKind::kOrientation : segment_kind_from_string(kind_text);
    if (!kind) {
      throw ImportError(file, 0, "segments(" + std::to_string(i + 1) + ").kind '" + kind_text +
                                     "' is not a segment kind (" + yaml::join(segment_kind_names()) + ")");
    }
    Segment seg = make_segment(static_cast<int>(i), *kind, field_text("label"), a[0], b[0]);
    rec.segments.push_back(seg);
  }
}

// Sensor description: rate [Hz] (fs, or from the median sample step), gyro, temperature, LSB sizes.
void set_mat_sensor_info(const MatData& m, const MatOptions& opt, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = m.fixed_rate() ? m.rate_v[0] : 0.0;  // 0: set by the timestamp repair
  info.has_gyro = m.has_gyro();
  info.has_temperature = m.temp != nullptr;
  info.accel_lsb_mps2 = m.acc_lsb();
  info.gyro_lsb_radps = m.gyr_lsb();
  rec.header.identity = opt.identity;
  rec.header.gravity_mps2 = opt.gravity_mps2;
}

}  // namespace

bool MatOptions::IsValid(std::string* error) const {
  if (!(time_scale_s > 0.0 && std::isfinite(time_scale_s))) return invalid(error, "time_scale_s must be > 0");
  if (!(finite_nonzero(accel_scale) && finite_nonzero(gyro_scale))) return invalid(error, "the scales must be finite and not 0");
  if (!gravity_or_unknown(gravity_mps2)) return invalid(error, "gravity_mps2 must be >= 0 (0: unknown)");
  return true;
}

void import_mat(const fs::path& file, const MatOptions& opt, Recording& rec, SampleSink& out) {
  require_valid(opt, "MAT options");
  MatSource src(file, opt.struct_name);
  MatData m = read_mat_data(src);
  check_mat_data(src, m);
  rec = new_recording(file, "mat");
  add_mat_segments(src, file, rec);
  set_mat_sensor_info(m, opt, rec);
  std::size_t n = 0, gaps = 0;
  if (m.t) {
    TimestampRepairStream repair(rec, out, m.fixed_rate() ? m.rate_v[0] : 0.0);
    n = stream_mat_samples(file, m, opt, repair);
    gaps = repair.finish().gaps;
  } else {
    n = stream_mat_samples(file, m, opt, out);
  }
  const bool has_gyro = m.has_gyro();
  add_import_event(rec, "imported " + std::to_string(n) + " samples from " + file.string() +
                            " (MATLAB file" + (opt.struct_name.empty() ? "" : ", struct " + opt.struct_name) +
                            "; accel from '" + (m.acc ? m.acc->name : m.acc_counts->name) + "'" +
                            (has_gyro ? ", gyro from '" + (m.gyr ? m.gyr->name : m.gyr_counts->name) + "'" : ", no gyro") +
                            (m.t ? ", time '" + m.t->name + "'" : ", rate '" + m.fs_name + "'") +
                            (gaps ? "; " + std::to_string(gaps) + " gap(s) flagged" : "") +
                            (src.segments_in_root() ? "; the struct read whole for its segments" : "") + ")");
}

Recording import_mat(const fs::path& file, const MatOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_mat(file, opt, rec, out); });
}

}  // namespace stend::io
