// Streaming import: a long CSV, ULog, DataFlash log, ROS 1 bag, rosbag2 (SQLite3), imucal,
// MPU-6050 or IMU-TK log goes into a run folder a chunk at a time,
// with peak memory bounded independently of its length (measured in a child process from
// /proc/self/status VmHWM), and with the same samples as the in-memory import; the windowed
// timestamp repair flags a gap at a window boundary as a whole-log repair does.
#include <stend/io/formats.hpp>
#include <stend/io/importers.hpp>
#include <stend/io/logs.hpp>
#include <stend/io/rosbag.hpp>
#include <stend/io/sample_sink.hpp>
#include <stend/io/timestamps.hpp>
#include <stend/testing/files.hpp>

#include <gtest/gtest.h>
#include <matio.h>

#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <sqlite3.h>
#include <topic_tools/shape_shifter.h>

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
long import_in_child(const Inputs& log, const fs::path& run, const std::string& format = "csv",
                     const ImportOptions& options = csv_options(), bool background = false) {
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
      if (background) sink.write_in_background();
      import_dataset(log, format, rec, sink, options);
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

  const long growth_kib = import_in_child({tmp / "long.csv"}, tmp / "long_run");
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

// `stend import` writes the run store on a thread of its own (RunSink::write_in_background): the
// same samples as written on the importer's thread, in bounded memory; a sink given up mid-way
// (a failed import) stops its thread without writing what waits.
TEST(ImportStream, WrittenInTheBackgroundTheRunHoldsTheSamplesOfAForegroundImport) {
  TempDir tmp("import-background");
  constexpr std::size_t kSamples = 300'000;  // many batches of RunSink::kBackgroundBatch
  write_log(tmp / "log.csv", kSamples);
  ASSERT_GE(import_in_child({tmp / "log.csv"}, tmp / "fg"), 0) << "the foreground import failed";
  const long growth_kib = import_in_child({tmp / "log.csv"}, tmp / "bg", "csv", csv_options(), true);
  ASSERT_GE(growth_kib, 0) << "the background import failed";
  expect_bounded_growth(growth_kib);
  const Recording fg = Recording::open(tmp / "fg", SampleLoading::kStream);
  const Recording bg = Recording::open(tmp / "bg", SampleLoading::kStream);
  ASSERT_EQ(fg.sample_count(), kSamples);
  ASSERT_EQ(bg.sample_count(), kSamples);
  expect_same_samples(fg.sample_source(), bg.sample_source(), kSamples);
  EXPECT_EQ(bg.events.size(), fg.events.size());

  Recording rec = open_dataset({tmp / "log.csv"}, "csv", csv_options());
  std::vector<ImuSample> all(kSamples);
  rec.sample_source().read(0, kSamples, all.data());
  {
    RunSink given_up(rec, tmp / "given_up", "name: x\n");
    given_up.write_in_background();
    for (std::size_t i = 0; i < kSamples; i += 1000) given_up.add_samples(all.data() + i, 1000);
    given_up.abandon();
    EXPECT_EQ(given_up.sample_count(), kSamples);  // handed over, not all written
  }
  std::error_code ec;
  fs::remove_all(tmp / "given_up", ec);
  EXPECT_FALSE(ec) << ec.message();
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

// Imports `files` (as `format`, with `options`) streamed into a run folder, in a child process, and
// checks: peak memory growth bounded, n samples at kRateHz, with temperature and one gap (at kGapAt)
// as `traits` say, each sample (time included) as `expect_sample(i, sample)` wants, and the same samples and info event as the in-memory import
// `in_memory` (the same reader into a vector), written.
// What a long log holds besides its samples.
struct LongLogTraits {
  bool temperature = true;  // has a temperature
  bool gap = true;          // one gap, at kGapAt (else none)
};

void check_long_log(const Inputs& files, const std::string& format, std::size_t n,
                    const std::function<Recording()>& in_memory,
                    const std::function<void(std::size_t, const ImuSample&)>& expect_sample,
                    const ImportOptions& options = {}, const LongLogTraits& traits = {}) {
  const fs::path& file = files.front();
  const fs::path run_dir = file.string() + ".run";
  ImportOptions patterns = options;
  patterns.set("accept_implausible", "true");  // the long logs' values are patterns, not a sensor at rest
  const long growth_kib = import_in_child(files, run_dir, format, patterns);
  ASSERT_GE(growth_kib, 0) << "the streamed import failed";
  // Whole in memory, the file alone is about 90 MiB and the samples 92 MiB; streamed, the readers'
  // buffers, the timestamp window, a chunk and the writer's buffers.
  expect_bounded_growth(growth_kib);

  const Recording run = Recording::open(run_dir, SampleLoading::kStream);
  ASSERT_EQ(run.sample_count(), n);
  EXPECT_EQ(run.header.experiment_name.rfind("import:", 0), 0u) << run.header.experiment_name;
  EXPECT_EQ(run.header.info.has_temperature, traits.temperature);
  EXPECT_NEAR(run.header.info.output_rate_hz, kRateHz, 1e-9 * kRateHz);
  std::vector<ImuSample> chunk(4096);
  std::size_t gaps = 0;
  for (std::size_t i = 0; i < n; i += chunk.size()) {
    const std::size_t count = std::min(chunk.size(), n - i);
    run.sample_source().read(i, count, chunk.data());
    for (std::size_t k = 0; k < count; ++k) {
      const ImuSample& s = chunk[k];
      ASSERT_NO_FATAL_FAILURE(expect_sample(i + k, s)) << "sample " << i + k;
      if (s.flags & kGapBefore) {
        EXPECT_EQ(i + k, kGapAt);
        ++gaps;
      }
    }
  }
  EXPECT_EQ(gaps, traits.gap ? 1u : 0u);

  Recording memory = in_memory();
  ASSERT_EQ(memory.samples.size(), n);
  EXPECT_EQ(memory.header.experiment_name, run.header.experiment_name);
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
  check_long_log({tmp / "long.ulg"}, "ulog", kLong, [&] { return import_ulog(tmp / "long.ulg"); },
                 [](std::size_t i, const ImuSample& s) {
                   ASSERT_EQ(s.t_s, static_cast<double>(1000 * i) * 1e-6);
                   ASSERT_EQ(s.accel_mps2.x(), static_cast<double>(i % 4096));
                   ASSERT_NEAR(s.gyro_radps.z(), static_cast<double>(i) + 0.5, 1e-6);  // interpolated
                   ASSERT_EQ(s.temperature_c, 20.0 + static_cast<double>(i % 64) / 4.0);
                 });
}

TEST(ImportStream, LongDataflashInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-dataflash");
  constexpr std::size_t kLong = 1'000'000;
  write_dataflash(tmp / "long.BIN", kLong);
  check_long_log({tmp / "long.BIN"}, "dataflash", kLong, [&] { return import_dataflash(tmp / "long.BIN"); },
                 [](std::size_t i, const ImuSample& s) {
                   ASSERT_EQ(s.t_s, static_cast<double>(1000 * i) * 1e-6);
                   ASSERT_EQ(s.gyro_radps.z(), static_cast<double>(i % 4096));
                   ASSERT_EQ(s.accel_mps2.x(), -static_cast<double>(i % 4096));
                   ASSERT_EQ(s.temperature_c, 20.0 + static_cast<double>(i % 64) / 4.0);
                 });
}

// ---------------------------------------------------------------------------------------------
// ROS bags: n Imu messages at kRateHz, header stamps T0 + k ms where k = i, and i + 3 from kGapAt on
// (three messages lost: a gap by the timestamps); accel x = i mod 4096 [m/s²], gyro z = −(i mod 512)
// [rad/s], frame_id "imu"; a Temperature message on /temp every 1000 Imu messages (20 + k/1000 °C,
// stamped with the Imu message it precedes, so sample i holds 20 + ⌊k/1000⌋).

constexpr std::int64_t kBagT0_ns = 1'700'000'000'000'000'000;
constexpr std::size_t kBagMessages = 300'000;

std::int64_t bag_stamp_ns(std::size_t i) {
  const auto k = static_cast<std::int64_t>(i < kGapAt ? i : i + 3);
  return kBagT0_ns + k * 1'000'000;
}
double bag_temperature(std::size_t i) {
  return 20.0 + static_cast<double>((i < kGapAt ? i : i + 3) / 1000);
}
void expect_bag_sample(std::size_t i, const ImuSample& s) {
  ASSERT_EQ(s.t_s, 1e-9 * static_cast<double>(bag_stamp_ns(i) - kBagT0_ns));
  ASSERT_EQ(s.accel_mps2.x(), static_cast<double>(i % 4096));
  ASSERT_EQ(s.gyro_radps.z(), -static_cast<double>(i % 512));
  ASSERT_EQ(s.temperature_c, bag_temperature(i));
}

// The fields of sensor_msgs/Imu after the header, as bag_stamp_ns's comment gives them.
std::vector<double> imu_fields(std::size_t i) {
  std::vector<double> v(4 + 9 + 3 + 9 + 3 + 9, 0.0);
  v[3] = 1.0;                                 // orientation w
  v[13 + 2] = -static_cast<double>(i % 512);  // angular_velocity z
  v[25] = static_cast<double>(i % 4096);      // linear_acceleration x
  return v;
}

ImportOptions bag_options() {
  ImportOptions o;
  o.set("temperature_topic", "/temp");
  return o;
}

// Written by librosbag's own writer (rosbag::Bag; messages through topic_tools::ShapeShifter, as
// rosbag_test.cpp does), lz4 chunks.
void write_long_ros1_bag(const fs::path& file, std::size_t n) {
  rosbag::Bag bag(file.string(), rosbag::bagmode::Write);
  bag.setCompression(rosbag::compression::LZ4);
  const auto message = [](const char* md5, const char* type, std::vector<std::uint8_t>& bytes) {
    topic_tools::ShapeShifter s;
    s.morph(md5, type, "(definition not needed by the reader)", "");
    ros::serialization::IStream in(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
    s.read(in);
    return s;
  };
  const auto header = [](ros::serialization::OStream& o, std::int64_t stamp_ns) {
    o.next(std::uint32_t{0});
    o.next(static_cast<std::uint32_t>(stamp_ns / 1'000'000'000));
    o.next(static_cast<std::uint32_t>(stamp_ns % 1'000'000'000));
    o.next(std::string("imu"));
  };
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t stamp = bag_stamp_ns(i);
    ros::Time record;
    record.fromNSec(static_cast<std::uint64_t>(stamp));
    if (i == 0 || bag_temperature(i) != bag_temperature(i - 1)) {
      std::vector<std::uint8_t> b(4 * 3 + 4 + 3 + 16);
      ros::serialization::OStream o(b.data(), static_cast<std::uint32_t>(b.size()));
      header(o, stamp);
      o.next(bag_temperature(i));
      o.next(0.0);
      bag.write("/temp", record, message("ff71b307acdbe7c871a5a6d7ed359100", "sensor_msgs/Temperature", b));
    }
    std::vector<std::uint8_t> b(4 * 3 + 4 + 3 + 8 * 37);
    ros::serialization::OStream o(b.data(), static_cast<std::uint32_t>(b.size()));
    header(o, stamp);
    for (double v : imu_fields(i)) o.next(v);
    bag.write("/imu", record, message("6a62c6daae103f4ff57a132d6f95cec2", "sensor_msgs/Imu", b));
  }
  bag.close();
}

// CDR (XCDR1, little endian): encapsulation 00 01 00 00, then the header (int32 sec, uint32
// nanosec, string "imu" as uint32 length with NUL and bytes) and float64s aligned to 8 from the
// end of the encapsulation (16 bytes of header: no padding).
std::vector<std::uint8_t> cdr_message(std::int64_t stamp_ns, const std::vector<double>& fields) {
  std::vector<std::uint8_t> b = {0x00, 0x01, 0x00, 0x00};
  const auto put = [&](const auto& v) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    b.insert(b.end(), p, p + sizeof v);
  };
  put(static_cast<std::int32_t>(stamp_ns / 1'000'000'000));
  put(static_cast<std::uint32_t>(stamp_ns % 1'000'000'000));
  put(std::uint32_t{4});
  b.insert(b.end(), {'i', 'm', 'u', '\0'});
  for (double v : fields) put(v);
  return b;
}

// A rosbag2 SQLite3 storage file in rosbag2's schema (as io/tests/rosbag2_writer/write_db3.py
// builds it), written with SQLite3 itself; each message received at its stamp.
void write_long_db3(const fs::path& file, std::size_t n) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const char* schema = R"(
    PRAGMA journal_mode = OFF; PRAGMA synchronous = OFF;
    CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
    CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
    CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                        serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
    CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
                          data BLOB NOT NULL);
    CREATE INDEX timestamp_idx ON messages (timestamp ASC);
    INSERT INTO schema VALUES (3, 'humble');
    INSERT INTO topics VALUES (1, '/imu', 'sensor_msgs/msg/Imu', 'cdr', '');
    INSERT INTO topics VALUES (2, '/temp', 'sensor_msgs/msg/Temperature', 'cdr', '');
    BEGIN;)";
  ASSERT_EQ(sqlite3_exec(db, schema, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  sqlite3_stmt* insert = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", -1, &insert,
                               nullptr),
            SQLITE_OK);
  const auto add = [&](int topic, std::int64_t t_ns, const std::vector<std::uint8_t>& data) {
    sqlite3_bind_int(insert, 1, topic);
    sqlite3_bind_int64(insert, 2, t_ns);
    sqlite3_bind_blob(insert, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(insert), SQLITE_DONE);
    sqlite3_reset(insert);
  };
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t stamp = bag_stamp_ns(i);
    if (i == 0 || bag_temperature(i) != bag_temperature(i - 1)) add(2, stamp, cdr_message(stamp, {bag_temperature(i), 0.0}));
    add(1, stamp, cdr_message(stamp, imu_fields(i)));
  }
  sqlite3_finalize(insert);
  ASSERT_EQ(sqlite3_exec(db, "COMMIT;", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
}

TEST(ImportStream, LongRos1BagInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-rosbag1");
  write_long_ros1_bag(tmp / "long.bag", kBagMessages);
  const RosbagOptions o{.topic = {}, .temperature_topic = "/temp", .identity = {}, .gravity_mps2 = 0.0};
  check_long_log({tmp / "long.bag"}, "rosbag1", kBagMessages, [&] { return import_rosbag1(tmp / "long.bag", o); },
                 expect_bag_sample, bag_options());
}

TEST(ImportStream, LongRosbag2SqliteInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-rosbag2");
  ASSERT_NO_FATAL_FAILURE(write_long_db3(tmp / "long.db3", kBagMessages));
  const RosbagOptions o{.topic = {}, .temperature_topic = "/temp", .identity = {}, .gravity_mps2 = 0.0};
  check_long_log({tmp / "long.db3"}, "rosbag2", kBagMessages, [&] { return import_rosbag2(tmp / "long.db3", o); },
                 expect_bag_sample, bag_options());
}

// ---------------------------------------------------------------------------------------------
// Text formats, printed: n samples at kRateHz; sample i has the index k = i, and i + 3 from kGapAt
// on where the format can show a gap.

constexpr std::size_t kTextLines = 1'000'000;

std::size_t text_index(std::size_t i) { return i < kGapAt ? i : i + 3; }

// imucal: the parts grouped as imucal writes them (x_p: the second half of the session first, then
// x_a: the first half), counts acc_x = k mod 4096, gyr_z = −(k mod 512); the index jumps by 4 at kGapAt.
void write_imucal(const fs::path& file, std::size_t n) {
  std::FILE* f = std::fopen(file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\n", f);
  const auto rows = [&](const char* part, std::size_t from, std::size_t to) {
    for (std::size_t i = from; i < to; ++i) {
      const std::size_t k = text_index(i);
      std::fprintf(f, "%s,%zu,%zu.0,0.0,2048.0,0.0,0.0,-%zu.0\n", part, k, k % 4096, k % 512);
    }
  };
  rows("x_p", n / 2, n);
  rows("x_a", 0, n / 2);
  std::fclose(f);
}

// MPU-6050 multi-position: "key,value" header (Fs 1000 Hz), counts ax = i mod 4096, gz = −(i mod 512).
void write_mpu6050(const fs::path& file, std::size_t n) {
  std::FILE* f = std::fopen(file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("Fs,1000\nLogging Type,1\nInitialization time,5\nWaiting time,10\nax,ay,az,gx,gy,gz\n", f);
  for (std::size_t i = 0; i < n; ++i) std::fprintf(f, "%zu,0,16384,0,0,-%zu\n", i % 4096, i % 512);
  std::fclose(f);
}

// IMU-TK: the accelerometer at t = k ms (x = k mod 4096 [m/s²]; three samples lost at kGapAt) and the
// gyro on its own clock half a period later, t = (j + ½) ms for j = −1 … n + 3, z = j [rad/s]: at the
// accelerometer times it interpolates to z = k − ½.
void write_imutk(const fs::path& acc, const fs::path& gyro, std::size_t n) {
  std::FILE* a = std::fopen(acc.c_str(), "w");
  std::FILE* g = std::fopen(gyro.c_str(), "w");
  ASSERT_TRUE(a && g);
  for (std::size_t i = 0; i < n; ++i) std::fprintf(a, "%.6f %zu 0 9.81\n", static_cast<double>(text_index(i)) * 1e-3, text_index(i) % 4096);
  for (long j = -1; j <= static_cast<long>(n) + 3; ++j) std::fprintf(g, "%.6f 0 0 %ld\n", (static_cast<double>(j) + 0.5) * 1e-3, j);
  std::fclose(a);
  std::fclose(g);
}

TEST(ImportStream, LongImucalSessionInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-imucal");
  ASSERT_NO_FATAL_FAILURE(write_imucal(tmp / "long.csv", kTextLines));
  ImportOptions o;
  o.set("rate_hz", "1000");
  ImucalOptions m;
  m.rate_hz = kRateHz;
  check_long_log({tmp / "long.csv"}, "imucal", kTextLines, [&] { return import_imucal_session(tmp / "long.csv", m); },
                 [](std::size_t i, const ImuSample& s) {
                   const std::size_t k = text_index(i);
                   ASSERT_EQ(s.t_s, static_cast<double>(k) / kRateHz);
                   ASSERT_EQ(s.accel_counts[0], static_cast<std::int32_t>(k % 4096));
                   ASSERT_EQ(s.gyro_counts[2], -static_cast<std::int32_t>(k % 512));
                 },
                 o, {.temperature = false, .gap = true});
}

TEST(ImportStream, LongMpu6050SessionInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-mpu6050");
  ASSERT_NO_FATAL_FAILURE(write_mpu6050(tmp / "long.csv", kTextLines));
  check_long_log({tmp / "long.csv"}, "mpu6050_multipos", kTextLines,
                 [&] { return import_mpu6050_multipos(tmp / "long.csv"); },
                 [](std::size_t i, const ImuSample& s) {
                   ASSERT_EQ(s.t_s, static_cast<double>(i) / kRateHz);
                   ASSERT_EQ(s.accel_counts[0], static_cast<std::int32_t>(i % 4096));
                   ASSERT_EQ(s.gyro_counts[2], -static_cast<std::int32_t>(i % 512));
                 },
                 {}, {.temperature = false, .gap = false});
}

TEST(ImportStream, LongImuTkFilesInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  TempDir tmp("import-stream-imutk");
  ASSERT_NO_FATAL_FAILURE(write_imutk(tmp / "acc.txt", tmp / "gyro.txt", kTextLines));
  check_long_log({tmp / "acc.txt", tmp / "gyro.txt"}, "imutk", kTextLines,
                 [&] { return import_imutk(tmp / "acc.txt", tmp / "gyro.txt"); },
                 [](std::size_t i, const ImuSample& s) {
                   const std::size_t k = text_index(i);
                   ASSERT_EQ(s.t_s, static_cast<double>(k) / kRateHz);
                   ASSERT_EQ(s.accel_mps2.x(), static_cast<double>(k % 4096));
                   ASSERT_NEAR(s.gyro_radps.z(), static_cast<double>(k) - 0.5, 1e-6);  // interpolated
                 },
                 {}, {.temperature = false, .gap = true});
}

// A MATLAB file of n samples at kRateHz (the gap at kGapAt): t, acc and gyro (N×3 doubles),
// temp, acc_counts (N×3 int16); top-level, or the fields of a struct `root`; v5 compressed or
// v7.3 (HDF5).
void write_mat(const fs::path& file, std::size_t n, mat_ft version, bool in_struct) {
  std::vector<double> t(n), acc(3 * n), gyro(3 * n), temp(n);
  std::vector<std::int16_t> counts(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = static_cast<double>(i + (i >= kGapAt ? 3 : 0)) / kRateHz;
    temp[i] = 25.0 + static_cast<double>(i % 100) * 0.01;
    for (std::size_t c = 0; c < 3; ++c) {
      acc[i + c * n] = static_cast<double>(i % 4096) * static_cast<double>(c + 1) * 1e-3;
      gyro[i + c * n] = -static_cast<double>(i % 512) * static_cast<double>(c + 1) * 1e-4;
      counts[i + c * n] = static_cast<std::int16_t>(static_cast<int>(i % 4096) - static_cast<int>(c));
    }
  }
  mat_t* mat = Mat_CreateVer(file.c_str(), nullptr, version);
  ASSERT_NE(mat, nullptr);
  std::size_t vec[2] = {n, 1}, tri[2] = {n, 3};
  matvar_t* vars[] = {Mat_VarCreate("t", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, vec, t.data(), 0),
                      Mat_VarCreate("acc", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, tri, acc.data(), 0),
                      Mat_VarCreate("gyro", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, tri, gyro.data(), 0),
                      Mat_VarCreate("temp", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, vec, temp.data(), 0),
                      Mat_VarCreate("acc_counts", MAT_C_INT16, MAT_T_INT16, 2, tri, counts.data(), 0)};
  if (in_struct) {
    const char* fields[] = {"t", "acc", "gyro", "temp", "acc_counts"};
    std::size_t one[2] = {1, 1};
    matvar_t* root = Mat_VarCreateStruct("root", 2, one, fields, 5);
    for (matvar_t* v : vars) Mat_VarSetStructFieldByName(root, v->name, 0, v);
    ASSERT_EQ(Mat_VarWrite(mat, root, MAT_COMPRESSION_ZLIB), 0);
    Mat_VarFree(root);
  } else {
    for (matvar_t* v : vars) {
      ASSERT_EQ(Mat_VarWrite(mat, v, MAT_COMPRESSION_ZLIB), 0);
      Mat_VarFree(v);
    }
  }
  Mat_Close(mat);
}

TEST(ImportStream, LongMatFilesInBoundedMemoryWithTheSamplesOfAnInMemoryImport) {
  struct Case {
    const char* name;
    mat_ft version;
    bool in_struct;
  };
  for (const Case& c : {Case{"v5 compressed", MAT_FT_MAT5, false}, Case{"v5 compressed struct", MAT_FT_MAT5, true},
                        Case{"v7.3", MAT_FT_MAT73, false}}) {
    SCOPED_TRACE(c.name);
    TempDir tmp("import-stream-mat");
    ASSERT_NO_FATAL_FAILURE(write_mat(tmp / "long.mat", kTextLines, c.version, c.in_struct));
    check_long_log({tmp / "long.mat"}, "mat", kTextLines, [&] { return import_mat(tmp / "long.mat"); },
                   [](std::size_t i, const ImuSample& s) {
                     ASSERT_EQ(s.t_s, static_cast<double>(i + (i >= kGapAt ? 3 : 0)) / kRateHz);
                     ASSERT_EQ(s.accel_mps2.y(), static_cast<double>(i % 4096) * 2.0 * 1e-3);
                     ASSERT_EQ(s.gyro_radps.z(), -static_cast<double>(i % 512) * 3.0 * 1e-4);
                     ASSERT_EQ(s.accel_counts[2], static_cast<std::int32_t>(i % 4096) - 2);
                     ASSERT_EQ(s.temperature_c, 25.0 + static_cast<double>(i % 100) * 0.01);
                   });
  }
}

// A damaged MAT 7.3 file (HDF5 read by libhdf5 through matio) is an import error naming the file,
// with nothing of libhdf5's own error stack on stderr ("HDF5-DIAG: Error detected …", which libhdf5
// prints by default): its header without the HDF5 signature after it, or the file cut short.
TEST(ImportStream, DamagedMat73FileIsAnErrorWithoutLibhdf5sOutput) {
  TempDir tmp("import-stream-mat73");
  const fs::path good = tmp / "good.mat";
  ASSERT_NO_FATAL_FAILURE(write_mat(good, 300, MAT_FT_MAT73, false));
  const std::string bytes = stend::testing::read_text(good);
  std::string no_signature = bytes;
  no_signature[513] = 'X';  // "\x89HDF" at byte 512
  stend::testing::write_text(tmp / "no_signature.mat", no_signature);
  stend::testing::write_text(tmp / "cut.mat", bytes.substr(0, bytes.size() * 6 / 10));
  for (const char* name : {"no_signature.mat", "cut.mat"}) {
    SCOPED_TRACE(name);
    std::string msg;
    ::testing::internal::CaptureStderr();
    try {
      import_mat(tmp / name);
    } catch (const std::exception& e) {
      msg = e.what();
    }
    const std::string err = ::testing::internal::GetCapturedStderr();
    EXPECT_NE(msg.find(name), std::string::npos) << msg;
    EXPECT_EQ(err.find("HDF5"), std::string::npos) << err;
  }
}

}  // namespace

// The element walk that refuses damaged .mat files before matio reads them (io/src/mat.cpp) checks
// every data subelement's tag: valid files with the other kinds of data subelement — a complex
// matrix (real and imaginary parts), a sparse one (row and column indices, values), a logical,
// a char array, small data elements packed into their tags — still import, plain and compressed.
TEST(ImportStream, MatFilesWithComplexSparseLogicalAndCharVariablesImport) {
  for (const matio_compression z : {MAT_COMPRESSION_NONE, MAT_COMPRESSION_ZLIB}) {
    SCOPED_TRACE(z == MAT_COMPRESSION_NONE ? "plain" : "compressed");
    TempDir tmp("import-stream-mat-kinds");
    const fs::path file = tmp / "kinds.mat";
    ASSERT_NO_FATAL_FAILURE(write_mat(file, 300, MAT_FT_MAT5, false));
    mat_t* mat = Mat_Open(file.c_str(), MAT_ACC_RDWR);
    ASSERT_NE(mat, nullptr);
    std::size_t one[2] = {1, 1}, row[2] = {1, 5}, sq[2] = {4, 4};
    double re[1] = {1.5}, im[1] = {-2.5};
    mat_complex_split_t c{re, im};
    double values[2] = {5.0, 6.0};
    mat_uint32_t ir[2] = {0, 2}, jc[5] = {0, 0, 1, 1, 2};
    mat_sparse_t sp{};
    sp.nzmax = 2, sp.ir = ir, sp.nir = 2, sp.jc = jc, sp.njc = 5, sp.ndata = 2, sp.data = values;
    std::uint8_t flags[5] = {1, 0, 1, 1, 0};
    char text[] = "hello";
    std::size_t two[2] = {1, 2};
    matvar_t* vars[] = {Mat_VarCreate("z", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, one, &c, MAT_F_COMPLEX),
                        Mat_VarCreate("sp", MAT_C_SPARSE, MAT_T_DOUBLE, 2, sq, &sp, MAT_F_DONT_COPY_DATA),
                        Mat_VarCreate("ok", MAT_C_UINT8, MAT_T_UINT8, 2, row, flags, MAT_F_LOGICAL),
                        Mat_VarCreate("note", MAT_C_CHAR, MAT_T_UTF8, 2, row, text, 0),
                        Mat_VarCreate("ab", MAT_C_CHAR, MAT_T_UINT8, 2, two, text, 0),
                        Mat_VarCreate("w", MAT_C_INT16, MAT_T_INT16, 2, one, jc, 0),
                        Mat_VarCreate("k", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, one, re, 0)};
    for (matvar_t* v : vars) {
      ASSERT_NE(v, nullptr);
      ASSERT_EQ(Mat_VarWrite(mat, v, z), 0);
      Mat_VarFree(v);
    }
    Mat_Close(mat);
    const Recording r = import_mat(file);
    ASSERT_EQ(r.samples.size(), 300u);
    EXPECT_EQ(r.samples[7].accel_mps2.y(), 7.0 * 2.0 * 1e-3);
  }
}
