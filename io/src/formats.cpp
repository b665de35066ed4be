// The format registry. See stend/io/formats.hpp.
#include <stend/io/formats.hpp>
#include <stend/io/logs.hpp>
#include <stend/io/rosbag.hpp>

#include <stend/io/importers.hpp>
#include <stend/io/plausibility.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/version.hpp>

#include <openssl/evp.h>
#include <stend/on_demand.hpp>

#include "arrays.hpp"
#include "import_common.hpp"
#include "import_event.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <stdexcept>

namespace stend::io {

namespace fs = std::filesystem;

namespace {

// The first `n` bytes of a file (fewer when it is shorter; none when it cannot be read).
std::string head(const fs::path& p, std::size_t n) {
  std::ifstream in(p, std::ios::binary);
  std::string out(n, '\0');
  in.read(out.data(), static_cast<std::streamsize>(n));
  out.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
  return out;
}

// The first lines of a text file that are neither blank nor comments ('#', '%').
std::vector<std::string> data_lines(const fs::path& p, std::size_t n) {
  std::vector<std::string> out;
  if (!fs::is_regular_file(p)) return out;
  std::ifstream in(p, std::ios::binary);
  std::string line;
  std::vector<char> buf(detail::kMaxLineBytes + 1);
  bool cut = false;  // a longer line is looked at by its beginning only
  while (out.size() < n && detail::read_bounded_line(in, buf, line, cut)) {
    const auto a = line.find_first_not_of(" \t");
    if (a == std::string::npos || line[a] == '#' || line[a] == '%') continue;
    if (line.find('\0') != std::string::npos) return {};  // binary
    out.push_back(line);
  }
  return out;
}

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

// Counts from the options as the nominal-LSB importers take them: LSB per g resp. per deg/s.
double per_g(const ValueScale& v, double fallback) { return v.counts() ? physics::kStandardGravity / v.lsb : fallback; }
double per_dps(const ValueScale& v, double fallback) { return v.counts() ? physics::kDegPerSecond / v.lsb : fallback; }

// A run folder's samples stay in its store; analyses read them a chunk at a time.
Recording open_run(const Inputs& in, const ImportOptions&) {
  return Recording::open(in[0], SampleLoading::kStream, TruthLoading::kStream);
}

MatOptions mat_options(const ImportOptions& o) {
  MatOptions m;
  m.time_scale_s = o.time_scale_s;
  m.accel_scale = o.accel_value.unit;
  m.gyro_scale = o.gyro_value.unit;
  m.gravity_mps2 = o.gravity_mps2;
  return m;
}
// Containers of named arrays: every input opened by `open` (one file per sensor), and the arrays
// the options name made a recording (import_arrays).
template <class Open>
void import_array_files(const Inputs& in, const ImportOptions& o, const std::string& format, const Open& open,
                        Recording& rec, SampleSink& out) {
  std::vector<std::unique_ptr<detail::ArrayFile>> files;
  std::vector<const detail::ArrayFile*> view;
  for (const auto& p : in) view.push_back(files.emplace_back(open(p)).get());
  detail::import_arrays(view, o, format, rec, out);
}

// Named variables (the options map columns, or several files: one per sensor) go through the
// named-array import; otherwise the variables are found under their usual names (import_mat).
void stream_mat(const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
  if (!o.maps_columns() && in.size() == 1) return import_mat(in[0], mat_options(o), rec, out);
  import_array_files(in, o, "mat", detail::open_mat_arrays, rec, out);
}
Recording open_mat(const Inputs& in, const ImportOptions& o) {
  return detail::import_in_memory([&](Recording& rec, SampleSink& out) { stream_mat(in, o, rec, out); });
}

void stream_npy(const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
  import_array_files(in, o, "npy", detail::open_npy, rec, out);
}
Recording open_npy(const Inputs& in, const ImportOptions& o) {
  return detail::import_in_memory([&](Recording& rec, SampleSink& out) { stream_npy(in, o, rec, out); });
}

void stream_records(const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
  import_array_files(in, o, "records", [&o](const fs::path& p) { return detail::open_records(p, o); }, rec, out);
}
Recording open_records(const Inputs& in, const ImportOptions& o) {
  return detail::import_in_memory([&](Recording& rec, SampleSink& out) { stream_records(in, o, rec, out); });
}

ImucalOptions imucal_options(const ImportOptions& o) {
  ImucalOptions m;
  if (o.rate_hz > 0.0) m.rate_hz = o.rate_hz;
  m.accel_lsb_per_g = per_g(o.accel_value, m.accel_lsb_per_g);
  m.gyro_lsb_per_dps = per_dps(o.gyro_value, m.gyro_lsb_per_dps);
  m.accel_offset_counts = o.accel_value.offset;
  m.gyro_offset_counts = o.gyro_value.offset;
  if (o.gravity_mps2 > 0.0) m.gravity_mps2 = o.gravity_mps2;
  return m;
}
Recording open_imucal(const Inputs& in, const ImportOptions& o) { return import_imucal_session(in[0], imucal_options(o)); }
void stream_imucal(const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
  import_imucal_session(in[0], imucal_options(o), rec, out);
}

Mpu6050MultiposOptions mpu6050_options(const ImportOptions& o) {
  Mpu6050MultiposOptions m;
  m.accel_lsb_per_g = per_g(o.accel_value, m.accel_lsb_per_g);
  m.gyro_lsb_per_dps = per_dps(o.gyro_value, m.gyro_lsb_per_dps);
  m.accel_offset_counts = o.accel_value.offset;
  m.gyro_offset_counts = o.gyro_value.offset;
  m.gravity_mps2 = o.gravity_mps2;
  return m;
}
Recording open_mpu6050(const Inputs& in, const ImportOptions& o) { return import_mpu6050_multipos(in[0], mpu6050_options(o)); }
void stream_mpu6050(const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
  import_mpu6050_multipos(in[0], mpu6050_options(o), rec, out);
}

ImuTkOptions imutk_options(const ImportOptions& o) {
  ImuTkOptions m;
  m.time_scale_s = o.time_scale_s;
  m.counts = o.accel_value.counts();
  m.accel_scale = m.counts ? o.accel_value.lsb : o.accel_value.unit;
  m.accel_offset_counts = o.accel_value.offset;
  m.gyro_scale = o.gyro_value.counts() ? o.gyro_value.lsb : o.gyro_value.unit;
  m.gyro_offset_counts = o.gyro_value.offset;
  m.rate_hz = o.rate_hz;
  m.gravity_mps2 = o.gravity_mps2;
  return m;
}
Recording open_imutk(const Inputs& in, const ImportOptions& o) {
  return import_imutk(in[0], in.size() > 1 ? in[1] : fs::path(), imutk_options(o));
}
void stream_imutk(const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
  import_imutk(in[0], in.size() > 1 ? in[1] : fs::path(), imutk_options(o), rec, out);
}

Recording open_table(const Inputs& in, const ImportOptions& o) { return import_static_table(in[0], o.gravity_mps2); }

MeansTableOptions means_options(const ImportOptions& o) {
  MeansTableOptions m;
  if (o.was_stated("delimiter")) m.delimiter = o.delimiter;
  m.counts = o.accel_value.counts();
  m.accel_scale = m.counts ? o.accel_value.lsb : o.accel_value.unit;
  m.accel_offset_counts = o.accel_value.offset;
  m.unit_stated = o.was_stated("accel_unit") || o.was_stated("accel_lsb");
  m.gravity_mps2 = o.gravity_mps2;
  return m;
}
// A table of means is checked for its units here: its rows, held, are no log (is_log).
Recording open_means(const Inputs& in, const ImportOptions& o) {
  Recording rec = import_means_table(in[0], means_options(o));
  check_held_means(rec, in[0], o);
  return rec;
}

Recording open_csv(const Inputs& in, const ImportOptions& o) { return import_csv(in[0], o.csv_mapping()); }
void stream_csv(const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
  import_csv(in[0], o.csv_mapping(), rec, out);
}

// OpenSSL's libcrypto, opened when an import first fingerprints its sources (core/on_demand/: only
// `stend import` needs it; loaded by every command, it costs each a millisecond at start).
struct LibCrypto {
  OnDemandLibrary lib{STEND_LIBCRYPTO_SONAME, "fingerprinting imported files (SHA-256)"};
  STEND_ON_DEMAND(lib, EVP_MD_CTX_new);
  STEND_ON_DEMAND(lib, EVP_MD_CTX_free);
  STEND_ON_DEMAND(lib, EVP_sha256);
  STEND_ON_DEMAND(lib, EVP_DigestInit_ex);
  STEND_ON_DEMAND(lib, EVP_DigestUpdate);
  STEND_ON_DEMAND(lib, EVP_DigestFinal_ex);
};
const LibCrypto& crypto() {
  static const LibCrypto table;
  return table;
}

std::string sha256_hex(const fs::path& p, const std::atomic<bool>* stop) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw InputError(p.string() + ": cannot read it to fingerprint it");
  const LibCrypto& c = crypto();
  std::unique_ptr<EVP_MD_CTX, decltype(c.EVP_MD_CTX_free)> ctx(c.EVP_MD_CTX_new(), c.EVP_MD_CTX_free);
  c.EVP_DigestInit_ex(ctx.get(), c.EVP_sha256(), nullptr);
  std::array<char, 1 << 16> buf{};
  while (in.read(buf.data(), buf.size()) || in.gcount() > 0) {
    if (stop != nullptr && *stop) throw InputError(p.string() + ": fingerprinting abandoned");
    c.EVP_DigestUpdate(ctx.get(), buf.data(), static_cast<std::size_t>(in.gcount()));
  }
  std::array<unsigned char, EVP_MAX_MD_SIZE> md{};
  unsigned int len = 0;
  c.EVP_DigestFinal_ex(ctx.get(), md.data(), &len);
  std::string hex;
  char two[3];
  for (unsigned int i = 0; i < len; ++i) {
    std::snprintf(two, sizeof two, "%02x", md[i]);
    hex += two;
  }
  return hex;
}

}  // namespace

