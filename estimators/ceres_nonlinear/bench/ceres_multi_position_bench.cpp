// Multi-position calibration benchmarks (docs/benchmarks.md, "ceres_nonlinear"):
//   BM_WholeProcess/51000/38 — static detection + accelerometer fit (unknown orientations) + gyro
//     fit (integration between static intervals) + both covariances, on a synthetic 51,000-sample
//     38-position record (accelerometer + gyro, 100 Hz). Target ≤ 0.1 s.
//   BM_WholeProcess/N/38 — the same at other record lengths (time ∝ samples).
//   BM_AccelFit/P — the Ceres accelerometer fit alone (intervals given) against the number of
//     positions P, 200 samples per interval.
//   BM_GyroIntegrationFit/P — the gyro integration fit alone against P.
// Run: build/estimators/ceres_nonlinear/ceres_multi_position_bench --benchmark_repetitions=5
#include "synthetic_record.hpp"

#include <benchmark/benchmark.h>

using namespace stend;
using namespace stend::ceres_nonlinear;

namespace {

CalibrationOptions accel_options() {
  CalibrationOptions o;
  o.processing.detector.trim_s = 0.5;
  o.processing.detector.max_gyro_radps = 0.05;
  o.estimate_gyro_bias = false;
  return o;
}

void BM_WholeProcess(benchmark::State& state) {
  synthetic::Spec spec;
  spec.samples = static_cast<std::size_t>(state.range(0));
  spec.positions = static_cast<int>(state.range(1));
  const synthetic::Record r = synthetic::make(spec);
  std::size_t intervals = 0;
  bool ok = true;
  for (auto _ : state) {
    const CalibrationResult a = calibrate_accelerometer_unknown_orientations(r.recording, accel_options());
    const CalibrationResult g = calibrate_gyro_integration(r.recording, a);
    intervals = a.intervals.size();
    ok = ok && a.ok() && g.ok();
    benchmark::DoNotOptimize(g.theta.data());
  }
  state.counters["intervals"] = static_cast<double>(intervals);
  state.counters["ok"] = ok ? 1.0 : 0.0;
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
}
BENCHMARK(BM_WholeProcess)
    ->Args({51000, 38})
    ->Args({25500, 38})
    ->Args({102000, 38})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

std::vector<processing::StaticPoint> intervals_of(const synthetic::Record& r) {
  std::vector<processing::StaticPoint> ivs;
  for (const auto& [a, b] : r.statics) ivs.push_back(make_interval(r.recording, a, b));
  return ivs;
}

synthetic::Spec positions_spec(int positions) {
  synthetic::Spec spec;
  spec.positions = positions;
  spec.samples = static_cast<std::size_t>(positions) * 300;  // 200 static + 100 turning per position
  spec.static_fraction = 2.0 / 3.0;
  return spec;
}

void BM_AccelFit(benchmark::State& state) {
  const synthetic::Record r = synthetic::make(positions_spec(static_cast<int>(state.range(0))));
  const auto ivs = intervals_of(r);
  CalibrationOptions o = accel_options();
  bool ok = true;
  for (auto _ : state) {
    const CalibrationResult a = calibrate_accelerometer_unknown_orientations(ivs, physics::kStandardGravity, o);
    ok = ok && a.ok();
    benchmark::DoNotOptimize(a.theta.data());
  }
  state.counters["ok"] = ok ? 1.0 : 0.0;
}
BENCHMARK(BM_AccelFit)->Arg(10)->Arg(20)->Arg(38)->Arg(76)->Arg(150)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GyroIntegrationFit(benchmark::State& state) {
  const synthetic::Record r = synthetic::make(positions_spec(static_cast<int>(state.range(0))));
  const CalibrationResult a = calibrate_accelerometer_unknown_orientations(intervals_of(r), physics::kStandardGravity, accel_options());
  bool ok = a.ok();
  for (auto _ : state) {
    const CalibrationResult g = calibrate_gyro_integration(r.recording, a);
    ok = ok && g.ok();
    benchmark::DoNotOptimize(g.theta.data());
  }
  state.counters["ok"] = ok ? 1.0 : 0.0;
}
BENCHMARK(BM_GyroIntegrationFit)->Arg(10)->Arg(20)->Arg(38)->Arg(76)->Arg(150)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
