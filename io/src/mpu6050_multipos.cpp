// The MPU-6050 multi-position session importer (import_mpu6050_multipos in
// stend/io/importers.hpp): "key,value" header lines, then the column names and 16-bit counts.
#include "import_common.hpp"

#include <stend/physics/units.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// The "key,value" header lines before the column names (values and their line numbers), and the
// column names with their line.
struct MpuHeader {
  std::map<std::string, double> values;
  std::map<std::string, std::size_t> lines;
  std::vector<std::string> names;
  std::size_t names_line = 0;
};

MpuHeader read_mpu_header(LineReader& r) {
  MpuHeader h;
  std::string line;
  while (r.next(line)) {
    if (is_blank(line)) continue;
    const auto f = split(line, ',');
    double v = 0.0;
    if (f.size() == 2 && !parse_double(f[0], v)) {
      if (!parse_double(f[1], v)) r.fail("header value '" + excerpt(f[1]) + "' is not a number");
      h.values[unquote(f[0])] = v;
      h.lines[unquote(f[0])] = r.line();
      continue;
    }
    for (auto n : f) h.names.push_back(unquote(n));
    break;
  }
  if (h.names.empty()) throw ImportError(r.file(), r.line(), "no column-name line (expected ax,ay,az,gx,gy,gz)");
  h.names_line = r.line();
  return h;
}

constexpr const char* kMpuColumns[6] = {"ax", "ay", "az", "gx", "gy", "gz"};

// Positions of ax..gz among the column names.
std::array<std::size_t, 6> mpu_columns(const fs::path& file, const MpuHeader& h) {
  std::array<std::size_t, 6> col{};
  for (std::size_t k = 0; k < 6; ++k) {
    const auto it = std::find(h.names.begin(), h.names.end(), kMpuColumns[k]);
    if (it == h.names.end()) {
      throw ImportError(file, h.names_line, std::string("no column '") + kMpuColumns[k] +
                                                "' (expected ax,ay,az,gx,gy,gz after the header)");
    }
    col[k] = static_cast<std::size_t>(it - h.names.begin());
  }
  return col;
}

// Sample rate [Hz] from the header line "Fs,<Hz>".
double mpu_rate(const fs::path& file, const MpuHeader& h) {
  const auto fs_it = h.values.find("Fs");
  if (fs_it == h.values.end() || !(fs_it->second > 0.0)) {
    throw ImportError(file, fs_it == h.values.end() ? 1 : h.lines.at("Fs"),
                      "no sample rate: expected a header line 'Fs,<Hz>' with a positive rate");
  }
  return fs_it->second;
}

// Every data line as a sample at t = index / rate [s]; counts × LSB [m/s², rad/s]. Returns the
// number of samples.
std::size_t read_mpu_samples(LineReader& r, const std::array<std::size_t, 6>& col, std::size_t fields, double rate,
                             const Mpu6050MultiposOptions& opt, double acc_lsb, double gyr_lsb, SampleSink& out) {
  SampleChunker chunks(out);
  std::string line;
  while (r.next(line)) {
    if (is_blank(line)) continue;
    const auto f = split(line, ',');
    if (f.size() != fields) {
      r.fail("expected " + std::to_string(fields) + " fields as on the column-name line, found " +
             std::to_string(f.size()));
    }
    ImuSample s;
    s.t_s = static_cast<double>(chunks.count()) / rate;
    for (int k = 0; k < 3; ++k) {
      const auto ka = static_cast<std::size_t>(k), kg = static_cast<std::size_t>(k + 3);
      s.accel_counts[k] = to_counts(r, number(r, f[col[ka]], kMpuColumns[ka]), kMpuColumns[ka]);
      s.gyro_counts[k] = to_counts(r, number(r, f[col[kg]], kMpuColumns[kg]), kMpuColumns[kg]);
      s.accel_mps2[k] = (s.accel_counts[k] - opt.accel_offset_counts) * acc_lsb;
      s.gyro_radps[k] = (s.gyro_counts[k] - opt.gyro_offset_counts) * gyr_lsb;
    }
    chunks.add(s);
  }
  chunks.flush();
  return chunks.count();
}

// The still interval at the start ("Initialization time" [s] in the header) as an orientation
// segment, up to the last sample's time t_last_s at most.
void add_initialization_segment(const MpuHeader& h, double t_last_s, Recording& rec) {
  const auto init = h.values.find("Initialization time");
  if (init == h.values.end() || !(init->second > 0.0)) return;
  const double t_end = std::min(init->second, t_last_s);
  Segment seg = make_segment(0, SegmentKind::kOrientation, "initialization", 0.0, t_end);
  seg.orientation = 0;
  seg.targets = "held still (Initialization time " + fmt_g(init->second) + " s)";
  rec.segments.push_back(seg);
}

}  // namespace

bool Mpu6050MultiposOptions::IsValid(std::string* error) const {
  if (!(accel_lsb_per_g > 0.0 && gyro_lsb_per_dps > 0.0)) return invalid(error, "the LSBs must be > 0");
  if (!(std::isfinite(accel_offset_counts) && std::isfinite(gyro_offset_counts))) return invalid(error, "the offsets must be finite");
  if (!gravity_or_unknown(gravity_mps2)) return invalid(error, "gravity_mps2 must be >= 0 (0: unknown)");
  return true;
}

void import_mpu6050_multipos(const fs::path& file, const Mpu6050MultiposOptions& opt, Recording& rec,
                             SampleSink& out) {
  require_valid(opt, "mpu6050_multipos options");
  LineReader r(file);
  const MpuHeader header = read_mpu_header(r);
  const std::array<std::size_t, 6> col = mpu_columns(file, header);
  const double rate = mpu_rate(file, header);
  rec = new_recording(file, "mpu6050_multipos");
  const double acc_lsb = physics::kStandardGravity / opt.accel_lsb_per_g;
  const double gyr_lsb = physics::kDegPerSecond / opt.gyro_lsb_per_dps;
  set_int16_sensor_info(rate, acc_lsb, gyr_lsb, rec);
  rec.header.identity.vendor = "InvenSense";
  rec.header.identity.model = "MPU-6050";
  rec.header.gravity_mps2 = opt.gravity_mps2;
  const std::size_t count = read_mpu_samples(r, col, header.names.size(), rate, opt, acc_lsb, gyr_lsb, out);
  if (count == 0) throw ImportError(file, 0, "no data lines after the column names");
  std::string hdr;
  for (const auto& [k, v] : header.values) hdr += (hdr.empty() ? "" : ", ") + k + " = " + fmt_g(v);
  add_initialization_segment(header, static_cast<double>(count - 1) / rate, rec);
  add_import_event(rec, "imported " + std::to_string(count) + " samples from " +
                            file.string() + " (MPU-6050 multi-position session; header: " + hdr +
                            "; counts converted with " + fmt_g(opt.accel_lsb_per_g) + " LSB/g (+-2 g) and " +
                            fmt_g(opt.gyro_lsb_per_dps) +
                            " LSB/(deg/s) (+-250 deg/s), 1 g = " + fmt_g(physics::kStandardGravity) + " m/s^2; no orientation "
                            "annotations beyond the initial still interval)");
}

Recording import_mpu6050_multipos(const fs::path& file, const Mpu6050MultiposOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_mpu6050_multipos(file, opt, rec, out); });
}

}  // namespace stend::io
