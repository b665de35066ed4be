// Log importers: PX4 ULog and ArduPilot DataFlash on real files from the formats' own writers
// (../shared/data/logs, skipped when absent), on small logs this test writes byte by byte (nested
// formats, padding, dropouts, corrupt definitions) and truncated at many offsets; EuRoC CSV in the
// dataset's own layout.
//
// The expected values from the real files were decoded independently of the importers with
// Python's struct module from the raw bytes (message layouts as the files' own FMT / F messages
// give them), e.g. for the ULog: struct.unpack_from('<Q3fIi3fIB', data) on the first
// sensor_combined D message, and '<QQI4f' on sensor_accel; for the DataFlash log
// struct.unpack('<QBffffffIIfBBHH', ...) on the IMU messages.
#include <stend/io/logs.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::read_text;
using stend::testing::shared_data;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

const fs::path kUlog = shared_data("logs/ulog/sample_log_small.ulg");
const fs::path kDataflash = shared_data("logs/dataflash/ardusub_small.BIN");

// The ImportError an import throws ("(no ImportError)" when it returns).
struct Caught {
  std::string what = "(no ImportError)";
  std::optional<std::uint64_t> offset;
};
Caught error_of(const std::function<void()>& fn) {
  Caught c;
  try {
    fn();
  } catch (const ImportError& e) {
    c.what = e.what();
    c.offset = e.offset();
  }
  return c;
}

double mean_accel_norm(const Recording& r) {
  double s = 0.0;
  for (const auto& x : r.samples) s += x.accel_mps2.norm();
  return s / static_cast<double>(r.samples.size());
}

double max_gyro_norm(const Recording& r) {
  double m = 0.0;
  for (const auto& x : r.samples) m = std::max(m, x.gyro_radps.norm());
  return m;
}

std::size_t gaps(const Recording& r) {
  std::size_t n = 0;
  for (const auto& x : r.samples) n += (x.flags & kGapBefore) ? 1 : 0;
  return n;
}

bool strictly_increasing(const Recording& r) {
  for (std::size_t i = 1; i < r.samples.size(); ++i) {
    if (!(r.samples[i].t_s > r.samples[i - 1].t_s)) return false;
  }
  return true;
}

// Little-endian bytes of a value.
template <class T>
std::string le(T v) {
  std::string s(sizeof(T), '\0');
  std::memcpy(s.data(), &v, sizeof(T));
  return s;
}

// A ULog written message by message.
struct UlogWriter {
  std::string bytes = std::string("ULog\x01\x12\x35\x01", 8) + le<std::uint64_t>(1000);
  std::size_t message(char type, const std::string& body) {
    const std::size_t at = bytes.size();
    bytes += le<std::uint16_t>(static_cast<std::uint16_t>(body.size())) + type + body;
    return at;
  }
  std::size_t format(const std::string& def) { return message('F', def); }
  void subscribe(std::uint8_t instance, std::uint16_t id, const std::string& topic) {
    message('A', std::string(1, static_cast<char>(instance)) + le(id) + topic);
  }
  void data(std::uint16_t id, const std::string& payload) { message('D', le(id) + payload); }
};

std::string vec3(float x, float y, float z) { return le(x) + le(y) + le(z); }

}  // namespace

// =============================================================================================
// PX4 ULog

TEST(ImportUlog, RealLogTakesSensorCombinedWhenSensorAccelIsSparse) {
  STEND_SKIP_IF_ABSENT(kUlog);
  ASSERT_TRUE(looks_like_ulog(kUlog));
  const Recording r = import_ulog(kUlog);
  // 1298 sensor_combined messages; sensor_accel / sensor_gyro hold 6 per instance.
  ASSERT_EQ(r.samples.size(), 1298u);
  EXPECT_EQ(r.header.experiment_name, "import:ulog");
  EXPECT_EQ(r.header.experiment_file, kUlog.string());
  EXPECT_EQ(r.header.clock, "wall");
  EXPECT_EQ(r.header.identity.vendor, "PX4");
  EXPECT_EQ(r.header.identity.model, "CUBEPILOT_CUBEORANGE");
  // sensor_combined has no temperature: sensor_selection names accel device 0x0025000A, the
  // device of sensor_accel instance 0 (first temperature 40.0254 °C at 21.31 s, held before it).
  EXPECT_TRUE(r.header.info.has_temperature);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].temperature_c), 40.02537155151367f);
  EXPECT_NE(r.header.identity.who_am_i.find("accel device_id 0x0025000A"), std::string::npos)
      << r.header.identity.who_am_i;
  EXPECT_NE(r.events[0].message.find("temperature interpolated from sensor_accel instance 0"), std::string::npos);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_NE(r.events[0].message.find("sensor_combined instance 0"), std::string::npos) << r.events[0].message;
  EXPECT_NE(r.events[0].message.find("sensor_accel instance 0: 6"), std::string::npos) << r.events[0].message;
  // First record: timestamp 20326716 us, gyro_rad, accelerometer_m_s2 (relative timestamp 0).
  EXPECT_EQ(r.samples[0].t_s, 0.0);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].gyro_radps.x()), 0.002968383487313986f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].gyro_radps.y()), 0.003646239871159196f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].accel_mps2.x()), 0.0012458056444302201f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].accel_mps2.y()), -0.15434497594833374f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].accel_mps2.z()), -9.63424301147461f);
  // Second at 20488019 us (a 161 ms jump, the one gap), last at 26822868 us.
  EXPECT_NEAR(r.samples[1].t_s, (20488019 - 20326716) * 1e-6, 1e-12);
  EXPECT_NEAR(r.samples.back().t_s, (26822868 - 20326716) * 1e-6, 1e-12);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples.back().accel_mps2.z()), -9.566828727722168f);
  EXPECT_TRUE(r.samples[1].flags & kGapBefore);
  EXPECT_EQ(gaps(r), 1u);
  EXPECT_TRUE(strictly_increasing(r));
  EXPECT_NEAR(r.header.info.output_rate_hz, 1e6 / 4888.0, 0.01);  // median interval 4888 us
  // Units: on the ground before take-off |a| ≈ g in m/s², rates a few mrad/s (rad/s, not deg/s).
  EXPECT_NEAR(mean_accel_norm(r), 9.7, 0.3);
  EXPECT_LT(max_gyro_norm(r), 1.0);
}