bool looks_like_run(const fs::path& p) { return fs::is_directory(p) && fs::exists(p / "run.json"); }

namespace {

// A little-endian MAT v4 file (no text header): its first matrix header — type MOPT (M = 0
// little-endian IEEE, O = 0, P = 0…5 the value type, T = 0…2 full/text/sparse), rows, columns,
// imagf 0|1, name length with the name's terminating NUL — and a name of identifier characters.
bool looks_like_mat4(const std::string& h) {
  if (h.size() < 22) return false;
  std::int32_t f[5];
  std::memcpy(f, h.data(), sizeof f);
  const std::int32_t type = f[0], rows = f[1], cols = f[2], imagf = f[3], namlen = f[4];
  if (type < 0 || type / 1000 != 0 || (type / 100) % 10 != 0 || (type / 10) % 10 > 5 || type % 10 > 2) return false;
  if (rows < 0 || cols < 0 || (imagf != 0 && imagf != 1) || namlen < 2 || namlen > 64) return false;
  if (h.size() < 20 + static_cast<std::size_t>(namlen) || h[19 + static_cast<std::size_t>(namlen)] != '\0') return false;
  const std::string name = h.substr(20, static_cast<std::size_t>(namlen) - 1);
  return std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

}  // namespace

bool looks_like_mat(const fs::path& p) {
  // MAT v5 (and v7): a 128-byte text header starting "MATLAB 5.0 MAT-file"; v7.3 is HDF5 with its
  // signature at offset 512 (after the same kind of text header); v4 has no header (looks_like_mat4).
  static const std::string kHdf5("\x89HDF\r\n\x1a\n", 8);
  const std::string h = head(p, 520);
  return starts_with(h, "MATLAB 5.0 MAT-file") || (h.size() >= 520 && h.compare(512, 8, kHdf5) == 0) ||
         looks_like_mat4(h);
}

bool looks_like_imucal(const fs::path& p) {
  const auto lines = data_lines(p, 1);
  return !lines.empty() && starts_with(lines[0], "part,samples");
}

bool looks_like_mpu6050_multipos(const fs::path& p) {
  const auto lines = data_lines(p, 1);
  return !lines.empty() && starts_with(lines[0], "Fs,");
}

bool looks_like_imutk(const fs::path& p) {
  const auto lines = data_lines(p, 5);
  if (lines.empty()) return false;
  for (const std::string& l : lines) {
    std::size_t fields = 0;
    std::size_t i = 0;
    auto sep = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == ';'; };
    while (i < l.size()) {
      while (i < l.size() && sep(l[i])) ++i;
      if (i >= l.size()) break;
      std::size_t j = i;
      while (j < l.size() && !sep(l[j])) ++j;
      char* end = nullptr;
      const std::string field = l.substr(i, j - i);
      std::strtod(field.c_str(), &end);
      if (end != field.c_str() + field.size()) return false;
      ++fields;
      i = j;
    }
    if (fields != 4) return false;
  }
  return true;
}

