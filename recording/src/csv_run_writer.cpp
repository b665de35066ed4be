// The CSV run store's writer (see csv_run_store.hpp): rows formatted straight into preallocated
// buffers drained by write(2).
#include "csv_run_store.hpp"
#include "store_files.hpp"

#include "stend/errors.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <charconv>
#include <cstring>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kImuBufferBytes = 1u << 20;
constexpr std::size_t kSmallBufferBytes = 64u << 10;

// One output file: a preallocated buffer drained by write(2).
struct OutFile {
  fs::path path;
  int fd = -1;
  std::unique_ptr<char[]> buf;
  std::size_t cap = 0, len = 0;
  std::uint64_t bytes = 0;  // written to the file so far (run.json records it at finish)

  OutFile() = default;
  OutFile(const OutFile&) = delete;
  OutFile& operator=(const OutFile&) = delete;
  ~OutFile() {
    if (fd >= 0) ::close(fd);
  }

  void open(const fs::path& p, std::size_t capacity) {
    path = p;
    fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
      throw IoError(fmt::format("{}: cannot create: {}", p.string(), std::strerror(errno)));
    }
    buf.reset(new char[capacity]);
    cap = capacity;
    len = 0;
  }
  void flush() {
    if (len == 0) return;
    const std::size_t n = len;
    len = 0;  // a failed write drops the buffer rather than repeating the error forever
    write_all(fd, buf.get(), n, path);
    bytes += n;
  }
  void append(std::string_view s) {
    if (cap - len < s.size()) flush();
    if (s.size() > cap) {
      write_all(fd, s.data(), s.size(), path);
      bytes += s.size();
      return;
    }
    std::memcpy(buf.get() + len, s.data(), s.size());
    len += s.size();
  }
  void sync() {
    if (fd >= 0 && ::fdatasync(fd) != 0 && errno != EINVAL && errno != EROFS) {
      throw IoError(fmt::format("{}: fdatasync failed: {}", path.string(), std::strerror(errno)));
    }
  }
};

inline char* put_double(char* p, double v) {
  if (v != v) return p;  // NaN: empty field
  return std::to_chars(p, p + csv::kMaxDoubleChars, v).ptr;
}
inline char* put_i32(char* p, std::int32_t v) {
  return std::to_chars(p, p + csv::kMaxInt32Chars, v).ptr;
}

// Sample times that are whole microseconds (every simulated clock at a rate dividing 1 MHz)
// are written as fixed decimals, which is exact: the text is m·10⁻⁶ and m / 1e6 == t was
// checked, so a correctly rounding parser returns t bit for bit. Anything else: shortest form.
inline char* put_time(char* p, double t) {
  if (t > 0.0 && t < 4.0e9) {
    const auto m = static_cast<std::uint64_t>(t * 1e6 + 0.5);
    if (static_cast<double>(m) / 1e6 == t) {
      p = std::to_chars(p, p + 20, m / 1000000).ptr;
      auto frac = static_cast<std::uint32_t>(m % 1000000);
      if (frac != 0) {
        char d[6];
        for (int i = 5; i >= 0; --i) {
          d[i] = static_cast<char>('0' + frac % 10);
          frac /= 10;
        }
        int n = 6;
        while (d[n - 1] == '0') --n;
        *p++ = '.';
        std::memcpy(p, d, 6);
        p += n;
      }
      return p;
    }
  }
  return put_double(p, t);
}

// Shortest-form text of recently written doubles, keyed by their bit pattern. Converted
// readings are quantized (SI = f(counts)), so a column takes few distinct values and most rows
// copy their text instead of running the shortest-round-trip algorithm (~40 ns per double).
// The text is a pure function of the bits, so a hit is always exact.
class TextCache {
 public:
  TextCache() : e_(new Entry[kSize]) {
    for (std::size_t i = 0; i < kSize; ++i) e_[i].bits = kEmpty;
  }
  char* put(char* p, double v) {
    if (v != v) return p;  // NaN: empty field (never looked up, so kEmpty never matches)
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    Entry& e = e_[(bits * 0x9E3779B97F4A7C15ull) >> (64 - kLog2Size)];
    if (e.bits == bits) {
      std::memcpy(p, e.text, sizeof e.text);
      return p + e.len;
    }
    char* const end = std::to_chars(p, p + csv::kMaxDoubleChars, v).ptr;
    const auto n = static_cast<std::size_t>(end - p);
    if (n <= sizeof e.text) {
      e.bits = bits;
      e.len = static_cast<std::uint8_t>(n);
      std::memcpy(e.text, p, n);
    }
    return end;
  }

