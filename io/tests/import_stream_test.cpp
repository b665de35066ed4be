// Streaming import: a long CSV, ULog or DataFlash log goes into a run folder a chunk at a time,
// with peak memory bounded independently of its length (measured in a child process from
// /proc/self/status VmHWM), and with the same samples as the in-memory import; the windowed
// timestamp repair flags a gap at a window boundary as a whole-log repair does.
#include <stend/io/formats.hpp>
#include <stend/io/importers.hpp>
#include <stend/io/logs.hpp>
#include <stend/io/sample_sink.hpp>
#include <stend/io/timestamps.hpp>
#include <stend/testing/files.hpp>

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::TempDir;

namespace {

constexpr double kRateHz = 1000.0;
// A gap (three samples lost) just before the first sample of the fourth timestamp window.
constexpr std::size_t kGapAt = 3 * kTimestampWindow;

// A CSV log of n samples at kRateHz: t [s] with microsecond digits, accel [m/s²] and gyro [rad/s]
// from a fixed integer pattern printed with 4 decimals (exactly reproducible on reading).
void write_log(const fs::path& file, std::size_t n) {
  std::FILE* f = std::fopen(file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("t,ax,ay,az,gx,gy,gz\n", f);
  std::uint64_t x = 12345;
  for (std::size_t i = 0, k = 0; i < n; ++i, ++k) {
    if (i == kGapAt) k += 3;
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    const auto r = [&](int shift) { return static_cast<int>((x >> shift) & 0xFFF) - 2048; };
    std::fprintf(f, "%.6f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n", static_cast<double>(k) / kRateHz, r(10) * 1e-4,
                 r(22) * 1e-4, 9.81 + r(34) * 1e-4, r(46) * 1e-5, r(52) * 1e-5, r(4) * 1e-5);
  }
  std::fclose(f);
}

ImportOptions csv_options() {
  ImportOptions o;
  o.set("time", "t");
  o.set("accel", "ax,ay,az");
  o.set("gyro", "gx,gy,gz");
  return o;
}

// Peak resident memory of this process [KiB] (VmHWM), −1 when unreadable.
long peak_rss_kib() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

// Peak-RSS growth the streamed import may show [KiB]. Under AddressSanitizer the figure measures
// the sanitizer (its quarantine keeps freed memory), so the bound is checked in the plain build.
#if defined(__SANITIZE_ADDRESS__)
constexpr long kGrowthBoundKib = -1;
#else
constexpr long kGrowthBoundKib = 64 * 1024;
#endif
void expect_bounded_growth(long growth_kib) {
  ::testing::Test::RecordProperty("peak_rss_growth_kib", static_cast<int>(growth_kib));
  if (kGrowthBoundKib > 0) {
    EXPECT_LT(growth_kib, kGrowthBoundKib) << "peak RSS grew by " << growth_kib << " KiB";
  }
}

// Imports `log` (as `format`) into the new run folder `run` in a child process; returns the growth
// of its peak resident memory [KiB] over the import (−1 when the import failed).
long import_in_child(const fs::path& log, const fs::path& run, const std::string& format = "csv",
                     const ImportOptions& options = csv_options()) {
  int fds[2];
  if (::pipe(fds) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    long growth = -1;
    try {
      const long before = peak_rss_kib();
      Recording rec;
      RunSink sink(rec, run, "name: streamed\n");
      import_dataset({log}, format, rec, sink, options);
      sink.finish();
      growth = peak_rss_kib() - before;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "import failed: %s\n", e.what());
    }
    [[maybe_unused]] const auto w = ::write(fds[1], &growth, sizeof growth);
    ::_exit(0);
  }
  ::close(fds[1]);
  long growth = -1;
  if (::read(fds[0], &growth, sizeof growth) != sizeof growth) growth = -1;
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return growth;
}

void expect_same_samples(const SampleSource& a, const SampleSource& b, std::uint64_t count) {
  std::vector<ImuSample> x(4096), y(4096);
  for (std::uint64_t i = 0; i < count; i += x.size()) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(x.size(), count - i));
    a.read(i, n, x.data());
    b.read(i, n, y.data());
    for (std::size_t k = 0; k < n; ++k) {
      ASSERT_EQ(x[k].t_s, y[k].t_s) << "sample " << i + k;
      ASSERT_EQ(x[k].flags, y[k].flags) << "sample " << i + k;
      ASSERT_EQ(x[k].accel_mps2, y[k].accel_mps2) << "sample " << i + k;
      ASSERT_EQ(x[k].gyro_radps, y[k].gyro_radps) << "sample " << i + k;
    }
  }
}

