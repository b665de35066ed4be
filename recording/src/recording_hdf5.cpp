// The HDF5 run store (run.h5): layout, durability and damage rules in docs/recording-format.md.
#include "hdf5_store.hpp"

#include "hdf5_global_heap.hpp"
#include "hdf5_metadata.hpp"
#include "stend/recording/hdf5.hpp"

#include <hdf5.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <utility>

namespace stend::detail {
namespace {

namespace fs = std::filesystem;

// 2: every string attribute is fixed-length (1 kept variable-length ones in the global heap,
// which libhdf5 1.10 can loop on for ever when the file is damaged; version 1 stays readable).
constexpr int kHdf5FormatVersion = 2;
// Samples per chunk: 64 Ki (65 s at 1 kHz); one chunk of a column is 128–512 KiB uncompressed.
constexpr hsize_t kChunkSamples = hsize_t{1} << 16;
constexpr hsize_t kSummaryColumns = 5;  // the /summary dataset's values
constexpr hsize_t kSmallChunk = 4096;  // truth rows, segment/event bytes, exceptions
// A counts channel is stored without its SI value when SI = counts·lsb + offset within this many
// LSB for every sample (the rest go to the exceptions table).
constexpr double kConversionTolerance_lsb = 1e-6;
constexpr int kChannels = 7;  // ax ay az gx gy gz temperature
constexpr const char* kCountsNames[kChannels] = {"ax_counts", "ay_counts", "az_counts", "gx_counts",
                                                 "gy_counts", "gz_counts", "temp_counts"};
constexpr const char* kSiNames[kChannels] = {"ax_mps2",  "ay_mps2",  "az_mps2", "gx_radps",
                                             "gy_radps", "gz_radps", "temp_c"};
constexpr const char* kSiUnits[kChannels] = {"m/s^2", "m/s^2", "m/s^2", "rad/s",
                                             "rad/s", "rad/s", "degC"};

// The HDF5 library serializes calls itself when built thread-safe; otherwise Stend does.
std::mutex& hdf5_mutex() {
  static std::mutex m;
  return m;
}
struct Hdf5Lock {
  std::unique_lock<std::mutex> lock;
  Hdf5Lock() {
    static const bool threadsafe = [] {
      hbool_t ts = 0;
      H5is_library_threadsafe(&ts);
      return ts > 0;
    }();
    if (!threadsafe) lock = std::unique_lock<std::mutex>(hdf5_mutex());
  }
};

// The innermost messages of the HDF5 error stack ("wrong B-tree signature; …").
std::string hdf5_error() {
  std::vector<std::string> msgs;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD,
           [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
             auto& out = *static_cast<std::vector<std::string>*>(data);
             if (n < 3 && e->desc) out.emplace_back(e->desc);
             return 0;
           },
           &msgs);
  H5Eclear2(H5E_DEFAULT);
  std::string s;
  for (const auto& m : msgs) s += (s.empty() ? "" : "; ") + m;
  return s.empty() ? "HDF5 error" : s;
}

// An hid_t closed by its own close function.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)), close_(o.close_) {}
  Handle& operator=(Handle&& o) noexcept {
    reset();
    id_ = std::exchange(o.id_, H5I_INVALID_HID);
    close_ = o.close_;
    return *this;
  }
  ~Handle() { reset(); }
  void reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = H5I_INVALID_HID;
  }
  hid_t get() const { return id_; }
  explicit operator bool() const { return id_ >= 0; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
};

[[noreturn]] void fail(const fs::path& file, const std::string& what) {
  throw std::runtime_error(fmt::format("{}: {} ({})", file.string(), what, hdf5_error()));
}
Handle check(hid_t id, herr_t (*close)(hid_t), const fs::path& file, const std::string& what) {
  if (id < 0) fail(file, what);
  return Handle(id, close);
}
void check(herr_t r, const fs::path& file, const std::string& what) {
  if (r < 0) fail(file, what);
}

// --- attributes --------------------------------------------------------------------------------

Handle fixed_string_type(std::size_t bytes) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), bytes);
  H5Tset_strpad(t.get(), H5T_STR_NULLPAD);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

