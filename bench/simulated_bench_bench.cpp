// Speed of the simulated bench: a one-hour static experiment at 1 kHz (sensor in a chamber held
// at 25 °C on a one-axis table), recorded to a run folder, in multiples of real time.
//   build/bin/simulated_bench_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "stend/experiment.hpp"
#include "stend/plugin_host.hpp"
#include "stend/runner.hpp"

#include <filesystem>
#include <unistd.h>

namespace {

const char* kExperiment = R"(
experiment: {name: bench_one_hour, seed: 3}
bench:
  gravity: {latitude_deg: 47.2, height_m: 50}
  sensor: {plugin: sim_imu, config: {output_rate_hz: 1000}}
  fixtures:
    - {id: table, plugin: sim_one_axis_table}
    - {id: chamber, plugin: sim_thermochamber, on: table, config: {initial_c: 25}}
procedure:
  - set_temperature: {fixture: chamber, setpoint_c: 25, tolerance_c: 0.5, hold_s: 0, record: false}
  - record: {duration_s: 3600}
)";

void BM_SimulatedBenchOneHour1kHz(benchmark::State& state) {
  stend::PluginHost host;
  host.scan({{STEND_BUILD_PLUGIN_DIR, "build tree"}});
  const stend::Experiment exp = stend::parse_experiment(kExperiment, "bench.yaml", host);
  const auto out = std::filesystem::temp_directory_path() / ("stend-bench-" + std::to_string(getpid()));
  double run_s = 0.0, wall_s = 0.0;
  std::uint64_t samples = 0;
  for (auto _ : state) {
    stend::RunOptions opt;
    opt.output_dir = out;
    const stend::RunResult r = stend::run_experiment(exp, host, opt);
    if (r.status != stend::RunStatus::kComplete) state.SkipWithError(r.message.c_str());
    run_s += r.run_time_s;
    wall_s += r.wall_time_s;
    samples += r.samples;
    std::filesystem::remove_all(r.dir);
  }
  std::filesystem::remove_all(out);
  state.counters["x_real_time"] = run_s / wall_s;
  state.counters["ns_per_sample"] = 1e9 * wall_s / static_cast<double>(samples);
  state.counters["samples"] = static_cast<double>(samples) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_SimulatedBenchOneHour1kHz)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
