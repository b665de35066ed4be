// The recording store: run folder writer (incremental, write(2)-based) and reader.
// Format: docs/recording-format.md.
#include "stend/recording/recording.hpp"

#include "stend/recording/csv.hpp"
#include "stend/errors.hpp"
#include "stend/recording/files.hpp"
#include "hdf5_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <limits>
#include <ostream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <utility>

namespace stend {
namespace {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

constexpr std::string_view kImuHeader =
    "t_s,ax_counts,ay_counts,az_counts,gx_counts,gy_counts,gz_counts,temp_counts,"
    "ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps,temp_c,flags";
constexpr const char* kImuColumnNames[] = {
    "t_s",     "ax_counts", "ay_counts", "az_counts", "gx_counts", "gy_counts",
    "gz_counts", "temp_counts", "ax_mps2", "ay_mps2",  "az_mps2",   "gx_radps",
    "gy_radps", "gz_radps", "temp_c",    "flags"};
constexpr std::size_t kImuColumns = sizeof(kImuColumnNames) / sizeof(kImuColumnNames[0]);
const std::vector<std::string> kSegmentColumns = {
    "id",      "step",    "kind",     "label",   "repeat",     "orientation", "orientation_count",
    "t_start_s", "t_end_s", "settled", "complete", "targets",  "setpoint_c",  "rate_per_s"};
const std::vector<std::string> kEventColumns = {"t_s", "level", "source", "message"};

constexpr double kFlushInterval_s = 1.0;
// Upper bound of one imu.csv row: 8 doubles, 7 int32, one uint32, 15 commas and a line feed.
constexpr std::size_t kImuRowMax =
    8 * csv::kMaxDoubleChars + 7 * csv::kMaxInt32Chars + 10 + 16;
constexpr std::size_t kImuBufferBytes = 1u << 20;
constexpr std::size_t kSmallBufferBytes = 64u << 10;

std::string errno_text(int err) { return std::strerror(err); }

void write_all(int fd, const char* p, std::size_t n, const fs::path& file) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      throw IoError(fmt::format("{}: write failed: {}", file.string(), errno_text(errno)));
    }
    p += w;
    n -= static_cast<std::size_t>(w);
  }
}

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
      throw IoError(fmt::format("{}: cannot create: {}", p.string(), errno_text(errno)));
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
      throw IoError(fmt::format("{}: fdatasync failed: {}", path.string(),
                                           errno_text(errno)));
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

std::string utc_now_iso() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  std::tm tm{};
  ::gmtime_r(&ts.tv_sec, &tm);
  char buf[64];
  const std::size_t n = std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return fmt::format("{}.{:03d}Z", std::string_view(buf, n),
                     static_cast<int>(ts.tv_nsec / 1000000));
}

void fsync_dir(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

void write_file(const fs::path& file, const std::string& content) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw IoError(fmt::format("{}: cannot create: {}", file.string(), errno_text(errno)));
  }
  try {
    write_all(fd, content.data(), content.size(), file);
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
}

ojson header_json(const RecordingHeader& h) {
  ojson j;
  j["format_version"] = kRecordingFormatVersion;
  j["status"] = to_string(h.status);
  j["experiment_name"] = h.experiment_name;
  j["experiment_file"] = h.experiment_file;
  j["stend_version"] = h.stend_version;
  j["start_time_utc"] = h.start_time_utc;
  j["clock"] = h.clock;
  j["seed"] = h.seed;
  j["gravity_mps2"] = h.gravity_mps2;
  j["latitude_deg"] = h.latitude_deg;
  j["height_m"] = h.height_m;
  j["mounting_R_sensor_from_mount"] = h.mounting_R;
  ojson identity;
  identity["vendor"] = h.identity.vendor;
  identity["model"] = h.identity.model;
  identity["serial"] = h.identity.serial;
  identity["who_am_i"] = h.identity.who_am_i;
  ojson info;
  info["output_rate_hz"] = h.info.output_rate_hz;
  info["accel_range_mps2"] = h.info.accel_range_mps2;
  info["gyro_range_radps"] = h.info.gyro_range_radps;
  info["accel_lsb_mps2"] = h.info.accel_lsb_mps2;
  info["gyro_lsb_radps"] = h.info.gyro_lsb_radps;
  info["temperature_lsb_c"] = h.info.temperature_lsb_c;
  info["has_gyro"] = h.info.has_gyro;
  info["has_temperature"] = h.info.has_temperature;
  j["sensor"] = {{"identity", identity}, {"info", info}};
  ojson plugins = ojson::array();
  for (const auto& p : h.plugins) {
    plugins.push_back({{"role", p.role}, {"name", p.name}, {"version", p.version}, {"file", p.file},
                       {"origin", p.origin}, {"hash", p.hash}});
  }
  j["plugins"] = plugins;
  j["truth_columns"] = h.truth_columns;
  return j;
}

// Invalid UTF-8 (e.g. raw bytes read from a device into a serial number) is replaced, not thrown.
std::string dump_json(const ojson& j) {
  return j.dump(2, ' ', false, ojson::error_handler_t::replace) + "\n";
}

}  // namespace

// =============================================================================================
// Writer

struct RecordingWriter::Impl {
  RecordingHeader header;
  OutFile imu, truth, segments, events;
  std::uint64_t samples = 0, truth_rows = 0, segment_rows = 0, event_rows = 0;
  double last_flush_run_s = -std::numeric_limits<double>::infinity();
  std::chrono::steady_clock::time_point last_flush_wall = std::chrono::steady_clock::now();
  bool finished = false;
  std::string scratch;
  TextCache text[7];  // ax ay az gx gy gz temp_c
  std::unique_ptr<detail::Hdf5RunWriter> h5;  // the HDF5 store; null when writing CSV

  void check_open(const char* what) const {
    if (finished) {
      throw std::logic_error(fmt::format("RecordingWriter::{}: the recording was already finished",
                                         what));
    }
  }
  // Writes run.json and experiment.yaml and creates the CSVs with their header lines.
  void create_files(const fs::path& run_dir, RecordingHeader h,
                    const std::string& resolved_experiment_yaml, RecordingFormat format);
  // Flush rule: ≥ 1 s of wall time since the last flush, or (CSV) ≥ 1 s of run time.
  bool flush_due(double run_time_s) const {
    return (!h5 && run_time_s - last_flush_run_s >= kFlushInterval_s) ||
           std::chrono::steady_clock::now() - last_flush_wall >= std::chrono::seconds(1);
  }
  void flush_all() {
    if (h5) {
      h5->flush();
      last_flush_wall = std::chrono::steady_clock::now();
      return;
    }
    imu.flush();
    truth.flush();
    segments.flush();
    events.flush();
    last_flush_wall = std::chrono::steady_clock::now();
  }
};