Handle vl_string_type() {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

// Creates or overwrites a scalar attribute.
void put_attr(hid_t obj, const char* name, hid_t type, const void* value, const fs::path& file) {
  if (H5Aexists(obj, name) > 0) H5Adelete(obj, name);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a = check(H5Acreate2(obj, name, type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                   file, fmt::format("cannot create attribute '{}'", name));
  check(H5Awrite(a.get(), type, value), file, fmt::format("cannot write attribute '{}'", name));
}
// A fixed-length string (format 2): the text lives in the attribute itself, never in the global
// heap. NUL-padded to at least one byte (HDF5 has no zero-size type).
void put_attr(hid_t obj, const char* name, const std::string& v, const fs::path& file) {
  std::string bytes = v;
  if (bytes.empty()) bytes.push_back('\0');
  const Handle t = fixed_string_type(bytes.size());
  put_attr(obj, name, t.get(), bytes.data(), file);
}
void put_attr(hid_t obj, const char* name, double v, const fs::path& file) {
  put_attr(obj, name, H5T_NATIVE_DOUBLE, &v, file);
}
void put_attr(hid_t obj, const char* name, std::int64_t v, const fs::path& file) {
  put_attr(obj, name, H5T_NATIVE_INT64, &v, file);
}

bool has_attr(hid_t obj, const char* name) { return H5Aexists(obj, name) > 0; }

// The number of values of an attribute or dataset's dataspace (a scalar is 1), -1 when unreadable.
hssize_t value_count(hid_t space) { return space >= 0 ? H5Sget_simple_extent_npoints(space) : -1; }

// What Stend reads from the file may be damaged: before any variable-length value is read (format
// 1's string attributes live in the global heap), the file's global heap collections are walked
// once (hdf5_global_heap.hpp); a damaged one is an error, never a read that loops for ever.
class GlobalHeapGuard {
 public:
  GlobalHeapGuard(fs::path file, hid_t h5) : file_(std::move(file)), h5_(h5) {}
  // Empty, or what is damaged ("FILE: the global heap collection at byte N … is damaged: …").
  const std::string& damage() {
    if (!checked_) {
      damage_ = global_heap_damage(file_, [&](std::uint64_t at) { return inside_a_chunk(at); });
      if (!damage_.empty()) damage_ = fmt::format("{}: {}", file_.string(), damage_);
      checked_ = true;
    }
    return damage_;
  }
  void check() {
    if (!damage().empty()) throw std::runtime_error(damage_);
  }

 private:
  // Whether byte `at` lies inside a chunk of one of the file's datasets (recorded samples that
  // happen to spell "GCOL"); asked only about collections that fail the walk.
  bool inside_a_chunk(std::uint64_t at) const;

  fs::path file_;
  hid_t h5_;
  bool checked_ = false;
  std::string damage_;
};

bool is_variable_string_attr(hid_t obj, const char* name) {
  if (H5Aexists(obj, name) <= 0) return false;
  Handle a(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle t(a ? H5Aget_type(a.get()) : H5I_INVALID_HID, H5Tclose);
  return t && H5Tis_variable_str(t.get()) > 0;
}

// A scalar string attribute: fixed-length (format 2) or variable-length (format 1, read only after
// the global heap was checked).
std::string get_string_attr(hid_t obj, const char* name, const fs::path& file, GlobalHeapGuard& heap) {
  Handle a = check(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file,
                   fmt::format("attribute '{}' is missing or damaged", name));
  Handle ft(H5Aget_type(a.get()), H5Tclose);
  Handle space(H5Aget_space(a.get()), H5Sclose);
  if (H5Tget_class(ft.get()) != H5T_STRING || value_count(space.get()) != 1)
    fail(file, fmt::format("attribute '{}' is not one string (damaged)", name));
  if (H5Tis_variable_str(ft.get()) > 0) {
    heap.check();
    const Handle t = vl_string_type();
    char* p = nullptr;
    check(H5Aread(a.get(), t.get(), &p), file, fmt::format("cannot read attribute '{}'", name));
    std::string s = p ? p : "";
    H5Dvlen_reclaim(t.get(), space.get(), H5P_DEFAULT, &p);
    return s;
  }
  std::error_code ec;
  const std::size_t n = H5Tget_size(ft.get());
  if (n == 0 || n > fs::file_size(file, ec))
    fail(file, fmt::format("attribute '{}' declares a string of {} bytes, not 1 to the file's size (damaged)", name, n));
  const Handle t = fixed_string_type(n);
  std::string s(n, '\0');
  check(H5Aread(a.get(), t.get(), s.data()), file, fmt::format("cannot read attribute '{}'", name));
  s.resize(std::strlen(s.c_str()));
  return s;
}
double get_double_attr(hid_t obj, const char* name, const fs::path& file) {
  Handle a = check(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file,
                   fmt::format("attribute '{}' is missing or damaged", name));
  Handle ft(H5Aget_type(a.get()), H5Tclose);
  Handle space(H5Aget_space(a.get()), H5Sclose);
  const H5T_class_t cls = H5Tget_class(ft.get());
  if ((cls != H5T_INTEGER && cls != H5T_FLOAT) || value_count(space.get()) != 1)
    fail(file, fmt::format("attribute '{}' is not one number (damaged)", name));
  double v = 0.0;
  check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v), file, fmt::format("cannot read attribute '{}'", name));
  return v;
}

// --- datasets ----------------------------------------------------------------------------------

struct DatasetSpec {
  const char* name;
  hid_t type;
  hsize_t cols = 0;  // 0: 1-D
  hsize_t chunk_rows = kChunkSamples;
  bool compress = false;  // shuffle + deflate level 1
};

Handle create_dataset(hid_t loc, const DatasetSpec& s, const fs::path& file) {
  const int rank = s.cols ? 2 : 1;
  const hsize_t dims[2] = {0, s.cols};
  const hsize_t maxdims[2] = {H5S_UNLIMITED, s.cols};
  const hsize_t chunk[2] = {s.chunk_rows, s.cols ? s.cols : 1};
  Handle space(H5Screate_simple(rank, dims, maxdims), H5Sclose);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(dcpl.get(), rank, chunk);
  if (s.compress) {
    H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), 1);
  }
  H5Pset_fletcher32(dcpl.get());  // a damaged chunk is an error on read, never wrong numbers
  return check(H5Dcreate2(loc, s.name, s.type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
               H5Dclose, file, fmt::format("cannot create dataset '{}'", s.name));
}

// Rows [at, at + rows) of a 1-D or 2-D dataset, extending it to at + rows.
void write_rows(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, hsize_t cols, const void* data,
                const fs::path& file, const char* name) {
  if (rows == 0) return;
  const int rank = cols ? 2 : 1;
  const hsize_t new_dims[2] = {at + rows, cols};
  check(H5Dset_extent(ds, new_dims), file, fmt::format("cannot extend dataset '{}'", name));
  Handle fspace(H5Dget_space(ds), H5Sclose);
  const hsize_t start[2] = {at, 0};
  const hsize_t count[2] = {rows, cols};
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
  Handle mspace(H5Screate_simple(rank, count, nullptr), H5Sclose);
  check(H5Dwrite(ds, mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, data), file,
        fmt::format("cannot write dataset '{}'", name));
}

hsize_t extent_rows(hid_t ds) {
  Handle space(H5Dget_space(ds), H5Sclose);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  return dims[0];
}

// Rows [at, at + rows) of a dataset into `out` (cols values per row; 0 for 1-D).
herr_t read_rows(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, hsize_t cols, void* out) {
  if (rows == 0) return 0;
  const int rank = cols ? 2 : 1;
  Handle fspace(H5Dget_space(ds), H5Sclose);
  const hsize_t start[2] = {at, 0};
  const hsize_t count[2] = {rows, cols};
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
  Handle mspace(H5Screate_simple(rank, count, nullptr), H5Sclose);
  return H5Dread(ds, mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, out);
}

// Fixed-length text datasets (status, message, end time), written in place.
constexpr std::size_t kStatusBytes = 16, kMessageBytes = 1024, kTimeBytes = 32;

