// Recording store throughput (CSV run folders): cost of one imu.csv row written and read back.
//
//   build-rec/bin/recording_bench                       # all
//   build-rec/bin/recording_bench --benchmark_filter=Hour
//
// BM_WriteRows: add_samples (10 samples per call, as the runner feeds them) + tick, measured
//   without finish() (whose fdatasync waits for the disk, once per run).
// BM_Finish: the one-off cost of finish() after 1 M rows (flush + fdatasync + run.json).
// BM_ReadRows: Recording::open of a 1 M-row recording (page cache warm).
// BM_OneHour: the whole 3.6 M-row, 1 kHz hour written, finished and read back once; reports the
//   real-time factor of the write side (the bench needs >= 1000x including recording).
#include <stend/physics/units.hpp>
#include <stend/recording/recording.hpp>

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <random>
#include <string>

namespace fs = std::filesystem;

namespace {

// MPU-6050 at ±2 g and ±250 deg/s: 16384 LSB/g, 131 LSB/(deg/s).
constexpr double kAccelLsb = stend::physics::kStandardGravity / 16384.0;
constexpr double kGyroLsb = stend::physics::kDegPerSecond / 131.0;

fs::path scratch_dir(const char* name) {
  static int counter = 0;
  return fs::temp_directory_path() / ("stend_recording_bench_" + std::to_string(::getpid()) +
                                      "_" + name + "_" + std::to_string(counter++));
}

stend::RecordingHeader header() {
  stend::RecordingHeader h;
  h.experiment_name = "bench";
  h.info.output_rate_hz = 1000.0;
  h.info.accel_lsb_mps2 = kAccelLsb;
  h.info.gyro_lsb_radps = kGyroLsb;
  h.clock = "simulated";
  h.truth_columns = {"air_c", "die_c"};
  return h;
}

// One simulated second of realistic MPU-6050-like samples (noisy counts, SI = counts * lsb with
// a small calibration term so the SI text is a full 15-17 digit double, as in real recordings).
std::vector<stend::ImuSample> one_second(std::uint64_t first_index, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 20.0);
  const double lsb_a = kAccelLsb, lsb_g = kGyroLsb;
  std::vector<stend::ImuSample> v(1000);
  for (std::size_t i = 0; i < v.size(); ++i) {
    auto& s = v[i];
    s.t_s = static_cast<double>(first_index + i) / 1000.0;
    for (int k = 0; k < 3; ++k) {
      s.accel_counts[k] = static_cast<std::int32_t>(std::lround(n(rng))) + (k == 2 ? 16384 : 0);
      s.gyro_counts[k] = static_cast<std::int32_t>(std::lround(n(rng)));
      s.accel_mps2[k] = s.accel_counts[k] * lsb_a * 1.0003 + 0.012;
      s.gyro_radps[k] = s.gyro_counts[k] * lsb_g * 0.9998 - 0.0004;
    }
    s.temperature_counts = -2000 + static_cast<std::int32_t>(std::lround(n(rng)));
    s.temperature_c = s.temperature_counts / 340.0 + 36.53;
  }
  return v;
}

// Writes `rows` rows (re-timing a pre-generated second) into `w`. With `unique`, every SI value
// is made distinct (worst case: no repeated text, every double goes through the shortest
// round-trip algorithm); otherwise SI values are a function of the counts, as in a sensor.
void write_rows(stend::RecordingWriter& w, const std::vector<stend::ImuSample>& sec,
                std::size_t rows, std::vector<stend::ImuSample>& scratch, bool unique = false) {
  scratch = sec;
  std::size_t done = 0;
  std::uint64_t second = 0;
  while (done < rows) {
    for (std::size_t b = 0; b < scratch.size() && done < rows; b += 10) {
      const std::size_t n = std::min<std::size_t>(10, rows - done);
      w.add_samples(scratch.data() + b, n);
      w.tick(scratch[b + n - 1].t_s);
      done += n;
    }
    ++second;
    const double shift = unique ? 1e-9 * static_cast<double>(second) : 0.0;
    for (std::size_t i = 0; i < scratch.size(); ++i) {
      scratch[i].t_s = static_cast<double>(second * 1000 + i + 1) / 1000.0;
      if (unique) {
        scratch[i].accel_mps2 = sec[i].accel_mps2.array() + shift;
        scratch[i].gyro_radps = sec[i].gyro_radps.array() + shift;
        scratch[i].temperature_c = sec[i].temperature_c + shift;
      }
    }
  }
}

