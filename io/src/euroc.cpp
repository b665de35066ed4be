// EuRoC MAV / ASL dataset IMU CSV (mav0/imu0/data.csv).
#include <stend/recording/csv.hpp>
#include <stend/io/logs.hpp>

#include "import_common.hpp"

#include <charconv>
#include <system_error>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// The column names, in file order, up to their unit: timestamp [ns], gyro [rad/s], accel [m/s²].
constexpr const char* kEurocColumns[7] = {"#timestamp", "w_RS_S_x", "w_RS_S_y", "w_RS_S_z",
                                          "a_RS_S_x",   "a_RS_S_y", "a_RS_S_z"};

// The csv file: `path` itself, or inside the folder mav0/imu0/data.csv, imu0/data.csv, data.csv.
fs::path euroc_csv(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) return path;
  for (const char* rel : {"mav0/imu0/data.csv", "imu0/data.csv", "data.csv"}) {
    if (fs::is_regular_file(path / rel, ec)) return path / rel;
  }
  throw ImportError(path, 0, "folder without an EuRoC IMU file (expected mav0/imu0/data.csv)");
}

// Whether a column-name line is EuRoC's (names compared up to their unit in brackets).
bool euroc_header(std::string_view line) {
  const auto f = split(line, ',');
  if (f.size() != 7) return false;
  for (std::size_t k = 0; k < 7; ++k) {
    if (trim(f[k].substr(0, f[k].find('['))) != kEurocColumns[k]) return false;
  }
  return true;
}

bool parse_ns(std::string_view s, std::int64_t& out) {
  s = trim(s);
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

}  // namespace

bool looks_like_euroc(const fs::path& path) {
  try {
    // The column-name line is about 150 bytes; a binary file is not read through.
    std::string head = file_prefix(euroc_csv(path), 1024);
    head = head.substr(0, head.find('\n'));
    if (!head.empty() && head.back() == '\r') head.pop_back();
    return euroc_header(head);
  } catch (const ImportError&) {
    return false;
  }
}

void import_euroc(const fs::path& path, const EurocOptions& opt, Recording& rec, SampleSink& out) {
  require_valid(opt, "EuRoC options");
  const fs::path file = euroc_csv(path);
  LineReader r(file);
  std::string line;
  if (!r.next(line) || !euroc_header(line)) {
    r.fail("expected the EuRoC column-name line '#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],"
           "w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]'");
  }
  rec = new_recording(file, "euroc");
  rec.header.info.has_gyro = true;
  rec.header.info.has_temperature = false;
  rec.header.identity = opt.identity;
  LogTimestampStream times(rec, out);
  std::vector<ImuSample> chunk;
  chunk.reserve(kDefaultChunkSamples);
  std::int64_t t0_ns = 0;
  std::size_t count = 0;
  while (r.next(line)) {
    if (trim(line).empty()) continue;
    const auto f = split(line, ',');
    if (f.size() != 7) r.fail("expected 7 fields (timestamp, 3 gyro, 3 accel), found " + std::to_string(f.size()));
    std::int64_t t_ns = 0;
    if (!parse_ns(f[0], t_ns)) r.fail("timestamp '" + excerpt(f[0]) + "' is not an integer [ns]");
    if (count++ == 0) t0_ns = t_ns;
    ImuSample s;
    s.t_s = seconds_since_ns(t0_ns, t_ns);
    for (int k = 0; k < 3; ++k) {
      double g = 0.0, a = 0.0;
      if (!parse_double(f[1 + k], g) || !parse_double(f[4 + k], a)) {
        r.fail("value '" + excerpt(parse_double(f[1 + k], g) ? f[4 + k] : f[1 + k]) + "' is not a number");
      }
      s.gyro_radps[k] = g;
      s.accel_mps2[k] = a;
    }
    chunk.push_back(s);
    if (chunk.size() == kDefaultChunkSamples) {
      times.add_samples(chunk.data(), chunk.size());
      chunk.clear();
    }
  }
  if (count == 0) throw ImportError(file, r.line(), "no samples after the column-name line");
  times.add_samples(chunk.data(), chunk.size());
  const TimestampSummary ts = times.finish();
  add_import_event(rec, "imported " + std::to_string(count) + " samples from " + file.string() +
                            " (EuRoC/ASL IMU CSV; gyro w_RS_S [rad/s] and accel a_RS_S [m/s^2] in the sensor frame S "
                            "as written; t = #timestamp [ns] relative to the first sample; " + ts.describe() +
                            "; no temperature)");
}

Recording import_euroc(const fs::path& path, const EurocOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_euroc(path, opt, rec, out); });
}

}  // namespace stend::io