void write_text(hid_t ds, std::size_t bytes, std::string_view text, const fs::path& file) {
  std::string v(text.substr(0, bytes));
  v.resize(bytes, '\0');
  const Handle t = fixed_string_type(bytes);
  check(H5Dwrite(ds, t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), file, "cannot write a text dataset");
}
Handle create_text(hid_t loc, const char* name, std::size_t bytes, std::string_view text, const fs::path& file) {
  const Handle t = fixed_string_type(bytes);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle ds = check(H5Dcreate2(loc, name, t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose,
                    file, fmt::format("cannot create dataset '{}'", name));
  write_text(ds.get(), bytes, text, file);
  return ds;
}
std::string read_text(hid_t loc, const char* name, const fs::path& file) {
  Handle ds = check(H5Dopen2(loc, name, H5P_DEFAULT), H5Dclose, file, fmt::format("dataset /{} is missing or damaged", name));
  Handle ft(H5Dget_type(ds.get()), H5Tclose);
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  const std::size_t bytes = H5Tget_size(ft.get());
  // Only what the writer makes: one fixed-length string of at most kMessageBytes.
  if (H5Tget_class(ft.get()) != H5T_STRING || H5Tis_variable_str(ft.get()) != 0 || value_count(space.get()) != 1 ||
      bytes == 0 || bytes > kMessageBytes)
    fail(file, fmt::format("dataset /{} is not a fixed-length string of at most {} bytes (damaged)", name, kMessageBytes));
  const Handle t = fixed_string_type(bytes);
  std::string v(bytes, '\0');
  check(H5Dread(ds.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), file, fmt::format("dataset /{} is damaged", name));
  v.resize(std::strlen(v.c_str()));
  return v;
}

// --- the counts→SI rule --------------------------------------------------------------------------

// How one channel is stored: counts (int16 or int32) with SI = counts·lsb + offset derived on
// read, or counts and SI side by side (a sensor whose SI is not that function of its counts).
struct Codec {
  bool si_stored = false;
  bool int16 = false;
  double lsb = 0.0, offset = 0.0;
  double si(std::int32_t c) const { return static_cast<double>(c) * lsb + offset; }
  bool fits(std::int32_t c) const { return !int16 || (c >= INT16_MIN && c <= INT16_MAX); }
  bool exact(std::int32_t c, double v) const {
    return fits(c) && std::abs(v - si(c)) <= kConversionTolerance_lsb * lsb;
  }
};

std::int32_t counts_of(const ImuSample& s, int ch) {
  return ch < 3 ? s.accel_counts[ch] : ch < 6 ? s.gyro_counts[ch - 3] : s.temperature_counts;
}
double si_of(const ImuSample& s, int ch) {
  return ch < 3 ? s.accel_mps2[ch] : ch < 6 ? s.gyro_radps[ch - 3] : s.temperature_c;
}
void set_channel(ImuSample& s, int ch, std::int32_t c, double v) {
  if (ch < 3) {
    s.accel_counts[ch] = c;
    s.accel_mps2[ch] = v;
  } else if (ch < 6) {
    s.gyro_counts[ch - 3] = c;
    s.gyro_radps[ch - 3] = v;
  } else {
    s.temperature_counts = c;
    s.temperature_c = v;
  }
}

// Each channel's codec from the sensor's LSB sizes and ranges and the first samples: counts only
// when every one of them converts exactly (the temperature offset is taken from the first).
std::array<Codec, kChannels> choose_codecs(const SensorInfo& info, const ImuSample* s, std::size_t n) {
  std::array<Codec, kChannels> out;
  for (int ch = 0; ch < kChannels; ++ch) {
    Codec& c = out[static_cast<std::size_t>(ch)];
    const double lsb = ch < 3 ? info.accel_lsb_mps2 : ch < 6 ? info.gyro_lsb_radps : info.temperature_lsb_c;
    const double range = ch < 3 ? info.accel_range_mps2 : ch < 6 ? info.gyro_range_radps : 0.0;
    if (!(lsb > 0.0) || !std::isfinite(lsb) || n == 0) {
      c.si_stored = true;
      continue;
    }
    c.lsb = lsb;
    if (ch == 6) c.offset = s[0].temperature_c - static_cast<double>(s[0].temperature_counts) * lsb;
    // An MPU-class sensor: ±range is ±32768 counts. Temperature has no range: int16 when the
    // first samples fit (a later one that does not is an exception).
    c.int16 = ch < 6 ? (range > 0.0 && range / lsb <= 32768.5) : true;
    std::size_t exact = 0;
    for (std::size_t i = 0; i < n; ++i) exact += c.exact(counts_of(s[i], ch), si_of(s[i], ch));
    c.si_stored = !std::isfinite(c.offset) || exact < n;
  }
  return out;
}

}  // namespace

// =============================================================================================
// Writer

struct Hdf5RunWriter::Impl {
  fs::path path;
  RecordingHeader header;
  std::string header_json, experiment_yaml;
  Handle file, samples_group;
  std::array<Codec, kChannels> codec;
  Handle ds_t, ds_flags, ds_counts[kChannels], ds_si[kChannels], ds_exceptions, ds_truth,
      ds_segments, ds_events, ds_summary, ds_status, ds_status_message, ds_end_time;
  // Samples not yet in the file, column by column.
  std::vector<double> t;
  std::vector<std::int32_t> counts[kChannels];
  std::vector<double> si[kChannels];
  std::vector<std::uint32_t> flags;
  std::vector<double> exceptions;  // rows of (index, channel, counts, si)
  std::vector<double> truth_rows;  // rows of (t_s, values…)
  std::string segment_bytes, event_bytes;
  std::uint64_t written = 0, gaps = 0, irregular = 0;
  hsize_t exceptions_written = 0, truth_written = 0, segment_bytes_written = 0, event_bytes_written = 0;
  double t_first = std::numeric_limits<double>::quiet_NaN(), t_last = t_first;

  std::size_t pending() const { return t.size(); }
  void create(const ImuSample* first, std::size_t n);
  void write_pending();
  void write_records();
  void write_summary();
};