void RecordingWriter::Impl::create_files(const fs::path& run_dir, RecordingHeader h,
                                         const std::string& resolved_experiment_yaml,
                                         RecordingFormat format) {
  Impl& I = *this;
  I.header = std::move(h);
  const std::string run_json = dump_json(header_json(I.header));
  write_file_atomic(run_dir / "run.json", run_json);
  write_file(run_dir / "experiment.yaml", resolved_experiment_yaml);
  if (format == RecordingFormat::kHdf5) {
    I.h5 = std::make_unique<detail::Hdf5RunWriter>(run_dir / detail::kHdf5FileName, I.header,
                                                   run_json, resolved_experiment_yaml);
    std::string line;
    csv::append_record(line, kSegmentColumns);
    I.h5->add_segment_record(line);
    line.clear();
    csv::append_record(line, kEventColumns);
    I.h5->add_event_record(line);
    return;
  }

  I.imu.open(run_dir / "imu.csv", kImuBufferBytes);
  I.truth.open(run_dir / "truth.csv", kSmallBufferBytes);
  I.segments.open(run_dir / "segments.csv", kSmallBufferBytes);
  I.events.open(run_dir / "events.csv", kSmallBufferBytes);

  I.imu.append(kImuHeader);
  I.imu.append("\n");
  std::string line;
  std::vector<std::string> truth_header{"t_s"};
  truth_header.insert(truth_header.end(), I.header.truth_columns.begin(),
                      I.header.truth_columns.end());
  csv::append_record(line, truth_header);
  I.truth.append(line);
  line.clear();
  csv::append_record(line, kSegmentColumns);
  I.segments.append(line);
  line.clear();
  csv::append_record(line, kEventColumns);
  I.events.append(line);
  I.flush_all();
}

RecordingWriter::RecordingWriter(const fs::path& run_dir, RecordingHeader header,
                                 const std::string& resolved_experiment_yaml,
                                 const RecordingWriterOptions& options)
    : impl_(std::make_unique<Impl>()), dir_(run_dir) {
  if (!header.mounting_R.empty() && header.mounting_R.size() != 9) {
    throw std::invalid_argument(fmt::format(
        "recording header: mounting_R has {} values, expected 9 (row-major 3x3) or none",
        header.mounting_R.size()));
  }
  for (std::size_t i = 0; i < header.truth_columns.size(); ++i) {
    const std::string& c = header.truth_columns[i];
    if (c.empty() || c == "t_s") {
      throw std::invalid_argument(fmt::format("recording header: truth column {} is named '{}'",
                                              i, c));
    }
    for (std::size_t k = 0; k < i; ++k) {
      if (header.truth_columns[k] == c) {
        throw std::invalid_argument(
            fmt::format("recording header: truth column '{}' appears twice", c));
      }
    }
  }
  try {
    // The reader checks experiment.yaml too; refuse now rather than write an unreadable run.
    (void)YAML::Load(resolved_experiment_yaml);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(fmt::format(
        "recording: the resolved experiment is not valid YAML (line {}, column {}): {}",
        e.mark.line + 1, e.mark.column + 1, e.msg));
  }
  if (header.start_time_utc.empty()) header.start_time_utc = utc_now_iso();
  header.status = RunStatus::kRunning;

  // "runs/x/" names the folder "runs/x".
  const fs::path target = run_dir.has_filename() ? run_dir : run_dir.parent_path();
  if (target.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(target.parent_path(), ec);
    if (ec) {
      throw IoError(fmt::format("{}: cannot create the parent directory: {}",
                                           target.parent_path().string(), ec.message()));
    }
  }
  if (::mkdir(target.c_str(), 0755) != 0) {
    if (errno == EEXIST) {
      throw std::runtime_error(fmt::format(
          "{}: run directory already exists; a recording is never overwritten — choose another "
          "run directory or remove this one",
          run_dir.string()));
    }
    throw IoError(
        fmt::format("{}: cannot create the run directory: {}", run_dir.string(), errno_text(errno)));
  }

  try {
    impl_->create_files(run_dir, std::move(header), resolved_experiment_yaml, options.format);
  } catch (...) {
    // The folder is ours (mkdir succeeded): do not leave a half-made run behind.
    impl_.reset();
    std::error_code ec;
    fs::remove_all(target, ec);
    throw;
  }
}

RecordingWriter::~RecordingWriter() {
  if (!impl_) return;
  try {
    impl_->flush_all();
  } catch (...) {
    // A destructor must not throw; the error was (or will be) visible through flush()/finish().
  }
}

void RecordingWriter::add_samples(const ImuSample* samples, std::size_t count) {
  Impl& I = *impl_;
  I.check_open("add_samples");
  if (count == 0) return;
  if (I.h5) {
    I.h5->add_samples(samples, count);
    I.samples += count;
    if (I.flush_due(samples[count - 1].t_s)) I.flush_all();
    return;
  }
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
  I.samples += count;
  // Also bounded by sample time, so durability holds even between sparse tick() calls.
  const double t_last = samples[count - 1].t_s;
  if (t_last - I.last_flush_run_s >= kFlushInterval_s) {
    I.flush_all();
    I.last_flush_run_s = t_last;
  }
}

