// Cost of SimImu::acquire per sample (the whole simulated bench must run ≥ 1000× real time at
// 1 kHz, i.e. < 1 µs per sample including the fixtures and the recording).
//   build/bin/sim_imu_bench
#include <benchmark/benchmark.h>

#include <vector>

#include <stend/sim/imu.hpp>

namespace {

// Constant truth: measures the sensor, not the bench composition.
class StaticTruth : public stend::TruthSource {
 public:
  stend::BenchTruth at(double t) const override {
    stend::BenchTruth b;
    b.t_s = t;
    b.specific_force_mps2 = {0.1, -0.2, 9.8};
    b.angular_rate_radps = {0.01, 0.02, 0.03};
    b.die_temperature_c = 27.0 + 1e-4 * t;
    return b;
  }
};

void run(benchmark::State& state, const stend::sim::SimImuConfig& c) {
  stend::sim::SimImu imu(c);
  StaticTruth truth;
  std::vector<stend::ImuSample> buf;
  buf.reserve(64);
  imu.start(0.0);
  double t = 0.0;
  std::size_t samples = 0;
  for (auto _ : state) {
    t += 0.01;  // the runner's 10-ms control period: 10 samples per call
    buf.clear();
    imu.acquire(t, truth, buf);
    samples += buf.size();
    benchmark::DoNotOptimize(buf.data());
  }
  // Seconds per sample (printed with an SI prefix, e.g. "95n" = 95 ns).
  state.counters["s_per_sample"] = benchmark::Counter(
      static_cast<double>(samples), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.SetItemsProcessed(static_cast<int64_t>(samples));
}

// MPU-6050 defaults: white + Gauss–Markov + random walk on 6 channels, no error terms.
void BM_SimImuDefaults(benchmark::State& state) { run(state, stend::sim::SimImuConfig{}); }

// Paper-like errors on every triad term, temperature polynomials, low-pass on.
void BM_SimImuFullModelLowpass(benchmark::State& state) {
  stend::sim::SimImuConfig c;
  c.accel.bias = {0.027, -0.01, 0.02};
  c.accel.scale = {0.0007, 0.001, -0.0005};
  c.accel.cross_axis << 0, 0.0055, 0.0002, 0.001, 0, -0.002, 0.003, 0.001, 0;
  c.accel.nonlinear_k2 = {1e-4, 1e-4, 1e-4};
  c.accel.bias_tc = {{1e-3, 1e-5}, {1e-3, 1e-5}, {1e-3, 1e-5}};
  c.accel.scale_tc = {{1e-5}, {1e-5}, {1e-5}};
  c.gyro.bias = {0.01, 0.01, 0.01};
  c.gyro.scale = {0.01, 0.01, 0.01};
  c.gyro.g_sensitivity << 1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3;
  c.lowpass_hz = 44.0;
  run(state, c);
}

BENCHMARK(BM_SimImuDefaults);
BENCHMARK(BM_SimImuFullModelLowpass);

}  // namespace

BENCHMARK_MAIN();