void Hdf5RunWriter::Impl::create(const ImuSample* first, std::size_t n) {
  silence_hdf5_error_printing();
  codec = choose_codecs(header.info, first, n);
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);  // required by SWMR
  // No chunk cache: each chunk goes to the file when written, so chunks lie in the file in the
  // order of their samples and a file cut short keeps the samples before the cut.
  H5Pset_cache(fapl.get(), 0, 0, 0, 1.0);
  file = check(H5Fcreate(path.c_str(), H5F_ACC_EXCL, H5P_DEFAULT, fapl.get()), H5Fclose, path,
               "cannot create the HDF5 file");
  const hid_t root = file.get();
  put_attr(root, "format", std::string("stend-run"), path);
  put_attr(root, "format_version", std::int64_t{kHdf5FormatVersion}, path);
  put_attr(root, "header_json", header_json, path);
  put_attr(root, "experiment_yaml", experiment_yaml, path);
  put_attr(root, "experiment_name", header.experiment_name, path);
  put_attr(root, "stend_version", header.stend_version, path);
  put_attr(root, "start_time_utc", header.start_time_utc, path);
  put_attr(root, "clock", header.clock, path);
  put_attr(root, "sensor_vendor", header.identity.vendor, path);
  put_attr(root, "sensor_model", header.identity.model, path);
  put_attr(root, "sensor_serial", header.identity.serial, path);
  put_attr(root, "output_rate_hz", header.info.output_rate_hz, path);
  put_attr(root, "gravity_mps2", header.gravity_mps2, path);

  samples_group = check(H5Gcreate2(root, "samples", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                        H5Gclose, path, "cannot create group 'samples'");
  const hid_t g = samples_group.get();
  ds_t = create_dataset(g, {"t_s", H5T_IEEE_F64LE, 0, kChunkSamples, true}, path);
  put_attr(ds_t.get(), "unit", std::string("s"), path);
  for (int ch = 0; ch < kChannels; ++ch) {
    const Codec& c = codec[static_cast<std::size_t>(ch)];
    const hid_t type = c.int16 && !c.si_stored ? H5T_STD_I16LE : H5T_STD_I32LE;
    ds_counts[ch] = create_dataset(g, {kCountsNames[ch], type, 0, kChunkSamples, c.si_stored}, path);
    if (c.si_stored) {
      ds_si[ch] = create_dataset(g, {kSiNames[ch], H5T_IEEE_F64LE, 0, kChunkSamples, true}, path);
      put_attr(ds_si[ch].get(), "unit", std::string(kSiUnits[ch]), path);
    } else {
      put_attr(ds_counts[ch].get(), "lsb", c.lsb, path);
      put_attr(ds_counts[ch].get(), "offset", c.offset, path);
      put_attr(ds_counts[ch].get(), "si_name", std::string(kSiNames[ch]), path);
      put_attr(ds_counts[ch].get(), "unit", std::string(kSiUnits[ch]), path);
    }
  }
  ds_flags = create_dataset(g, {"flags", H5T_STD_U32LE, 0, kChunkSamples, true}, path);
  ds_exceptions = create_dataset(g, {"exceptions", H5T_IEEE_F64LE, 4, kSmallChunk / 4, true}, path);
  put_attr(ds_exceptions.get(), "columns", std::string("index,channel,counts,si"), path);

  std::string truth_columns = "t_s";
  for (const auto& c : header.truth_columns) truth_columns += "," + c;
  ds_truth = create_dataset(root, {"truth", H5T_IEEE_F64LE, 1 + header.truth_columns.size(),
                                   std::max<hsize_t>(1, kSmallChunk / (1 + header.truth_columns.size())), true},
                            path);
  put_attr(ds_truth.get(), "columns", truth_columns, path);
  ds_segments = create_dataset(root, {"segments_csv", H5T_STD_U8LE, 0, kSmallChunk, true}, path);
  ds_events = create_dataset(root, {"events_csv", H5T_STD_U8LE, 0, kSmallChunk, true}, path);
  // Fixed-size datasets overwritten in place (the file's metadata does not move when the run
  // ends, so a file cut short keeps its header): summary, status and how the run ended.
  {
    const hsize_t dims[1] = {kSummaryColumns};
    Handle space(H5Screate_simple(1, dims, nullptr), H5Sclose);
    ds_summary = check(H5Dcreate2(root, "summary", H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
                                  H5P_DEFAULT, H5P_DEFAULT),
                       H5Dclose, path, "cannot create dataset 'summary'");
    put_attr(ds_summary.get(), "columns",
             std::string("sample_count,gap_count,t_first_s,t_last_s,irregular_interval_count"), path);
  }
  ds_status = create_text(root, "status", kStatusBytes, to_string(RunStatus::kRunning), path);
  ds_status_message = create_text(root, "status_message", kMessageBytes, "", path);
  ds_end_time = create_text(root, "end_time_utc", kTimeBytes, "", path);
  write_summary();
  check(H5Fstart_swmr_write(root), path, "cannot start SWMR writing");
}

void Hdf5RunWriter::Impl::write_pending() {
  const hsize_t n = pending();
  if (n == 0) return;
  write_rows(ds_t.get(), H5T_NATIVE_DOUBLE, written, n, 0, t.data(), path, "t_s");
  for (int ch = 0; ch < kChannels; ++ch) {
    write_rows(ds_counts[ch].get(), H5T_NATIVE_INT32, written, n, 0, counts[ch].data(), path,
               kCountsNames[ch]);
    if (ds_si[ch]) write_rows(ds_si[ch].get(), H5T_NATIVE_DOUBLE, written, n, 0, si[ch].data(), path, kSiNames[ch]);
    counts[ch].clear();
    si[ch].clear();
  }
  write_rows(ds_flags.get(), H5T_NATIVE_UINT32, written, n, 0, flags.data(), path, "flags");
  written += n;
  t.clear();
  flags.clear();
}

void Hdf5RunWriter::Impl::write_records() {
  const hsize_t ne = exceptions.size() / 4;
  write_rows(ds_exceptions.get(), H5T_NATIVE_DOUBLE, exceptions_written, ne, 4, exceptions.data(), path, "exceptions");
  exceptions_written += ne;
  exceptions.clear();
  const hsize_t cols = 1 + header.truth_columns.size();
  const hsize_t nt = truth_rows.size() / cols;
  write_rows(ds_truth.get(), H5T_NATIVE_DOUBLE, truth_written, nt, cols, truth_rows.data(), path, "truth");
  truth_written += nt;
  truth_rows.clear();
  write_rows(ds_segments.get(), H5T_NATIVE_UINT8, segment_bytes_written, segment_bytes.size(), 0,
             segment_bytes.data(), path, "segments_csv");
  segment_bytes_written += segment_bytes.size();
  segment_bytes.clear();
  write_rows(ds_events.get(), H5T_NATIVE_UINT8, event_bytes_written, event_bytes.size(), 0,
             event_bytes.data(), path, "events_csv");
  event_bytes_written += event_bytes.size();
  event_bytes.clear();
}

void Hdf5RunWriter::Impl::write_summary() {
  const double rate_hz = header.info.output_rate_hz;
  const double v[kSummaryColumns] = {static_cast<double>(written), static_cast<double>(gaps), t_first, t_last,
                                     rate_hz > 0.0 ? static_cast<double>(irregular) : -1.0};
  check(H5Dwrite(ds_summary.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v), path,
        "cannot write dataset 'summary'");
}

Hdf5RunWriter::Hdf5RunWriter(fs::path file, const RecordingHeader& header, std::string header_json,
                             std::string experiment_yaml)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = std::move(file);
  impl_->header = header;
  impl_->header_json = std::move(header_json);
  impl_->experiment_yaml = std::move(experiment_yaml);
}

Hdf5RunWriter::~Hdf5RunWriter() {
  if (!impl_->file) return;
  try {
    flush();
  } catch (...) {
    // A destructor must not throw; flush()/finish() report write errors.
  }
}

