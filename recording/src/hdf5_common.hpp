// What the HDF5 run store's writer and reader share: the layout's constants, the library lock,
// handles that close themselves, checked calls whose errors name the file, attribute, dataset and
// text helpers, and the counts→SI rule of a stored channel. Layout: docs/recording-format.md.
// Internal to stend_recording.
#pragma once

#include "stend/recording/recording.hpp"

#include <hdf5.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

namespace stend::detail {

// 2: every string attribute is fixed-length (1 kept variable-length ones in the global heap,
// which libhdf5 1.10 can loop on for ever when the file is damaged; version 1 stays readable).
inline constexpr int kHdf5FormatVersion = 2;
// Samples per chunk: 64 Ki (65 s at 1 kHz); one chunk of a column is 128–512 KiB uncompressed.
inline constexpr hsize_t kChunkSamples = hsize_t{1} << 16;
inline constexpr hsize_t kSummaryColumns = 5;  // the /summary dataset's values
inline constexpr hsize_t kSmallChunk = 4096;  // truth rows, segment/event bytes, exceptions
// A counts channel is stored without its SI value when SI = counts·lsb + offset within this many
// LSB for every sample (the rest go to the exceptions table).
inline constexpr double kConversionTolerance_lsb = 1e-6;
inline constexpr int kChannels = 7;  // ax ay az gx gy gz temperature
inline constexpr const char* kCountsNames[kChannels] = {"ax_counts", "ay_counts", "az_counts", "gx_counts",
                                                        "gy_counts", "gz_counts", "temp_counts"};
inline constexpr const char* kSiNames[kChannels] = {"ax_mps2",  "ay_mps2",  "az_mps2", "gx_radps",
                                                    "gy_radps", "gz_radps", "temp_c"};
inline constexpr const char* kSiUnits[kChannels] = {"m/s^2", "m/s^2", "m/s^2", "rad/s",
                                                    "rad/s", "rad/s", "degC"};
// Fixed-length text datasets (status, message, end time), written in place [bytes].
inline constexpr std::size_t kStatusBytes = 16, kMessageBytes = 1024, kTimeBytes = 32;

// Held while calling the library: it serializes calls itself when built thread-safe; otherwise
// Stend does.
struct Hdf5Lock {
  std::unique_lock<std::mutex> lock;
  Hdf5Lock();
};

// The innermost messages of the HDF5 error stack ("wrong B-tree signature; …"); clears it.
std::string hdf5_error();

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

// Reading: throws InputError "FILE: WHAT (the HDF5 error stack)" — the file cannot be used as a
// run store. check() returns the handle of a call that returned `id`, or fails when it is negative.
[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what);
Handle check(hid_t id, herr_t (*close)(hid_t), const std::filesystem::path& file, const std::string& what);
void check(herr_t r, const std::filesystem::path& file, const std::string& what);
// Writing: the same with IoError — the file system refused the write.
[[noreturn]] void fail_write(const std::filesystem::path& file, const std::string& what);
Handle check_write(hid_t id, herr_t (*close)(hid_t), const std::filesystem::path& file, const std::string& what);
void check_write(herr_t r, const std::filesystem::path& file, const std::string& what);

// --- attributes ---------------------------------------------------------------------------------

Handle fixed_string_type(std::size_t bytes);
Handle vl_string_type();
// Creates or overwrites a scalar attribute. A string is fixed-length (format 2): the text lives in
// the attribute itself, never in the global heap.
void put_attr(hid_t obj, const char* name, const std::string& v, const std::filesystem::path& file);
void put_attr(hid_t obj, const char* name, double v, const std::filesystem::path& file);
void put_attr(hid_t obj, const char* name, std::int64_t v, const std::filesystem::path& file);
inline bool has_attr(hid_t obj, const char* name) { return H5Aexists(obj, name) > 0; }
// The number of values of an attribute or dataset's dataspace (a scalar is 1), -1 when unreadable.
inline hssize_t value_count(hid_t space) { return space >= 0 ? H5Sget_simple_extent_npoints(space) : -1; }

// --- datasets -----------------------------------------------------------------------------------

struct DatasetSpec {
  const char* name;
  hid_t type;
  hsize_t cols = 0;  // 0: 1-D
  hsize_t chunk_rows = kChunkSamples;
  bool compress = false;  // shuffle + deflate level 1
};
// An extensible chunked dataset of no rows, each chunk with a checksum.
Handle create_dataset(hid_t loc, const DatasetSpec& s, const std::filesystem::path& file);
// Rows [at, at + rows) of a 1-D or 2-D dataset, extending it to at + rows.
void write_rows(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, hsize_t cols, const void* data,
                const std::filesystem::path& file, const char* name);
hsize_t extent_rows(hid_t ds);
// Rows [at, at + rows) of a dataset into `out` (cols values per row; 0 for 1-D).
herr_t read_rows(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, hsize_t cols, void* out);

// A fixed-length text dataset of `bytes` bytes: written in place, created, read back.
void write_text(hid_t ds, std::size_t bytes, std::string_view text, const std::filesystem::path& file);
Handle create_text(hid_t loc, const char* name, std::size_t bytes, std::string_view text,
                   const std::filesystem::path& file);
std::string read_text(hid_t loc, const char* name, const std::filesystem::path& file);

// --- the counts→SI rule -------------------------------------------------------------------------

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

// Channel `ch` (0..kChannels−1: ax ay az gx gy gz temperature) of a sample: counts, SI, both.
inline std::int32_t counts_of(const ImuSample& s, int ch) {
  return ch < 3 ? s.accel_counts[ch] : ch < 6 ? s.gyro_counts[ch - 3] : s.temperature_counts;
}
inline double si_of(const ImuSample& s, int ch) {
  return ch < 3 ? s.accel_mps2[ch] : ch < 6 ? s.gyro_radps[ch - 3] : s.temperature_c;
}
inline void set_channel(ImuSample& s, int ch, std::int32_t c, double v) {
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

}  // namespace stend::detail
