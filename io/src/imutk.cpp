// IMU-TK text files (import_imutk, export_imutk in stend/io/importers.hpp): one file of
// accelerometer lines 't x y z' and optionally one of gyroscope lines, the gyroscope interpolated
// at the accelerometer's times when they differ.
#include "import_common.hpp"

#include <stend/io/timestamps.hpp>
#include <stend/recording/files.hpp>
#include <stend/physics/units.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>
#include <system_error>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Whitespace, comma or semicolon separated (IMU-TK files come in all three).
std::vector<std::string_view> split_any(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  auto sep = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == ';'; };
  while (i < line.size()) {
    while (i < line.size() && sep(line[i])) ++i;
    if (i >= line.size()) break;
    std::size_t j = i;
    while (j < line.size() && !sep(line[j])) ++j;
    out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// One line of an IMU-TK triad file: time [s] (× the time scale), the three values, its line.
struct TriadLine {
  double t = 0.0;
  std::array<double, 3> v{};
  std::size_t line = 0;
};

// The lines of an IMU-TK triad file one at a time ('#', '%' comments and blank lines skipped),
// each checked: four values, time not going back.
class TriadReader {
 public:
  TriadReader(const fs::path& file, double time_scale) : r_(file), time_scale_(time_scale) {}
  bool next(TriadLine& out) {
    std::string line;
    while (r_.next(line)) {
      std::string_view v = trim(line);
      if (v.empty() || v.front() == '#' || v.front() == '%') continue;
      const auto f = split_any(v);
      if (f.size() != 4) r_.fail("expected 4 values 't x y z', found " + std::to_string(f.size()));
      const double t = number(r_, f[0], "t") * time_scale_;
      if (count_ > 0 && t < prev_t_) {  // repeats are repaired from the rate afterwards
        r_.fail("timestamp " + fmt_g(t) + " s goes back (previous " + fmt_g(prev_t_) + " s)");
      }
      out.t = prev_t_ = t;
      for (std::size_t k = 0; k < 3; ++k) out.v[k] = number(r_, f[k + 1], k == 0 ? "x" : k == 1 ? "y" : "z");
      out.line = r_.line();
      ++count_;
      return true;
    }
    if (count_ == 0) throw ImportError(r_.file(), 0, "no samples (expected lines 't x y z')");
    return false;
  }
  const fs::path& file() const { return r_.file(); }

 private:
  LineReader r_;
  double time_scale_;
  double prev_t_ = 0.0;
  std::size_t count_ = 0;
};

void write_number(std::string& out, double v) {
  char buf[32];
  const auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, ec == std::errc() ? p : buf);
}

// A value of a triad line as an integer count (counts = true).
std::int32_t triad_count(const TriadLine& l, double v, const fs::path& file) {
  if (!std::isfinite(v) || std::abs(v - std::round(v)) > 1e-6 || std::abs(v) > 2147483647.0) {
    throw ImportError(file, l.line, fmt_g(v) + " is not an integer count (counts = true)");
  }
  return static_cast<std::int32_t>(std::lround(v));
}

// What a first pass over a triad file finds: its lines (checked), time span [s] and median
// interval [s] (over the first kTimestampWindow lines, as the timestamp repair takes its rate).
struct TriadScan {
  std::size_t lines = 0;
  double t_first = 0.0, t_last = 0.0, median_dt = 0.0;
};

TriadScan scan_triad(const fs::path& file, double time_scale) {
  TriadReader in(file, time_scale);
  TriadScan scan;
  std::vector<ImuSample> window;  // the first lines' times, for median_interval
  for (TriadLine l; in.next(l); ++scan.lines) {
    if (scan.lines == 0) scan.t_first = l.t;
    scan.t_last = l.t;
    if (window.size() < kTimestampWindow) window.emplace_back().t_s = l.t;
  }
  scan.median_dt = median_interval(window);
  return scan;
}

// Whether the gyro lines have the accelerometer's timestamps (within tol [s]), read side by side.
bool same_times(const fs::path& acc_file, const fs::path& gyro_file, double time_scale, double tol) {
  TriadReader acc(acc_file, time_scale), gyr(gyro_file, time_scale);
  for (TriadLine a, g;;) {
    const bool more_a = acc.next(a), more_g = gyr.next(g);
    if (more_a != more_g) return false;
    if (!more_a) return true;
    if (std::abs(g.t - a.t) > tol) return false;
  }
}