TEST(ImportUlog, RealLogSensorAccelGyroByInstanceWithTemperature) {
  STEND_SKIP_IF_ABSENT(kUlog);
  UlogOptions opt;
  opt.source = UlogSource::kSensorAccelGyro;
  opt.instance = 1;
  const Recording r = import_ulog(kUlog, opt);
  ASSERT_EQ(r.samples.size(), 6u);
  EXPECT_TRUE(r.header.info.has_temperature);
  // sensor_accel instance 1, first message: timestamp_sample 21310770, device_id 0x00380022.
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].accel_mps2.x()), 0.35673606395721436f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].accel_mps2.z()), -9.912714004516602f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].temperature_c), 28.246023178100586f);
  // sensor_gyro instance 1 has the same timestamp_sample: matched, not interpolated.
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].gyro_radps.x()), 0.017656758427619934f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].gyro_radps.z()), -0.006178534124046564f);
  EXPECT_NE(r.header.identity.who_am_i.find("accel device_id 0x00380022"), std::string::npos)
      << r.header.identity.who_am_i;
  EXPECT_NE(r.events[0].message.find("gyro logged at the accelerometer times"), std::string::npos);

  opt.instance = -1;  // all three hold 6: the first is taken
  const Recording r0 = import_ulog(kUlog, opt);
  EXPECT_FLOAT_EQ(static_cast<float>(r0.samples[0].temperature_c), 40.02537155151367f);
  EXPECT_FLOAT_EQ(static_cast<float>(r0.samples[0].accel_mps2.x()), 0.6821298003196716f);

  opt.instance = 7;
  const Caught e = error_of([&] { import_ulog(kUlog, opt); });
  EXPECT_NE(e.what.find("no IMU data"), std::string::npos) << e.what;
  EXPECT_NE(e.what.find("instance 7"), std::string::npos) << e.what;
}

TEST(ImportUlog, DetectionByContent) {
  STEND_SKIP_IF_ABSENT(kUlog);
  STEND_SKIP_IF_ABSENT(kDataflash);
  EXPECT_TRUE(looks_like_ulog(kUlog));
  EXPECT_FALSE(looks_like_ulog(kDataflash));
  EXPECT_FALSE(looks_like_dataflash(kUlog));
  EXPECT_FALSE(looks_like_euroc(kUlog));
  EXPECT_FALSE(looks_like_ulog("/nonexistent/file.ulg"));
}

// A written log: a nested type before the IMU fields, sensor_accel without its trailing padding,
// sensor_gyro at other times (interpolated), a dropout, a repeated timestamp, a sync marker, and
// an info message.
TEST(ImportUlog, WrittenLogNestedPaddingDropoutInterpolation) {
  UlogWriter w;
  w.message('I', std::string(1, 16) + "char[7] sys_name" + "TestFC!");
  w.format("inner:uint16_t a;uint8_t[3] b;");  // 5 bytes
  w.format("sensor_accel:uint64_t timestamp;inner[2] extra;uint64_t timestamp_sample;uint32_t device_id;"
           "float x;float y;float z;float temperature;uint8_t[6] _padding0;");
  w.format("sensor_gyro:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;float y;float z;"
           "float temperature;");
  w.subscribe(0, 3, "sensor_accel");
  w.subscribe(0, 4, "sensor_gyro");
  auto accel = [&](std::uint64_t t, float x) {
    w.data(3, le(t) + std::string(10, '\x7f') + le(t) + le<std::uint32_t>(0xABCD) + vec3(x, 0.f, -9.8f) + le(25.5f));
  };
  auto gyro = [&](std::uint64_t t, float z) {
    w.data(4, le(t) + le(t) + le<std::uint32_t>(0x1234) + vec3(0.f, 0.f, z) + le(25.5f));
  };
  gyro(1000, 0.0f);
  accel(1500, 1.0f);
  gyro(2000, 1.0f);
  accel(2500, 2.0f);
  w.message('S', std::string("\x2F\x73\x13\x20\x25\x0C\xBB\x12", 8));
  gyro(3000, 2.0f);
  accel(3500, 3.0f);
  accel(3500, 4.0f);  // repeated timestamp: kept, counted
  w.message('O', le<std::uint16_t>(50));
  gyro(9000, 8.0f);
  accel(8500, 5.0f);  // after the dropout: a gap
  TempDir dir("ulog");
  write_text(dir / "written.ulg", w.bytes);
  const Recording r = import_ulog(dir / "written.ulg");
  ASSERT_EQ(r.samples.size(), 5u);
  EXPECT_EQ(r.header.identity.vendor, "TestFC!");
  EXPECT_EQ(r.samples[0].accel_mps2.x(), 1.0);  // offsets past the nested inner[2] (10 bytes)
  EXPECT_EQ(r.samples[0].temperature_c, 25.5);
  EXPECT_NEAR(r.samples[0].gyro_radps.z(), 0.5, 1e-12);  // halfway between 1000 and 2000 us
  EXPECT_NEAR(r.samples[2].gyro_radps.z(), 2.5, 1e-12);  // 3500 us: 2 + (8 − 2)·500/6000
  EXPECT_NEAR(r.samples[4].gyro_radps.z(), 7.5, 1e-12);  // 8500 us: 2 + (8 − 2)·5500/6000
  EXPECT_NEAR(r.samples[4].t_s, 7000e-6, 1e-12);
  EXPECT_TRUE(r.samples[4].flags & kGapBefore);
  EXPECT_FALSE(r.samples[1].flags & kGapBefore);
  EXPECT_NE(r.events[0].message.find("1 repeated"), std::string::npos) << r.events[0].message;
  EXPECT_NE(r.events[0].message.find("1 dropout(s) (50 ms)"), std::string::npos) << r.events[0].message;
  EXPECT_NE(r.events[0].message.find("interpolated"), std::string::npos) << r.events[0].message;
}

