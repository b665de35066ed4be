// Pieces every importer in io/ shares: reading text lines and binary files with positions for
// error messages, the recording every import starts from, its "info" event, and the timestamp
// checks (median interval, gaps, repeats).
#pragma once

#include <stend/io/importers.hpp>
#include <stend/io/timestamps.hpp>

#include "import_event.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <optional>
#include <fstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace stend::io::detail {

// ---------------------------------------------------------------------------------------------
// Text

// The longest line a text log may have [bytes]: an IMU log's line is under a kilobyte; a longer
// one (a column-name line or a field of megabytes) is refused, never held whole.
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;  // 1 MiB

// A line reader's buffer [bytes]: a line is read through it a piece at a time (a crafted imucal file
// of 1024 runs, a reader each, took a gigabyte with a buffer of kMaxLineBytes per reader).
inline constexpr std::size_t kLinePieceBytes = 4096;

// One line of `in` into `line` ('\n' and a '\r' before it removed) through `buf` a piece of its
// size − 1 at a time (≥ 2 bytes): true when a line was read; `cut` when it was longer than
// kMaxLineBytes (its rest skipped, not stored).
bool read_bounded_line(std::istream& in, std::vector<char>& buf, std::string& line, bool& cut);

// Lines of a text file with their 1-based numbers (CR and a UTF-8 byte-order mark removed); a line
// longer than kMaxLineBytes fails naming its number.
class LineReader {
 public:
  explicit LineReader(const std::filesystem::path& file);
  bool next(std::string& line);
  std::size_t line() const { return line_; }
  const std::filesystem::path& file() const { return file_; }
  [[noreturn]] void fail(const std::string& message) const { throw ImportError(file_, line_, message); }
  // Where the next line starts, to come back to it with seek (line(): the lines before it).
  std::streampos tell() { return in_.tellg(); }
  void seek(std::streampos pos, std::size_t lines_before) {
    in_.clear();
    in_.seekg(pos);
    line_ = lines_before;
  }

 private:
  std::filesystem::path file_;
  std::ifstream in_;
  std::size_t line_ = 0;
  std::vector<char> buf_ = std::vector<char>(kLinePieceBytes);
};

std::string_view trim(std::string_view s);
// Splits on `delim`; ' ' splits on runs of spaces and tabs. The second form fills `out` (its
// memory kept from line to line).
std::vector<std::string_view> split(std::string_view line, char delim);
void split(std::string_view line, char delim, std::vector<std::string_view>& out);
bool parse_double(std::string_view s, double& out);
// "%.6g"
std::string fmt_g(double v);

// --- text tables (the csv, imucal, mpu6050_multipos and static-table importers) ---------------

// `s` trimmed, and without one pair of double quotes around it.
std::string unquote(std::string_view s);
bool is_blank(std::string_view s);
// The number in `field`, column `what` of the line `r` read last; else fails naming both.
double number(const LineReader& r, std::string_view field, const std::string& what);
// `v` as an integer count (within 1e-6 of one, and of int32); else fails naming column `what`.
std::int32_t to_counts(const LineReader& r, double v, const std::string& what);
// Truth snapshots (kTruthColumns) holding specific force f [m/s²] and zero rate over t0 … t1 [s]:
// at its start, middle and end (snapshots in time order; a time already passed is not repeated).
void add_held_truth(Recording& rec, double t0, double t1, const std::array<double, 3>& f);
// The same for any truth layout: snapshots holding `row` (one value per header truth column, which
// the caller set) over t0 … t1 [s].
void add_held_truth(Recording& rec, double t0, double t1, const std::vector<double>& row);
// Sensor description of a 16-bit accelerometer + gyroscope without temperature: rate [Hz], LSB
// sizes [m/s², rad/s per count] and the ±32768-count ranges.
void set_int16_sensor_info(double rate_hz, double acc_lsb, double gyr_lsb, Recording& rec);
// "0x" and `digits` upper-case hex digits: fmt_hex(0xA3, 2) = "0xA3".
std::string fmt_hex(std::uint64_t v, int digits);