void RecordingWriter::add_truth(double t_s, const std::vector<double>& values) {
  Impl& I = *impl_;
  I.check_open("add_truth");
  if (values.size() != I.header.truth_columns.size()) {
    throw std::invalid_argument(fmt::format(
        "RecordingWriter::add_truth: {} values for {} truth columns", values.size(),
        I.header.truth_columns.size()));
  }
  ++I.truth_rows;
  if (I.h5) {
    I.h5->add_truth(t_s, values);
    return;
  }
  OutFile& f = I.truth;
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

void RecordingWriter::add_truth(const RecordedTruth& truth) {
  std::vector<double> row;
  for_each_truth_row(truth, 0, truth.rows(), [&](double t, const double* values, bool) {
    row.assign(values, values + truth.columns());
    add_truth(t, row);
  });
}

void RecordingWriter::add_segment(const Segment& s) {
  Impl& I = *impl_;
  I.check_open("add_segment");
  std::string& line = I.scratch;
  line.clear();
  fmt::format_to(std::back_inserter(line), "{},{},", s.id, s.step);
  csv::append_field(line, to_string(s.kind));
  line.push_back(',');
  csv::append_field(line, s.label);
  fmt::format_to(std::back_inserter(line), ",{},{},{},", s.repeat, s.orientation,
                 s.orientation_count);
  csv::append_double(line, s.t_start_s);
  line.push_back(',');
  csv::append_double(line, s.t_end_s);
  line.append(s.settled ? ",1," : ",0,");
  line.append(s.complete ? "1," : "0,");
  csv::append_field(line, s.targets);
  line.push_back(',');
  csv::append_double(line, s.setpoint_c);
  line.push_back(',');
  csv::append_double(line, s.rate);
  line.push_back('\n');
  if (I.h5) {
    I.h5->add_segment_record(line);
  } else {
    I.segments.append(line);
  }
  ++I.segment_rows;
}

void RecordingWriter::add_event(const Event& e) {
  Impl& I = *impl_;
  I.check_open("add_event");
  std::string& line = I.scratch;
  line.clear();
  csv::append_double(line, e.t_s);
  line.push_back(',');
  csv::append_field(line, e.level);
  line.push_back(',');
  csv::append_field(line, e.source);
  line.push_back(',');
  csv::append_field(line, e.message);
  line.push_back('\n');
  if (I.h5) {
    I.h5->add_event_record(line);
    I.flush_all();
  } else {
    I.events.append(line);
    I.events.flush();
  }
  ++I.event_rows;
}

void RecordingWriter::tick(double run_time_s) {
  Impl& I = *impl_;
  if (I.flush_due(run_time_s)) {
    I.flush_all();
    I.last_flush_run_s = run_time_s;
  }
}

void RecordingWriter::flush() { impl_->flush_all(); }

void RecordingWriter::finish(RunStatus status, const std::string& message) {
  if (status == RunStatus::kRunning)
    throw std::invalid_argument("RecordingWriter::finish: the final status cannot be 'running'");
  Impl& I = *impl_;
  I.flush_all();
  // Data reaches the disk before run.json claims a final status.
  I.imu.sync();
  I.truth.sync();
  I.segments.sync();
  I.events.sync();
  I.header.status = status;
  ojson j = header_json(I.header);
  const std::string end_time = utc_now_iso();
  j["end_time_utc"] = end_time;
  j["status_message"] = message;
  j["sample_count"] = I.samples;
  j["truth_count"] = I.truth_rows;
  j["segment_count"] = I.segment_rows;
  j["event_count"] = I.event_rows;
  if (!I.h5) {
    // Lengths beside the row counts: a reader tells a truncated or extended file from a whole one.
    j["file_bytes"] = {{"imu.csv", I.imu.bytes}, {"truth.csv", I.truth.bytes},
                       {"segments.csv", I.segments.bytes}, {"events.csv", I.events.bytes}};
  }
  // run.h5 first: it is the source of truth, run.json its readable copy.
  if (I.h5) I.h5->finish(status, end_time, message);
  write_file_atomic(dir_ / "run.json", dump_json(j));
  fsync_dir(dir_);
  I.finished = true;
}

std::uint64_t RecordingWriter::sample_count() const { return impl_->samples; }

// =============================================================================================
// Reader

namespace {

[[noreturn]] void fail_at(const fs::path& file, std::size_t line, const std::string& what) {
  throw std::runtime_error(fmt::format("{}:{}: {}", file.string(), line, what));
}

std::string read_whole_file(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    throw std::runtime_error(fmt::format("{}: cannot open: {}", file.string(), errno_text(errno)));
  }
  std::string out;
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      throw IoError(fmt::format("{}: read failed: {}", file.string(), errno_text(err)));
    }
    if (n == 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return out;
}

// Typed access to run.json with errors that name the key.
class JsonFields {
 public:
  JsonFields(const nlohmann::json& j, fs::path file) : j_(j), file_(std::move(file)) {}

  const nlohmann::json* find(const nlohmann::json& obj, const char* key) const {
    auto it = obj.find(key);
    return it == obj.end() ? nullptr : &*it;
  }
  [[noreturn]] void bad(const std::string& key, const char* expected) const {
    throw std::runtime_error(
        fmt::format("{}: key '{}' should be {}", file_.string(), key, expected));
  }
  void str(const nlohmann::json& obj, const char* key, const std::string& path,
           std::string& out) const {
    if (const auto* v = find(obj, key)) {
      if (!v->is_string()) bad(path, "a string");
      out = v->get<std::string>();
    }
  }
  void num(const nlohmann::json& obj, const char* key, const std::string& path, double& out) const {
    if (const auto* v = find(obj, key)) {
      if (v->is_null()) {
        out = std::numeric_limits<double>::quiet_NaN();  // JSON has no NaN; written as null
      } else if (v->is_number()) {
        out = v->get<double>();
      } else {
        bad(path, "a number (or null for NaN)");
      }
    }
  }
  void boolean(const nlohmann::json& obj, const char* key, const std::string& path,
               bool& out) const {
    if (const auto* v = find(obj, key)) {
      if (!v->is_boolean()) bad(path, "true or false");
      out = v->get<bool>();
    }
  }
  const nlohmann::json& root() const { return j_; }

 private:
  const nlohmann::json& j_;
  fs::path file_;
};

// run.json's text as JSON; a syntax error names the file and line.
nlohmann::json parse_run_json(const fs::path& file, const std::string& text) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    const std::size_t upto = std::min<std::size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
    const auto line =
        1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(upto), '\n'));
    fail_at(file, line, fmt::format("invalid JSON ({})", e.what()));
  } catch (const nlohmann::json::exception& e) {  // e.g. a number out of range
    throw std::runtime_error(fmt::format("{}: invalid JSON ({})", file.string(), e.what()));
  }
}

// format_version (refused outside 1..kRecordingFormatVersion) and status.
void read_version_and_status(const nlohmann::json& j, const JsonFields& f, const fs::path& file,
                             RecordingHeader& h) {
  const auto* ver = f.find(j, "format_version");
  if (!ver || !ver->is_number_integer()) f.bad("format_version", "an integer (required)");
  const auto version = ver->get<std::int64_t>();
  if (version < 1 || version > kRecordingFormatVersion) {
    throw std::runtime_error(fmt::format(
        "{}: format_version {} is not readable by this Stend (reads 1..{}); {}", file.string(),
        version, kRecordingFormatVersion,
        version > kRecordingFormatVersion ? "upgrade Stend" : "the file is damaged"));
  }
  const auto* st = f.find(j, "status");
  const auto status = st && st->is_string() ? run_status_from_string(st->get<std::string>()) : std::nullopt;
  if (!status) f.bad("status", "one of running, complete, interrupted, failed (required)");
  h.status = *status;
}

