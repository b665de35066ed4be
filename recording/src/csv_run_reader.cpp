// The CSV run store's reader (see csv_run_store.hpp): imu.csv through a fast path that falls back
// to a per-field parse naming the bad column, truth.csv, segments.csv and events.csv.
#include "csv_run_store.hpp"
#include "store_files.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <fstream>
#include <limits>
#include <system_error>
#include <utility>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

// --- imu.csv ------------------------------------------------------------------------------------

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

// --- truth.csv ----------------------------------------------------------------------------------

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

// The data rows of a CSV file counted without parsing them (`stend info` skips the truth): the
// complete, non-empty lines after the column-name line.
std::uint64_t count_data_rows(const fs::path& file) {
  constexpr std::size_t kChunkBytes = 65536;  // read at a time [bytes]
  std::ifstream in(file, std::ios::binary);
  std::vector<char> buf(kChunkBytes);
  std::uint64_t rows = 0;
  bool past_header = false, has_text = false;
  while (in.read(buf.data(), static_cast<std::streamsize>(buf.size())) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      const char c = buf[static_cast<std::size_t>(i)];
      if (c == '\n') {
        if (past_header && has_text) ++rows;
        past_header = true;
        has_text = false;
      } else if (c != '\r') {
        has_text = true;
      }
    }
  }
  return rows;
}

}  // namespace

void open_csv(const fs::path& run_dir, const nlohmann::json& run_json, Recording& r, SampleLoading loading,
              TruthLoading truth) {
  std::error_code ec;
  const fs::path imu = run_dir / "imu.csv";
  if (!fs::exists(imu, ec)) {
    throw InputError(fmt::format("{}: missing (every recording has run.h5 or imu.csv)", imu.string()));
  }
  std::vector<FileRead> files{read_imu(imu, r)};
  r.written_samples = r.samples.size();
  const fs::path truth_csv = run_dir / "truth.csv";
  const bool read_truth_rows = truth != TruthLoading::kSkip && fs::exists(truth_csv, ec);  // kStream too: CSV has no index
  files.push_back(read_truth_rows ? read_truth(truth_csv, r) : file_not_read(truth_csv));
  r.truth_rows = read_truth_rows || !fs::exists(truth_csv, ec) ? r.truth_t.size() : count_data_rows(truth_csv);
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

}  // namespace stend::detail