void Hdf5RunWriter::add_samples(const ImuSample* s, std::size_t n) {
  Impl& I = *impl_;
  if (n == 0) return;
  if (!I.file) I.create(s, n);
  if (std::isnan(I.t_first)) I.t_first = s[0].t_s;
  for (std::size_t i = 0; i < n; ++i) {
    const ImuSample& x = s[i];
    const std::uint64_t index = I.written + I.pending();
    I.t.push_back(x.t_s);
    for (int ch = 0; ch < kChannels; ++ch) {
      const Codec& c = I.codec[static_cast<std::size_t>(ch)];
      const std::int32_t cnt = counts_of(x, ch);
      const double v = si_of(x, ch);
      if (c.si_stored) {
        I.si[ch].push_back(v);
        I.counts[ch].push_back(cnt);
        continue;
      }
      if (!c.exact(cnt, v)) {
        I.exceptions.insert(I.exceptions.end(),
                            {static_cast<double>(index), static_cast<double>(ch), static_cast<double>(cnt), v});
      }
      I.counts[ch].push_back(std::clamp<std::int32_t>(cnt, c.int16 ? INT16_MIN : INT32_MIN,
                                                      c.int16 ? INT16_MAX : INT32_MAX));
    }
    I.flags.push_back(x.flags);
    I.gaps += (x.flags & kGapBefore) != 0;
    if (index > 0) I.irregular += interval_irregular(x.t_s - I.t_last, I.header.info.output_rate_hz);
    I.t_last = x.t_s;
    if (I.pending() == kChunkSamples) I.write_pending();
  }
}

void Hdf5RunWriter::add_truth(double t_s, const std::vector<double>& values) {
  impl_->truth_rows.push_back(t_s);
  impl_->truth_rows.insert(impl_->truth_rows.end(), values.begin(), values.end());
}

void Hdf5RunWriter::add_segment_record(std::string_view r) { impl_->segment_bytes.append(r); }
void Hdf5RunWriter::add_event_record(std::string_view r) { impl_->event_bytes.append(r); }

