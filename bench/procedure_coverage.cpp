// procedure_coverage — every shipped procedure on the twin, seed after seed: the procedure played
// on a sensor with planted errors (stend/sim/procedure_player.hpp), written as a log with its
// quirks (stend/sim/twin_log.hpp: shipped_twins), read back through the csv importer with the
// import keys a user gives, aligned to the procedure through alignment::align_recording (as
// `stend fit LOG --experiment` does; `stend import --experiment` runs the same align on the same
// blocks), fitted with the shipped model (ceres_nonlinear's fit_model_file, as `stend fit`) and
// each fitted parameter's 95 % interval checked against the planted value. Prints a Markdown table
// (docs/real-data.md, "Shipped procedures on the twin: interval coverage") and the parameters
// below 90 %.
//
//   procedure_coverage [--seeds N] [--first SEED] [--procedure NAME] [--quirks LIST] [--detail]
//                      [--bias-instability]
//
// --quirks gives every twin the quirks listed (comma-separated names of stend/sim/twin_log.hpp, e.g.
// "bursty" or "bursty,counts") instead of its own;
// --detail lists every parameter's coverage (else those below 90 %), with the mean and spread of
// (fitted − planted)/standard error; --bias-instability gives the twin's sensor the simulator's own
// bias instability and random walk (off in the twin: docs/real-data.md).
#include <stend/alignment/align.hpp>
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/core/procedure_geometry.hpp>
#include <stend/io/formats.hpp>
#include <stend/sim/twin_check.hpp>
#include <stend/sim/twin_log.hpp>

#include <fmt/format.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;

namespace {

struct Args {
  int seeds = 100;
  std::uint64_t first = 1;
  std::string only;
  bool detail = false;
  bool bias_instability = false;
  std::vector<sim::Quirk> quirks;  // empty: each twin's own
};

std::vector<sim::Quirk> quirks_from_list(const std::string& list) {
  std::vector<sim::Quirk> out;
  std::size_t from = 0;
  while (from <= list.size()) {
    const std::size_t comma = std::min(list.find(',', from), list.size());
    out.push_back(sim::quirk_from_name(list.substr(from, comma - from)));
    from = comma + 1;
  }
  return out;
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--seeds") a.seeds = std::stoi(value());
    else if (arg == "--first") a.first = std::stoull(value());
    else if (arg == "--procedure") a.only = value();
    else if (arg == "--detail") a.detail = true;
    else if (arg == "--bias-instability") a.bias_instability = true;
    else if (arg == "--quirks") a.quirks = quirks_from_list(value());
    else throw std::invalid_argument("unknown argument " + arg +
                                     " (--seeds N, --first SEED, --procedure NAME, --quirks LIST, --detail, "
                                     "--bias-instability)");
  }
  return a;
}

// One parameter over the seeds.
struct Tally {
  int estimated = 0, covered = 0, held = 0, failed = 0;
  double z_sum = 0.0, z_sq = 0.0;
  double coverage() const { return estimated > 0 ? static_cast<double>(covered) / estimated : std::nan(""); }
};

// One procedure over the seeds.
struct Run {
  const sim::ShippedTwin* twin = nullptr;
  std::vector<sim::Quirk> quirks;  // the log's
  std::vector<std::string> order;  // parameter names in the document's order
  std::map<std::string, Tally> params;
  int played = 0, aligned = 0, fitted = 0;
  std::vector<std::string> problems;  // the first few, by seed
  double seconds = 0.0;
};

void note(Run& run, std::uint64_t seed, const std::string& what) {
  if (run.problems.size() < 5) run.problems.push_back(fmt::format("seed {}: {}", seed, what.substr(0, 300)));
}

// One seed: play, write, import, align, fit, check.
void one_seed(Run& run, const Experiment& exp, const ceres_nonlinear::ModelFileOptions& model, std::uint64_t seed,
              const fs::path& dir, bool bias_instability) {
  sim::TwinSetup setup = sim::twin_setup(run.quirks, seed);
  if (bias_instability) {  // the simulator's own bias instability and random walk (procedure_player.hpp)
    const sim::SimImuConfig defaults;
    setup.sensor.accel_bias_instability_mps2 = defaults.accel_bias_instability_mps2;
    setup.sensor.accel_random_walk = defaults.accel_random_walk;
    setup.sensor.gyro_bias_instability_radps = defaults.gyro_bias_instability_radps;
    setup.sensor.gyro_random_walk = defaults.gyro_random_walk;
  }
  const sim::Played played = sim::play_procedure(exp, setup.sensor, setup.player);
  ++run.played;
  const fs::path log = dir / (run.twin->name + ".csv");
  io::ImportOptions options;
  for (const auto& [key, value] : sim::write_twin_csv(log, played, setup.csv)) options.set(key, value);
  Recording rec = io::open_dataset({log}, "csv", options);
  try {
    alignment::align_recording(rec, exp);
  } catch (const std::exception& e) {
    note(run, seed, std::string("not aligned: ") + e.what());
    return;
  }
  ++run.aligned;
  const ceres_nonlinear::ModelFileFit fit = ceres_nonlinear::fit_model_file(rec, model);
  if (!fit.ok()) note(run, seed, "fit: " + fit.message);
  else ++run.fitted;
  for (const sim::ParameterCheck& c : sim::check_against_truth(ceres_nonlinear::results_document(model, fit), played.truth)) {
    if (!run.params.count(c.name)) run.order.push_back(c.name);
    Tally& t = run.params[c.name];
    if (c.held) ++t.held;
    if (!c.held && !c.estimated) ++t.failed;
    if (!c.estimated) continue;
    ++t.estimated;
    t.covered += c.covered ? 1 : 0;
    t.z_sum += c.z();
    t.z_sq += c.z() * c.z();
  }
}