void BM_WriteRows(benchmark::State& state) {
  const auto rows = static_cast<std::size_t>(state.range(0));
  const bool unique = state.range(1) != 0;
  state.SetLabel(unique ? "every SI value distinct" : "SI = f(counts)");
  std::mt19937_64 rng(1);
  auto sec = one_second(1, rng);
  if (unique) {
    for (std::size_t i = 0; i < sec.size(); ++i) {
      sec[i].accel_mps2 = sec[i].accel_mps2.array() + 1e-12 * static_cast<double>(i);
      sec[i].gyro_radps = sec[i].gyro_radps.array() + 1e-12 * static_cast<double>(i);
      sec[i].temperature_c += 1e-12 * static_cast<double>(i);
    }
  }
  std::vector<stend::ImuSample> scratch;
  for (auto _ : state) {
    state.PauseTiming();
    const fs::path dir = scratch_dir("write");
    state.ResumeTiming();
    {
      stend::RecordingWriter w(dir, header(), "name: bench\n", {stend::RecordingFormat::kCsv});
      write_rows(w, sec, rows, scratch, unique);
      w.flush();
      state.PauseTiming();
    }
    fs::remove_all(dir);
    state.ResumeTiming();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
  state.counters["time_per_row"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(rows),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_Finish(benchmark::State& state) {
  std::mt19937_64 rng(2);
  const auto sec = one_second(1, rng);
  std::vector<stend::ImuSample> scratch;
  for (auto _ : state) {
    state.PauseTiming();
    const fs::path dir = scratch_dir("finish");
    {
      stend::RecordingWriter w(dir, header(), "name: bench\n", {stend::RecordingFormat::kCsv});
      write_rows(w, sec, 1'000'000, scratch);
      state.ResumeTiming();
      w.finish(stend::RunStatus::kComplete);
      state.PauseTiming();
    }
    fs::remove_all(dir);
    state.ResumeTiming();
  }
}

void BM_ReadRows(benchmark::State& state) {
  const auto rows = static_cast<std::size_t>(state.range(0));
  const fs::path dir = scratch_dir("read");
  {
    std::mt19937_64 rng(3);
    const auto sec = one_second(1, rng);
    std::vector<stend::ImuSample> scratch;
    stend::RecordingWriter w(dir, header(), "name: bench\n", {stend::RecordingFormat::kCsv});
    write_rows(w, sec, rows, scratch);
    w.finish(stend::RunStatus::kComplete);
  }
  for (auto _ : state) {
    auto r = stend::Recording::open(dir);
    if (r.samples.size() != rows) state.SkipWithError("wrong row count");
    benchmark::DoNotOptimize(r.samples.data());
  }
  fs::remove_all(dir);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
  state.counters["time_per_row"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(rows),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_OneHour(benchmark::State& state) {
  constexpr std::size_t kRows = 3'600'000;
  std::mt19937_64 rng(4);
  const auto sec = one_second(1, rng);
  std::vector<stend::ImuSample> scratch;
  using clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const fs::path dir = scratch_dir("hour");
    const auto t0 = clock::now();
    double write_s = 0.0, finish_s = 0.0;
    {
      stend::RecordingWriter w(dir, header(), "name: hour\n", {stend::RecordingFormat::kCsv});
      write_rows(w, sec, kRows, scratch);
      const auto t1 = clock::now();
      w.finish(stend::RunStatus::kComplete);
      write_s = std::chrono::duration<double>(t1 - t0).count();
      finish_s = std::chrono::duration<double>(clock::now() - t1).count();
    }
    const auto t2 = clock::now();
    const auto r = stend::Recording::open(dir);
    const double read_s = std::chrono::duration<double>(clock::now() - t2).count();
    if (r.samples.size() != kRows) state.SkipWithError("wrong row count");
    state.counters["write_ns_per_row"] = write_s * 1e9 / kRows;
    state.counters["finish_s"] = finish_s;
    state.counters["realtime_x"] = 3600.0 / (write_s + finish_s);
    state.counters["read_ns_per_row"] = read_s * 1e9 / kRows;
    state.counters["MB"] = static_cast<double>(fs::file_size(dir / "imu.csv")) / 1e6;
    fs::remove_all(dir);
  }
}

}  // namespace

BENCHMARK(BM_WriteRows)
    ->Args({100'000, 0})
    ->Args({1'000'000, 0})
    ->Args({1'000'000, 1})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Finish)->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadRows)->Arg(1'000'000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OneHour)->Iterations(1)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