// Names, clock, seed, site (gravity [m/s²], latitude [deg], height [m]) and mounting.
void read_run_fields(const nlohmann::json& j, const JsonFields& f, RecordingHeader& h) {
  f.str(j, "experiment_name", "experiment_name", h.experiment_name);
  f.str(j, "experiment_file", "experiment_file", h.experiment_file);
  f.str(j, "stend_version", "stend_version", h.stend_version);
  f.str(j, "start_time_utc", "start_time_utc", h.start_time_utc);
  f.str(j, "clock", "clock", h.clock);
  if (const auto* v = f.find(j, "seed")) {
    if (!v->is_number_unsigned() && !(v->is_number_integer() && v->get<std::int64_t>() >= 0)) {
      f.bad("seed", "a non-negative integer");
    }
    h.seed = v->get<std::uint64_t>();
  }
  f.num(j, "gravity_mps2", "gravity_mps2", h.gravity_mps2);
  f.num(j, "latitude_deg", "latitude_deg", h.latitude_deg);
  f.num(j, "height_m", "height_m", h.height_m);
  if (const auto* v = f.find(j, "mounting_R_sensor_from_mount")) {
    if (!v->is_array() || (v->size() != 0 && v->size() != 9)) {
      f.bad("mounting_R_sensor_from_mount", "an array of 9 numbers (row-major)");
    }
    h.mounting_R.clear();
    for (const auto& x : *v) {
      if (x.is_null()) {
        h.mounting_R.push_back(std::numeric_limits<double>::quiet_NaN());
      } else if (x.is_number()) {
        h.mounting_R.push_back(x.get<double>());
      } else {
        f.bad("mounting_R_sensor_from_mount", "an array of 9 numbers (row-major)");
      }
    }
  }
}

// "sensor": identity and info (rate [Hz], ranges and LSB sizes in SI, what it measures).
void read_sensor(const nlohmann::json& j, const JsonFields& f, RecordingHeader& h) {
  const auto* sensor = f.find(j, "sensor");
  if (!sensor) return;
  if (!sensor->is_object()) f.bad("sensor", "an object");
  if (const auto* id = f.find(*sensor, "identity")) {
    if (!id->is_object()) f.bad("sensor.identity", "an object");
    f.str(*id, "vendor", "sensor.identity.vendor", h.identity.vendor);
    f.str(*id, "model", "sensor.identity.model", h.identity.model);
    f.str(*id, "serial", "sensor.identity.serial", h.identity.serial);
    f.str(*id, "who_am_i", "sensor.identity.who_am_i", h.identity.who_am_i);
  }
  if (const auto* info = f.find(*sensor, "info")) {
    if (!info->is_object()) f.bad("sensor.info", "an object");
    f.num(*info, "output_rate_hz", "sensor.info.output_rate_hz", h.info.output_rate_hz);
    f.num(*info, "accel_range_mps2", "sensor.info.accel_range_mps2", h.info.accel_range_mps2);
    f.num(*info, "gyro_range_radps", "sensor.info.gyro_range_radps", h.info.gyro_range_radps);
    f.num(*info, "accel_lsb_mps2", "sensor.info.accel_lsb_mps2", h.info.accel_lsb_mps2);
    f.num(*info, "gyro_lsb_radps", "sensor.info.gyro_lsb_radps", h.info.gyro_lsb_radps);
    f.num(*info, "temperature_lsb_c", "sensor.info.temperature_lsb_c", h.info.temperature_lsb_c);
    f.boolean(*info, "has_gyro", "sensor.info.has_gyro", h.info.has_gyro);
    f.boolean(*info, "has_temperature", "sensor.info.has_temperature", h.info.has_temperature);
  }
}

// "plugins" (role, name, version, file of each) and "truth_columns".
void read_plugins_and_truth_columns(const nlohmann::json& j, const JsonFields& f, RecordingHeader& h) {
  if (const auto* plugins = f.find(j, "plugins")) {
    if (!plugins->is_array()) f.bad("plugins", "an array");
    h.plugins.clear();
    for (std::size_t i = 0; i < plugins->size(); ++i) {
      const auto& p = (*plugins)[i];
      const std::string path = fmt::format("plugins[{}]", i);
      if (!p.is_object()) f.bad(path, "an object");
      PluginUse u;
      f.str(p, "role", path + ".role", u.role);
      f.str(p, "name", path + ".name", u.name);
      f.str(p, "version", path + ".version", u.version);
      f.str(p, "file", path + ".file", u.file);
      if (p.contains("origin")) f.str(p, "origin", path + ".origin", u.origin);  // absent before they were recorded
      if (p.contains("hash")) f.str(p, "hash", path + ".hash", u.hash);
      h.plugins.push_back(std::move(u));
    }
  }
  if (const auto* cols = f.find(j, "truth_columns")) {
    if (!cols->is_array()) f.bad("truth_columns", "an array of strings");
    h.truth_columns.clear();
    for (const auto& c : *cols) {
      if (!c.is_string()) f.bad("truth_columns", "an array of strings");
      h.truth_columns.push_back(c.get<std::string>());
    }
  }
}

// The header from run.json's text; `file` names where the text came from in errors. Returns the
// parsed JSON (for the counts the writer recorded at finish).
nlohmann::json read_run_json(const fs::path& file, const std::string& text, RecordingHeader& h) {
  const nlohmann::json j = parse_run_json(file, text);
  if (!j.is_object()) fail_at(file, 1, "expected a JSON object");
  const JsonFields f(j, file);
  read_version_and_status(j, f, file, h);
  read_run_fields(j, f, h);
  read_sensor(j, f, h);
  read_plugins_and_truth_columns(j, f, h);
  return j;
}

// What reading one CSV file found: its whole rows (header and blank lines not counted; nullopt when
// the rows were not read), the line of the last whole one, whether the file ends inside a line (no
// line feed), and its length [bytes].
struct FileRead {
  fs::path path;
  bool exists = true;
  std::optional<std::uint64_t> rows;
  std::size_t last_line = 0;
  bool cut = false;
  std::uint64_t bytes = 0;
};

// The FileRead of a file that is not there, or whose rows were not read (its length only).
FileRead file_not_read(const fs::path& file) {
  FileRead f;
  f.path = file;
  std::error_code ec;
  f.exists = fs::exists(file, ec);
  if (f.exists) f.bytes = fs::file_size(file, ec);
  return f;
}