Run run_procedure(const sim::ShippedTwin& twin, const Args& args, const fs::path& dir) {
  Run run;
  run.twin = &twin;
  run.quirks = args.quirks.empty() ? twin.quirks : args.quirks;
  const auto start = std::chrono::steady_clock::now();
  const Experiment exp = load_observed_procedure((fs::path(STEND_SOURCE_DIR) / twin.procedure).string());
  const ceres_nonlinear::ModelFileOptions model =
      ceres_nonlinear::load_model_file((fs::path(STEND_SOURCE_DIR) / twin.model).string());
  for (int k = 0; k < args.seeds; ++k) {
    const std::uint64_t seed = args.first + static_cast<std::uint64_t>(k);
    try {
      one_seed(run, exp, model, seed, dir, args.bias_instability);
    } catch (const std::exception& e) {
      note(run, seed, e.what());
    }
  }
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return run;
}

// The coverages of the parameters a procedure identifies (estimated in every fitted seed).
std::vector<double> identified_coverages(const Run& run) {
  std::vector<double> c;
  for (const auto& name : run.order) {
    const Tally& t = run.params.at(name);
    if (t.estimated > 0 && t.held == 0) c.push_back(t.coverage());
  }
  std::sort(c.begin(), c.end());
  return c;
}

std::string percent(double v) { return std::isfinite(v) ? fmt::format("{:.0f} %", 100.0 * v) : "—"; }

void print_table(const std::vector<Run>& runs, const Args& args) {
  std::printf("| procedure | model | twin's quirks | parameters identified / held | coverage min | coverage median | "
              "seeds aligned / fitted | time |\n|---|---|---|---|---|---|---|---|\n");
  for (const Run& r : runs) {
    const std::vector<double> c = identified_coverages(r);
    int held = 0;
    for (const auto& [name, t] : r.params) held += t.held > 0 && t.estimated == 0 ? 1 : 0;
    const double median = c.empty() ? std::nan("") : (c[(c.size() - 1) / 2] + c[c.size() / 2]) / 2.0;
    std::printf("| %s | %s | %s | %zu / %d | %s | %s | %d / %d of %d | %.0f s |\n", r.twin->name.c_str(),
                fs::path(r.twin->model).filename().c_str(), sim::quirk_list(r.quirks).c_str(), c.size(), held,
                percent(c.empty() ? std::nan("") : c.front()).c_str(), percent(median).c_str(), r.aligned, r.fitted,
                args.seeds, r.seconds);
  }
}

void print_details(const std::vector<Run>& runs, const Args& args) {
  std::printf("\n| procedure | parameter | coverage | seeds | mean z | sd z |\n|---|---|---|---|---|---|\n");
  for (const Run& r : runs)
    for (const auto& name : r.order) {
      const Tally& t = r.params.at(name);
      if (t.estimated == 0 || (!args.detail && t.coverage() >= 0.9)) continue;
      const double mean = t.z_sum / t.estimated, sd = std::sqrt(std::max(0.0, t.z_sq / t.estimated - mean * mean));
      std::printf("| %s | %s | %s | %d | %+.2f | %.2f |\n", r.twin->name.c_str(), name.c_str(), percent(t.coverage()).c_str(),
                  t.estimated, mean, sd);
    }
  for (const Run& r : runs)
    for (const auto& p : r.problems) std::printf("\n%s: %s", r.twin->name.c_str(), p.c_str());
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Args args = parse(argc, argv);
    const fs::path dir = fs::temp_directory_path() / fmt::format("stend_coverage_{}", ::getpid());
    fs::create_directories(dir);
    std::vector<Run> runs;
    for (const sim::ShippedTwin& twin : sim::shipped_twins()) {
      if (!args.only.empty() && twin.name != args.only) continue;
      runs.push_back(run_procedure(twin, args, dir));
      std::fprintf(stderr, "%s: %d seeds, %.0f s\n", twin.name.c_str(), args.seeds, runs.back().seconds);
    }
    fs::remove_all(dir);
    print_table(runs, args);
    print_details(runs, args);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "procedure_coverage: %s\n", e.what());
    return 2;
  }
}