bool looks_like_static_table(const fs::path& p) {
  const auto lines = data_lines(p, 1);
  if (lines.empty()) return false;
  const std::string& h = lines[0];
  const bool input = h.find("angle_deg") != std::string::npos || h.find("f_x_mps2") != std::string::npos;
  return input && (h.find("a_x_mps2") != std::string::npos || h.find("a_y_mps2") != std::string::npos ||
                   h.find("a_z_mps2") != std::string::npos);
}

RosbagOptions rosbag_options(const ImportOptions& o) {
  RosbagOptions r;
  r.topic = o.topic;
  r.temperature_topic = o.temperature_topic;
  r.gravity_mps2 = o.gravity_mps2;
  return r;
}

const std::vector<Format>& formats() {
  static const std::vector<Format> table = {
      {"run", "a Stend run folder (run.json, imu.csv, ...)", looks_like_run, open_run, 1, nullptr, false, true},
      {"mat", "MATLAB .mat (v4, v5, 7.3): t|fs, acc, gyro, temp, counts, segments; or the variables --accel, --gyro, "
              "--time, --temperature name (one file per sensor too)",
       looks_like_mat, open_mat, 4, stream_mat, true, true},
      {"npy", "NumPy .npy / .npz (np.save, np.savez, np.savez_compressed): the arrays --accel, --gyro, --time, "
              "--temperature name (one file per sensor too)",
       looks_like_npy, open_npy, 4, stream_npy, true},
      {"imucal", "imucal annotated session (part,samples,acc_*,gyr_* counts)", looks_like_imucal, open_imucal, 1,
       stream_imucal},
      {"mpu6050_multipos", "MPU-6050 multi-position session (Fs,… header, ax..gz counts)", looks_like_mpu6050_multipos,
       open_mpu6050, 1, stream_mpu6050},
      {"static_table", "table of static means against known inputs (angle_deg or f_*_mps2, a_*_mps2)",
       looks_like_static_table, open_table},
      {"means_table", "table of means without inputs: one row per orientation, ax ay az (named or the only three "
                      "columns), optional n and sigma; units by --accel-unit or --accel-lsb",
       looks_like_means_table, open_means},
      {"imutk", "IMU-TK text 't x y z' (ACC [GYRO]; any extension, .mat included)", looks_like_imutk, open_imutk, 2,
       stream_imutk},
      {"ulog", "PX4 ULog: sensor_accel + sensor_gyro (with temperature), else sensor_combined", looks_like_ulog,
       [](const Inputs& in, const ImportOptions& o) { return import_ulog(in[0], {.instance = o.instance}); }, 1,
       [](const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
         import_ulog(in[0], {.instance = o.instance}, rec, out);
       }},
      {"dataflash", "ArduPilot DataFlash .BIN: IMU records (with temperature)", looks_like_dataflash,
       [](const Inputs& in, const ImportOptions& o) { return import_dataflash(in[0], {.instance = o.instance}); }, 1,
       [](const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
         import_dataflash(in[0], {.instance = o.instance}, rec, out);
       }},
      {"euroc", "EuRoC / ASL: mav0/imu0/data.csv (or the folder holding mav0/)", looks_like_euroc,
       [](const Inputs& in, const ImportOptions&) { return import_euroc(in[0]); }, 1,
       [](const Inputs& in, const ImportOptions&, Recording& rec, SampleSink& out) { import_euroc(in[0], {}, rec, out); }},
      {"rosbag1", "ROS 1 bag v2.0: sensor_msgs/Imu (--topic)", looks_like_rosbag1,
       [](const Inputs& in, const ImportOptions& o) { return import_rosbag1(in[0], rosbag_options(o)); }, 1,
       [](const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
         import_rosbag1(in[0], rosbag_options(o), rec, out);
       }},
      {"rosbag2", "ROS 2 bag (SQLite3 .db3 or MCAP, file or folder): sensor_msgs/msg/Imu (--topic)", looks_like_rosbag2,
       [](const Inputs& in, const ImportOptions& o) { return import_rosbag2(in[0], rosbag_options(o)); }, 1,
       [](const Inputs& in, const ImportOptions& o, Recording& rec, SampleSink& out) {
         import_rosbag2(in[0], rosbag_options(o), rec, out);
       }},
      {"records", "raw binary records of a stated layout (--record-layout t:f64,ax:i16,…; --byte-order, --header-bytes): "
                  "each field an array to name (one file per sensor too)",
       nullptr, open_records, 4, stream_records, true},
      {"csv", "generic delimited text with mapped columns (--accel/--mapping ...)", nullptr, open_csv, 1, stream_csv},
  };
  return table;
}