// The FileRead of `rows` rows read through `rd`; a cut last line is counted in r.
FileRead file_read(const csv::Reader& rd, std::uint64_t rows, Recording& r) {
  r.dropped_partial_lines += rd.partial();
  return {rd.path(), true, rows, rd.line(), rd.partial() > 0, rd.file_size()};
}

// --- imu.csv ---------------------------------------------------------------------------------

inline bool fast_double(const char*& p, const char* e, double& v) {
  if (p == e || *p == ',') {
    v = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  const auto r = std::from_chars(p, e, v);
  if (r.ec != std::errc{}) return false;
  p = r.ptr;
  return true;
}

template <class Int>
inline bool fast_int(const char*& p, const char* e, Int& v) {
  const auto r = std::from_chars(p, e, v);
  if (r.ec != std::errc{}) return false;
  p = r.ptr;
  return true;
}

inline bool sep(const char*& p, const char* e) {
  if (p == e || *p != ',') return false;
  ++p;
  return true;
}

bool parse_imu_fast(std::string_view line, ImuSample& s) {
  const char* p = line.data();
  const char* const e = p + line.size();
  if (!fast_double(p, e, s.t_s) || !sep(p, e)) return false;
  for (int k = 0; k < 3; ++k) {
    if (!fast_int(p, e, s.accel_counts[k]) || !sep(p, e)) return false;
  }
  for (int k = 0; k < 3; ++k) {
    if (!fast_int(p, e, s.gyro_counts[k]) || !sep(p, e)) return false;
  }
  if (!fast_int(p, e, s.temperature_counts) || !sep(p, e)) return false;
  for (int k = 0; k < 3; ++k) {
    if (!fast_double(p, e, s.accel_mps2[k]) || !sep(p, e)) return false;
  }
  for (int k = 0; k < 3; ++k) {
    if (!fast_double(p, e, s.gyro_radps[k]) || !sep(p, e)) return false;
  }
  if (!fast_double(p, e, s.temperature_c) || !sep(p, e)) return false;
  if (!fast_int(p, e, s.flags)) return false;
  return p == e;
}

std::vector<std::string_view> split_plain(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      out.push_back(line.substr(start));
      return out;
    }
    out.push_back(line.substr(start, comma - start));
    start = comma + 1;
  }
}

// Tolerant per-field parse (leading '+', "NaN", "Inf", …) that names the bad column.
void parse_imu_slow(std::string_view line, ImuSample& s, const fs::path& file, std::size_t ln) {
  const auto f = split_plain(line);
  if (f.size() != kImuColumns) {
    fail_at(file, ln, fmt::format("expected {} comma-separated fields, found {}", kImuColumns,
                                  f.size()));
  }
  auto bad = [&](std::size_t col, const char* what) {
    fail_at(file, ln, fmt::format("column {} ({}): '{}' is not {}", col + 1,
                                  kImuColumnNames[col], excerpt(f[col]), what));
  };
  auto dbl = [&](std::size_t col, double& out) {
    if (!csv::parse_double(f[col], out)) bad(col, "a number");
  };
  auto i32 = [&](std::size_t col, std::int32_t& out) {
    std::int64_t v = 0;
    if (!csv::parse_int(f[col], v) || v < std::numeric_limits<std::int32_t>::min() ||
        v > std::numeric_limits<std::int32_t>::max()) {
      bad(col, "a 32-bit integer");
    }
    out = static_cast<std::int32_t>(v);
  };
  dbl(0, s.t_s);
  for (int k = 0; k < 3; ++k) i32(1 + static_cast<std::size_t>(k), s.accel_counts[k]);
  for (int k = 0; k < 3; ++k) i32(4 + static_cast<std::size_t>(k), s.gyro_counts[k]);
  i32(7, s.temperature_counts);
  for (int k = 0; k < 3; ++k) dbl(8 + static_cast<std::size_t>(k), s.accel_mps2[k]);
  for (int k = 0; k < 3; ++k) dbl(11 + static_cast<std::size_t>(k), s.gyro_radps[k]);
  dbl(14, s.temperature_c);
  std::uint64_t flags = 0;
  if (!csv::parse_uint(f[15], flags) || flags > std::numeric_limits<std::uint32_t>::max()) {
    bad(15, "an unsigned 32-bit integer");
  }
  s.flags = static_cast<std::uint32_t>(flags);
}

FileRead read_imu(const fs::path& file, Recording& r) {
  csv::Reader rd(file);
  std::string_view line;
  if (!rd.next_line(line)) return file_read(rd, 0, r);  // empty, or the header itself was cut short
  if (line != kImuHeader) {
    fail_at(file, rd.line(),
            fmt::format("unexpected header '{}'; expected '{}'", excerpt(line), kImuHeader));
  }
  const std::uint64_t header_bytes = rd.bytes_consumed();
  bool reserved = false;
  while (rd.next_line(line)) {
    if (line.empty()) continue;
    ImuSample& s = r.samples.emplace_back();
    if (!parse_imu_fast(line, s)) parse_imu_slow(line, s, file, rd.line());
    if (!reserved && r.samples.size() == 4096) {
      // Size the vector once from the average row length instead of growing it by doubling.
      reserved = true;
      const double per_row =
          static_cast<double>(rd.bytes_consumed() - header_bytes) / 4096.0;
      const double remaining = static_cast<double>(rd.file_size() - rd.bytes_consumed());
      r.samples.reserve(4096 + static_cast<std::size_t>(remaining / per_row * 1.05) + 16);
    }
  }
  return file_read(rd, r.samples.size(), r);
}

// --- truth.csv -------------------------------------------------------------------------------