// Appended data (a D message cut where the appended section starts) and corrupt bytes skipped up
// to the next sync marker, as pyulog reads them.
TEST(ImportUlog, WrittenLogAppendedDataAndResync) {
  UlogWriter w;
  const std::size_t flags_at = w.message('B', std::string(8, '\0') + std::string(1, '\x01') + std::string(7, '\0') +
                                                  le<std::uint64_t>(0) + le<std::uint64_t>(0) + le<std::uint64_t>(0));
  w.format("sensor_combined:uint64_t timestamp;float[3] gyro_rad;uint32_t gyro_integral_dt;"
           "int32_t accelerometer_timestamp_relative;float[3] accelerometer_m_s2;");
  w.subscribe(0, 1, "sensor_combined");
  auto sample = [&](std::uint64_t t, float ax) {
    w.data(1, le(t) + vec3(0.f, 0.f, 0.1f) + le<std::uint32_t>(0) + le<std::int32_t>(0) + vec3(ax, 0.f, -9.8f));
  };
  for (int i = 0; i < 4; ++i) sample(1000u * static_cast<unsigned>(i + 1), static_cast<float>(i));
  w.bytes += std::string("\x05\x00zjunk!", 8) + std::string("\x2F\x73\x13\x20\x25\x0C\xBB\x12", 8);  // corrupt, then sync
  sample(5000, 4.f);
  sample(6000, 5.f);
  w.bytes.resize(w.bytes.size() - 5);  // the last message cut: the appended data starts here
  const std::uint64_t appended = w.bytes.size();
  std::memcpy(w.bytes.data() + flags_at + 3 + 16, &appended, sizeof appended);
  sample(7000, 6.f);
  TempDir dir("ulog-appended");
  write_text(dir / "appended.ulg", w.bytes);
  const Recording r = import_ulog(dir / "appended.ulg");
  ASSERT_EQ(r.samples.size(), 6u);  // 4, then 1 after the resync, the cut one lost, 1 appended
  EXPECT_EQ(r.samples[4].accel_mps2.x(), 4.0);
  EXPECT_TRUE(r.samples[4].flags & kGapBefore);  // bytes were skipped before it
  EXPECT_EQ(r.samples[5].accel_mps2.x(), 6.0);
  EXPECT_TRUE(r.samples[5].flags & kGapBefore);  // 2 ms after the previous one at 1 kHz
  EXPECT_EQ(r.samples[5].gyro_radps.z(), static_cast<double>(0.1f));
  EXPECT_NE(r.events[0].message.find("1 resync(s) (16 bytes skipped)"), std::string::npos) << r.events[0].message;
}

