// Speed of the simulated bench: a one-hour static experiment at 1 kHz (sensor in a chamber held
// at 25 °C on a one-axis table), in multiples of real time — recorded to a run folder
// (BM_SimulatedBenchOneHour1kHz), and with every record dropped (…NoWriter: the simulator and the
// runner alone).
//   build/bin/simulated_bench_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "stend/core/experiment.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/core/runner.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>
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

// Drops every record (counts the samples so that nothing is optimized away).
class NullSink final : public stend::RunSink {
 public:
  void add_samples(const stend::ImuSample* samples, std::size_t count) override {
    if (count > 0) last_t_s_ = samples[count - 1].t_s;
    samples_ += count;
  }
  void add_truth(double, const std::vector<double>&) override {}
  void add_segment(const stend::Segment&) override {}
  void add_event(const stend::Event&) override {}
  void tick(double) override {}
  void finish(stend::RunStatus, const std::string&) override {}

 private:
  std::uint64_t samples_ = 0;
  double last_t_s_ = 0.0;
};

void run_bench(benchmark::State& state, bool write) {
  stend::PluginHost host;
  host.scan({{STEND_BUILD_PLUGIN_DIR, "build tree"}});
  const stend::Experiment exp = stend::parse_experiment(kExperiment, "bench.yaml", host);
  const auto out = std::filesystem::temp_directory_path() / ("stend-bench-" + std::to_string(getpid()));
  double run_s = 0.0, wall_s = 0.0;
  std::uint64_t samples = 0;
  for (auto _ : state) {
    stend::RunOptions opt;
    opt.output_dir = out;
    NullSink sink;
    const stend::RunResult r = write ? stend::run_experiment(exp, host, opt) : stend::run_experiment_to(exp, host, opt, sink);
    if (r.status != stend::RunStatus::kComplete) state.SkipWithError(r.message.c_str());
    run_s += r.run_time_s;
    wall_s += r.wall_time_s;
    samples += r.samples;
    if (write) std::filesystem::remove_all(r.dir);
  }
  std::filesystem::remove_all(out);
  state.counters["x_real_time"] = run_s / wall_s;
  state.counters["ns_per_sample"] = 1e9 * wall_s / static_cast<double>(samples);
  state.counters["samples"] = static_cast<double>(samples) / static_cast<double>(state.iterations());
}

void BM_SimulatedBenchOneHour1kHz(benchmark::State& state) { run_bench(state, true); }
void BM_SimulatedBenchOneHour1kHzNoWriter(benchmark::State& state) { run_bench(state, false); }
BENCHMARK(BM_SimulatedBenchOneHour1kHz)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_SimulatedBenchOneHour1kHzNoWriter)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