FileRead read_truth(const fs::path& file, Recording& r) {
  csv::Reader rd(file);
  std::vector<std::string> fields;
  if (!rd.next_record(fields)) return file_read(rd, 0, r);
  std::vector<std::string> expected{"t_s"};
  expected.insert(expected.end(), r.header.truth_columns.begin(), r.header.truth_columns.end());
  if (fields != expected) {
    std::string got, want;
    csv::append_record(got, fields);
    csv::append_record(want, expected);
    got.pop_back();
    want.pop_back();
    fail_at(file, rd.line(),
            fmt::format("header '{}' does not match run.json truth_columns (expected '{}')", excerpt(got),
                        excerpt(want)));
  }
  const std::size_t n = r.header.truth_columns.size();
  std::string_view line;
  std::vector<double> row(n);
  while (rd.next_line(line)) {
    if (line.empty()) continue;
    const char* p = line.data();
    const char* const e = p + line.size();
    double t = 0.0;
    bool ok = fast_double(p, e, t);
    for (std::size_t k = 0; ok && k < n; ++k) ok = sep(p, e) && fast_double(p, e, row[k]);
    ok = ok && p == e;
    if (!ok) {
      const auto f = split_plain(line);
      if (f.size() != n + 1) {
        fail_at(file, rd.line(),
                fmt::format("expected {} comma-separated fields, found {}", n + 1, f.size()));
      }
      for (std::size_t k = 0; k <= n; ++k) {
        double v = 0.0;
        if (!csv::parse_double(f[k], v)) {
          fail_at(file, rd.line(), fmt::format("column {} ({}): '{}' is not a number", k + 1,
                                               expected[k], excerpt(f[k])));
        }
        if (k == 0) {
          t = v;
        } else {
          row[k - 1] = v;
        }
      }
    }
    r.truth_t.push_back(t);
    r.truth.push_back(row);
  }
  return file_read(rd, r.truth_t.size(), r);
}

// --- segments.csv / events.csv ---------------------------------------------------------------


bool blank(const std::vector<std::string>& f) { return f.size() == 1 && f[0].empty(); }

void check_header(const csv::Reader& rd, const std::vector<std::string>& got,
                  const std::vector<std::string>& want) {
  if (got != want) {
    std::string a, b;
    csv::append_record(a, got);
    csv::append_record(b, want);
    a.pop_back();
    b.pop_back();
    fail_at(rd.path(), rd.line(), fmt::format("unexpected header '{}'; expected '{}'", excerpt(a), b));
  }
}

FileRead read_segments(csv::Reader& rd, Recording& r) {
  const fs::path& file = rd.path();
  std::vector<std::string> f;
  if (!rd.next_record(f)) return file_read(rd, 0, r);
  check_header(rd, f, kSegmentColumns);
  std::uint64_t rows = 0;
  while (rd.next_record(f)) {
    if (blank(f)) continue;
    if (f.size() != kSegmentColumns.size()) {
      fail_at(file, rd.line(), fmt::format("expected {} fields, found {}",
                                           kSegmentColumns.size(), f.size()));
    }
    auto bad = [&](std::size_t col, const char* what) {
      fail_at(file, rd.line(), fmt::format("column {} ({}): '{}' is not {}", col + 1,
                                           kSegmentColumns[col], excerpt(f[col]), what));
    };
    auto integer = [&](std::size_t col, int& out) {
      std::int64_t v = 0;
      if (!csv::parse_int(f[col], v) || v < std::numeric_limits<int>::min() ||
          v > std::numeric_limits<int>::max()) {
        bad(col, "an integer");
      }
      out = static_cast<int>(v);
    };
    auto number = [&](std::size_t col, double& out) {
      if (!csv::parse_double(f[col], out)) bad(col, "a number");
    };
    auto flag = [&](std::size_t col, bool& out) {
      if (!csv::parse_bool(f[col], out)) bad(col, "0 or 1");
    };
    Segment s;
    integer(0, s.id);
    integer(1, s.step);
    const auto kind = segment_kind_from_string(f[2]);
    if (!kind) bad(2, "a segment kind (orientation, rate, rotation, set_temperature, record, wait, detected)");
    s.kind = *kind;
    s.label = std::move(f[3]);
    integer(4, s.repeat);
    integer(5, s.orientation);
    integer(6, s.orientation_count);
    number(7, s.t_start_s);
    number(8, s.t_end_s);
    flag(9, s.settled);
    flag(10, s.complete);
    s.targets = std::move(f[11]);
    number(12, s.setpoint_c);
    number(13, s.rate);
    r.segments.push_back(std::move(s));
    ++rows;
  }
  return file_read(rd, rows, r);
}

FileRead read_events(csv::Reader& rd, Recording& r) {
  const fs::path& file = rd.path();
  std::vector<std::string> f;
  if (!rd.next_record(f)) return file_read(rd, 0, r);
  check_header(rd, f, kEventColumns);
  std::uint64_t rows = 0;
  while (rd.next_record(f)) {
    if (blank(f)) continue;
    if (f.size() != kEventColumns.size()) {
      fail_at(file, rd.line(),
              fmt::format("expected {} fields, found {}", kEventColumns.size(), f.size()));
    }
    Event e;
    if (!csv::parse_double(f[0], e.t_s)) {
      fail_at(file, rd.line(), fmt::format("column 1 (t_s): '{}' is not a number", excerpt(f[0])));
    }
    e.level = std::move(f[1]);
    e.source = std::move(f[2]);
    e.message = std::move(f[3]);
    r.events.push_back(std::move(e));
    ++rows;
  }
  return file_read(rd, rows, r);
}

// The experiment's YAML, checked.
void check_experiment_yaml(const fs::path& where, const std::string& text) {
  try {
    (void)YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(fmt::format("{}:{}:{}: invalid YAML: {}", where.string(),
                                         e.mark.line + 1, e.mark.column + 1, e.msg));
  }
}

// When run.h5's header attributes cannot be read (`damage`), the header the writer also put in
// run.json (and the experiment in experiment.yaml) beside it; without run.json the run is unreadable.
void read_header_beside_damaged_hdf5(const fs::path& file, const std::string& damage, Recording& r) {
  std::error_code ec;
  const fs::path run_json = file.parent_path() / "run.json";
  if (!fs::exists(run_json, ec))
    throw std::runtime_error(fmt::format("{}; {} is missing, so the run's header cannot be read", damage, run_json.string()));
  read_run_json(run_json, read_whole_file(run_json), r.header);
  const fs::path yaml = file.parent_path() / "experiment.yaml";
  if (fs::exists(yaml, ec)) {
    r.experiment_yaml = read_whole_file(yaml);
    check_experiment_yaml(yaml, r.experiment_yaml);
  }
}

