#include "import_common.hpp"

#include <stend/recording/version.hpp>

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <system_error>
#include <utility>

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

bool finite_nonzero(double v) { return std::isfinite(v) && v != 0.0; }
bool gravity_or_unknown(double g_mps2) { return std::isfinite(g_mps2) && g_mps2 >= 0.0; }

namespace detail {

LineReader::LineReader(const fs::path& file) : file_(file), in_(file, std::ios::binary) {
  if (!in_) {
    throw ImportError(file, 0, std::string("cannot open: ") + std::strerror(errno) + " (check the path)");
  }
}

bool read_bounded_line(std::istream& in, std::vector<char>& buf, std::string& line, bool& cut) {
  cut = false;
  line.clear();
  for (bool any = false;; any = true) {
    in.getline(buf.data(), static_cast<std::streamsize>(buf.size()));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got == 0 && in.eof() && !any) return false;
    const bool delimited = !in.fail() && !in.eof();  // the '\n' was read (and counted in gcount)
    const bool full = in.fail() && !in.eof();        // buf filled before any '\n': more of the line follows
    line.append(buf.data(), delimited ? got - 1 : got);
    if (line.size() > kMaxLineBytes) {
      cut = true;
      in.clear();
      if (full) in.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
      break;
    }
    if (!full) break;
    in.clear();
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return true;
}

bool LineReader::next(std::string& line) {
  bool cut = false;
  if (!read_bounded_line(in_, buf_, line, cut)) return false;
  ++line_;
  if (cut) {
    line.clear();
    fail("the line is longer than " + std::to_string(kMaxLineBytes) + " bytes: not a line of a text log (a column-name "
         "line or a field this long is refused, not read whole)");
  }
  if (line_ == 1 && line.size() >= 3 && static_cast<unsigned char>(line[0]) == 0xEF &&
      static_cast<unsigned char>(line[1]) == 0xBB && static_cast<unsigned char>(line[2]) == 0xBF) {
    line.erase(0, 3);  // UTF-8 byte-order mark
  }
  return true;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line, char delim) {
  std::vector<std::string_view> out;
  split(line, delim, out);
  return out;
}

void split(std::string_view line, char delim, std::vector<std::string_view>& out) {
  out.clear();
  if (delim == ' ') {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i >= line.size()) break;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      out.push_back(line.substr(i, j - i));
      i = j;
    }
    return;
  }
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == delim) {
      out.push_back(trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
}

namespace {

// A plain decimal — [-]digits[.digits], no exponent — of at most 19 digits is m / 10^k; when
// m < 2^53 and k ≤ 22 both are exact doubles and the one correctly rounded division is the double
// nearest the decimal, the value std::from_chars gives (Clinger's fast path). A text log's
// fields are nearly all such; false sends anything else to std::from_chars.
bool parse_plain_decimal(std::string_view s, double& out) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                      1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const char* p = s.data();
  const char* const end = p + s.size();
  const bool negative = p != end && *p == '-';
  p += negative;
  std::uint64_t m = 0;
  int digits = 0, fraction = -1;  // fraction: digits after the point (-1: no point yet)
  for (; p != end; ++p) {
    const auto d = static_cast<unsigned>(*p - '0');
    if (d < 10) {
      if (++digits > 19) return false;
      m = m * 10 + d;
      fraction += fraction >= 0;
    } else if (*p == '.' && fraction < 0) {
      fraction = 0;
    } else {
      return false;
    }
  }
  if (digits == 0 || m >= (std::uint64_t{1} << 53) || fraction > 22) return false;
  const double v = fraction > 0 ? static_cast<double>(m) / kPow10[fraction] : static_cast<double>(m);
  out = negative ? -v : v;
  return true;
}

}  // namespace

bool parse_double(std::string_view s, double& out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  if (parse_plain_decimal(s, out)) return true;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

// ---------------------------------------------------------------------------------------------
// Text tables

std::string unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return std::string(s);
}

bool is_blank(std::string_view s) { return trim(s).empty(); }

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
           " is not an integer count (values in physical units take --accel-unit / --gyro-unit, not an LSB)");
  }
  return static_cast<std::int32_t>(std::lround(v));
}

void add_held_truth(Recording& rec, double t0, double t1, const std::array<double, 3>& f) {
  rec.header.truth_columns = kTruthColumns;
  add_held_truth(rec, t0, t1, std::vector<double>{f[0], f[1], f[2], 0.0, 0.0, 0.0});
}

void add_held_truth(Recording& rec, double t0, double t1, const std::vector<double>& row) {
  for (const double t : {t0, 0.5 * (t0 + t1), t1}) {
    if (!rec.truth_t.empty() && !(t > rec.truth_t.back())) continue;
    rec.truth_t.push_back(t);
    rec.truth.push_back(row);
  }
}

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

std::string fmt_g(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string fmt_hex(std::uint64_t v, int digits) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "0x%0*llX", digits, static_cast<unsigned long long>(v));
  return buf;
}

BinaryReader::BinaryReader(const fs::path& file) : file_(file), in_(file, std::ios::binary) {
  if (!in_) throw ImportError(file, 0, std::string("cannot open: ") + std::strerror(errno) + " (check the path)");
  in_.seekg(0, std::ios::end);
  size_ = static_cast<std::size_t>(in_.tellg());
}