void Hdf5RunWriter::flush() {
  Impl& I = *impl_;
  if (!I.file) return;  // nothing to flush into until the first samples
  I.write_pending();
  I.write_records();
  // The rows reach the file before /summary counts them: /summary is contiguous, so its values go
  // to the file at H5Dwrite, while the datasets' new extents wait in the metadata cache for the
  // flush. Summary first, a kill during the flush could leave it counting rows the file lacks.
  check(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
  I.write_summary();
  check(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
}

void Hdf5RunWriter::finish(RunStatus status,
                           const std::string& end_time_utc, const std::string& message) {
  Impl& I = *impl_;
  if (!I.file) I.create(nullptr, 0);
  flush();
  write_text(I.ds_status_message.get(), kMessageBytes, message, I.path);
  write_text(I.ds_end_time.get(), kTimeBytes, end_time_utc, I.path);
  check(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
  write_text(I.ds_status.get(), kStatusBytes, to_string(status), I.path);  // last: the commit point
  check(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
}

// =============================================================================================
// Reader

namespace {

// SI values of stored counts: out[i] = in[i] · lsb + offset, over every sample of every channel
// read. Vectorised (at -O2, GCC's cheapest cost model leaves a widening conversion scalar).
template <class Count>
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((noinline, optimize("tree-vectorize", "vect-cost-model=dynamic")))
#endif
void counts_to_si(const Count* __restrict in, std::size_t n, double lsb, double offset, double* __restrict out) {
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(in[i]) * lsb + offset;
}

// The bench truth on the file: dataset /truth, rows of (t_s, values…), read a window at a time.
class Hdf5Truth final : public RecordedTruth {
 public:
  Hdf5Truth(fs::path path, Handle ds, std::uint64_t rows, std::size_t width)
      : path_(std::move(path)), ds_(std::move(ds)), rows_(rows), width_(width) {}
  std::uint64_t rows() const override { return rows_; }
  std::size_t columns() const override { return width_ > 0 ? width_ - 1 : 0; }
  void read(std::uint64_t first, std::size_t count, double* t, double* values, bool* whole) const override {
    if (count == 0) return;
    if (first > rows_ || count > rows_ - first)
      throw std::out_of_range(fmt::format("{}: truth rows {}..{} requested, {} stored", path_.string(), first,
                                          first + count, rows_));
    thread_local std::vector<double> v;
    v.resize(count * width_);
    {
      Hdf5Lock lock;
      if (read_rows(ds_.get(), H5T_NATIVE_DOUBLE, first, count, width_, v.data()) < 0)
        fail(path_, fmt::format("dataset /truth is damaged (rows {}..{})", first, first + count));
    }
    const std::size_t cols = columns();
    for (std::size_t i = 0; i < count; ++i) {
      t[i] = v[i * width_];
      whole[i] = true;
      std::copy_n(v.data() + i * width_ + 1, cols, values + i * cols);
    }
  }

 private:
  fs::path path_;
  Handle ds_;
  std::uint64_t rows_;
  std::size_t width_;
};

// The samples of run.h5, read a chunk at a time from the file.
class Hdf5Samples final : public SampleSource {
 public:
  Hdf5Samples(fs::path path, Handle file, std::uint64_t size, Handle t, Handle flags,
              std::array<Handle, kChannels> counts, std::array<Handle, kChannels> si,
              std::array<Codec, kChannels> codec, std::vector<std::array<double, 4>> exceptions)
      : path_(std::move(path)), file_(std::move(file)), size_(size), t_(std::move(t)),
        flags_(std::move(flags)), counts_(std::move(counts)), si_(std::move(si)),
        codec_(codec), exceptions_(std::move(exceptions)) {}

  std::uint64_t size() const override { return size_; }

  void read(std::uint64_t first, std::size_t count, ImuSample* out) const override {
    if (count == 0) return;
    check_range(first, count);
    std::vector<double> d(count);
    std::vector<std::int32_t> c(count);
    std::vector<std::uint32_t> f(count);
    Hdf5Lock lock;
    read_into(t_.get(), H5T_NATIVE_DOUBLE, first, count, d.data(), "t_s");
    for (std::size_t i = 0; i < count; ++i) out[i].t_s = d[i];
    read_into(flags_.get(), H5T_NATIVE_UINT32, first, count, f.data(), "flags");
    for (std::size_t i = 0; i < count; ++i) out[i].flags = f[i];
    for (int ch = 0; ch < kChannels; ++ch) {
      const Codec& k = codec_[static_cast<std::size_t>(ch)];
      read_into(counts_[static_cast<std::size_t>(ch)].get(), H5T_NATIVE_INT32, first, count, c.data(), kCountsNames[ch]);
      if (k.si_stored) {
        read_into(si_[static_cast<std::size_t>(ch)].get(), H5T_NATIVE_DOUBLE, first, count, d.data(), kSiNames[ch]);
        for (std::size_t i = 0; i < count; ++i) set_channel(out[i], ch, c[i], d[i]);
      } else {
        for (std::size_t i = 0; i < count; ++i) set_channel(out[i], ch, c[i], k.si(c[i]));
      }
    }
    for (const auto* e = exceptions_in(first); e != exceptions_.data() + exceptions_.size() &&
                                               (*e)[0] < static_cast<double>(first + count); ++e) {
      set_channel(out[static_cast<std::size_t>((*e)[0]) - first], static_cast<int>((*e)[1]),
                  static_cast<std::int32_t>((*e)[2]), (*e)[3]);
    }
  }

  void read_column(Channel ch, std::uint64_t first, std::size_t count, double* out) const override {
    if (count == 0) return;
    check_range(first, count);
    Hdf5Lock lock;
    if (ch == Channel::kTime || ch == Channel::kFlags) {
      const bool time = ch == Channel::kTime;
      read_into((time ? t_ : flags_).get(), H5T_NATIVE_DOUBLE, first, count, out, time ? "t_s" : "flags");
      return;
    }
    const int k = static_cast<int>(ch) - static_cast<int>(Channel::kAx);
    const Codec& c = codec_[static_cast<std::size_t>(k)];
    if (c.si_stored) {
      read_into(si_[static_cast<std::size_t>(k)].get(), H5T_NATIVE_DOUBLE, first, count, out, kSiNames[k]);
      return;
    }
    // Counts read in their stored width (no conversion inside the library, which serialises
    // callers) and turned into SI here, in parallel across threads.
    auto from_counts = [&](auto stored, hid_t mem_type) {
      // One buffer per thread, kept between calls (a fresh one per chunk is a page-zeroing mmap).
      thread_local std::vector<decltype(stored)> raw;
      raw.resize(count);
      read_into(counts_[static_cast<std::size_t>(k)].get(), mem_type, first, count, raw.data(), kCountsNames[k]);
      counts_to_si(raw.data(), count, c.lsb, c.offset, out);
    };
    if (c.int16) {
      from_counts(std::int16_t{}, H5T_NATIVE_INT16);
    } else {
      from_counts(std::int32_t{}, H5T_NATIVE_INT32);
    }
    for (const auto* e = exceptions_in(first); e != exceptions_.data() + exceptions_.size() &&
                                               (*e)[0] < static_cast<double>(first + count); ++e) {
      if (static_cast<int>((*e)[1]) == k) out[static_cast<std::size_t>((*e)[0]) - first] = (*e)[3];
    }
  }

 private:
  void check_range(std::uint64_t first, std::size_t count) const {
    if (first + count > size_) {
      throw std::out_of_range(fmt::format("{}: samples [{}, {}) requested, {} readable",
                                          path_.string(), first, first + count, size_));
    }
  }
  void read_into(hid_t ds, hid_t mem_type, std::uint64_t first, std::size_t count, void* out,
                 const char* name) const {
    if (read_rows(ds, mem_type, first, count, 0, out) < 0) {
      throw std::runtime_error(fmt::format(
          "{}: dataset /samples/{} is damaged: samples {}..{} cannot be read ({})", path_.string(),
          name, first, first + count - 1, hdf5_error()));
    }
  }
  const std::array<double, 4>* exceptions_in(std::uint64_t first) const {
    const auto it = std::lower_bound(exceptions_.begin(), exceptions_.end(), static_cast<double>(first),
                                     [](const std::array<double, 4>& e, double i) { return e[0] < i; });
    return exceptions_.data() + (it - exceptions_.begin());
  }

  fs::path path_;
  Handle file_;
  std::uint64_t size_;
  Handle t_, flags_;
  std::array<Handle, kChannels> counts_, si_;
  std::array<Codec, kChannels> codec_;
  std::vector<std::array<double, 4>> exceptions_;  // sorted by index
};

// Index of the first chunk of `ds` that does not lie whole inside the file (chunks are appended in
// address order), `chunks` when every one does.
hsize_t first_missing_chunk(hid_t ds, hsize_t chunks, std::uint64_t file_size) {
  auto present = [&](hsize_t k) {
    const hsize_t offset[1] = {k * kChunkSamples};
    unsigned mask = 0;
    haddr_t addr = HADDR_UNDEF;
    hsize_t bytes = 0;
    if (H5Dget_chunk_info_by_coord(ds, offset, &mask, &addr, &bytes) < 0) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
    return addr != HADDR_UNDEF && addr + bytes <= file_size;
  };
  if (chunks == 0 || present(chunks - 1)) return chunks;
  hsize_t lo = 0, hi = chunks - 1;  // invariant: chunk hi is missing, all chunks before lo present
  while (lo < hi) {
    const hsize_t mid = lo + (hi - lo) / 2;
    if (present(mid)) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo;
}

Handle open_dataset(hid_t loc, const char* name, const fs::path& file, const char* where) {
  Handle dapl(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
  // A modest cache: one uncompressed chunk of a double column (512 KiB) and a little more.
  H5Pset_chunk_cache(dapl.get(), 101, std::size_t{1} << 20, 1.0);
  Handle ds = check(H5Dopen2(loc, name, dapl.get()), H5Dclose, file,
                    fmt::format("dataset {}{} is missing or damaged", where, name));
  // Stend writes numbers and bytes only: a variable-length or reference type (whose values libhdf5
  // would look up in the global heap) is damage.
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!type || H5Tis_variable_str(type.get()) != 0 || H5Tdetect_class(type.get(), H5T_VLEN) != 0 ||
      H5Tdetect_class(type.get(), H5T_REFERENCE) != 0)
    fail(file, fmt::format("dataset {}{} has a variable-length or reference type, not a number (damaged)", where, name));
  return ds;
}

// Whether byte `at` of the file lies inside the stored data (a chunk, or contiguous storage) of
// one of its datasets.
struct ChunkSearch {
  std::uint64_t at;
  bool found = false;
};
herr_t search_dataset(hid_t root, const char* name, const H5O_info_t* info, void* data) {
  auto& s = *static_cast<ChunkSearch*>(data);
  if (info->type != H5O_TYPE_DATASET) return 0;
  Handle ds(H5Dopen2(root, name, H5P_DEFAULT), H5Dclose);
  if (!ds) return 0;
  const haddr_t contiguous = H5Dget_offset(ds.get());
  if (contiguous != HADDR_UNDEF) {
    s.found = s.at >= contiguous && s.at - contiguous < H5Dget_storage_size(ds.get());
    return s.found ? 1 : 0;
  }
  hsize_t chunks = 0;
  if (H5Dget_num_chunks(ds.get(), H5S_ALL, &chunks) < 0) return 0;
  const int rank = [&] {
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    return H5Sget_simple_extent_ndims(space.get());
  }();
  std::vector<hsize_t> offset(static_cast<std::size_t>(std::max(rank, 1)) + 1);
  for (hsize_t i = 0; i < chunks; ++i) {
    unsigned mask = 0;
    haddr_t addr = HADDR_UNDEF;
    hsize_t bytes = 0;
    if (H5Dget_chunk_info(ds.get(), H5S_ALL, i, offset.data(), &mask, &addr, &bytes) < 0) break;
    if (addr != HADDR_UNDEF && s.at >= addr && s.at - addr < bytes) {
      s.found = true;
      return 1;
    }
  }
  return 0;
}

bool GlobalHeapGuard::inside_a_chunk(std::uint64_t at) const {
  ChunkSearch s{at};
  H5Ovisit2(h5_, H5_INDEX_NAME, H5_ITER_NATIVE, search_dataset, &s, H5O_INFO_BASIC);
  H5Eclear2(H5E_DEFAULT);
  return s.found;
}

// Every object linked from the root, recursively, checked before libhdf5 loads its header: the
// link visit hands each link to the callback before it loads the object the link points to, and
// stops when the callback does. Empty, or what is wrong.
std::string check_linked_headers(hid_t root, Hdf5HeaderCheck& headers) {
  struct Visit {
    Hdf5HeaderCheck* headers;
    std::string why;
  } visit{&headers, {}};
  const herr_t rc = H5Lvisit(
      root, H5_INDEX_NAME, H5_ITER_NATIVE,
      [](hid_t, const char* name, const H5L_info_t* info, void* data) -> herr_t {
        auto& v = *static_cast<Visit*>(data);
        if (info->type != H5L_TYPE_HARD) return 0;
        v.why = v.headers->linked_object(info->u.address);
        if (!v.why.empty()) v.why = fmt::format("/{}: {}", name, v.why);
        return v.why.empty() ? 0 : 1;
      },
      &visit);
  if (rc < 0 && visit.why.empty()) visit.why = "its groups' links cannot be read (" + hdf5_error() + ")";
  H5Eclear2(H5E_DEFAULT);
  return visit.why;
}

std::string read_bytes(hid_t ds, const fs::path& file, const char* name) {
  std::string s(extent_rows(ds), '\0');
  if (read_rows(ds, H5T_NATIVE_UINT8, 0, s.size(), 0, s.data()) < 0)
    fail(file, fmt::format("dataset /{} is damaged", name));
  return s;
}

}  // namespace

namespace {

void read_hdf5_run(const fs::path& path, TruthLoading truth, Hdf5Run& run) {
  silence_hdf5_error_printing();
  Hdf5Lock lock;
  // SWMR read opens a file whose writer is still running or was killed (its status flags still
  // say "open for SWMR writing"); a finished file opens the same way.
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  // A truncated file is opened anyway (the library's "skip_eof_check" file-access property, which
  // h5clear uses): what lies past the end reads as damaged, and the samples before it are kept.
  hbool_t skip_eof_check = 1;
  if (H5Pexist(fapl.get(), "skip_eof_check") > 0) H5Pset(fapl.get(), "skip_eof_check", &skip_eof_check);
  // A metadata block that fails its checksum is damage, not a write in progress: no retries (SWMR
  // readers otherwise retry 100 times with growing sleeps).
  H5Pset_metadata_read_attempts(fapl.get(), 2);
  // libhdf5 decodes only object headers Stend has checked (hdf5_metadata.hpp): those it reads to
  // open the file, then every linked object's, visited before anything else is opened.
  Hdf5HeaderCheck headers(path);
  auto refuse = [&](const std::string& why) {
    throw std::runtime_error(fmt::format("{}: cannot be opened as an HDF5 run store: {}", path.string(), why));
  };
  if (const std::string why = headers.at_open(); !why.empty()) refuse(why);
  Handle file = check(H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, fapl.get()),
                      H5Fclose, path, "cannot be opened as an HDF5 run store (damaged or not HDF5)");
  const hid_t root = file.get();
  if (const std::string why = check_linked_headers(root, headers); !why.empty()) refuse(why);
  GlobalHeapGuard heap(path, root);
  // Format 1's string attributes live in the global heap: when that is damaged the header cannot
  // be read from this file (Recording::open takes it from run.json), the samples still can.
  const bool header_readable = !is_variable_string_attr(root, "format") || heap.damage().empty();
  if (header_readable) {
    if (!has_attr(root, "format") || get_string_attr(root, "format", path, heap) != "stend-run")
      fail(path, "not a Stend run store, or its header is damaged (attribute format = 'stend-run' cannot be read)");
    const double version = get_double_attr(root, "format_version", path);
    if (version < 1 || version > kHdf5FormatVersion) {
      throw std::runtime_error(fmt::format("{}: format_version {} is not readable by this Stend (reads 1..{})",
                                           path.string(), version, kHdf5FormatVersion));
    }
  } else {
    run.header_damage = heap.damage();
  }
  const std::string status = read_text(root, "status", path);
  const auto st = run_status_from_string(status);
  if (!st) fail(path, fmt::format("attribute 'status' is '{}', not a run status", status));
  run.status = *st;
  if (header_readable) run.header_json = get_string_attr(root, "header_json", path, heap);
  double summary_samples = -1.0;  // samples written as of the last flush (/summary), −1 unknown
  {
    Handle ds = open_dataset(root, "summary", path, "/");
    // Files from before the irregular-interval count hold 4 columns.
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    hsize_t dims[1] = {0};
    const bool whole = H5Sget_simple_extent_dims(space.get(), dims, nullptr) == 1 && dims[0] <= kSummaryColumns;
    double v[kSummaryColumns] = {-1, -1, 0, 0, -1};
    if (whole && H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) >= 0) {
      // Counts (samples, gaps, irregular intervals), −1 for unknown: anything else is damage.
      auto count = [](double x) { return x >= -1.0 && x <= 9007199254740992.0 && x == std::floor(x); };
      if (count(v[0]) && count(v[1]) && count(v[4])) {
        summary_samples = v[0];
        run.gap_count = static_cast<std::int64_t>(v[1]);
        run.irregular_count = static_cast<std::int64_t>(v[4]);
      } else {
        run.damage += (run.damage.empty() ? "" : "; ") +
                      fmt::format("{}: dataset /summary holds {:g}, {:g} and {:g} where counts of samples, gaps and "
                                  "irregular intervals belong",
                                  path.string(), v[0], v[1], v[4]);
      }
    }
    H5Eclear2(H5E_DEFAULT);
  }
  if (header_readable) run.experiment_yaml = get_string_attr(root, "experiment_yaml", path, heap);

  // Truth, segments and events: a damaged one is reported and left empty; the samples stay.
  auto keep_going = [&](auto&& read) {
    try {
      read();
    } catch (const std::runtime_error& e) {
      run.damage += (run.damage.empty() ? "" : "; ") + std::string(e.what());
    }
  };
  keep_going([&] {
    Handle ds = open_dataset(root, "truth", path, "/");
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    hsize_t dims[2] = {0, 0};
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    run.truth_rows = dims[0];
    run.truth_columns = dims[1] > 0 ? static_cast<std::size_t>(dims[1] - 1) : 0;
    if (truth == TruthLoading::kSkip) return;
    if (truth == TruthLoading::kStream) {
      run.truth_store = std::make_shared<Hdf5Truth>(path, std::move(ds), dims[0], static_cast<std::size_t>(dims[1]));
      return;
    }
    std::vector<double> v(dims[0] * dims[1]);
    if (read_rows(ds.get(), H5T_NATIVE_DOUBLE, 0, dims[0], dims[1], v.data()) < 0)
      fail(path, "dataset /truth is damaged");
    for (hsize_t r = 0; r < dims[0]; ++r) {
      run.truth_t.push_back(v[r * dims[1]]);
      run.truth.emplace_back(v.begin() + static_cast<std::ptrdiff_t>(r * dims[1] + 1),
                             v.begin() + static_cast<std::ptrdiff_t>((r + 1) * dims[1]));
    }
  });
  keep_going([&] { run.segments_csv = read_bytes(open_dataset(root, "segments_csv", path, "/").get(), path, "segments_csv"); });
  keep_going([&] { run.events_csv = read_bytes(open_dataset(root, "events_csv", path, "/").get(), path, "events_csv"); });

  Handle g = check(H5Gopen2(root, "samples", H5P_DEFAULT), H5Gclose, path,
                   "group /samples is missing or damaged");
  Handle t = open_dataset(g.get(), "t_s", path, "/samples/");
  Handle flags = open_dataset(g.get(), "flags", path, "/samples/");
  std::array<Handle, kChannels> counts, si;
  std::array<Codec, kChannels> codec;
  std::uint64_t n = std::min(extent_rows(t.get()), extent_rows(flags.get()));
  std::vector<hid_t> columns{t.get(), flags.get()};
  for (int ch = 0; ch < kChannels; ++ch) {
    const auto k = static_cast<std::size_t>(ch);
    counts[k] = open_dataset(g.get(), kCountsNames[ch], path, "/samples/");
    n = std::min<std::uint64_t>(n, extent_rows(counts[k].get()));
    columns.push_back(counts[k].get());
    if (H5Lexists(g.get(), kSiNames[ch], H5P_DEFAULT) > 0) {
      si[k] = open_dataset(g.get(), kSiNames[ch], path, "/samples/");
      n = std::min<std::uint64_t>(n, extent_rows(si[k].get()));
      columns.push_back(si[k].get());
      codec[k].si_stored = true;
    } else {
      codec[k].lsb = get_double_attr(counts[k].get(), "lsb", path);
      codec[k].offset = get_double_attr(counts[k].get(), "offset", path);
      Handle type(H5Dget_type(counts[k].get()), H5Tclose);
      codec[k].int16 = H5Tget_size(type.get()) == 2;  // read in the stored width
    }
  }
  // The writer extends the datasets before it records their rows in /summary: fewer rows than
  // recorded is damage, and so is any difference once the run finished.
  if (summary_samples >= 0.0 && (summary_samples > static_cast<double>(n) ||
                                 (run.status != RunStatus::kRunning && summary_samples != static_cast<double>(n)))) {
    run.damage += (run.damage.empty() ? "" : "; ") +
                  fmt::format("{}: dataset /samples holds {} rows, dataset /summary records {} written", path.string(),
                              n, static_cast<std::uint64_t>(summary_samples));
  }
  run.written_samples = summary_samples > static_cast<double>(n) ? static_cast<std::uint64_t>(summary_samples) : n;
  // Samples whose chunks are all inside the file: a truncated file keeps those before the cut.
  std::error_code ec;
  const std::uint64_t file_size = fs::file_size(path, ec);
  const hsize_t chunks = (n + kChunkSamples - 1) / kChunkSamples;
  hsize_t good = chunks;
  for (hid_t ds : columns) good = std::min(good, first_missing_chunk(ds, chunks, file_size));
  if (good < chunks) {
    run.damage += (run.damage.empty() ? "" : "; ") + fmt::format("the file is truncated or damaged after sample {} of {} (a chunk of "
                             "the samples lies outside the file or cannot be located)",
                             good * kChunkSamples, n);
    n = good * kChunkSamples;
  }

  std::vector<std::array<double, 4>> exceptions;
  {
    // Without its exceptions a counts channel would give wrong SI values: this one is required.
    Handle ds = open_dataset(g.get(), "exceptions", path, "/samples/");
    const hsize_t rows = extent_rows(ds.get());
    exceptions.resize(rows);
    if (read_rows(ds.get(), H5T_NATIVE_DOUBLE, 0, rows, 4, exceptions.data()) < 0)
      fail(path, "dataset /samples/exceptions (the samples whose SI is not counts·lsb + offset) is damaged");
    std::stable_sort(exceptions.begin(), exceptions.end(),
                     [](const auto& a, const auto& b) { return a[0] < b[0]; });
  }
  run.samples = std::make_shared<Hdf5Samples>(path, std::move(file), n, std::move(t), std::move(flags),
                                              std::move(counts), std::move(si), codec, std::move(exceptions));
}

}  // namespace

Hdf5Run open_hdf5_run(const fs::path& path, TruthLoading truth) {
  Hdf5Run run;
  try {
    read_hdf5_run(path, truth, run);
  } catch (const std::runtime_error& e) {
    if (run.header_damage.empty()) throw;
    // A damaged global heap first: it is what the rest of the damage most likely goes with.
    throw std::runtime_error(fmt::format("{}; besides, {}", run.header_damage, e.what()));
  }
  return run;
}

}  // namespace stend::detail

namespace stend {
void silence_hdf5_error_printing() {
  static std::once_flag once;
  std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}
}  // namespace stend