// run.h5: header, experiment, truth, segments and events; samples behind the file's source.
void open_hdf5(const fs::path& file, Recording& r, SampleLoading loading, TruthLoading truth) {
  detail::Hdf5Run h = detail::open_hdf5_run(file, truth);
  if (h.header_damage.empty()) {
    read_run_json(file.string() + ":header_json", h.header_json, r.header);
    r.experiment_yaml = std::move(h.experiment_yaml);
    check_experiment_yaml(file.string() + ":experiment_yaml", r.experiment_yaml);
  } else {
    read_header_beside_damaged_hdf5(file, h.header_damage, r);
    h.damage = h.header_damage + (h.damage.empty() ? "" : "; " + h.damage);
  }
  r.header.status = h.status;
  if (h.truth_columns != r.header.truth_columns.size() && h.truth_rows > 0) {
    throw std::runtime_error(fmt::format("{}: dataset /truth has {} value columns, the header names {}",
                                         file.string(), h.truth_columns, r.header.truth_columns.size()));
  }
  r.truth_t = std::move(h.truth_t);
  r.truth = std::move(h.truth);
  r.truth_store = std::move(h.truth_store);
  r.truth_rows = h.truth_rows;
  csv::Reader segments(file.string() + ":segments_csv", h.segments_csv);
  read_segments(segments, r);
  csv::Reader events(file.string() + ":events_csv", h.events_csv);
  read_events(events, r);
  r.format = RecordingFormat::kHdf5;
  r.written_samples = h.written_samples;
  r.damage = std::move(h.damage);
  r.gap_count = h.gap_count;
  r.irregular_count = h.irregular_count;
  if (loading == SampleLoading::kStream) {
    r.source = std::move(h.samples);
    return;
  }
  r.samples.resize(h.samples->size());
  for_each_chunk(*h.samples, [&](const ImuSample* c, std::size_t n, std::uint64_t first) {
    std::copy(c, c + n, r.samples.begin() + static_cast<std::ptrdiff_t>(first));
  });
}

// run.json's count `key` under `obj`, nullopt when absent (run folders from before that count).
std::optional<std::uint64_t> recorded_count(const nlohmann::json& obj, const char* key) {
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_number_unsigned()) return std::nullopt;
  return it->get<std::uint64_t>();
}

// What is damaged in one file of a finished run, against the rows and bytes run.json records
// (absent counts are not compared); empty when the file is whole.
std::string file_damage(const FileRead& f, std::optional<std::uint64_t> rows,
                        std::optional<std::uint64_t> bytes) {
  if (!f.exists) {
    if (rows.value_or(0) == 0 && bytes.value_or(0) == 0) return {};
    return fmt::format("{}: missing; run.json records {} rows", f.path.string(), rows.value_or(0));
  }
  std::vector<std::string> what;
  if (f.cut) what.push_back("the last line is cut mid-line (no line feed at the end of the file)");
  if (rows && f.rows && *rows != *f.rows) {
    what.push_back(fmt::format("run.json records {} rows, {} whole rows found (the last good line is {})",
                               *rows, *f.rows, f.last_line));
  }
  if (bytes && *bytes != f.bytes)
    what.push_back(fmt::format("run.json records {} bytes, the file holds {}", *bytes, f.bytes));
  if (what.empty()) return {};
  std::string out = fmt::format("{}:{}: ", f.path.string(), f.cut ? f.last_line + 1 : f.last_line);
  for (std::size_t i = 0; i < what.size(); ++i) out += (i ? "; " : "") + what[i];
  return out;
}

// A finished run's files against what its writer recorded in run.json at finish: what differs
// goes to r.damage (the rows read stay usable), and r.written_samples becomes the samples written.
void check_recorded_counts(const nlohmann::json& run_json, const std::vector<FileRead>& files, Recording& r) {
  if (r.header.status == RunStatus::kRunning) return;  // killed: no counts, a cut last line is expected
  constexpr std::pair<const char*, const char*> kRowKeys[] = {
      {"imu.csv", "sample_count"}, {"truth.csv", "truth_count"},
      {"segments.csv", "segment_count"}, {"events.csv", "event_count"}};
  const auto bytes_it = run_json.find("file_bytes");
  for (const FileRead& f : files) {
    const std::string name = f.path.filename().string();
    std::optional<std::uint64_t> rows, bytes;
    for (const auto& [file, key] : kRowKeys)
      if (name == file) rows = recorded_count(run_json, key);
    if (bytes_it != run_json.end() && bytes_it->is_object()) bytes = recorded_count(*bytes_it, name.c_str());
    const std::string d = file_damage(f, rows, bytes);
    if (d.empty()) continue;
    r.damage += (r.damage.empty() ? "" : "; ") + d;
    if (name == "imu.csv" && rows) r.written_samples = *rows;
  }
}

// The CSV files of a run folder, checked against the counts in run.json.
void open_csv(const fs::path& run_dir, const nlohmann::json& run_json, Recording& r, SampleLoading loading,
              TruthLoading truth) {
  std::error_code ec;
  const fs::path imu = run_dir / "imu.csv";
  if (!fs::exists(imu, ec)) {
    throw std::runtime_error(fmt::format("{}: missing (every recording has run.h5 or imu.csv)", imu.string()));
  }
  std::vector<FileRead> files{read_imu(imu, r)};
  r.written_samples = r.samples.size();
  const fs::path truth_csv = run_dir / "truth.csv";
  const bool read_truth_rows = truth != TruthLoading::kSkip && fs::exists(truth_csv, ec);  // kStream too: CSV has no index
  files.push_back(read_truth_rows ? read_truth(truth_csv, r) : file_not_read(truth_csv));
  r.truth_rows = r.truth_t.size();
  for (const auto& [name, read] : {std::pair{"segments.csv", &read_segments}, std::pair{"events.csv", &read_events}}) {
    if (!fs::exists(run_dir / name, ec)) {
      files.push_back(file_not_read(run_dir / name));
      continue;
    }
    csv::Reader rd(run_dir / name);
    files.push_back(read(rd, r));
  }
  check_recorded_counts(run_json, files, r);
  r.gap_count = std::count_if(r.samples.begin(), r.samples.end(),
                              [](const ImuSample& s) { return (s.flags & kGapBefore) != 0; });
  if (loading == SampleLoading::kStream)
    r.source = std::make_shared<MemorySamples>(std::exchange(r.samples, {}));
}

}  // namespace

