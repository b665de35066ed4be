// stend_twin_log — a twin log of a procedure: the experiment file's observed steps played by a
// simulated person on a simulated sensor with planted errors (stend/sim/procedure_player.hpp),
// written as a CSV with a real log's quirks (stend/sim/twin_log.hpp). Prints the `stend import`
// flags that read it back; --truth writes the planted errors (the names of ceres.json's list; also
// in the frame convention of a fit with unknown orientations) and the steps as they were played.
//
//   stend_twin_log PROCEDURE.yaml LOG.csv [--seed N] [--quirks no_time,low_rate,bursty,counts,short]
//                  [--rate-hz HZ] [--truth TRUTH.json]
#include <stend/core/procedure_geometry.hpp>
#include <stend/sim/twin_log.hpp>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace {

struct Args {
  std::string procedure, log, truth;
  std::uint64_t seed = 1;
  std::vector<stend::sim::Quirk> quirks;
  double rate_hz = 0.0;  // 0: the quirks' (100 Hz, 16 Hz with low_rate)
};

[[noreturn]] void usage(const std::string& problem) {
  std::fprintf(stderr,
               "%s\nusage: stend_twin_log PROCEDURE.yaml LOG.csv [--seed N] [--quirks Q1,Q2,...] [--rate-hz HZ] "
               "[--truth TRUTH.json]\n  quirks: no_time, low_rate, bursty, counts, short\n",
               problem.c_str());
  std::exit(2);
}

std::vector<stend::sim::Quirk> quirks_from(const std::string& list) {
  std::vector<stend::sim::Quirk> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= list.size(); ++i)
    if (i == list.size() || list[i] == ',') {
      if (i > start) out.push_back(stend::sim::quirk_from_name(list.substr(start, i - start)));
      start = i + 1;
    }
  return out;
}

Args parse(int argc, char** argv) {
  Args a;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--seed") a.seed = std::stoull(value());
    else if (arg == "--quirks") a.quirks = quirks_from(value());
    else if (arg == "--rate-hz") a.rate_hz = std::stod(value());
    else if (arg == "--truth") a.truth = value();
    else if (arg == "-h" || arg == "--help") usage("a twin log of a procedure, with a real log's quirks");
    else if (!arg.empty() && arg[0] == '-') usage("unknown option " + arg);
    else positional.push_back(arg);
  }
  if (positional.size() != 2) usage("give the procedure file and the log to write");
  a.procedure = positional[0];
  a.log = positional[1];
  return a;
}

// "name": value pairs of a parameter map, one a line.
void write_map(std::ofstream& out, const std::map<std::string, double>& values) {
  bool first = true;
  for (const auto& [name, value] : values) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s\n    \"%s\": %.17g", first ? "" : ",", name.c_str(), value);
    out << buf;
    first = false;
  }
}

// The planted truth (and the same sensor in the frame convention a fit with unknown orientations
// reports), the noise densities and the steps as played.
void write_truth(const std::string& file, const stend::sim::Played& played) {
  std::ofstream out(file);
  out << "{\n  \"parameters\": {";
  write_map(out, played.truth.parameters);
  out << "\n  },\n  \"in_accel_frame_convention\": {";
  write_map(out, played.truth.in_accel_frame_convention().parameters);
  bool first = true;
  char buf[400];
  std::snprintf(buf, sizeof buf, "\n  },\n  \"accel_noise_density\": %.17g,\n  \"gyro_noise_density\": %.17g,\n  \"steps\": [",
                played.truth.accel_noise_density, played.truth.gyro_noise_density);
  out << buf;
  first = true;
  for (const auto& s : played.steps) {
    std::snprintf(buf, sizeof buf,
                  "%s\n    {\"label\": \"%s\", \"t_start_s\": %.4f, \"t_end_s\": %.4f, \"up\": [%.9f, %.9f, %.9f], "
                  "\"rotation_deg\": [%.6f, %.6f, %.6f], \"rate_dps\": %g}",
                  first ? "" : ",", s.label.c_str(), s.t_start_s, s.t_end_s, s.up[0], s.up[1], s.up[2], s.rotation_deg[0],
                  s.rotation_deg[1], s.rotation_deg[2], s.rate_dps);
    out << buf;
    first = false;
  }
  out << "\n  ]\n}\n";
  if (!out) throw std::runtime_error("cannot write " + file);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Args a = parse(argc, argv);
    stend::sim::TwinSetup setup = stend::sim::twin_setup(a.quirks, a.seed);
    if (a.rate_hz > 0.0) setup.player.rate_hz = a.rate_hz;
    const stend::Experiment exp = stend::load_observed_procedure(a.procedure);
    if (const auto dir = std::filesystem::path(a.log).parent_path(); !dir.empty()) std::filesystem::create_directories(dir);
    const stend::sim::Played played = stend::sim::play_procedure(exp, setup.sensor, setup.player);
    const auto keys = stend::sim::write_twin_csv(a.log, played, setup.csv);
    if (!a.truth.empty()) write_truth(a.truth, played);
    std::fprintf(stderr, "%s: %zu samples at %g Hz, %.1f s, quirks: %s\n", a.log.c_str(), played.samples.size(),
                 played.info.output_rate_hz, played.samples.empty() ? 0.0 : played.samples.back().t_s,
                 stend::sim::quirk_list(a.quirks).c_str());
    std::printf("%s\n", stend::sim::import_flags(keys).substr(1).c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stend_twin_log: %s\n", e.what());
    return 2;
  }
}