// Crafted logs that were quadratic, each imported within 5 s (the times are the old ones):
// 16 000 subscriptions of one topic instance (a pass over the file per msg_id: 18 s); 80 000
// flag-bits messages (their appended-data offsets checked against every message: 18 s); 160 000
// gyro records before the accelerometer's first time, in decreasing time (the gyro window held
// them all: 9 s); 200 000 records all at one time (each pairing searched the window: 14 s).
TEST(ImportUlog, CraftedLogsAreLinearInTime) {
  const std::string accel_fmt = "sensor_accel:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
                                "float x;float y;float z;float temperature;";
  const std::string gyro_fmt = "sensor_gyro:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
                               "float x;float y;float z;float temperature;";
  auto record = [](std::uint64_t t, float z) { return le(t) + le(t) + le<std::uint32_t>(1) + vec3(0.f, 0.f, z) + le(25.f); };
  auto formats = [&](UlogWriter& w) {
    w.format(accel_fmt);
    w.format(gyro_fmt);
  };
  TempDir dir("ulog-crafted");
  auto import_timed = [&](const std::string& name, const UlogWriter& w) {
    write_text(dir / name, w.bytes);
    const auto start = std::chrono::steady_clock::now();
    Recording r = import_ulog(dir / name);
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5)) << name;
    return r;
  };
  {
    constexpr int kIds = 16000;
    UlogWriter w;
    formats(w);
    for (int i = 0; i < kIds; ++i) {
      w.subscribe(0, static_cast<std::uint16_t>(i), "sensor_accel");
      w.subscribe(0, static_cast<std::uint16_t>(kIds + i), "sensor_gyro");
    }
    for (int i = 0; i < kIds; ++i) {
      const std::uint64_t t = 1000000 + 1000 * static_cast<std::uint64_t>(i);
      w.data(static_cast<std::uint16_t>(i), record(t, -9.8f));
      w.data(static_cast<std::uint16_t>(kIds + i), record(t, static_cast<float>(i)));
    }
    const Recording r = import_timed("subscriptions.ulg", w);
    ASSERT_EQ(r.samples.size(), static_cast<std::size_t>(kIds));
    EXPECT_EQ(r.samples[12345].gyro_radps.z(), 12345.0);  // in file order across the msg_ids
  }
  auto imu_after = [&](UlogWriter& w, std::uint64_t t0, int n) {
    for (int i = 0; i < n; ++i) {
      const std::uint64_t t = t0 + 1000 * static_cast<std::uint64_t>(i);
      w.data(0, record(t, -9.8f));
      w.data(1, record(t, static_cast<float>(i)));
    }
  };
  {
    UlogWriter w;
    const std::string flags = std::string(8, '\0') + std::string(1, '\x01') + std::string(7, '\0');
    for (std::uint64_t i = 0; i < 80000; ++i)  // offsets past the file's end: they cut nothing
      w.message('B', flags + le(std::uint64_t{1} << 62 | 3 * i) + le((std::uint64_t{1} << 62) + 3 * i + 1) +
                         le((std::uint64_t{1} << 62) + 3 * i + 2));
    formats(w);
    w.subscribe(0, 0, "sensor_accel");
    w.subscribe(0, 1, "sensor_gyro");
    imu_after(w, 1000000, 200);
    EXPECT_EQ(import_timed("flag_bits.ulg", w).samples.size(), 200u);
  }
  {
    UlogWriter w;
    formats(w);
    w.subscribe(0, 0, "sensor_accel");
    w.subscribe(0, 1, "sensor_gyro");
    constexpr std::uint64_t kT0 = 10000000000;
    for (std::uint64_t i = 0; i < 160000; ++i) w.data(1, record(kT0 - 1000 - 10 * i, 0.f));
    imu_after(w, kT0, 200);
    const Recording r = import_timed("gyro_before.ulg", w);
    ASSERT_EQ(r.samples.size(), 200u);
    EXPECT_EQ(r.samples[199].gyro_radps.z(), 199.0);
  }
  {
    constexpr int kRecords = 200000;
    UlogWriter w;
    formats(w);
    w.subscribe(0, 0, "sensor_accel");
    w.subscribe(0, 1, "sensor_gyro");
    for (int i = 0; i < kRecords; ++i) {
      w.data(0, record(10000000, -9.8f));
      w.data(1, record(10000000, static_cast<float>(i)));
    }
    const Recording r = import_timed("one_time.ulg", w);
    ASSERT_EQ(r.samples.size(), static_cast<std::size_t>(kRecords));
    for (int i : {0, 4095, 4096, 123457, kRecords - 1})  // each paired with its own record's gyro
      EXPECT_EQ(r.samples[static_cast<std::size_t>(i)].gyro_radps.z(), static_cast<double>(i)) << i;
    EXPECT_NE(r.events[0].message.find("gyro logged at the accelerometer times"), std::string::npos) << r.events[0].message;
  }
}

TEST(ImportUlog, BadFilesNameTheOffsetAndWhatWasExpected) {
  TempDir dir("ulog-bad");
  {  // wrong magic
    write_text(dir / "magic.ulg", std::string("ULoX\x01\x12\x35\x01", 8) + le<std::uint64_t>(0));
    const Caught e = error_of([&] { import_ulog(dir / "magic.ulg"); });
    EXPECT_EQ(e.offset, 0u);
    EXPECT_NE(e.what.find("magic.ulg: byte 0: not a ULog file"), std::string::npos) << e.what;
    EXPECT_FALSE(looks_like_ulog(dir / "magic.ulg"));
  }
  {  // a definition with an unknown type
    UlogWriter w;
    const std::size_t at = w.format("sensor_accel:uint64_t timestamp;flot x;float y;float z;");
    w.subscribe(0, 1, "sensor_accel");
    write_text(dir / "type.ulg", w.bytes);
    const Caught e = error_of([&] { import_ulog(dir / "type.ulg"); });
    EXPECT_EQ(e.offset, at);
    EXPECT_NE(e.what.find("field 'x' has type 'flot'"), std::string::npos) << e.what;
  }
  {  // no IMU topic
    UlogWriter w;
    w.format("vehicle_status:uint64_t timestamp;uint8_t arming_state;");
    w.subscribe(0, 1, "vehicle_status");
    w.data(1, le<std::uint64_t>(5) + "\x01");
    write_text(dir / "noimu.ulg", w.bytes);
    const Caught e = error_of([&] { import_ulog(dir / "noimu.ulg"); });
    EXPECT_EQ(e.offset, w.bytes.size());
    EXPECT_NE(e.what.find("no IMU data: expected sensor_accel + sensor_gyro or sensor_combined"), std::string::npos)
        << e.what;
  }
  {  // a message type that does not exist, with no sync marker after it
    UlogWriter w;
    const std::size_t at = w.message('z', "abc");
    write_text(dir / "unknown.ulg", w.bytes);
    const Caught e = error_of([&] { import_ulog(dir / "unknown.ulg"); });
    EXPECT_EQ(e.offset, at);
    EXPECT_NE(e.what.find("unknown message type 0x7A"), std::string::npos) << e.what;
  }
}