namespace {

// Recording::open before its errors are classified.
Recording open_run_folder(const fs::path& run_dir, SampleLoading loading, TruthLoading truth) {
  std::error_code ec;
  if (!fs::is_directory(run_dir, ec)) {
    throw std::runtime_error(
        fmt::format("{}: not a run directory (it does not exist or is not a folder)",
                    run_dir.string()));
  }
  Recording r;
  r.dir = run_dir;
  const fs::path h5 = run_dir / detail::kHdf5FileName;
  if (fs::exists(h5, ec)) {
    open_hdf5(h5, r, loading, truth);
    return r;
  }
  const fs::path run_json = run_dir / "run.json";
  if (!fs::exists(run_json, ec)) {
    throw std::runtime_error(fmt::format(
        "{}: missing; {} is not a Stend recording (or its writer died before starting)",
        run_json.string(), run_dir.string()));
  }
  const nlohmann::json run_json_fields = read_run_json(run_json, read_whole_file(run_json), r.header);

  const fs::path yaml = run_dir / "experiment.yaml";
  if (fs::exists(yaml, ec)) {
    r.experiment_yaml = read_whole_file(yaml);
    check_experiment_yaml(yaml, r.experiment_yaml);
  }
  // A run whose writer was killed before its first samples has run.json alone: no samples.
  if (!fs::exists(run_dir / "imu.csv", ec) && r.header.status == RunStatus::kRunning) {
    r.format = RecordingFormat::kHdf5;
    if (loading == SampleLoading::kStream) r.source = std::make_shared<MemorySamples>(std::vector<ImuSample>{});
    return r;
  }
  open_csv(run_dir, run_json_fields, r, loading, truth);
  return r;
}

}  // namespace

Recording Recording::open(const fs::path& run_dir, SampleLoading loading, TruthLoading truth) {
  try {
    return open_run_folder(run_dir, loading, truth);
  } catch (const InputError&) {
    throw;
  } catch (const IoError&) {
    throw;
  } catch (const std::runtime_error& e) {  // every other reader error is about the folder's content
    throw InputError(e.what());
  }
}

void require_whole(const Recording& rec) {
  if (rec.damage.empty()) return;
  throw InputError(fmt::format("{}: the run is damaged ({} of {} samples are readable): {}", rec.dir.string(),
                               rec.sample_count(), rec.written_samples, rec.damage));
}

void write_recording(const Recording& rec, const fs::path& dir, const RecordingWriterOptions& options) {
  RecordingWriter w(dir, rec.header, rec.experiment_yaml, options);
  for_each_chunk(rec.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t) { w.add_samples(c, n); });
  w.add_truth(*rec.recorded_truth());
  for (const auto& s : rec.segments) w.add_segment(s);
  for (const auto& e : rec.events) w.add_event(e);
  if (rec.header.status == RunStatus::kRunning) {
    w.flush();
  } else {
    w.finish(rec.header.status);
  }
}

const SampleSource& Recording::sample_source() const {
  if (source) return *source;
  if (!memory_view_ || &memory_view_->samples() != &samples)
    memory_view_ = std::make_shared<MemorySamples>(samples);
  return *memory_view_;
}

std::shared_ptr<const RecordedTruth> Recording::recorded_truth() const {
  if (truth_store) return truth_store;
  return std::make_shared<MemoryTruth>(truth_t, truth, header.truth_columns.size());
}

int Recording::truth_column(const std::string& name) const {
  const auto& c = header.truth_columns;
  const auto it = std::find(c.begin(), c.end(), name);
  return it == c.end() ? -1 : static_cast<int>(it - c.begin());
}

const char* to_string(RunStatus s) {
  switch (s) {
    case RunStatus::kRunning: return "running";
    case RunStatus::kComplete: return "complete";
    case RunStatus::kInterrupted: return "interrupted";
    case RunStatus::kFailed: return "failed";
  }
  return "?";
}

std::optional<RunStatus> run_status_from_string(std::string_view name) {
  for (RunStatus s : {RunStatus::kRunning, RunStatus::kComplete, RunStatus::kInterrupted, RunStatus::kFailed})
    if (name == to_string(s)) return s;
  return std::nullopt;
}

std::ostream& operator<<(std::ostream& os, RunStatus s) { return os << to_string(s); }

const char* to_string(RecordingFormat f) { return f == RecordingFormat::kHdf5 ? "hdf5" : "csv"; }

std::optional<RecordingFormat> recording_format_from_string(std::string_view name) {
  for (RecordingFormat f : {RecordingFormat::kHdf5, RecordingFormat::kCsv})
    if (name == to_string(f)) return f;
  return std::nullopt;
}

// HDF5: t_s (double), 7 counts (int32), 7 SI values (double), flags (uint32); CSV: the longest
// imu.csv row. A truth value is a double, or its longest text and a comma.
std::size_t max_bytes_per_sample(RecordingFormat f) {
  return f == RecordingFormat::kHdf5 ? 8 + 7 * 4 + 7 * 8 + 4 : kImuRowMax;
}
std::size_t max_bytes_per_truth_value(RecordingFormat f) {
  return f == RecordingFormat::kHdf5 ? 8 : csv::kMaxDoubleChars + 1;
}

namespace {
constexpr std::pair<SegmentKind, const char*> kSegmentKindNames[] = {
    {SegmentKind::kOrientation, "orientation"}, {SegmentKind::kRate, "rate"},
    {SegmentKind::kRotation, "rotation"},       {SegmentKind::kSetTemperature, "set_temperature"},
    {SegmentKind::kRecord, "record"},           {SegmentKind::kWait, "wait"},
    {SegmentKind::kDetected, "detected"},
};
}  // namespace

const char* to_string(SegmentKind k) {
  for (const auto& [kind, name] : kSegmentKindNames)
    if (kind == k) return name;
  return "?";
}

std::optional<SegmentKind> segment_kind_from_string(std::string_view name) {
  for (const auto& [kind, text] : kSegmentKindNames)
    if (name == text) return kind;
  return std::nullopt;
}

const std::vector<std::string>& segment_kind_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& [kind, name] : kSegmentKindNames) out.emplace_back(name);
    return out;
  }();
  return names;
}

std::ostream& operator<<(std::ostream& os, SegmentKind k) { return os << to_string(k); }

void Segment::print(std::ostream& os) const {
  os << fmt::format("#{} {}{} {:.2f}–{:.2f} s", id, to_string(kind), label.empty() ? "" : " '" + label + "'", t_start_s, t_end_s);
  if (!settled) os << " [unsettled]";
  if (!complete) os << " [incomplete]";
}

bool Segment::equals(const Segment& o, double tol) const {
  auto same = [tol](double a, double b) {
    return (std::isnan(a) && std::isnan(b)) || std::abs(a - b) <= tol * std::max(1.0, std::abs(a));
  };
  return id == o.id && step == o.step && kind == o.kind && label == o.label && repeat == o.repeat &&
         orientation == o.orientation && orientation_count == o.orientation_count && same(t_start_s, o.t_start_s) &&
         same(t_end_s, o.t_end_s) && settled == o.settled && complete == o.complete && targets == o.targets &&
         same(setpoint_c, o.setpoint_c) && same(rate, o.rate);
}

}  // namespace stend