void BinaryReader::load(std::size_t offset, std::size_t count, std::string_view what_text) const {
  const std::string what(what_text);
  if (offset > size_ || count > size_ - offset) {
    fail(offset, "the file ends inside " + what + " (expected " + std::to_string(count) + " bytes, " +
                     std::to_string(offset > size_ ? 0 : size_ - offset) + " remain; truncated?)");
  }
  start_ = offset;
  buffer_.resize(std::min(std::max(count, kBinaryWindow), size_ - offset));
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(offset));
  in_.read(reinterpret_cast<char*>(buffer_.data()), static_cast<std::streamsize>(buffer_.size()));
  if (static_cast<std::size_t>(in_.gcount()) != buffer_.size()) {
    fail(offset, "cannot read " + what + ": " + std::strerror(errno) + " (the file changed while it was read?)");
  }
}

std::optional<std::size_t> BinaryReader::find(std::size_t from, const std::uint8_t* pattern, std::size_t count) const {
  // The bytes already buffered are searched first: a log that resyncs at every few bytes reads
  // each byte once (a window loaded per search made it quadratic). Windows overlap by count − 1
  // bytes, so that a match across a window boundary is found.
  for (std::size_t pos = from; pos + count <= size_;) {
    const bool buffered = pos >= start_ && pos + count <= start_ + buffer_.size();
    if (!buffered) need(pos, std::min(kBinaryWindow, size_ - pos), "a search for a sync marker");
    const std::size_t n = start_ + buffer_.size() - pos;  // bytes buffered from pos on (≥ count)
    const std::uint8_t* begin = at(pos);
    const auto* hit = std::search(begin, begin + n, pattern, pattern + count);
    if (hit != begin + n) return pos + static_cast<std::size_t>(hit - begin);
    pos += n - (count - 1);
  }
  return std::nullopt;
}

std::string file_prefix(const fs::path& file, std::size_t count) {
  std::ifstream in(file, std::ios::binary);
  std::string out(count, '\0');
  if (!in) return {};
  in.read(out.data(), static_cast<std::streamsize>(count));
  out.resize(static_cast<std::size_t>(in.gcount()));
  return out;
}

std::string fixed_string(const std::uint8_t* p, std::size_t size) {
  const auto* c = reinterpret_cast<const char*>(p);
  return std::string(c, static_cast<std::size_t>(std::find(c, c + size, '\0') - c));
}

Segment make_segment(int id, SegmentKind kind, const std::string& label, double t0, double t1) {
  Segment s;
  s.id = id;
  s.step = id;
  s.kind = kind;
  s.label = label;
  s.t_start_s = t0;
  s.t_end_s = t1;
  s.settled = true;
  s.complete = true;
  return s;
}

Recording new_recording(const fs::path& file, const std::string& format) {
  Recording rec;
  rec.dir = file;
  rec.header.status = RunStatus::kComplete;
  rec.header.experiment_name = "import:" + format;
  rec.header.experiment_file = file.string();
  rec.header.stend_version = stend::version();
  rec.header.clock = "wall";
  return rec;
}

Recording import_in_memory(const std::function<void(Recording& rec, SampleSink& out)>& import) {
  std::vector<ImuSample> samples;
  VectorSink sink(samples);
  Recording rec;
  import(rec, sink);
  rec.samples = std::move(samples);
  if (!rec.samples.empty()) place_import_events(rec.events, rec.samples.front().t_s);
  return rec;
}

double median_interval(const std::vector<ImuSample>& s) {
  if (s.size() < 2) return 0.0;
  std::vector<double> dt;
  dt.reserve(s.size() - 1);
  for (std::size_t i = 1; i < s.size(); ++i) dt.push_back(s[i].t_s - s[i - 1].t_s);
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return dt[dt.size() / 2];
}

void LogTimestampStream::fix_rate(const std::vector<ImuSample>& s) {
  sum_.bursts = find_bursts(s);
  const double dt = sum_.bursts ? sum_.bursts->mean_interval_s : median_interval(s);
  sum_.rate_hz = dt > 0.0 ? 1.0 / dt : 0.0;
  sum_.gap_s = sum_.bursts ? sum_.bursts->gap_s : gap_threshold(dt, 0.0);
  rec_->header.info.output_rate_hz = sum_.rate_hz;
}

// Sample s after the time prev_t [s] (NaN: none): a gap, a repeat or a step back, counted.
void LogTimestampStream::count(const ImuSample& s, double prev_t) {
  if (s.t_s == prev_t) ++sum_.repeated;
  if (s.t_s < prev_t) ++sum_.decreasing;
}

void LogTimestampStream::process(std::vector<ImuSample>& s, bool first, double prev_t) {
  if (first) fix_rate(s);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double before = i == 0 ? prev_t : s[i - 1].t_s;
    if (sum_.rate_hz > 0.0 && s[i].t_s - before > sum_.gap_s) {
      s[i].flags |= kGapBefore;
      ++sum_.gaps;
    }
    count(s[i], before);
  }
}

TimestampSummary LogTimestampStream::finish() {
  pass_rest();
  if (sum_.bursts)
    add_import_event(*rec_, sum_.bursts->describe() + ": " + sum_.bursts->rate_text() + "; the samples' own times are kept",
                     "warning");
  return sum_;
}

std::string TimestampSummary::rate_and_gaps() const {
  return "rate " + fmt_g(rate_hz) + " Hz " +
         (bursts ? "the mean rate (the timestamps come in bursts)" : "from the median interval") + "; " +
         std::to_string(gaps) + " gap(s) flagged where the time jumps by more than " + fmt_g(gap_s * 1e3) + " ms";
}

std::string TimestampSummary::describe() const {
  return rate_and_gaps() + "; " + std::to_string(repeated) + " repeated and " + std::to_string(decreasing) +
         " decreasing timestamp(s), kept in file order";
}

}  // namespace detail
}  // namespace stend::io