 private:
  struct Entry {
    std::uint64_t bits;
    std::uint8_t len;
    char text[23];
  };
  static constexpr unsigned kLog2Size = 10;
  static constexpr std::size_t kSize = std::size_t{1} << kLog2Size;
  static constexpr std::uint64_t kEmpty = 0x7FF8DEADBEEF0001ull;  // a NaN
  std::unique_ptr<Entry[]> e_;
};

}  // namespace

struct CsvRunWriter::Impl {
  OutFile imu, truth, segments, events;
  TextCache text[7];  // ax ay az gx gy gz temp_c
};

CsvRunWriter::CsvRunWriter(const fs::path& run_dir, const std::vector<std::string>& truth_columns)
    : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.imu.open(run_dir / "imu.csv", kImuBufferBytes);
  I.truth.open(run_dir / "truth.csv", kSmallBufferBytes);
  I.segments.open(run_dir / "segments.csv", kSmallBufferBytes);
  I.events.open(run_dir / "events.csv", kSmallBufferBytes);
  I.imu.append(kImuHeader);
  I.imu.append("\n");
  std::vector<std::string> truth_header{"t_s"};
  truth_header.insert(truth_header.end(), truth_columns.begin(), truth_columns.end());
  std::string line;
  csv::append_record(line, truth_header);
  I.truth.append(line);
}

CsvRunWriter::~CsvRunWriter() = default;

void CsvRunWriter::add_samples(const ImuSample* samples, std::size_t count) {
  Impl& I = *impl_;
  OutFile& f = I.imu;
  char* const base = f.buf.get();
  for (std::size_t i = 0; i < count; ++i) {
    if (f.cap - f.len < kImuRowMax) f.flush();
    const ImuSample& s = samples[i];
    char* p = base + f.len;
    p = put_time(p, s.t_s);
    *p++ = ',';
    p = put_i32(p, s.accel_counts[0]);
    *p++ = ',';
    p = put_i32(p, s.accel_counts[1]);
    *p++ = ',';
    p = put_i32(p, s.accel_counts[2]);
    *p++ = ',';
    p = put_i32(p, s.gyro_counts[0]);
    *p++ = ',';
    p = put_i32(p, s.gyro_counts[1]);
    *p++ = ',';
    p = put_i32(p, s.gyro_counts[2]);
    *p++ = ',';
    p = put_i32(p, s.temperature_counts);
    *p++ = ',';
    p = I.text[0].put(p, s.accel_mps2[0]);
    *p++ = ',';
    p = I.text[1].put(p, s.accel_mps2[1]);
    *p++ = ',';
    p = I.text[2].put(p, s.accel_mps2[2]);
    *p++ = ',';
    p = I.text[3].put(p, s.gyro_radps[0]);
    *p++ = ',';
    p = I.text[4].put(p, s.gyro_radps[1]);
    *p++ = ',';
    p = I.text[5].put(p, s.gyro_radps[2]);
    *p++ = ',';
    p = I.text[6].put(p, s.temperature_c);
    *p++ = ',';
    p = std::to_chars(p, p + 10, s.flags).ptr;
    *p++ = '\n';
    f.len = static_cast<std::size_t>(p - base);
  }
}

void CsvRunWriter::add_truth(double t_s, const std::vector<double>& values) {
  OutFile& f = impl_->truth;
  const std::size_t need = (values.size() + 1) * (csv::kMaxDoubleChars + 1);
  if (need > f.cap) {
    std::string line;
    csv::append_double(line, t_s);
    for (double v : values) {
      line.push_back(',');
      csv::append_double(line, v);
    }
    line.push_back('\n');
    f.append(line);
  } else {
    if (f.cap - f.len < need) f.flush();
    char* p = f.buf.get() + f.len;
    p = put_double(p, t_s);
    for (double v : values) {
      *p++ = ',';
      p = put_double(p, v);
    }
    *p++ = '\n';
    f.len = static_cast<std::size_t>(p - f.buf.get());
  }
}

void CsvRunWriter::add_segment_record(std::string_view record) { impl_->segments.append(record); }

void CsvRunWriter::add_event_record(std::string_view record) {
  impl_->events.append(record);
  impl_->events.flush();
}

void CsvRunWriter::flush() {
  for (OutFile* f : {&impl_->imu, &impl_->truth, &impl_->segments, &impl_->events}) f->flush();
}

void CsvRunWriter::sync() {
  for (OutFile* f : {&impl_->imu, &impl_->truth, &impl_->segments, &impl_->events}) f->sync();
}

nlohmann::ordered_json CsvRunWriter::file_bytes() const {
  const Impl& I = *impl_;
  return {{"imu.csv", I.imu.bytes}, {"truth.csv", I.truth.bytes}, {"segments.csv", I.segments.bytes},
          {"events.csv", I.events.bytes}};
}

}  // namespace stend::detail