// Cut at many offsets: an ImportError at or before the cut, or (cut at a message boundary) a
// recording with no more samples. Never anything else.
void check_truncations(const fs::path& file, const std::function<Recording(const fs::path&)>& import,
                       std::size_t full_samples) {
  const std::string bytes = read_text(file);
  TempDir dir("truncated");
  std::mt19937 rng(12);
  std::vector<std::size_t> cuts = {0, 1, 2, 3, 7, 15, 16, 17, 18, 19, 100, bytes.size() - 1};
  std::uniform_int_distribution<std::size_t> any(0, bytes.size() - 1);
  for (int i = 0; i < 40; ++i) cuts.push_back(any(rng));
  for (std::size_t cut : cuts) {
    const fs::path cut_file = dir / ("cut_" + std::to_string(cut));
    write_text(cut_file, bytes.substr(0, cut));
    try {
      const Recording r = import(cut_file);
      EXPECT_LE(r.samples.size(), full_samples) << "cut at " << cut;
    } catch (const ImportError& e) {
      ASSERT_TRUE(e.offset().has_value()) << e.what();
      EXPECT_LE(*e.offset(), cut) << e.what();
      EXPECT_NE(std::string(e.what()).find(cut_file.string()), std::string::npos) << e.what();
    }
    fs::remove(cut_file);
  }
}

// Random bytes overwritten: a recording or an ImportError with an offset, never another exception.
void check_corruptions(const fs::path& file, const std::function<Recording(const fs::path&)>& import) {
  const std::string bytes = read_text(file);
  TempDir dir("corrupted");
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::size_t> any(0, bytes.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int trial = 0; trial < 30; ++trial) {
    std::string b = bytes;
    for (int k = 0; k < 8; ++k) b[any(rng)] = static_cast<char>(byte(rng));
    const fs::path bad = dir / ("corrupt_" + std::to_string(trial));
    write_text(bad, b);
    try {
      import(bad);
    } catch (const ImportError& e) {
      EXPECT_TRUE(e.offset().has_value()) << e.what();
    }
    fs::remove(bad);
  }
}

TEST(ImportUlog, TruncatedAtManyOffsets) {
  STEND_SKIP_IF_ABSENT(kUlog);
  check_truncations(kUlog, [](const fs::path& f) { return import_ulog(f); }, 1298);
}

// Cut inside its last message (a power loss): the samples before the cut read, the cut said.
TEST(ImportUlog, ALogCutInsideAMessageKeepsEveryWholeMessage) {
  STEND_SKIP_IF_ABSENT(kUlog);
  const std::string bytes = read_text(kUlog);
  const Recording whole = import_ulog(kUlog);
  TempDir dir("ulog-cut");
  const std::size_t cut = bytes.size() - 5;
  write_text(dir / "cut.ulg", bytes.substr(0, cut));
  const Recording r = import_ulog(dir / "cut.ulg");
  EXPECT_GE(r.samples.size() + 2, whole.samples.size());
  EXPECT_GT(r.samples.size(), 0u);
  const auto warning = std::find_if(r.events.begin(), r.events.end(), [](const Event& e) { return e.level == "warning"; });
  ASSERT_NE(warning, r.events.end());
  EXPECT_NE(warning->message.find("cut short at byte " + std::to_string(cut) + ", inside a '"), std::string::npos)
      << warning->message;
}

TEST(ImportUlog, CorruptedBytes) {
  STEND_SKIP_IF_ABSENT(kUlog);
  check_corruptions(kUlog, [](const fs::path& f) { return import_ulog(f); });
}

// =============================================================================================
// ArduPilot DataFlash

TEST(ImportDataflash, RealArduSubLog) {
  STEND_SKIP_IF_ABSENT(kDataflash);
  ASSERT_TRUE(looks_like_dataflash(kDataflash));
  EXPECT_FALSE(looks_like_euroc(kDataflash));
  const Recording r = import_dataflash(kDataflash);
  ASSERT_EQ(r.samples.size(), 594u);  // 594 IMU messages, all instance 0
  EXPECT_EQ(r.header.experiment_name, "import:dataflash");
  EXPECT_EQ(r.header.identity.vendor, "ArduPilot");
  EXPECT_EQ(r.header.identity.model, "ArduSub V4.1.0 (89639005)");
  EXPECT_TRUE(r.header.info.has_temperature);
  // First IMU message: TimeUS 265678654, GyrX..Z, AccX..Z, T.
  EXPECT_EQ(r.samples[0].t_s, 0.0);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].gyro_radps.x()), -0.007749793119728565f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].gyro_radps.z()), 0.002518214052543044f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].accel_mps2.x()), 0.15149246156215668f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].accel_mps2.z()), -9.770174026489258f);
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples[0].temperature_c), 51.049110412597656f);
  EXPECT_NEAR(r.samples[1].t_s, (265718506 - 265678654) * 1e-6, 1e-12);
  EXPECT_NEAR(r.samples.back().t_s, (289398424 - 265678654) * 1e-6, 1e-12);  // 23.7 s
  EXPECT_FLOAT_EQ(static_cast<float>(r.samples.back().temperature_c), 51.18888854980469f);
  EXPECT_TRUE(strictly_increasing(r));
  EXPECT_NEAR(r.header.info.output_rate_hz, 25.0, 0.5);
  // Units: the vehicle sits still, |a| ≈ g in m/s², gyro in rad/s; T ≈ 51.1 °C (data README).
  EXPECT_NEAR(mean_accel_norm(r), 9.8, 0.1);
  EXPECT_LT(max_gyro_norm(r), 0.2);
  double t_mean = 0.0;
  for (const auto& s : r.samples) t_mean += s.temperature_c / static_cast<double>(r.samples.size());
  EXPECT_NEAR(t_mean, 51.1, 0.1);
  EXPECT_NE(r.events[0].message.find("GyrX rad/s"), std::string::npos) << r.events[0].message;

  DataflashOptions opt;
  opt.instance = 1;
  const Caught e = error_of([&] { import_dataflash(kDataflash, opt); });
  EXPECT_NE(e.what.find("no IMU instance 1 (messages per instance: 0: 594)"), std::string::npos) << e.what;
}