// One sample per accelerometer line: time [s] and value × accel_scale [m/s²] (with the counts).
ImuSample accel_sample(const TriadLine& a, const fs::path& acc_file, const ImuTkOptions& opt) {
  ImuSample s;
  s.t_s = a.t;
  for (int k = 0; k < 3; ++k) {
    const double v = a.v[static_cast<std::size_t>(k)];
    if (opt.counts) s.accel_counts[k] = triad_count(a, v, acc_file);
    s.accel_mps2[k] = (v - opt.accel_offset_counts) * opt.accel_scale;
  }
  return s;
}

// Gyro values g (file units) into a sample: g × gyro_scale [rad/s], with the counts (`count` turns
// a value into one).
template <class Count>
void set_gyro(const std::array<double, 3>& g, const ImuTkOptions& opt, Count count, ImuSample& s) {
  for (int k = 0; k < 3; ++k) {
    const double v = g[static_cast<std::size_t>(k)];
    if (opt.counts) s.gyro_counts[k] = count(v);
    s.gyro_radps[k] = (v - opt.gyro_offset_counts) * opt.gyro_scale;
  }
}

// The gyro linearly interpolated at rising times t [s] from a two-line window sliding over the gyro
// file (counts are the rounded interpolated values).
class GyroInterpolator {
 public:
  GyroInterpolator(const fs::path& file, double time_scale) : in_(file, time_scale) {
    in_.next(a_);
    if (!in_.next(b_)) b_ = a_;
  }
  std::array<double, 3> at(double t) {
    while (b_.t < t && a_.line != b_.line) {
      a_ = b_;
      if (!in_.next(b_)) b_ = a_;  // past the last line: its value
    }
    const double span = b_.t - a_.t;
    const double u = span > 0.0 ? std::clamp((t - a_.t) / span, 0.0, 1.0) : 0.0;
    std::array<double, 3> g{};
    for (std::size_t k = 0; k < 3; ++k) g[k] = a_.v[k] + u * (b_.v[k] - a_.v[k]);
    return g;
  }

 private:
  TriadReader in_;
  TriadLine a_, b_;  // the lines around the last time asked for (the same line at the file's end)
};

// Sensor description: rate [Hz] (given, else left to the timestamp repair) and the
// LSB sizes when the files hold counts.
void set_imutk_sensor_info(const ImuTkOptions& opt, bool has_gyro, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = opt.rate_hz;  // 0: set by the timestamp repair
  info.has_gyro = has_gyro;
  info.has_temperature = false;
  if (opt.counts) {
    info.accel_lsb_mps2 = opt.accel_scale;
    info.gyro_lsb_radps = has_gyro ? opt.gyro_scale : 0.0;
  }
  rec.header.identity = opt.identity;
  rec.header.gravity_mps2 = opt.gravity_mps2;
}

}  // namespace

bool ImuTkOptions::IsValid(std::string* error) const {
  if (!(time_scale_s > 0.0 && std::isfinite(time_scale_s))) return invalid(error, "time_scale_s must be > 0");
  if (!(finite_nonzero(accel_scale) && finite_nonzero(gyro_scale))) return invalid(error, "the scales must be finite and not 0");
  if (!(std::isfinite(accel_offset_counts) && std::isfinite(gyro_offset_counts))) return invalid(error, "the offsets must be finite");
  if (!(rate_hz >= 0.0 && std::isfinite(rate_hz))) return invalid(error, "rate_hz must be >= 0 (0: from the timestamps)");
  if (!gravity_or_unknown(gravity_mps2)) return invalid(error, "gravity_mps2 must be >= 0 (0: unknown)");
  return true;
}