TEST(ImportStream, LongCsvLogInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream");
  constexpr std::size_t kLong = 2'000'000, kShort = 50'000;  // the short log fits one window
  write_log(tmp / "long.csv", kLong);
  write_log(tmp / "short.csv", kShort);

  const long growth_kib = import_in_child(tmp / "long.csv", tmp / "long_run");
  ASSERT_GE(growth_kib, 0) << "the streamed import failed";
  // Whole in memory, the samples alone take 2 M × 96 bytes ≈ 183 MiB; streamed, the timestamp
  // window, a chunk and the writer's buffers.
  expect_bounded_growth(growth_kib);

  const Recording run = Recording::open(tmp / "long_run", SampleLoading::kStream);
  ASSERT_EQ(run.sample_count(), kLong);
  EXPECT_EQ(run.header.experiment_name, "import:csv");
  EXPECT_NEAR(run.header.info.output_rate_hz, kRateHz, 1e-9 * kRateHz);
  // The gap at the window boundary, and only it, is flagged.
  std::uint64_t gaps = 0, gap_at = 0;
  const std::vector<double> flags = read_column(run.sample_source(), Channel::kFlags, 0, kLong);
  for (std::size_t i = 0; i < flags.size(); ++i)
    if (static_cast<std::uint32_t>(flags[i]) & kGapBefore) gap_at = i, ++gaps;
  EXPECT_EQ(gaps, 1u);
  EXPECT_EQ(gap_at, kGapAt);

  // Today's import of the short log (whole in memory, then written) against the same lines of the
  // streamed run.
  Recording in_memory = open_dataset({tmp / "short.csv"}, "csv", csv_options());
  in_memory.experiment_yaml = "name: in memory\n";
  write_recording(in_memory, tmp / "short_run", RecordingWriterOptions{});
  const Recording short_run = Recording::open(tmp / "short_run", SampleLoading::kStream);
  ASSERT_EQ(short_run.sample_count(), kShort);
  expect_same_samples(short_run.sample_source(), run.sample_source(), kShort);
}

// Repeated timestamps over several windows: each window is rebuilt from the rate the first one
// fitted, so the times come out evenly spaced across window boundaries as in a whole-log repair.
TEST(ImportStream, WindowedRepairRebuildsRepeatedTimesAcrossWindows) {
  constexpr std::size_t n = 3 * kTimestampWindow + 124;  // even: every window holds whole pairs
  Recording rec;
  std::vector<ImuSample> out;
  VectorSink sink(out);
  TimestampRepairStream repair(rec, sink);
  for (std::size_t i = 0; i < n; ++i) {
    ImuSample s;
    s.t_s = static_cast<double>(i / 2) * 0.01;  // 200 Hz logged with two decimals: pairs repeat
    repair.add_samples(&s, 1);
  }
  const TimestampRepair r = repair.finish();
  ASSERT_EQ(out.size(), n);
  EXPECT_NEAR(r.rate_hz, 200.0, 1e-6);
  EXPECT_EQ(r.gaps, 0u);
  EXPECT_NEAR(rec.header.info.output_rate_hz, 200.0, 1e-6);
  for (std::size_t i = 1; i < n; ++i) ASSERT_NEAR(out[i].t_s - out[i - 1].t_s, 0.005, 1e-6) << "sample " << i;
  ASSERT_FALSE(rec.events.empty());
  EXPECT_EQ(rec.events.front().level, "warning");
}