namespace {

// A DataFlash FMT message.
std::string df_fmt(std::uint8_t type, std::uint8_t length, const std::string& name, const std::string& format,
                   const std::string& columns) {
  auto fixed = [](const std::string& s, std::size_t n) { return (s + std::string(n, '\0')).substr(0, n); };
  return std::string("\xA3\x95\x80", 3) + static_cast<char>(type) + static_cast<char>(length) + fixed(name, 4) +
         fixed(format, 16) + fixed(columns, 64);
}

std::string df_fmt_of_fmt() { return df_fmt(0x80, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"); }

}  // namespace

// A written log: two IMU instances, the gyro in deg/s by FMTU/UNIT/MULT, corrupt bytes skipped.
TEST(ImportDataflash, WrittenLogUnitsInstancesResync) {
  auto fixed = [](const std::string& t, std::size_t n) { return (t + std::string(n, '\0')).substr(0, n); };
  auto head = [](std::uint8_t type) { return std::string("\xA3\x95", 2) + static_cast<char>(type); };
  std::string b = df_fmt_of_fmt() + df_fmt(178, 76, "UNIT", "QbZ", "TimeUS,Id,Label") +
                  df_fmt(179, 20, "MULT", "Qbd", "TimeUS,Id,Mult") +
                  df_fmt(177, 44, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds") +
                  df_fmt(162, 40, "IMU", "QBfffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,T");
  for (const auto& [id, label] : std::vector<std::pair<char, std::string>>{
           {'k', "deg/s"}, {'o', "m/s/s"}, {'O', "degC"}, {'s', "s"}, {'#', "instance"}}) {
    b += head(178) + le<std::uint64_t>(1) + id + fixed(label, 64);
  }
  for (const auto& [id, mult] : std::vector<std::pair<char, double>>{{'-', 0.0}, {'0', 1.0}, {'F', 1e-6}}) {
    b += head(179) + le<std::uint64_t>(1) + id + le(mult);
  }
  b += head(177) + le<std::uint64_t>(1) + static_cast<char>(162) + fixed("s#kkkoooO", 16) + fixed("F-0000000", 16);
  auto imu = [&](std::uint64_t t_us, std::uint8_t instance, float gz_dps, float temp) {
    b += head(162) + le(t_us) + static_cast<char>(instance) + vec3(0.f, 0.f, gz_dps) + vec3(0.f, 0.f, -9.8f) + le(temp);
  };
  for (int i = 0; i < 6; ++i) {
    imu(100000u + 10000u * static_cast<unsigned>(i), 0, 90.f, 30.f + static_cast<float>(i));
    if (i % 2 == 0) imu(100000u + 10000u * static_cast<unsigned>(i), 1, 0.f, 20.f);
    if (i == 3) b += "corrupt";
  }
  TempDir dir("df-written");
  write_text(dir / "written.BIN", b);
  const Recording r = import_dataflash(dir / "written.BIN");
  ASSERT_EQ(r.samples.size(), 6u);  // instance 0 has the most
  EXPECT_NEAR(r.samples[0].gyro_radps.z(), std::numbers::pi / 2.0, 1e-6);  // 90 deg/s
  EXPECT_EQ(r.samples[5].temperature_c, 35.0);
  EXPECT_NEAR(r.samples[5].t_s, 0.05, 1e-12);
  EXPECT_TRUE(r.samples[4].flags & kGapBefore);  // after the corrupt bytes
  EXPECT_EQ(gaps(r), 1u);
  EXPECT_NE(r.events[0].message.find("1 resync(s) (7 bytes skipped)"), std::string::npos) << r.events[0].message;
  EXPECT_NE(r.events[0].message.find("GyrX deg/s x 0.0174533"), std::string::npos) << r.events[0].message;
  DataflashOptions opt;
  opt.instance = 1;
  const Recording r1 = import_dataflash(dir / "written.BIN", opt);
  ASSERT_EQ(r1.samples.size(), 3u);
  EXPECT_EQ(r1.samples[2].temperature_c, 20.0);
  EXPECT_NEAR(r1.samples[2].t_s, 0.04, 1e-12);
}

// A log cut inside its last message (a power loss): every whole message read, the cut said.
TEST(ImportDataflash, ALogCutInsideAMessageKeepsEveryWholeMessage) {
  auto head = [](std::uint8_t type) { return std::string("\xA3\x95", 2) + static_cast<char>(type); };
  std::string b = df_fmt_of_fmt() + df_fmt(162, 40, "IMU", "QBfffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,T");
  for (int i = 0; i < 8; ++i)
    b += head(162) + le<std::uint64_t>(100000u + 10000u * static_cast<unsigned>(i)) + static_cast<char>(0) +
         vec3(0.f, 0.f, 0.f) + vec3(0.f, 0.f, -9.8f) + le(25.0f);
  const std::size_t cut = b.size() - 15;  // 25 of the last message's 40 bytes
  TempDir dir("df-cut");
  write_text(dir / "cut.BIN", b.substr(0, cut));
  const Recording r = import_dataflash(dir / "cut.BIN");
  EXPECT_EQ(r.samples.size(), 7u);
  const auto warning = std::find_if(r.events.begin(), r.events.end(), [](const Event& e) { return e.level == "warning"; });
  ASSERT_NE(warning, r.events.end());
  EXPECT_NE(warning->message.find("cut short at byte " + std::to_string(cut) + ", inside a 'IMU' message that starts at byte " +
                                  std::to_string(b.size() - 40) + ": its 25 byte(s) are dropped"),
            std::string::npos)
      << warning->message;
}

// Crafted resyncs at every third byte (headers of a type no FMT defines) over 4 MiB: each byte is
// read once, not a 1 MiB window per resync (which took minutes).
TEST(ImportDataflash, ResyncsAtEveryFewBytesAreLinearInTime) {
  constexpr std::size_t kCraftedBytes = std::size_t{4} << 20;
  std::string b = df_fmt_of_fmt() + df_fmt(162, 40, "IMU", "QBfffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,T");
  b.reserve(b.size() + kCraftedBytes + 64);
  while (b.size() < kCraftedBytes) b += std::string("\xA3\x95\x01", 3);
  TempDir dir("df-resync");
  write_text(dir / "resync.BIN", b);
  const auto start = std::chrono::steady_clock::now();
  try {
    (void)import_dataflash(dir / "resync.BIN");
  } catch (const std::exception&) {  // no IMU message: refused, which is fine; the time is the point
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(ImportDataflash, BadFilesNameTheOffsetAndWhatWasExpected) {
  TempDir dir("df-bad");
  {  // an IMU format with a type char that does not exist
    const std::string fmt_of_fmt = df_fmt_of_fmt();
    const std::string imu = df_fmt(10, 3 + 8 + 24 + 4, "IMU", "QfffffX", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ");
    std::string msg = std::string("\xA3\x95\x0A", 3) + le<std::uint64_t>(5) + std::string(28, '\0');
    write_text(dir / "type.BIN", fmt_of_fmt + imu + msg);
    const Caught e = error_of([&] { import_dataflash(dir / "type.BIN"); });
    EXPECT_EQ(e.offset, fmt_of_fmt.size());
    EXPECT_NE(e.what.find("format char 'X'"), std::string::npos) << e.what;
  }
  {  // no IMU messages
    const std::string bytes = df_fmt_of_fmt() + df_fmt(11, 3 + 8, "BARO", "Q", "TimeUS") +
                              std::string("\xA3\x95\x0B", 3) + le<std::uint64_t>(7);
    write_text(dir / "noimu.BIN", bytes);
    const Caught e = error_of([&] { import_dataflash(dir / "noimu.BIN"); });
    EXPECT_EQ(e.offset, bytes.size());
    EXPECT_NE(e.what.find("no IMU data: expected IMU"), std::string::npos) << e.what;
  }
  {  // wrong magic
    write_text(dir / "magic.BIN", "A3 95 is what a DataFlash log starts with");
    const Caught e = error_of([&] { import_dataflash(dir / "magic.BIN"); });
    EXPECT_EQ(e.offset, 0u);
    EXPECT_NE(e.what.find("not a DataFlash log (expected the message header bytes A3 95)"), std::string::npos) << e.what;
    EXPECT_FALSE(looks_like_dataflash(dir / "magic.BIN"));
  }
}

TEST(ImportDataflash, TruncatedAtManyOffsets) {
  STEND_SKIP_IF_ABSENT(kDataflash);
  check_truncations(kDataflash, [](const fs::path& f) { return import_dataflash(f); }, 594);
}

TEST(ImportDataflash, CorruptedBytes) {
  STEND_SKIP_IF_ABSENT(kDataflash);
  check_corruptions(kDataflash, [](const fs::path& f) { return import_dataflash(f); });
}

// =============================================================================================
// EuRoC / ASL

namespace {

constexpr const char* kEurocHeader =
    "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],"
    "a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";

}  // namespace

TEST(ImportEuroc, OfficialLayoutFolderOrFile) {
  TempDir dir("euroc");
  fs::create_directories(dir / "mav0/imu0");
  // Lines as the dataset writes them (MH_01_easy starts at 1403636579758555392 ns, 200 Hz); the
  // fourth repeats the third's timestamp, and one sample is missing before the last.
  write_text(dir / "mav0/imu0/data.csv",
             std::string(kEurocHeader) +
                 "1403636579758555392,-0.099134701513277898,0.14032447186034408,0.02129801649725213,"
                 "8.1476917083333333,-0.37592158333333331,-2.4026292499999999\n"
                 "1403636579763555584,-0.099134701513277898,0.14032447186034408,0.021996142974984949,"
                 "8.033280791666666,-0.40861041666666664,-2.4026292499999999\n"
                 "1403636579768555520,-0.098436575035545239,0.12775817526116593,0.014316751557048383,"
                 "7.8861807916666662,-0.42495483333333333,-2.4026292499999999\n"
                 "1403636579768555520,-0.1,0.13,0.014,7.9,-0.42,-2.40\n"
                 "1403636579783555584,-0.1,0.13,0.014,7.9,-0.42,-2.40\n");
  EXPECT_TRUE(looks_like_euroc(dir.path()));
  EXPECT_TRUE(looks_like_euroc(dir / "mav0/imu0/data.csv"));
  const Recording r = import_euroc(dir.path());
  ASSERT_EQ(r.samples.size(), 5u);
  EXPECT_EQ(r.header.experiment_name, "import:euroc");
  EXPECT_EQ(r.header.experiment_file, (dir / "mav0/imu0/data.csv").string());
  EXPECT_EQ(r.samples[0].t_s, 0.0);
  EXPECT_DOUBLE_EQ(r.samples[1].t_s, 5000192e-9);  // exact to the nanosecond
  EXPECT_DOUBLE_EQ(r.samples[4].t_s, 25000192e-9);
  EXPECT_DOUBLE_EQ(r.samples[0].gyro_radps.x(), -0.099134701513277898);
  EXPECT_DOUBLE_EQ(r.samples[0].accel_mps2.x(), 8.1476917083333333);
  EXPECT_DOUBLE_EQ(r.samples[0].accel_mps2.z(), -2.4026292499999999);
  EXPECT_NEAR(r.header.info.output_rate_hz, 200.0, 0.01);
  EXPECT_TRUE(r.samples[4].flags & kGapBefore);
  EXPECT_EQ(gaps(r), 1u);
  EXPECT_NE(r.events[0].message.find("1 repeated"), std::string::npos) << r.events[0].message;
  EXPECT_FALSE(r.header.info.has_temperature);
}

TEST(ImportEuroc, BadFiles) {
  TempDir dir("euroc-bad");
  write_text(dir / "other.csv", "t,ax,ay,az\n0,1,2,3\n");
  EXPECT_FALSE(looks_like_euroc(dir / "other.csv"));
  EXPECT_FALSE(looks_like_euroc(dir.path()));  // no mav0/imu0/data.csv
  Caught e = error_of([&] { import_euroc(dir / "other.csv"); });
  EXPECT_NE(e.what.find("other.csv:1: expected the EuRoC column-name line"), std::string::npos) << e.what;
  write_text(dir / "short.csv", std::string(kEurocHeader) + "1403636579758555392,1,2,3,4,5\n");
  e = error_of([&] { import_euroc(dir / "short.csv"); });
  EXPECT_NE(e.what.find("short.csv:2: expected 7 fields"), std::string::npos) << e.what;
  write_text(dir / "ns.csv", std::string(kEurocHeader) + "1.4e18,1,2,3,4,5,6\n");
  e = error_of([&] { import_euroc(dir / "ns.csv"); });
  EXPECT_NE(e.what.find("ns.csv:2: timestamp '1.4e18' is not an integer [ns]"), std::string::npos) << e.what;
}

// Inputs the fuzz targets found (fuzz/regressions/, replayed by the fuzz ctests): an id field
// holding a value its integer type cannot take is a clear ImportError at the record, not
// undefined behaviour.
TEST(ImportUlog, DeviceIdOutOfRangeIsAnError) {
  const fs::path log = stend::testing::source_path("fuzz/regressions/import_ulog/device_id_out_of_range.ulg");
  const Caught c = error_of([&] { stend::io::import_ulog(log); });
  EXPECT_NE(c.what.find("byte 436: field 'device_id' of 'sensor_accel' is 1.47718e+19, not a 32-bit id"),
            std::string::npos) << c.what;
}

// A format's array size beyond any message (the fuzz target: 3.7e78, cast to an integer — UBSan).
TEST(ImportUlog, ArraySizeBeyondAnyMessageIsAnError) {
  const fs::path log = stend::testing::source_path("fuzz/regressions/import_ulog/array_size_3e78.ulg");
  const Caught c = error_of([&] { stend::io::import_ulog(log); });
  EXPECT_NE(c.what.find("byte 59: format 'sensor_combined': field 'gyro_rad' has a bad array size"), std::string::npos)
      << c.what;
}

TEST(ImportUlog, RelativeTimestampOutsideA32BitOffsetIsAnError) {
  // sensor_combined's accelerometer_timestamp_relative was added to the timestamp as a signed
  // 64-bit sum (UBSan: overflow; the fuzz target found a field retyped to int64).
  const fs::path log = stend::testing::source_path("fuzz/regressions/import_ulog/relative_timestamp_overflow.ulg");
  const Caught c = error_of([&] { stend::io::import_ulog(log); });
  EXPECT_NE(c.what.find("field 'accelerometer_timestamp_relative' of 'sensor_combined' is "), std::string::npos) << c.what;
  EXPECT_NE(c.what.find("not a 32-bit offset from the record's timestamp"), std::string::npos) << c.what;
}

TEST(ImportDataflash, UnitIdOutOfRangeIsAnError) {
  const fs::path log = stend::testing::source_path("fuzz/regressions/import_dataflash/unit_id_out_of_range.BIN");
  const Caught c = error_of([&] { stend::io::import_dataflash(log); });
  EXPECT_NE(c.what.find("byte 741: 'FMTU.FmtType' is 1.16733e+19, not an integer in [0, 256)"), std::string::npos)
      << c.what;
}