void import_imutk(const fs::path& acc_file, const fs::path& gyro_file, const ImuTkOptions& opt, Recording& rec,
                  SampleSink& out) {
  require_valid(opt, "IMU-TK options");
  const TriadScan acc = scan_triad(acc_file, opt.time_scale_s);
  const bool has_gyro = !gyro_file.empty();
  const TriadScan gyr = has_gyro ? scan_triad(gyro_file, opt.time_scale_s) : TriadScan{};
  const double tol = opt.time_tolerance_s >= 0.0 ? opt.time_tolerance_s : 0.01 * acc.median_dt;
  const bool matched = has_gyro && acc.lines == gyr.lines && same_times(acc_file, gyro_file, opt.time_scale_s, tol);
  rec = new_recording(acc_file, "imutk");
  set_imutk_sensor_info(opt, has_gyro, rec);

  TimestampRepairStream repair(rec, out, opt.rate_hz);
  SampleChunker chunks(repair);
  TriadReader acc_in(acc_file, opt.time_scale_s);
  std::optional<TriadReader> gyr_matched;
  std::optional<GyroInterpolator> gyr_interpolated;
  if (matched) gyr_matched.emplace(gyro_file, opt.time_scale_s);
  if (has_gyro && !matched) gyr_interpolated.emplace(gyro_file, opt.time_scale_s);
  std::size_t dropped = 0;
  for (TriadLine a; acc_in.next(a);) {
    ImuSample s = accel_sample(a, acc_file, opt);
    if (gyr_matched) {
      TriadLine g;
      gyr_matched->next(g);
      set_gyro(g.v, opt, [&](double v) { return triad_count(g, v, gyro_file); }, s);
    } else if (gyr_interpolated) {
      if (s.t_s < gyr.t_first - tol || s.t_s > gyr.t_last + tol) {
        ++dropped;
        continue;
      }
      set_gyro(gyr_interpolated->at(s.t_s), opt, [](double v) { return static_cast<std::int32_t>(std::lround(v)); }, s);
    }
    chunks.add(s);
  }
  if (chunks.count() == 0) {
    throw ImportError(gyro_file, 0, "the gyro timestamps (" + fmt_g(gyr.t_first) + " … " + fmt_g(gyr.t_last) +
                                        " s) do not overlap the accelerometer's (" + fmt_g(acc.t_first) + " … " +
                                        fmt_g(acc.t_last) + " s); check time_scale_s");
  }
  chunks.flush();
  const std::size_t gaps = repair.finish().gaps;
  std::string merge_note;
  if (matched) merge_note = "gyro samples matched by timestamp";
  if (gyr_interpolated) {
    merge_note = "gyro linearly interpolated at the accelerometer times (the files' timestamps differ)" +
                 (dropped ? "; " + std::to_string(dropped) + " accelerometer sample(s) outside the gyro's time span dropped"
                          : std::string());
  }
  add_import_event(rec, "imported " + std::to_string(chunks.count()) + " samples from " +
                            acc_file.string() + (has_gyro ? " and " + gyro_file.string() : std::string()) +
                            " (IMU-TK text; time scale " + fmt_g(opt.time_scale_s) + " s/unit, " +
                            (opt.counts ? "counts" : "physical units") + ", accel scale " +
                            fmt_g(opt.accel_scale) + ", gyro scale " + fmt_g(opt.gyro_scale) +
                            (merge_note.empty() ? "" : "; " + merge_note) +
                            (gaps ? "; " + std::to_string(gaps) + " gap(s) flagged" : "") + ")");
}

Recording import_imutk(const fs::path& acc_file, const fs::path& gyro_file, const ImuTkOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_imutk(acc_file, gyro_file, opt, rec, out); });
}

void export_imutk(const Recording& rec, const fs::path& acc_file, const fs::path& gyro_file,
                  bool counts) {
  auto write = [&](const fs::path& file, bool gyro) {
    std::string out;
    out.reserve(rec.samples.size() * 80);
    for (const auto& s : rec.samples) {
      write_number(out, s.t_s);
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        if (counts) {
          out += std::to_string(gyro ? s.gyro_counts[k] : s.accel_counts[k]);
        } else {
          write_number(out, gyro ? s.gyro_radps[k] : s.accel_mps2[k]);
        }
      }
      out += '\n';
    }
    write_file_atomic(file, out);
  };
  write(acc_file, false);
  if (!gyro_file.empty()) write(gyro_file, true);
}

}  // namespace stend::io