// A ULog of n accelerometer samples at kRateHz (sensor_accel, timestamp_sample 1000·i + 500 µs,
// x = i mod 4096 [m/s²], temperature 20 + (i mod 64)/4 [°C]) and n + 1 gyro samples half a period
// earlier (sensor_gyro, 1000·i µs, z = i [rad/s]: interpolated at the accelerometer times, z = i + ½
// up to rounding), interleaved in time order, with a dropout before accelerometer sample kGapAt; written
// message by message as PX4 does (logs_test.cpp's UlogWriter, to a file).
void write_ulog(const fs::path& file, std::size_t n) {
  std::FILE* f = std::fopen(file.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  const auto put = [&](const void* p, std::size_t size) { std::fwrite(p, 1, size, f); };
  const auto message = [&](char type, const std::string& body) {
    const auto size = static_cast<std::uint16_t>(body.size());
    put(&size, 2);
    put(&type, 1);
    put(body.data(), body.size());
  };
  const auto le = [](auto v) { return std::string(reinterpret_cast<const char*>(&v), sizeof v); };
  std::fwrite("ULog\x01\x12\x35\x01", 1, 8, f);
  put("\xe8\x03\0\0\0\0\0\0", 8);  // start time 1000 µs
  message('F', "sensor_accel:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;float y;"
               "float z;float temperature;");
  message('F', "sensor_gyro:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;float y;"
               "float z;float temperature;");
  message('A', std::string(1, '\0') + le(std::uint16_t{0}) + "sensor_accel");
  message('A', std::string(1, '\0') + le(std::uint16_t{1}) + "sensor_gyro");
  const auto sample = [&](std::uint16_t id, std::uint64_t t_us, float x, float z, float temperature) {
    message('D', le(id) + le(t_us) + le(t_us) + le(std::uint32_t{0x1234}) + le(x) + le(0.0f) + le(z) + le(temperature));
  };
  for (std::size_t i = 0; i <= n; ++i) {
    sample(1, 1000 * i, 0.0f, static_cast<float>(i), 20.0f);
    if (i == n) break;
    if (i == kGapAt) message('O', le(std::uint16_t{5}));
    sample(0, 1000 * i + 500, static_cast<float>(i % 4096), -9.8f, 20.0f + static_cast<float>(i % 64) / 4.0f);
  }
  std::fclose(f);
}

// A DataFlash log of n IMU messages of instance 0 at kRateHz (TimeUS 1000·i + 500, GyrZ = i mod 4096
// [rad/s], AccX = −i mod 4096 [m/s²], T = 20 + (i mod 64)/4 [°C]) and n/2 of instance 1 (skipped),
// no units (assumed SI), with corrupt bytes before instance-0 message kGapAt; written as ArduPilot
// does (logs_test.cpp's df_fmt, to a file).
void write_dataflash(const fs::path& file, std::size_t n) {
  std::FILE* f = std::fopen(file.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  const auto put = [&](const std::string& bytes) { std::fwrite(bytes.data(), 1, bytes.size(), f); };
  const auto le = [](auto v) { return std::string(reinterpret_cast<const char*>(&v), sizeof v); };
  const auto fmt = [](std::uint8_t type, std::uint8_t length, const std::string& name, const std::string& format,
                      const std::string& columns) {
    const auto fixed = [](const std::string& t, std::size_t size) { return (t + std::string(size, '\0')).substr(0, size); };
    return std::string("\xA3\x95\x80", 3) + static_cast<char>(type) + static_cast<char>(length) + fixed(name, 4) +
           fixed(format, 16) + fixed(columns, 64);
  };
  put(fmt(0x80, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"));
  put(fmt(162, 40, "IMU", "QBfffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,T"));
  const auto imu = [&](std::uint64_t t_us, std::uint8_t instance, float gz, float ax, float temp) {
    put(std::string("\xA3\x95\xA2", 3) + le(t_us) + static_cast<char>(instance) + le(0.0f) + le(0.0f) + le(gz) +
        le(ax) + le(0.0f) + le(-9.8f) + le(temp));
  };
  for (std::size_t i = 0; i < n; ++i) {
    if (i == kGapAt) put("corrupt");
    const auto v = static_cast<float>(i % 4096);
    imu(1000 * i + 500, 0, v, -v, 20.0f + static_cast<float>(i % 64) / 4.0f);
    if (i % 2 == 0) imu(1000 * i + 500, 1, 1.0f, 1.0f, 1.0f);
  }
  std::fclose(f);
}

// Imports `file` (as `format`) streamed into a run folder, in a child process, and checks: peak
// memory growth bounded, n samples at kRateHz with temperature, each as `expect_sample(i, sample)`
// wants, one gap (at kGapAt), and the same samples and info event as the in-memory import
// `in_memory` (the same reader into a vector), written.
void check_long_log(const fs::path& file, const std::string& format, std::size_t n,
                    const std::function<Recording()>& in_memory,
                    const std::function<void(std::size_t, const ImuSample&)>& expect_sample) {
  const fs::path run_dir = file.string() + ".run";
  const long growth_kib = import_in_child(file, run_dir, format, ImportOptions{});
  ASSERT_GE(growth_kib, 0) << "the streamed import failed";
  // Whole in memory, the file alone is about 90 MiB and the samples 92 MiB; streamed, the readers'
  // buffers, the timestamp window, a chunk and the writer's buffers.
  expect_bounded_growth(growth_kib);

  const Recording run = Recording::open(run_dir, SampleLoading::kStream);
  ASSERT_EQ(run.sample_count(), n);
  EXPECT_EQ(run.header.experiment_name, "import:" + format);
  EXPECT_TRUE(run.header.info.has_temperature);
  EXPECT_NEAR(run.header.info.output_rate_hz, kRateHz, 1e-9 * kRateHz);
  std::vector<ImuSample> chunk(4096);
  std::size_t gaps = 0;
  for (std::size_t i = 0; i < n; i += chunk.size()) {
    const std::size_t count = std::min(chunk.size(), n - i);
    run.sample_source().read(i, count, chunk.data());
    for (std::size_t k = 0; k < count; ++k) {
      const ImuSample& s = chunk[k];
      ASSERT_EQ(s.t_s, static_cast<double>(1000 * (i + k)) * 1e-6) << "sample " << i + k;
      ASSERT_NO_FATAL_FAILURE(expect_sample(i + k, s)) << "sample " << i + k;
      if (s.flags & kGapBefore) {
        EXPECT_EQ(i + k, kGapAt);
        ++gaps;
      }
    }
  }
  EXPECT_EQ(gaps, 1u);

  Recording memory = in_memory();
  ASSERT_EQ(memory.samples.size(), n);
  memory.experiment_yaml = "name: in memory\n";
  write_recording(memory, file.string() + ".memory_run", RecordingWriterOptions{});
  const Recording memory_run = Recording::open(file.string() + ".memory_run", SampleLoading::kStream);
  expect_same_samples(memory_run.sample_source(), run.sample_source(), n);
  ASSERT_FALSE(run.events.empty());
  EXPECT_EQ(memory.events.front().message, run.events.front().message);
}

TEST(ImportStream, LongUlogInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-ulog");
  constexpr std::size_t kLong = 1'000'000;
  write_ulog(tmp / "long.ulg", kLong);
  check_long_log(tmp / "long.ulg", "ulog", kLong, [&] { return import_ulog(tmp / "long.ulg"); },
                 [](std::size_t i, const ImuSample& s) {
                   ASSERT_EQ(s.accel_mps2.x(), static_cast<double>(i % 4096));
                   ASSERT_NEAR(s.gyro_radps.z(), static_cast<double>(i) + 0.5, 1e-6);  // interpolated
                   ASSERT_EQ(s.temperature_c, 20.0 + static_cast<double>(i % 64) / 4.0);
                 });
}

TEST(ImportStream, LongDataflashInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-dataflash");
  constexpr std::size_t kLong = 1'000'000;
  write_dataflash(tmp / "long.BIN", kLong);
  check_long_log(tmp / "long.BIN", "dataflash", kLong, [&] { return import_dataflash(tmp / "long.BIN"); },
                 [](std::size_t i, const ImuSample& s) {
                   ASSERT_EQ(s.gyro_radps.z(), static_cast<double>(i % 4096));
                   ASSERT_EQ(s.accel_mps2.x(), -static_cast<double>(i % 4096));
                   ASSERT_EQ(s.temperature_c, 20.0 + static_cast<double>(i % 64) / 4.0);
                 });
}

}  // namespace