std::string format_names() {
  std::string out;
  for (const auto& f : formats()) out += (out.empty() ? "" : " | ") + f.name;
  return out;
}

const Format& find_format(const std::string& name) {
  for (const auto& f : formats())
    if (f.name == name) return f;
  throw std::invalid_argument("unknown format '" + name + "' (formats: " + format_names() + ")");
}

namespace {

// Every input exists: a missing one is named as such, not as a format that cannot be told.
void require_inputs_exist(const Inputs& inputs) {
  std::error_code ec;
  for (const auto& p : inputs)
    if (!fs::exists(p, ec)) throw InputError("no such file: " + p.string());
}

}  // namespace

namespace {

// The options say nothing contradictory (ImportOptions::IsValid), checked before anything reads them.
void require_valid_options(const ImportOptions& options) {
  std::string problem;
  if (!options.IsValid(&problem)) throw std::invalid_argument("import options: " + problem);
}

}  // namespace

const Format& detect_format(const Inputs& inputs, const ImportOptions& options) {
  if (inputs.empty()) throw std::invalid_argument("no input file");
  require_valid_options(options);
  require_inputs_exist(inputs);
  if (!options.record_layout.empty()) return find_format("records");  // raw records say nothing of themselves
  for (const auto& f : formats()) {
    if (!f.detect || inputs.size() > f.max_inputs || (options.maps_columns() && !f.takes_names)) continue;
    if (std::all_of(inputs.begin(), inputs.end(), [&](const fs::path& p) { return f.detect(p); })) return f;
  }
  if (options.maps_columns()) return find_format("csv");
  std::string list;
  for (const auto& f : formats()) list += "\n  " + f.name + ": " + f.description;
  throw InputError((inputs.size() > 1 ? "these " + std::to_string(inputs.size()) + " inputs" : inputs[0].string()) +
                   ": cannot tell the format from the content; give --format, one of:" + list);
}

