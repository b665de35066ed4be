// What a run would produce, and whether it may: the estimate of its run time, samples and bytes
// before it starts, checked against the experiment's limits and the free space; a run name that
// names one folder. See stend/core/runner.hpp.
#include "stend/core/runner.hpp"

#include "stend/core/eta.hpp"

#include <fmt/format.h>

#include <sys/statvfs.h>

#include <cmath>
#include <stdexcept>

namespace stend {

namespace {

// Planned run time of the procedure, for the run's estimate (estimate_run): ProcedureEta's plan
// before anything ran, with the chamber's start temperature unknown (temperature steps at their
// hold time, moves at EtaDefaults::move_s), so this is an estimate.
double planned_duration(const Experiment& exp) { return ProcedureEta(exp.procedure).remaining_s(0.0, NAN); }

std::string human_bytes(double bytes) {
  const char* units[] = {"B", "kB", "MB", "GB", "TB", "PB"};
  int u = 0;
  while (bytes >= 1000.0 && u < 5) {
    bytes /= 1000.0;
    ++u;
  }
  return fmt::format("{:.3g} {}", bytes, units[u]);
}

// Run time in words: "3d04h05m06s", "1h02m40s", "12.5 s".
std::string human_duration(double s) {
  if (!(s < 1e15)) return fmt::format("{:.3g} s", s);
  if (s < 60.0) return fmt::format("{:.3g} s", s);
  const auto t = static_cast<long long>(s + 0.5);
  if (t >= 86400) return fmt::format("{}d{:02}h{:02}m{:02}s", t / 86400, (t / 3600) % 24, (t / 60) % 60, t % 60);
  if (t >= 3600) return fmt::format("{}h{:02}m{:02}s", t / 3600, (t / 60) % 60, t % 60);
  return fmt::format("{}m{:02}s", t / 60, t % 60);
}

// Space free for this user on the file system holding `dir` or, when it does not exist yet, its
// nearest existing ancestor [bytes]; NaN when it cannot be asked.
double free_bytes(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::path p = std::filesystem::absolute(dir, ec);
  if (ec) return NAN;
  while (!std::filesystem::exists(p, ec) && p.has_parent_path() && p != p.parent_path()) p = p.parent_path();
  struct statvfs st {};
  if (::statvfs(p.c_str(), &st) != 0) return NAN;
  return static_cast<double>(st.f_bavail) * static_cast<double>(st.f_frsize);
}

}  // namespace

std::string RunEstimate::str() const {
  return fmt::format("run time {}, {:.3g} samples, up to {} ({})", human_duration(run_time_s), samples,
                     human_bytes(bytes), to_string(format));
}

RunEstimate estimate_run(const Experiment& exp, Bench& bench, const RunOptions& options) {
  RunEstimate e;
  e.format = options.store.format;
  e.run_time_s = planned_duration(exp);
  double unrecorded_s = 0.0;  // settling with record: false
  for (const Step& s : exp.procedure)
    if (s.kind == Step::Kind::kSetTemperature && !s.record_settling) unrecorded_s += s.hold_s;
  e.samples = std::ceil(bench.sensor().info().output_rate_hz * (e.run_time_s - unrecorded_s));
  const double truth_rows = std::ceil(e.run_time_s / options.truth_period_s) + 1.0;
  e.bytes = e.samples * static_cast<double>(max_bytes_per_sample(e.format)) +
            truth_rows * static_cast<double>((bench.truth_columns().size() + 1) * max_bytes_per_truth_value(e.format));
  return e;
}

void check_run_limits(const Experiment& exp, const RunEstimate& e, const std::filesystem::path& output_dir) {
  const RunLimits& l = exp.limits;
  const std::string hint = "shorten the procedure (durations, repeats, orientations) or raise the limit in the experiment's "
                           "'limits:' block (docs/experiment-format.md)";
  auto refuse = [&](const std::string& key, const std::string& what) {
    throw ExperimentError(l.where, key, "the run would exceed " + key + ": " + what + " [" + e.str() + "]", hint);
  };
  if (!(e.run_time_s <= l.max_run_time_s))
    refuse("limits.max_run_time_s", fmt::format("expected run time {} ({:.6g} s) > {:.6g} s", human_duration(e.run_time_s),
                                                e.run_time_s, l.max_run_time_s));
  if (!(e.samples <= l.max_samples))
    refuse("limits.max_samples", fmt::format("{:.6g} samples > {:.6g}", e.samples, l.max_samples));
  if (!(e.bytes <= l.max_bytes))
    refuse("limits.max_bytes", fmt::format("up to {} ({:.6g} bytes) > {:.6g} bytes", human_bytes(e.bytes), e.bytes, l.max_bytes));
  const double free = free_bytes(output_dir);
  if (std::isfinite(free) && e.bytes > free)
    throw ExperimentError(l.where, "outputs.directory",
                          fmt::format("the run would write up to {} ({:.6g} bytes) but the file system of '{}' has {} "
                                      "({:.6g} bytes) free [{}]",
                                      human_bytes(e.bytes), e.bytes, output_dir.string(), human_bytes(free), free, e.str()),
                          "free space there, choose another output folder (-o), or shorten the procedure");
}

void check_run_name(const std::string& name) {
  auto refuse = [&](const std::string& why) {
    std::string shown;
    for (const char c : name.substr(0, 80)) {
      const auto u = static_cast<unsigned char>(c);
      shown += u < 0x20 || u == 0x7f ? fmt::format("\\x{:02x}", u) : std::string(1, c);
    }
    throw std::invalid_argument(
        fmt::format("run name '{}' {}: a run name names one folder inside the output folder", shown, why));
  };
  if (name.empty()) refuse("is empty");
  if (name == "." || name == "..") refuse("is a dot name");
  if (name.size() > 255) refuse(fmt::format("is {} bytes long, more than 255", name.size()));
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '/' || c == '\\') refuse(fmt::format("contains the path separator '{}'", c));
    if (u < 0x20 || u == 0x7f) refuse(fmt::format("contains the control character 0x{:02x}", u));
  }
}

}  // namespace stend
