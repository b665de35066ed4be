// Overlapping Allan deviation at octave τ over 10^8 samples, streaming, with confidence
// intervals (Greenhall EDF + chi-squared quantiles) for every octave; and every deviation kind
// together (ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, TOTDEV with noise identification and
// intervals, stend/noise/deviations.hpp) over the same input.
//
//   ninja -C build allan_bench && build/bin/allan_bench
//
// The estimator core is the library stend_noise (stats/noise: the streams, EDF and intervals).
// Input: a 2^16-sample table of Gaussian
// noise fed in 4096-sample chunks at pseudo-random offsets (generating 10^8 normals would take
// longer than the estimator; the table keeps the process small so that peak RSS measures the
// estimator's state). Counters: peak_rss_MiB (getrusage, whole process), state_MiB (the
// estimator's own allocation), octaves, and Msamples/s.
#include <stend/noise/allan_stream.hpp>
#include <stend/noise/deviations.hpp>
#include <stend/noise/edf.hpp>

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cstdint>
#include <random>
#include <vector>

namespace {

using stend::noise::NoiseType;
using stend::noise::OverlappingAllanStream;

const std::vector<double>& noise_table() {
  static const std::vector<double> table = [] {
    std::vector<double> t(1u << 16);
    std::mt19937_64 gen(1);
    std::normal_distribution<double> normal;
    for (auto& v : t) v = 0.05 * normal(gen) + 0.3;  // a gyro axis: bias + white noise
    return t;
  }();
  return table;
}

double peak_rss_mib() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

void BM_AllanOctaveOverlappingWithIntervals(benchmark::State& state) {
  const auto n = static_cast<std::uint64_t>(state.range(0));
  const auto& table = noise_table();
  constexpr std::size_t kChunk = OverlappingAllanStream::kBlock;
  std::size_t octaves = 0, state_bytes = 0;
  for (auto _ : state) {
    OverlappingAllanStream allan(OverlappingAllanStream::kDefaultMaxM, n);
    std::uint64_t lcg = 12345;
    for (std::uint64_t done = 0; done < n; done += kChunk) {
      lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
      const std::size_t offset = static_cast<std::size_t>((lcg >> 33) % (table.size() - kChunk));
      allan.add(table.data() + offset, static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, n - done)));
    }
    const auto result = allan.octaves();
    double sink = 0.0;
    for (const auto& o : result) {
      const double adev = std::sqrt(o.avar);
      const double edf = stend::noise::edf_overlapping_adev(
          NoiseType::kWhite, static_cast<double>(n) + 1.0, static_cast<double>(o.m));
      const auto ci = stend::noise::deviation_interval(adev, edf, stend::stats::kOneSigma);
      sink += ci.lo + ci.hi;
    }
    benchmark::DoNotOptimize(sink);
    octaves = result.size();
    state_bytes = allan.state_bytes();
  }
  state.counters["octaves"] = static_cast<double>(octaves);
  state.counters["state_MiB"] = static_cast<double>(state_bytes) / (1024.0 * 1024.0);
  state.counters["peak_rss_MiB"] = peak_rss_mib();
  state.counters["Msamples/s"] = benchmark::Counter(static_cast<double>(n) * 1e-6,
                                                    benchmark::Counter::kIsIterationInvariantRate);
}

void BM_AllDeviationsOctave(benchmark::State& state) {
  const auto n = static_cast<std::uint64_t>(state.range(0));
  const auto& table = noise_table();
  constexpr std::size_t kChunk = 4096;
  std::size_t points = 0, state_bytes = 0;
  for (auto _ : state) {
    // Octave factors up to 2^20 (τ ≤ 17 min at 1 kHz): history and head of 64 MiB.
    stend::noise::DeviationStream devs(stend::noise::DeviationOptions{.factors = {}, .max_m = 1u << 20});
    std::uint64_t lcg = 12345;
    for (std::uint64_t done = 0; done < n; done += kChunk) {
      lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
      const std::size_t offset = static_cast<std::size_t>((lcg >> 33) % (table.size() - kChunk));
      devs.add_rate(table.data() + offset, static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, n - done)));
    }
    double sink = 0.0;
    points = 0;
    for (auto kind : stend::noise::kAllDeviationKinds) {
      for (const auto& p : devs.result(kind)) {
        sink += p.lo + p.hi;
        ++points;
      }
    }
    benchmark::DoNotOptimize(sink);
    state_bytes = devs.state_bytes();
  }
  state.counters["points"] = static_cast<double>(points);
  state.counters["state_MiB"] = static_cast<double>(state_bytes) / (1024.0 * 1024.0);
  state.counters["peak_rss_MiB"] = peak_rss_mib();
  state.counters["Msamples/s"] = benchmark::Counter(static_cast<double>(n) * 1e-6,
                                                    benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_AllDeviationsOctave)->Arg(10000000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_AllDeviationsOctave)
    ->Arg(100000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_AllanOctaveOverlappingWithIntervals)
    ->Arg(1000000)
    ->Arg(10000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_AllanOctaveOverlappingWithIntervals)
    ->Arg(100000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(7)
    ->ReportAggregatesOnly(true);

BENCHMARK_MAIN();