namespace {

// The format to read `inputs` with, after checking the options and the input count.
const Format& choose_format(const Inputs& inputs, const std::string& format, const ImportOptions& options) {
  require_valid_options(options);
  require_inputs_exist(inputs);
  const Format& f = format.empty() || format == "auto" ? detect_format(inputs, options) : find_format(format);
  if (inputs.empty() || inputs.size() > f.max_inputs)
    throw std::invalid_argument("format " + f.name + " takes " +
                                (f.max_inputs == 1 ? std::string("one input") : "1 to " + std::to_string(f.max_inputs) + " inputs") +
                                ", got " + std::to_string(inputs.size()));
  return f;
}

// Whether the samples of format `f` are a log's, checked on the way in (plausibility.hpp): not a run
// folder's (checked when it was made), nor a table of means' (its rows, held, are no stretch of a
// log, and an axis a static table does not measure reads NaN; a means table checks its rows itself).
bool is_log(const Format& f) { return f.name != "run" && f.name != "static_table" && f.name != "means_table"; }

// The event stating the format and the import options.
void add_format_event(Recording& rec, const Format& f, const std::string& format, const ImportOptions& options) {
  std::string stated;
  for (const auto& s : options.stated) stated += (stated.empty() ? "" : "; ") + s;
  add_import_event(rec, "format " + f.name + (format.empty() || format == "auto" ? " (detected from the content)" : " (given)") +
                            "; import options: " + (stated.empty() ? "none (the format's defaults)" : stated));
}

}  // namespace

Recording open_dataset(const Inputs& inputs, const std::string& format, const ImportOptions& options,
                       std::string* used) {
  const Format& f = choose_format(inputs, format, options);
  Recording rec = f.open(inputs, options);
  if (used) *used = f.name;
  if (f.name == "run") return rec;
  if (is_log(f)) check_samples(rec, inputs[0], options);
  add_format_event(rec, f, format, options);
  return rec;
}

void import_dataset(const Inputs& inputs, const std::string& format, Recording& rec, SampleSink& out,
                    const ImportOptions& options, std::string* used) {
  const Format& f = choose_format(inputs, format, options);
  if (used) *used = f.name;
  SampleCheck checked(rec, out, inputs[0], options);
  SampleSink& to = is_log(f) ? static_cast<SampleSink&>(checked) : out;
  if (f.stream) {
    f.stream(inputs, options, rec, to);
  } else {
    rec = f.open(inputs, options);
    for_each_chunk(rec.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t) { to.add_samples(c, n); });
    rec.samples = {};
    rec.source.reset();
  }
  if (is_log(f)) checked.finish(rec);
  if (f.name != "run") add_format_event(rec, f, format, options);
}

void add_provenance(Recording& rec, const Inputs& inputs, const std::string& format, const std::atomic<bool>* stop) {
  for (const auto& p : inputs) {
    add_import_event(rec, "source " + fs::absolute(p).lexically_normal().string() + ": " +
                              std::to_string(fs::file_size(p)) + " bytes, sha256 " + sha256_hex(p, stop) + ", format " +
                              format + ", imported by stend " + stend::version());
  }
}

}  // namespace stend::io