// ---------------------------------------------------------------------------------------------
// Binary

static_assert(std::endian::native == std::endian::little, "the binary log readers assume a little-endian host");

// A little-endian value at p (no bounds check: the caller checked the bytes are in the file).
template <class T>
T load_le(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// A binary file read through a bounded buffer (kBinaryWindow bytes, more only for a single larger
// range), with bounds checks: every read past the end throws an ImportError naming the offset and
// what was being read. need() brings bytes [offset, offset + count) into the buffer, reading from
// the file only when they are not already in it; at() points into the buffer and stays valid until
// a need() of bytes outside it. Reading is logically const (the buffer is a cache of the file).
class BinaryReader {
 public:
  static constexpr std::size_t kBinaryWindow = std::size_t{1} << 20;  // 1 MiB
  explicit BinaryReader(const std::filesystem::path& file);
  const std::filesystem::path& file() const { return file_; }
  std::size_t size() const { return size_; }
  const std::uint8_t* at(std::size_t offset) const { return buffer_.data() + (offset - start_); }
  // `what` names the bytes in a failure's message: text, or a function that makes it, called only
  // when the bytes must be read from the file (a message's name joined per message cost a heap
  // allocation per record).
  void need(std::size_t offset, std::size_t count, std::string_view what) const {
    if (!buffered(offset, count)) load(offset, count, what);
  }
  template <class Describe, class = std::enable_if_t<std::is_invocable_r_v<std::string, const Describe&>>>
  void need(std::size_t offset, std::size_t count, const Describe& what) const {
    if (!buffered(offset, count)) load(offset, count, what());
  }
  template <class T>
  T get(std::size_t offset, std::string_view what) const {
    need(offset, sizeof(T), what);
    return load_le<T>(at(offset));
  }
  // Offset of the first occurrence of `pattern` at or after `from`, if any.
  std::optional<std::size_t> find(std::size_t from, const std::uint8_t* pattern, std::size_t count) const;
  [[noreturn]] void fail(std::size_t offset, const std::string& message) const {
    throw ImportError(file_, ByteOffset{offset}, message);
  }

 private:
  bool buffered(std::size_t offset, std::size_t count) const {
    return offset >= start_ && offset <= size_ && count <= size_ - offset && offset + count <= start_ + buffer_.size();
  }
  void load(std::size_t offset, std::size_t count, std::string_view what) const;

  std::filesystem::path file_;
  std::size_t size_ = 0;
  mutable std::ifstream in_;
  mutable std::vector<std::uint8_t> buffer_;
  mutable std::size_t start_ = 0;  // file offset of buffer_[0]
};

// The first `count` bytes of a file (fewer when it is shorter; none when it cannot be read).
std::string file_prefix(const std::filesystem::path& file, std::size_t count);

// Text of a fixed-size char field, up to the first NUL.
std::string fixed_string(const std::uint8_t* p, std::size_t size);

// ---------------------------------------------------------------------------------------------
// Recordings and timestamps

// A closed, settled, complete segment `id` (its step too) of [t0, t1] s.
Segment make_segment(int id, SegmentKind kind, const std::string& label, double t0, double t1);
// Status complete, experiment "import:<format>", clock "wall", experiment_file and dir = file.
Recording new_recording(const std::filesystem::path& file, const std::string& format);
// Events of source "import" (import_event.hpp).
using stend::io::add_import_event;
using stend::io::place_import_events;
// A streaming import (rec, out) → the recording with its samples in memory and its import events at
// the first sample's time: the in-memory form of every importer that streams.
Recording import_in_memory(const std::function<void(Recording& rec, SampleSink& out)>& import);

// Samples passed one at a time, handed on to `out` in chunks of kDefaultChunkSamples.
class SampleChunker {
 public:
  explicit SampleChunker(SampleSink& out) : out_(&out) { chunk_.reserve(kDefaultChunkSamples); }
  void add(const ImuSample& s) {
    chunk_.push_back(s);
    ++count_;
    if (chunk_.size() == kDefaultChunkSamples) flush();
  }
  // Hands on what is held (call once at the end).
  void flush() {
    out_->add_samples(chunk_.data(), chunk_.size());
    chunk_.clear();
  }
  std::size_t count() const { return count_; }

 private:
  SampleSink* out_;
  std::vector<ImuSample> chunk_;
  std::size_t count_ = 0;
};

// Seconds from t0_us to t_us (timestamps in µs), exact to the microsecond.
inline double seconds_since_us(std::uint64_t t0_us, std::uint64_t t_us) {
  return (t_us >= t0_us ? static_cast<double>(t_us - t0_us) : -static_cast<double>(t0_us - t_us)) * 1e-6;
}
// The same for signed nanoseconds (ROS, EuRoC). Two times further apart than int64 holds (a
// corrupt timestamp, centuries off) are subtracted as doubles: never an overflow.
inline double seconds_since_ns(std::int64_t t0_ns, std::int64_t t_ns) {
  std::int64_t d = 0;
  if (!__builtin_sub_overflow(t_ns, t0_ns, &d)) return static_cast<double>(d) * 1e-9;
  return (static_cast<double>(t_ns) - static_cast<double>(t0_ns)) * 1e-9;
}

double median_interval(const std::vector<ImuSample>& s);

// The timestamps of a log taken as they come (in file order): output rate from the median
// interval, gaps flagged where the time jumps by more than gap_threshold(median interval, 0),
// repeated and decreasing timestamps counted (they do not stop an import). A bursty log
// (find_bursts, stend/io/timestamps.hpp): the rate is its mean rate and a gap longer than
// Bursts::gap_s.
struct TimestampSummary {
  double rate_hz = 0.0;
  double gap_s = 0.0;          // intervals longer than this are gaps [s]
  std::optional<Bursts> bursts;
  std::size_t gaps = 0;        // samples flagged kGapBefore by the timestamps
  std::size_t repeated = 0;    // t equal to the previous sample's
  std::size_t decreasing = 0;  // t before the previous sample's
  // "rate 100 Hz from the median interval; 2 gap(s) flagged where …" (for the info event)
  std::string rate_and_gaps() const;
  std::string describe() const;  // rate_and_gaps, the repeated and decreasing ones
};

// The summary above on a stream, with memory bounded by kTimestampWindow: the first window fixes
// the rate and the gap threshold; every window is flagged at its gaps and counted (its first
// sample against the last of the window before), then passed on to `out`. A log of at most one
// window is checked exactly as a whole. The rate goes into rec.header.info.output_rate_hz before
// the first samples reach `out`; finish() adds a warning event to `rec` when the log is bursty.
class LogTimestampStream final : public WindowSink {
 public:
  LogTimestampStream(Recording& rec, SampleSink& out) : WindowSink(out), rec_(&rec) {}
  // Passes the rest on.
  TimestampSummary finish();

 private:
  void process(std::vector<ImuSample>& s, bool first, double prev_t) override;
  void fix_rate(const std::vector<ImuSample>& first_window);
  void count(const ImuSample& s, double prev_t);
  Recording* rec_;
  TimestampSummary sum_;
};

// Linear interpolation of y(t) at `at`; t ascending. False outside [t.front() − tol, t.back() + tol]
// (the value is then left alone); inside, clamped to the end values.
template <class V>
bool interpolate_at(const std::vector<double>& t, const std::vector<V>& y, double at, double tol, V& out) {
  if (t.empty() || at < t.front() - tol || at > t.back() + tol) return false;
  std::size_t j = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), at) - t.begin());
  if (j == 0) {
    out = y.front();
  } else if (j == t.size()) {
    out = y.back();
  } else {
    const double span = t[j] - t[j - 1];
    const double u = span > 0.0 ? (at - t[j - 1]) / span : 0.0;
    out = y[j - 1] + (y[j] - y[j - 1]) * u;
  }
  return true;
}

}  // namespace stend::io::detail
