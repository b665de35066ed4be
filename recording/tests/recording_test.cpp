// Recording store: round trip, tolerance of interrupted writes, durability under SIGKILL, scale.
#include <stend/errors.hpp>
#include <stend/model/terms.hpp>
#include <stend/recording/instruments.hpp>
#include <stend/recording/recording.hpp>
#include <stend/sdk.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>
#include <stend/testing/program.hpp>

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "../src/hdf5_chunks.hpp"      // hdf5_fletcher32
#include "../src/hdf5_file_bytes.hpp"  // lookup3, to make a checksum right after an edit

namespace fs = std::filesystem;
using stend::kNaN;
using stend::Event;
using stend::ImuSample;
using stend::Recording;
using stend::RecordingHeader;
using stend::RecordingWriter;
using stend::Segment;
using stend::testing::read_text;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

// These tests are about the CSV run folder (its files' text and its reader).
const stend::RecordingWriterOptions kCsv{stend::RecordingFormat::kCsv};
constexpr double kInf = std::numeric_limits<double>::infinity();

// Bit-exact equality, with every NaN equal to every NaN (the CSV keeps no NaN payload).
bool same(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::memcmp(&a, &b, sizeof a) == 0;
}

double monotonic_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

RecordingHeader make_header() {
  RecordingHeader h;
  h.experiment_name = "six-position, \"quoted\" & ünïcode";
  h.experiment_file = "/lab/configs/six_position.yaml";
  h.stend_version = "0.1.0";
  h.plugins = {{"sensor", "sim_imu", "0.1.0", "/usr/lib/stend/plugins/libsim_imu.so", "install prefix", "crc32:0123abcd"},
               {"table", "sim_table", "0.2.0", "libsim_table.so", "experiment", ""}};
  h.identity = {"InvenSense", "MPU-6050", "SN-0042", "0x68"};
  h.info.output_rate_hz = 1000.0;
  h.info.accel_range_mps2 = 2 * 9.80665;
  h.info.gyro_range_radps = 250.0 * M_PI / 180.0;
  h.info.accel_lsb_mps2 = 9.80665 / 16384.0;
  h.info.gyro_lsb_radps = M_PI / 180.0 / 131.0;
  h.info.temperature_lsb_c = 1.0 / 340.0;
  h.info.has_gyro = true;
  h.info.has_temperature = true;  // an absent instrument's round trip: AbsentInstrumentsAreNaNBothWays
  h.gravity_mps2 = 9.8153872;
  h.latitude_deg = 55.7558;
  h.height_m = 151.3;
  h.mounting_R = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  h.seed = 0xFEDCBA9876543210ull;  // above 2^63: must survive JSON
  h.clock = "simulated";
  h.truth_columns = {"table.angle.cmd_deg", "air_c", "f_x_mps2", "odd, name \"x\""};
  h.start_time_utc = "2024-03-01T10:00:00.000Z";
  return h;
}

std::uint64_t splitmix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Sample k (1-based) of a deterministic 1 kHz stream: cheap to regenerate for checking.
ImuSample make_sample(std::uint64_t k) {
  ImuSample s;
  s.t_s = static_cast<double>(k) / 1000.0;
  const double lsb_a = 9.80665 / 16384.0, lsb_g = M_PI / 180.0 / 131.0;
  std::uint64_t h = splitmix(k);
  auto noise = [&h]() {  // roughly ±100 counts
    h = splitmix(h);
    return static_cast<std::int32_t>(h % 201) - 100;
  };
  for (int i = 0; i < 3; ++i) {
    s.accel_counts[i] = noise() + (i == 2 ? 16384 : 0);
    s.gyro_counts[i] = noise();
    // Odd samples: SI = f(counts), as a sensor converts (repeated values, the writer's text
    // cache); even samples: every value distinct.
    s.accel_mps2[i] = s.accel_counts[i] * lsb_a +
                      (k % 2 == 0 ? 1e-9 * static_cast<double>(h % 1000003) : 0.0);
    s.gyro_radps[i] = s.gyro_counts[i] * lsb_g;
  }
  s.temperature_counts = -1234 + static_cast<std::int32_t>(k % 7);
  s.temperature_c = s.temperature_counts / 340.0 + 36.53;
  s.flags = k % 5 == 0 ? static_cast<std::uint32_t>(stend::kGapBefore) : 0u;
  return s;
}

void expect_same_sample(const ImuSample& a, const ImuSample& b, std::size_t i) {
  ASSERT_TRUE(same(a.t_s, b.t_s)) << "sample " << i;
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(a.accel_counts[k], b.accel_counts[k]) << "sample " << i;
    ASSERT_EQ(a.gyro_counts[k], b.gyro_counts[k]) << "sample " << i;
    ASSERT_TRUE(same(a.accel_mps2[k], b.accel_mps2[k])) << "sample " << i << " axis " << k;
    ASSERT_TRUE(same(a.gyro_radps[k], b.gyro_radps[k])) << "sample " << i << " axis " << k;
  }
  ASSERT_EQ(a.temperature_counts, b.temperature_counts) << "sample " << i;
  ASSERT_TRUE(same(a.temperature_c, b.temperature_c)) << "sample " << i;
  ASSERT_EQ(a.flags, b.flags) << "sample " << i;
}

// The run in `dir` streams back exactly the samples `s`, in order.
void expect_streams_back(const fs::path& dir, const std::vector<ImuSample>& s) {
  const Recording r = Recording::open(dir, stend::SampleLoading::kStream);
  ASSERT_EQ(r.sample_count(), s.size());
  std::vector<ImuSample> got(s.size());
  r.source->read(0, s.size(), got.data());
  for (std::size_t i = 0; i < s.size(); ++i) {
    expect_same_sample(got[i], s[i], i);
    if (::testing::Test::HasFatalFailure()) return;
  }
}

class RecordingTest : public ::testing::Test {
 protected:
  const TempDir tmp_{"recording"};
  const fs::path root_ = tmp_.path();
};

// A small complete recording with awkward values everywhere.
struct Written {
  RecordingHeader header;
  std::string yaml;
  std::vector<ImuSample> samples;
  std::vector<double> truth_t;
  std::vector<std::vector<double>> truth;
  std::vector<Segment> segments;
  std::vector<Event> events;
};

Written write_small(const fs::path& dir, bool finish = true) {
  Written w;
  w.header = make_header();
  w.yaml = "name: six-position\nprocedure:\n  - record: {duration_s: 10}\n";
  for (std::uint64_t k = 1; k <= 2000; ++k) w.samples.push_back(make_sample(k));
  // Edge values must round-trip bit-exactly too.
  ImuSample& e = w.samples[10];
  e.accel_mps2 = {-0.0, std::numeric_limits<double>::denorm_min(),
                  std::numeric_limits<double>::max()};
  e.gyro_radps = {std::numeric_limits<double>::lowest(), std::numeric_limits<double>::min(),
                  0.1 + 0.2};
  e.temperature_c = kNaN;
  e.accel_counts[0] = std::numeric_limits<std::int32_t>::min();
  e.accel_counts[1] = std::numeric_limits<std::int32_t>::max();
  e.flags = 0xFFFFFFFFu;
  w.samples[11].gyro_radps = {kInf, -kInf, 1e300};
  w.samples[12].t_s = 86400.0 * 3 + 0.000001;  // µs over days (out of order on purpose)

  for (int k = 0; k < 50; ++k) {
    w.truth_t.push_back(0.1 * k);
    w.truth.push_back({10.0 * k, 25.0 + 0.01 * k, k == 3 ? kNaN : -9.80665 / 3.0, -0.0});
  }

  Segment s1;
  s1.id = 0;
  s1.step = 0;
  s1.kind = stend::SegmentKind::kSetTemperature;
  s1.label = "soak, 25 \"degC\"";
  s1.t_start_s = 0.0;
  s1.t_end_s = 600.25;
  s1.targets = "chamber.temperature=25 degC";
  s1.setpoint_c = 25.0;
  Segment s2;
  s2.id = 1;
  s2.step = 2;
  s2.kind = stend::SegmentKind::kOrientation;
  s2.label = "";
  s2.repeat = 3;
  s2.orientation = 4;
  s2.orientation_count = 6;
  s2.t_start_s = 600.25;
  s2.t_end_s = 1.0 / 3.0;
  s2.settled = false;
  s2.complete = false;
  s2.targets = "table.angle=10 deg; table.tilt=-90 deg\nsecond line";
  s2.rate = -12.5;
  w.segments = {s1, s2};

  w.events = {{0.0, "info", "runner", "start"},
              {1.5, "warning", "chamber", "overshoot 0.3 degC, retrying \"soon\""},
              {2.25, "error", "sensor", "line one\nline two\r\nline three"},
              {3.0, "info", "operator", ""}};

  RecordingWriter writer(dir, w.header, w.yaml, kCsv);
  writer.add_samples(w.samples.data(), 1000);
  writer.tick(1.0);
  writer.add_samples(w.samples.data() + 1000, w.samples.size() - 1000);
  for (std::size_t i = 0; i < w.truth.size(); ++i) writer.add_truth(w.truth_t[i], w.truth[i]);
  for (const auto& s : w.segments) writer.add_segment(s);
  for (const auto& ev : w.events) writer.add_event(ev);
  EXPECT_EQ(writer.sample_count(), w.samples.size());
  EXPECT_EQ(writer.dir(), dir);
  if (finish) writer.finish(stend::RunStatus::kComplete, "all steps done");
  return w;
}

}  // namespace

TEST_F(RecordingTest, RoundTripIsExact) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir);
  for (const char* f : {"run.json", "experiment.yaml", "imu.csv", "truth.csv", "segments.csv",
                        "events.csv"}) {
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  }
  EXPECT_FALSE(fs::exists(dir / "run.json.tmp"));

  const Recording r = Recording::open(dir);
  EXPECT_EQ(r.dir, dir);
  EXPECT_EQ(r.header.status, stend::RunStatus::kComplete);
  EXPECT_TRUE(r.complete());
  EXPECT_EQ(r.dropped_partial_lines, 0u);
  EXPECT_EQ(r.experiment_yaml, w.yaml);

  const RecordingHeader& h = r.header;
  EXPECT_EQ(h.experiment_name, w.header.experiment_name);
  EXPECT_EQ(h.experiment_file, w.header.experiment_file);
  EXPECT_EQ(h.stend_version, w.header.stend_version);
  ASSERT_EQ(h.plugins.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(h.plugins[i].role, w.header.plugins[i].role);
    EXPECT_EQ(h.plugins[i].name, w.header.plugins[i].name);
    EXPECT_EQ(h.plugins[i].version, w.header.plugins[i].version);
    EXPECT_EQ(h.plugins[i].file, w.header.plugins[i].file);
    EXPECT_EQ(h.plugins[i].origin, w.header.plugins[i].origin);
    EXPECT_EQ(h.plugins[i].hash, w.header.plugins[i].hash);
  }
  EXPECT_EQ(h.identity.vendor, "InvenSense");
  EXPECT_EQ(h.identity.model, "MPU-6050");
  EXPECT_EQ(h.identity.serial, "SN-0042");
  EXPECT_EQ(h.identity.who_am_i, "0x68");
  EXPECT_TRUE(same(h.info.output_rate_hz, w.header.info.output_rate_hz));
  EXPECT_TRUE(same(h.info.accel_range_mps2, w.header.info.accel_range_mps2));
  EXPECT_TRUE(same(h.info.gyro_range_radps, w.header.info.gyro_range_radps));
  EXPECT_TRUE(same(h.info.accel_lsb_mps2, w.header.info.accel_lsb_mps2));
  EXPECT_TRUE(same(h.info.gyro_lsb_radps, w.header.info.gyro_lsb_radps));
  EXPECT_TRUE(same(h.info.temperature_lsb_c, w.header.info.temperature_lsb_c));
  EXPECT_TRUE(h.info.has_gyro);
  EXPECT_TRUE(h.info.has_temperature);
  EXPECT_TRUE(h.info.has_accel);
  EXPECT_TRUE(same(h.gravity_mps2, w.header.gravity_mps2));
  EXPECT_TRUE(same(h.latitude_deg, w.header.latitude_deg));
  EXPECT_TRUE(same(h.height_m, w.header.height_m));
  EXPECT_EQ(h.mounting_R, w.header.mounting_R);
  EXPECT_EQ(h.seed, w.header.seed);
  EXPECT_EQ(h.clock, "simulated");
  EXPECT_EQ(h.truth_columns, w.header.truth_columns);
  EXPECT_EQ(h.start_time_utc, w.header.start_time_utc);
  EXPECT_EQ(h.status, stend::RunStatus::kComplete);

  ASSERT_EQ(r.samples.size(), w.samples.size());
  for (std::size_t i = 0; i < w.samples.size(); ++i) {
    expect_same_sample(r.samples[i], w.samples[i], i);
    if (HasFatalFailure()) return;
  }
  ASSERT_EQ(r.truth_t.size(), w.truth_t.size());
  ASSERT_EQ(r.truth.size(), w.truth.size());
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    EXPECT_TRUE(same(r.truth_t[i], w.truth_t[i]));
    ASSERT_EQ(r.truth[i].size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) EXPECT_TRUE(same(r.truth[i][k], w.truth[i][k])) << i;
  }
  EXPECT_EQ(r.truth_column("air_c"), 1);
  EXPECT_EQ(r.truth_column("odd, name \"x\""), 3);
  EXPECT_EQ(r.truth_column("nope"), -1);

  ASSERT_EQ(r.segments.size(), w.segments.size());
  for (std::size_t i = 0; i < w.segments.size(); ++i) {
    const Segment &a = r.segments[i], &b = w.segments[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.step, b.step);
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.label, b.label);
    EXPECT_EQ(a.repeat, b.repeat);
    EXPECT_EQ(a.orientation, b.orientation);
    EXPECT_EQ(a.orientation_count, b.orientation_count);
    EXPECT_TRUE(same(a.t_start_s, b.t_start_s));
    EXPECT_TRUE(same(a.t_end_s, b.t_end_s));
    EXPECT_EQ(a.settled, b.settled);
    EXPECT_EQ(a.complete, b.complete);
    EXPECT_EQ(a.targets, b.targets);
    EXPECT_TRUE(same(a.setpoint_c, b.setpoint_c)) << i;
    EXPECT_TRUE(same(a.rate, b.rate)) << i;
  }
  EXPECT_TRUE(std::isnan(r.segments[0].rate));
  EXPECT_TRUE(std::isnan(r.segments[1].setpoint_c));

  ASSERT_EQ(r.events.size(), w.events.size());
  for (std::size_t i = 0; i < w.events.size(); ++i) {
    EXPECT_TRUE(same(r.events[i].t_s, w.events[i].t_s));
    EXPECT_EQ(r.events[i].level, w.events[i].level);
    EXPECT_EQ(r.events[i].source, w.events[i].source);
    EXPECT_EQ(r.events[i].message, w.events[i].message);
  }
}

TEST_F(RecordingTest, FilesAreSelfDescribing) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir);
  // run.json is plain JSON with units in the key names and the finish fields.
  const auto j = nlohmann::json::parse(read_text(dir / "run.json"));
  EXPECT_EQ(j.at("format_version"), stend::kRecordingFormatVersion);
  EXPECT_EQ(j.at("status"), "complete");
  EXPECT_EQ(j.at("status_message"), "all steps done");
  EXPECT_EQ(j.at("sample_count"), w.samples.size());
  EXPECT_EQ(j.at("event_count"), w.events.size());
  EXPECT_TRUE(j.at("end_time_utc").is_string());
  EXPECT_EQ(j.at("sensor").at("info").at("output_rate_hz"), 1000.0);
  EXPECT_EQ(j.at("seed").get<std::uint64_t>(), 0xFEDCBA9876543210ull);

  const std::string imu = read_text(dir / "imu.csv");
  EXPECT_EQ(imu.substr(0, imu.find('\n')),
            "t_s,ax_counts,ay_counts,az_counts,gx_counts,gy_counts,gz_counts,temp_counts,"
            "ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps,temp_c,flags");
  // NaN is an empty field; the t_s column keeps µs over days.
  EXPECT_NE(imu.find(",,4294967295\n"), std::string::npos);
  EXPECT_NE(imu.find("\n259200.000001,"), std::string::npos);
  const std::string truth = read_text(dir / "truth.csv");
  EXPECT_EQ(truth.substr(0, truth.find('\n')),
            "t_s,table.angle.cmd_deg,air_c,f_x_mps2,\"odd, name \"\"x\"\"\"");
  const std::string seg = read_text(dir / "segments.csv");
  EXPECT_EQ(seg.substr(0, seg.find('\n')),
            "id,step,kind,label,repeat,orientation,orientation_count,t_start_s,t_end_s,settled,"
            "complete,targets,setpoint_c,rate_per_s");
  EXPECT_NE(seg.find("\"soak, 25 \"\"degC\"\"\""), std::string::npos);
  EXPECT_EQ(read_text(dir / "experiment.yaml"), w.yaml);
}

TEST_F(RecordingTest, UnfinishedRunStaysRunning) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir, /*finish=*/false);  // writer destroyed without finish()
  const Recording r = Recording::open(dir);
  EXPECT_EQ(r.header.status, stend::RunStatus::kRunning);
  EXPECT_FALSE(r.complete());
  EXPECT_EQ(r.samples.size(), w.samples.size());  // the destructor flushed
  EXPECT_EQ(r.segments.size(), 2u);
  const auto j = nlohmann::json::parse(read_text(dir / "run.json"));
  EXPECT_FALSE(j.contains("end_time_utc"));
}

TEST_F(RecordingTest, FinishStatusesAndMisuse) {
  {
    RecordingWriter w(root_ / "a", make_header(), "", kCsv);
    EXPECT_THROW(w.finish(stend::RunStatus::kRunning), std::invalid_argument);
    EXPECT_THROW(w.add_truth(0.0, {1.0}), std::invalid_argument);  // 4 columns expected
    w.finish(stend::RunStatus::kInterrupted, "operator pressed Ctrl-C");
    ImuSample s;
    EXPECT_THROW(w.add_samples(&s, 1), std::logic_error);
    EXPECT_THROW(w.add_event({0.0, "info", "runner", "late"}), std::logic_error);
  }
  const Recording a = Recording::open(root_ / "a");
  EXPECT_EQ(a.header.status, stend::RunStatus::kInterrupted);
  EXPECT_FALSE(a.complete());
  EXPECT_TRUE(a.samples.empty());
  EXPECT_EQ(a.experiment_yaml, "");
  {
    RecordingWriter w(root_ / "b", make_header(), "x: 1\n", kCsv);
    w.finish(stend::RunStatus::kFailed, "sensor stopped answering");
  }
  EXPECT_EQ(Recording::open(root_ / "b").header.status, stend::RunStatus::kFailed);

  RecordingHeader bad = make_header();
  bad.mounting_R = {1, 0, 0};
  EXPECT_THROW(RecordingWriter(root_ / "c", bad, "", kCsv), std::invalid_argument);
  bad = make_header();
  bad.truth_columns = {"air_c", "air_c"};
  EXPECT_THROW(RecordingWriter(root_ / "d", bad, "", kCsv), std::invalid_argument);
  EXPECT_THROW(RecordingWriter(root_ / "e", make_header(), "a: [1, 2\n", kCsv), std::invalid_argument);
  EXPECT_FALSE(fs::exists(root_ / "e"));
}

TEST_F(RecordingTest, InvalidUtf8InHeaderDoesNotBreakRunJson) {
  RecordingHeader h = make_header();
  h.identity.serial = "SN\xff\xfe";  // raw bytes read from a device
  { RecordingWriter w(root_ / "run", h, "", kCsv); }
  const Recording r = Recording::open(root_ / "run");
  EXPECT_EQ(r.header.identity.serial.substr(0, 2), "SN");
  EXPECT_EQ(r.header.identity.model, "MPU-6050");
}

TEST_F(RecordingTest, StartTimeFilledWhenEmpty) {
  RecordingHeader h = make_header();
  h.start_time_utc.clear();
  { RecordingWriter w(root_ / "run", h, "", kCsv); }
  const Recording r = Recording::open(root_ / "run");
  ASSERT_EQ(r.header.start_time_utc.size(), 24u) << r.header.start_time_utc;  // ...T..:..:..mmmZ
  EXPECT_EQ(r.header.start_time_utc[10], 'T');
  EXPECT_EQ(r.header.start_time_utc.back(), 'Z');
}

TEST_F(RecordingTest, ExistingRunDirectoryIsRefused) {
  const fs::path dir = root_ / "run";
  write_small(dir);
  const std::string before = read_text(dir / "imu.csv");
  try {
    RecordingWriter w(dir, make_header(), "", kCsv);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("already exists"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_text(dir / "imu.csv"), before);  // untouched
  EXPECT_EQ(Recording::open(dir).header.status, stend::RunStatus::kComplete);
  // An empty directory counts as existing too.
  fs::create_directories(root_ / "empty");
  EXPECT_THROW(RecordingWriter(root_ / "empty", make_header(), "", kCsv), std::runtime_error);
  // Parents are created.
  EXPECT_NO_THROW(RecordingWriter(root_ / "deep" / "er" / "run", make_header(), "", kCsv));
  // A trailing slash names the same folder.
  EXPECT_NO_THROW(RecordingWriter(root_ / "slash" / "", make_header(), "", kCsv));
  EXPECT_TRUE(fs::exists(root_ / "slash" / "imu.csv"));
  EXPECT_THROW(RecordingWriter(root_ / "slash" / "", make_header(), "", kCsv), std::runtime_error);
}

TEST_F(RecordingTest, TruncatedLastLineIsTolerated) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir);
  // Cut each CSV inside its last record, as a SIGKILL during write(2) would.
  for (const char* name : {"imu.csv", "truth.csv", "segments.csv", "events.csv"}) {
    const fs::path p = dir / name;
    const auto size = fs::file_size(p);
    fs::resize_file(p, size - 3);
  }
  const Recording r = Recording::open(dir);
  EXPECT_EQ(r.dropped_partial_lines, 4u);
  ASSERT_EQ(r.samples.size(), w.samples.size() - 1);
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    expect_same_sample(r.samples[i], w.samples[i], i);
    if (HasFatalFailure()) return;
  }
  EXPECT_EQ(r.truth.size(), w.truth.size() - 1);
  EXPECT_EQ(r.segments.size(), 1u);
  ASSERT_EQ(r.events.size(), 3u);
  EXPECT_EQ(r.events[2].message, w.events[2].message);

  // Cut inside a quoted multi-line message: still only that record is lost.
  std::string ev = read_text(dir / "events.csv");
  const auto cut = ev.find("line two");
  ASSERT_NE(cut, std::string::npos);
  write_text(dir / "events.csv", ev.substr(0, cut + 4));
  const Recording r2 = Recording::open(dir);
  EXPECT_EQ(r2.events.size(), 2u);
  EXPECT_EQ(r2.dropped_partial_lines, 4u);

  // A file cut exactly at a line boundary loses nothing and drops nothing.
  std::string imu = read_text(dir / "imu.csv");
  imu.resize(imu.rfind('\n') + 1);
  write_text(dir / "imu.csv", imu);
  const Recording r3 = Recording::open(dir);
  EXPECT_EQ(r3.samples.size(), w.samples.size() - 1);
  EXPECT_EQ(r3.dropped_partial_lines, 3u);

  // Even the header line may be cut (killed right after creation).
  write_text(dir / "imu.csv", "t_s,ax_co");
  const Recording r4 = Recording::open(dir);
  EXPECT_TRUE(r4.samples.empty());
  EXPECT_EQ(r4.dropped_partial_lines, 4u);
}

TEST_F(RecordingTest, MissingOptionalFilesAreEmpty) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir);
  for (const char* f : {"truth.csv", "segments.csv", "events.csv", "experiment.yaml"}) {
    fs::remove(dir / f);
  }
  const Recording r = Recording::open(dir);
  EXPECT_EQ(r.samples.size(), w.samples.size());
  EXPECT_TRUE(r.truth.empty());
  EXPECT_TRUE(r.truth_t.empty());
  EXPECT_TRUE(r.segments.empty());
  EXPECT_TRUE(r.events.empty());
  EXPECT_TRUE(r.experiment_yaml.empty());

  fs::remove(dir / "imu.csv");
  EXPECT_THROW(Recording::open(dir), std::runtime_error);
  EXPECT_THROW(Recording::open(root_ / "does_not_exist"), std::runtime_error);
}

namespace {
// Expects Recording::open to throw a runtime_error whose message holds every needle.
void expect_open_error(const fs::path& dir, std::initializer_list<std::string> needles) {
  try {
    (void)Recording::open(dir);
    ADD_FAILURE() << "expected an error mentioning " << *needles.begin();
  } catch (const std::runtime_error& e) {
    for (const auto& n : needles) {
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos)
          << "'" << n << "' not in: " << e.what();
    }
  }
}
}  // namespace

TEST_F(RecordingTest, CorruptionInTheMiddleNamesFileAndLine) {
  const fs::path dir = root_ / "run";
  write_small(dir);
  const std::string imu = read_text(dir / "imu.csv");
  const std::string truth = read_text(dir / "truth.csv");
  const std::string seg = read_text(dir / "segments.csv");
  const std::string json = read_text(dir / "run.json");

  auto line_start = [](const std::string& s, int line) {  // 1-based
    std::size_t p = 0;
    for (int i = 1; i < line; ++i) p = s.find('\n', p) + 1;
    return p;
  };

  // A garbage value on line 100 of imu.csv.
  std::string bad = imu;
  bad[line_start(bad, 100) + 3] = 'x';
  write_text(dir / "imu.csv", bad);
  expect_open_error(dir, {"imu.csv:100:"});

  // A short row on line 57.
  bad = imu;
  const auto p57 = line_start(bad, 57);
  bad.erase(p57, bad.find('\n', p57) - p57);
  bad.insert(p57, "0.056,1,2");
  write_text(dir / "imu.csv", bad);
  expect_open_error(dir, {"imu.csv:57:", "16"});

  // A wrong header.
  write_text(dir / "imu.csv", "time,ax\n" + imu.substr(imu.find('\n') + 1));
  expect_open_error(dir, {"imu.csv:1:", "header"});
  write_text(dir / "imu.csv", imu);

  // A count that is not an integer names the column.
  bad = imu;
  const auto p3 = line_start(bad, 3);
  const auto c1 = bad.find(',', p3);
  bad.insert(c1 + 1, "1.5");
  write_text(dir / "imu.csv", bad);
  expect_open_error(dir, {"imu.csv:3:", "ax_counts"});
  write_text(dir / "imu.csv", imu);

  // truth.csv whose header disagrees with run.json.
  write_text(dir / "truth.csv", "t_s,a,b\n" + truth.substr(truth.find('\n') + 1));
  expect_open_error(dir, {"truth.csv:1:", "truth_columns"});
  bad = truth;
  bad.insert(line_start(bad, 5), "1,2\n");
  write_text(dir / "truth.csv", bad);
  expect_open_error(dir, {"truth.csv:5:"});
  write_text(dir / "truth.csv", truth);

  // segments.csv: a bad boolean on the second record.
  bad = seg;
  const auto q = bad.find(",0,0,\"table");
  ASSERT_NE(q, std::string::npos);
  bad.replace(q, 5, ",no,0,");
  write_text(dir / "segments.csv", bad);
  expect_open_error(dir, {"segments.csv:3:", "settled"});
  // segments.csv: a kind that is not a segment kind on the second record.
  bad = seg;
  const auto k = bad.find(",orientation,", line_start(bad, 3));
  ASSERT_NE(k, std::string::npos);
  bad.replace(k, 13, ",orientaton,");
  write_text(dir / "segments.csv", bad);
  expect_open_error(dir, {"segments.csv:3:", "kind", "orientaton"});
  // A stray quote in the middle of an unquoted field.
  write_text(dir / "segments.csv", seg.substr(0, line_start(seg, 2)) + "1,2,ab\"c\n" +
                                 seg.substr(line_start(seg, 2)));
  expect_open_error(dir, {"segments.csv:2:"});
  write_text(dir / "segments.csv", seg);

  // run.json: broken JSON names the line; a newer format is refused with advice.
  write_text(dir / "run.json", json.substr(0, 40) + "\n\n  ]" + json.substr(40));
  expect_open_error(dir, {"run.json:", "JSON"});
  auto j = nlohmann::json::parse(json);
  j["format_version"] = 99;
  write_text(dir / "run.json", j.dump(2));
  expect_open_error(dir, {"run.json", "99", "upgrade"});
  j = nlohmann::json::parse(json);
  j["sensor"]["info"]["output_rate_hz"] = "fast";
  write_text(dir / "run.json", j.dump(2));
  expect_open_error(dir, {"run.json", "sensor.info.output_rate_hz"});
  write_text(dir / "run.json", json);

  // experiment.yaml that is not YAML names file, line and column.
  write_text(dir / "experiment.yaml", "name: x\nprocedure: [a, b\n");
  expect_open_error(dir, {"experiment.yaml:"});
}

TEST_F(RecordingTest, TickFlushesAfterOneSecondOfRunTime) {
  const fs::path dir = root_ / "run";
  RecordingWriter w(dir, make_header(), "", kCsv);
  const auto header_size = fs::file_size(dir / "imu.csv");
  std::vector<ImuSample> s;
  for (std::uint64_t k = 1; k <= 3000; ++k) s.push_back(make_sample(k));
  w.add_samples(s.data(), 1);  // t = 0.001: the first data leaves at once
  w.tick(0.001);
  const auto after_first = fs::file_size(dir / "imu.csv");
  EXPECT_GT(after_first, header_size);
  w.add_samples(s.data() + 1, 899);  // up to t = 0.9
  w.tick(0.9);
  EXPECT_EQ(fs::file_size(dir / "imu.csv"), after_first);  // buffered (< 1 s since the flush)
  w.add_samples(s.data() + 900, 200);  // up to t = 1.1
  w.tick(1.1);
  EXPECT_GT(fs::file_size(dir / "imu.csv"), after_first);  // ≥ 1 s of run time: written
  EXPECT_EQ(Recording::open(dir).samples.size(), 1100u);  // readable while the writer lives

  // Events leave immediately.
  w.add_event({1.0, "info", "operator", "note"});
  const Recording r = Recording::open(dir);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_EQ(r.events[0].message, "note");

  // Wall time alone also flushes (a slow real-time run).
  w.add_samples(s.data() + 1100, 10);
  w.tick(1.11);
  const auto before = fs::file_size(dir / "imu.csv");
  std::this_thread::sleep_for(std::chrono::milliseconds(1050));
  w.add_samples(s.data() + 1110, 10);
  w.tick(1.12);
  EXPECT_GT(fs::file_size(dir / "imu.csv"), before);
}

// An import's writer flushes every N samples, never by the clock or by run time: the work is the
// same at any load.
TEST_F(RecordingTest, FlushEverySamplesIgnoresTheClock) {
  const fs::path dir = root_ / "run";
  stend::RecordingWriterOptions options = kCsv;
  options.flush_every_samples = 1000;
  RecordingWriter w(dir, make_header(), "", options);
  std::vector<ImuSample> s;
  for (std::uint64_t k = 1; k <= 3000; ++k) s.push_back(make_sample(k));
  w.add_samples(s.data(), 100);  // t up to 0.1
  const auto buffered = fs::file_size(dir / "imu.csv");
  std::this_thread::sleep_for(std::chrono::milliseconds(1050));
  w.add_samples(s.data() + 100, 50);  // > 1 s of wall time, < 1000 samples: still buffered
  w.tick(1.5);                        // and > 1 s of run time
  EXPECT_EQ(fs::file_size(dir / "imu.csv"), buffered);
  w.add_samples(s.data() + 150, 1850);  // 2000 samples: a flush due
  EXPECT_EQ(Recording::open(dir).samples.size(), 2000u);
}

// ---------------------------------------------------------------------------------------------
// SIGKILL: the child records at a simulated 1 kHz; after each tick(t) it publishes t (and the
// wall time) in shared memory. The parent kills it without warning and reads what is on disk.

namespace {

struct TickLog {
  std::atomic<double> last_tick{-1.0};
  std::atomic<int> n{0};
  static constexpr int kMax = 8192;
  double wall_s[kMax];
  double run_s[kMax];
};

// Never returns. Runs `batch` samples per tick, sleeping `sleep_us` between batches.
[[noreturn]] void child_record(const fs::path& dir, TickLog* log, int batch, int sleep_us,
                               const stend::RecordingWriterOptions& options = kCsv) {
  try {
    RecordingHeader h = make_header();
    h.clock = "wall";
    RecordingWriter w(dir, h, "name: killed\n", options);
    std::vector<ImuSample> buf(static_cast<std::size_t>(batch));
    std::uint64_t k = 0;
    for (;;) {
      for (auto& s : buf) s = make_sample(++k);
      w.add_samples(buf.data(), buf.size());
      const double t = static_cast<double>(k) / 1000.0;
      if (k % 200 == 0) w.add_truth(t, {0.0, 25.0, 9.8, 0.0});
      w.tick(t);
      log->last_tick.store(t, std::memory_order_release);
      const int i = log->n.load(std::memory_order_relaxed);
      if (i < TickLog::kMax) {
        log->wall_s[i] = monotonic_s();
        log->run_s[i] = t;
        log->n.store(i + 1, std::memory_order_release);
      }
      if (sleep_us > 0) ::usleep(static_cast<useconds_t>(sleep_us));
    }
  } catch (...) {
    ::_exit(3);
  }
}

struct Killed {
  Recording rec;
  double last_tick = -1.0;
  double kill_wall_s = 0.0;
  std::vector<std::pair<double, double>> ticks;  // (wall, run)
};

Killed run_and_kill(const fs::path& dir, int batch, int sleep_us, double run_wall_s) {
  void* mem = ::mmap(nullptr, sizeof(TickLog), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS,
                     -1, 0);
  if (mem == MAP_FAILED) throw std::runtime_error("mmap failed");
  auto* log = new (mem) TickLog();
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) child_record(dir, log, batch, sleep_us);

  // Wait for the first tick, then let it run.
  const double t0 = monotonic_s();
  while (log->last_tick.load() < 0.0 && monotonic_s() - t0 < 20.0) ::usleep(1000);
  const double started = monotonic_s();
  while (monotonic_s() - started < run_wall_s) ::usleep(5000);
  Killed k;
  k.kill_wall_s = monotonic_s();
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
      << "child ended otherwise (status " << status << ")";
  k.last_tick = log->last_tick.load();
  for (int i = 0; i < log->n.load(); ++i) k.ticks.emplace_back(log->wall_s[i], log->run_s[i]);
  ::munmap(mem, sizeof(TickLog));
  k.rec = Recording::open(dir);  // must not throw
  return k;
}

void expect_clean_samples(const Recording& r) {
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    // Every row on disk is exactly what the child generated, in order, strictly increasing.
    const ImuSample expected = make_sample(i + 1);
    expect_same_sample(r.samples[i], expected, i);
    if (::testing::Test::HasFatalFailure()) return;
    if (i > 0) {
      ASSERT_GT(r.samples[i].t_s, r.samples[i - 1].t_s);
    }
  }
}

}  // namespace

TEST_F(RecordingTest, SigkillLosesAtMostOneSecondOfRunTime) {
  // ~20x real time: 10 samples (10 ms) per tick, ~0.5 ms sleep.
  const fs::path dir = root_ / "killed";
  const Killed k = run_and_kill(dir, 10, 500, 0.8);
  const Recording& r = k.rec;
  EXPECT_EQ(r.header.status, stend::RunStatus::kRunning);
  EXPECT_FALSE(r.complete());
  EXPECT_EQ(r.experiment_yaml, "name: killed\n");
  EXPECT_LE(r.dropped_partial_lines, 2u);
  ASSERT_GT(k.last_tick, 1.0) << "the child did not get going";
  ASSERT_FALSE(r.samples.empty());
  expect_clean_samples(r);
  const double last = r.samples.back().t_s;
  EXPECT_GE(last, k.last_tick - 1.0) << "lost more than 1 s of run time";
  EXPECT_LE(last, k.last_tick + 1.0);  // nothing invented either
  for (std::size_t i = 0; i < r.truth_t.size(); ++i) ASSERT_LT(r.truth_t[i], last + 1.0);
  std::printf("[          ] killed at run time %.3f s; %zu samples survive, last at %.3f s\n",
              k.last_tick, r.samples.size(), last);
}

TEST_F(RecordingTest, SigkillLosesAtMostOneSecondOfWallTime) {
  // Slower than real time (a real bench waiting on a device): run time alone would not
  // reach 1 s before the kill, so only the wall-time rule can have written the data.
  const fs::path dir = root_ / "killed";
  const Killed k = run_and_kill(dir, 5, 20000, 2.3);
  const Recording& r = k.rec;
  EXPECT_EQ(r.header.status, stend::RunStatus::kRunning);
  ASSERT_FALSE(r.samples.empty());
  expect_clean_samples(r);
  // Whatever had been ticked more than ~1 s of wall time before the kill is on disk.
  // (0.25 s of slack for scheduling on a loaded machine.)
  double must_have = 0.0;
  for (const auto& [wall, run] : k.ticks) {
    if (wall <= k.kill_wall_s - 1.25) must_have = std::max(must_have, run);
  }
  ASSERT_GT(must_have, 0.1) << "the child did not get going";
  EXPECT_LT(k.last_tick, 1.0) << "run time passed 1 s: this test no longer isolates wall time";
  EXPECT_GE(r.samples.back().t_s, must_have);
  std::printf("[          ] killed at run time %.3f s; last sample %.3f s (needed >= %.3f)\n",
              k.last_tick, r.samples.back().t_s, must_have);
}

// ---------------------------------------------------------------------------------------------

TEST_F(RecordingTest, OneHourAtOneKilohertzWritesAndReadsBack) {
  constexpr std::size_t kRows = 3'600'000;
  const fs::path dir = root_ / "hour";
  // Generate one second at a time, as the runner would.
  std::vector<ImuSample> second(1000);
  using clock = std::chrono::steady_clock;
  clock::duration write_time{};
  std::uint64_t k = 0;
  {
    RecordingWriter w(dir, make_header(), "name: hour\n", kCsv);
    while (k < kRows) {
      for (auto& s : second) s = make_sample(++k);
      const auto t0 = clock::now();
      for (std::size_t b = 0; b < second.size(); b += 10) {
        w.add_samples(second.data() + b, 10);
        w.tick(second[b + 9].t_s);
      }
      write_time += clock::now() - t0;
    }
    const auto t0 = clock::now();
    w.finish(stend::RunStatus::kComplete);
    write_time += clock::now() - t0;
    EXPECT_EQ(w.sample_count(), kRows);
  }
  const auto t1 = clock::now();
  const Recording r = Recording::open(dir);
  const auto read_time = clock::now() - t1;
  ASSERT_EQ(r.samples.size(), kRows);
  EXPECT_TRUE(r.complete());
  for (std::size_t i = 0; i < kRows; ++i) {
    expect_same_sample(r.samples[i], make_sample(i + 1), i);
    if (HasFatalFailure()) return;
  }
  const double ws = std::chrono::duration<double>(write_time).count();
  const double rs = std::chrono::duration<double>(read_time).count();
  std::printf("[          ] %zu rows (%.0f MB): write %.1f ns/row (%.0fx real time), read %.1f "
              "ns/row\n",
              kRows, static_cast<double>(fs::file_size(dir / "imu.csv")) / 1e6,
              ws * 1e9 / kRows, 3600.0 / ws, rs * 1e9 / kRows);
}

// =============================================================================================
// The HDF5 run store (run.h5), the default format.

namespace {

const stend::RecordingWriterOptions kHdf5{stend::RecordingFormat::kHdf5};

std::string fmt_name(int i) { return "killed" + std::to_string(i); }

void expect_same_recording(const Recording& r, const Written& w) {
  ASSERT_EQ(r.sample_count(), w.samples.size());
  std::vector<ImuSample> got(w.samples.size());
  r.sample_source().read(0, got.size(), got.data());
  for (std::size_t i = 0; i < got.size(); ++i) {
    expect_same_sample(got[i], w.samples[i], i);
    if (::testing::Test::HasFatalFailure()) return;
  }
  ASSERT_EQ(r.truth_t.size(), w.truth_t.size());
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    EXPECT_TRUE(same(r.truth_t[i], w.truth_t[i]));
    for (std::size_t k = 0; k < w.truth[i].size(); ++k) EXPECT_TRUE(same(r.truth[i][k], w.truth[i][k]));
  }
  ASSERT_EQ(r.segments.size(), w.segments.size());
  for (std::size_t i = 0; i < w.segments.size(); ++i) EXPECT_TRUE(r.segments[i].equals(w.segments[i], 0.0));
  ASSERT_EQ(r.events.size(), w.events.size());
  for (std::size_t i = 0; i < w.events.size(); ++i) EXPECT_EQ(r.events[i].message, w.events[i].message);
}

// A 1 kHz MPU-class stream whose SI values are the counts converted (as a sensor does):
// white noise of a few counts on each axis, a slowly warming die.
ImuSample mpu_sample(std::uint64_t k) {
  const RecordingHeader h = make_header();
  ImuSample s;
  s.t_s = static_cast<double>(k) / 1000.0;
  std::uint64_t x = splitmix(k);
  auto noise = [&x](int spread) {
    x = splitmix(x);
    return static_cast<std::int32_t>(x % static_cast<std::uint64_t>(2 * spread + 1)) - spread;
  };
  for (int i = 0; i < 3; ++i) {
    s.accel_counts[i] = noise(12) + (i == 2 ? 16384 : 40);
    s.gyro_counts[i] = noise(6) - 20;
    s.accel_mps2[i] = s.accel_counts[i] * h.info.accel_lsb_mps2;
    s.gyro_radps[i] = s.gyro_counts[i] * h.info.gyro_lsb_radps;
  }
  s.temperature_counts = -3000 + static_cast<std::int32_t>(k / 5000) + noise(1);
  s.temperature_c = s.temperature_counts * h.info.temperature_lsb_c + 36.53;
  return s;
}

}  // namespace

TEST_F(RecordingTest, Hdf5RoundTripIsExact) {
  const fs::path dir = root_ / "run";
  stend::RecordingWriterOptions o;  // the default format
  ASSERT_EQ(o.format, stend::RecordingFormat::kHdf5);
  const Written w = [&] {
    // write_small writes CSV; do the same through the default writer.
    Written x = write_small(root_ / "csv");
    RecordingWriter writer(dir, x.header, x.yaml);
    writer.add_samples(x.samples.data(), x.samples.size());
    for (std::size_t i = 0; i < x.truth.size(); ++i) writer.add_truth(x.truth_t[i], x.truth[i]);
    for (const auto& s : x.segments) writer.add_segment(s);
    for (const auto& ev : x.events) writer.add_event(ev);
    writer.finish(stend::RunStatus::kComplete, "all steps done");
    return x;
  }();
  EXPECT_TRUE(fs::exists(dir / "run.h5"));
  EXPECT_FALSE(fs::exists(dir / "imu.csv"));
  for (auto loading : {stend::SampleLoading::kInMemory, stend::SampleLoading::kStream}) {
    const Recording r = Recording::open(dir, loading);
    EXPECT_EQ(r.format, stend::RecordingFormat::kHdf5);
    EXPECT_TRUE(r.complete());
    EXPECT_EQ(r.experiment_yaml, w.yaml);
    EXPECT_EQ(r.header.seed, w.header.seed);
    EXPECT_EQ(r.header.experiment_name, w.header.experiment_name);
    EXPECT_EQ(r.header.truth_columns, w.header.truth_columns);
    EXPECT_EQ(r.header.mounting_R, w.header.mounting_R);
    EXPECT_TRUE(r.damage.empty()) << r.damage;
    EXPECT_EQ(loading == stend::SampleLoading::kStream, r.source != nullptr);
    expect_same_recording(r, w);
  }
  // read_column reads one column and gives what read() gives.
  const Recording r = Recording::open(dir, stend::SampleLoading::kStream);
  for (auto c : {stend::Channel::kTime, stend::Channel::kAx, stend::Channel::kGz, stend::Channel::kTemperature}) {
    std::vector<double> col(1500);
    r.source->read_column(c, 300, col.size(), col.data());
    for (std::size_t i = 0; i < col.size(); ++i)
      ASSERT_TRUE(same(col[i], stend::value_of(w.samples[300 + i], c))) << stend::to_string(c) << " " << i;
  }
}

TEST_F(RecordingTest, Hdf5StoresCountsInNativeWidthAndDerivesSi) {
  const fs::path dir = root_ / "run";
  constexpr std::uint64_t kN = 200'000;
  std::vector<ImuSample> s;
  for (std::uint64_t k = 1; k <= kN; ++k) s.push_back(mpu_sample(k));
  s[70'000].accel_counts[0] = 40'000;  // beyond int16: kept exactly as an exception
  s[70'001].gyro_radps[2] = 0.5;       // SI that is not f(counts): kept exactly too
  {
    RecordingWriter w(dir, make_header(), "name: mpu\n");
    for (std::size_t b = 0; b < s.size(); b += 10) w.add_samples(s.data() + b, 10);
    w.finish(stend::RunStatus::kComplete);
  }
  expect_streams_back(dir, s);
  if (HasFatalFailure()) return;
  const double bytes_per_sample = static_cast<double>(fs::file_size(dir / "run.h5")) / kN;
  std::printf("[          ] %llu samples: %.2f bytes per sample on disk\n",
              static_cast<unsigned long long>(kN), bytes_per_sample);
  EXPECT_LE(bytes_per_sample, 20.0);
}

TEST_F(RecordingTest, Hdf5KeepsSiOnlyChannels) {
  // An import: SI values with no counts and no LSB sizes.
  const fs::path dir = root_ / "run";
  RecordingHeader h = make_header();
  h.info.accel_lsb_mps2 = h.info.gyro_lsb_radps = h.info.temperature_lsb_c = 0.0;
  std::vector<ImuSample> s;
  for (std::uint64_t k = 1; k <= 5000; ++k) {
    ImuSample x = mpu_sample(k);
    x.accel_counts[0] = x.accel_counts[1] = x.accel_counts[2] = 0;
    x.accel_mps2[0] += 1e-7 * static_cast<double>(k);
    s.push_back(x);
  }
  {
    RecordingWriter w(dir, h, "");
    w.add_samples(s.data(), s.size());
  }  // not finished: still "running"
  const Recording r = Recording::open(dir);
  EXPECT_EQ(r.header.status, stend::RunStatus::kRunning);
  ASSERT_EQ(r.samples.size(), s.size());
  for (std::size_t i = 0; i < s.size(); ++i) expect_same_sample(r.samples[i], s[i], i);
}

TEST_F(RecordingTest, Hdf5KilledBeforeTheFirstSampleHasNone) {
  const fs::path dir = root_ / "run";
  {
    RecordingWriter w(dir, make_header(), "name: x\n");
    w.add_event({0.0, "info", "runner", "start"});
  }  // no samples ever came: run.h5 was never created
  const Recording r = Recording::open(dir, stend::SampleLoading::kStream);
  EXPECT_EQ(r.header.status, stend::RunStatus::kRunning);
  EXPECT_EQ(r.sample_count(), 0u);
}

TEST_F(RecordingTest, Hdf5SurvivesAHundredSigkills) {
  // 1 kHz in real time (10 samples every 10 ms, a wall-clock bench), killed after a random
  // 0.2–1.5 s; ten writers at a time. Every file reopens, says "running", holds the samples in
  // order exactly as written, and lost at most about one second of wall time.
  constexpr int kKills = 100, kParallel = 10;
  std::uint64_t seed = 12345;
  int reopened = 0;
  double worst_loss_s = 0.0;
  for (int round = 0; round < kKills / kParallel; ++round) {
    struct Child {
      pid_t pid;
      TickLog* log;
      fs::path dir;
      double kill_after_s, started = 0.0, kill_wall_s = 0.0;
      bool killed = false;
    };
    std::vector<Child> children;
    for (int c = 0; c < kParallel; ++c) {
      void* mem = ::mmap(nullptr, sizeof(TickLog), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
      ASSERT_NE(mem, MAP_FAILED);
      auto* log = new (mem) TickLog();
      seed = splitmix(seed);
      const fs::path dir = root_ / fmt_name(round * kParallel + c);
      std::fflush(nullptr);
      const pid_t pid = ::fork();
      ASSERT_GE(pid, 0);
      if (pid == 0) child_record(dir, log, 10, 10'000, kHdf5);
      children.push_back({pid, log, dir, 0.2 + 1.3 * static_cast<double>(seed % 1000) / 1000.0});
    }
    const double t0 = monotonic_s();
    for (std::size_t left = children.size(); left > 0;) {
      ::usleep(2000);
      for (Child& c : children) {
        if (c.killed) continue;
        if (c.started == 0.0 && c.log->last_tick.load() >= 0.0) c.started = monotonic_s();
        if ((c.started > 0.0 && monotonic_s() - c.started >= c.kill_after_s) || monotonic_s() - t0 > 30.0) {
          c.kill_wall_s = monotonic_s();
          ::kill(c.pid, SIGKILL);
          c.killed = true;
          --left;
        }
      }
    }
    for (Child& c : children) {
      int status = 0;
      ::waitpid(c.pid, &status, 0);
      EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << c.dir << " status " << status;
      double must_have = 0.0;  // run time ticked ≥ 1 s (+0.25 s scheduling slack) before the kill
      for (int i = 0; i < c.log->n.load(); ++i)
        if (c.log->wall_s[i] <= c.kill_wall_s - 1.25) must_have = std::max(must_have, c.log->run_s[i]);
      const double last_tick = c.log->last_tick.load();
      ::munmap(c.log, sizeof(TickLog));
      Recording r;
      try {
        r = Recording::open(c.dir);
      } catch (const std::exception& e) {
        ADD_FAILURE() << c.dir << " does not reopen: " << e.what();
        continue;
      }
      ++reopened;
      EXPECT_EQ(r.header.status, stend::RunStatus::kRunning) << c.dir;
      EXPECT_TRUE(r.damage.empty()) << c.dir << ": " << r.damage;
      expect_clean_samples(r);
      const double last = r.samples.empty() ? 0.0 : r.samples.back().t_s;
      EXPECT_GE(last, must_have) << c.dir << ": lost more than ~1 s";
      EXPECT_LE(last, last_tick + 1e-9) << c.dir;
      worst_loss_s = std::max(worst_loss_s, last_tick - last);
    }
  }
  EXPECT_EQ(reopened, kKills);
  std::printf("[          ] %d kills, every file reopened; worst loss %.3f s of run time\n", kKills,
              worst_loss_s);
}

namespace {

// A finished 1 kHz MPU-class run of `n` samples in `dir`; returns the samples written.
std::vector<ImuSample> write_mpu_run(const fs::path& dir, std::uint64_t n) {
  std::vector<ImuSample> s;
  for (std::uint64_t k = 1; k <= n; ++k) s.push_back(mpu_sample(k));
  RecordingWriter w(dir, make_header(), "name: mpu\n");
  for (std::size_t b = 0; b < s.size(); b += 100) w.add_samples(s.data() + b, std::min<std::size_t>(100, s.size() - b));
  w.add_event({1.0, "info", "runner", "start"});
  w.finish(stend::RunStatus::kComplete);
  return s;
}

// Opens a damaged copy: either a clear error naming run.h5, or a recording whose readable samples
// are exactly those written (reading them all succeeds or fails with an error naming the damage).
// Returns the readable sample count, or -1 when the file does not open.
long long open_damaged(const fs::path& dir, const std::vector<ImuSample>& written) {
  Recording r;
  try {
    r = Recording::open(dir, stend::SampleLoading::kStream);
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "run.h5").string()), std::string::npos) << e.what();
    return -1;
  }
  const auto& src = r.sample_source();
  EXPECT_LE(src.size(), written.size());
  EXPECT_EQ(r.written_samples, written.size());
  if (src.size() < written.size()) {
    EXPECT_FALSE(r.damage.empty());
  }
  std::vector<ImuSample> got(stend::kDefaultChunkSamples);
  for (std::uint64_t first = 0; first < src.size(); first += got.size()) {
    const std::size_t n = std::min<std::uint64_t>(got.size(), src.size() - first);
    try {
      src.read(first, n, got.data());
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("run.h5"), std::string::npos) << what;
      EXPECT_NE(what.find("damaged"), std::string::npos) << what;
      return static_cast<long long>(first);
    }
    for (std::size_t i = 0; i < n; ++i) {
      expect_same_sample(got[i], written[first + i], first + i);  // never wrong numbers
      if (::testing::Test::HasFatalFailure()) return static_cast<long long>(first);
    }
  }
  return static_cast<long long>(src.size());
}

}  // namespace

TEST_F(RecordingTest, Hdf5TruncatedFileKeepsTheSamplesBeforeTheCut) {
  const fs::path dir = root_ / "run";
  const auto written = write_mpu_run(dir, 300'000);
  const auto size = fs::file_size(dir / "run.h5");
  int opened = 0;
  for (double frac : {0.99, 0.9, 0.75, 0.5, 0.3, 0.1, 0.001}) {
    const fs::path cut = root_ / ("cut" + std::to_string(static_cast<int>(frac * 1000)));
    fs::copy(dir, cut);
    fs::resize_file(cut / "run.h5", static_cast<std::uintmax_t>(static_cast<double>(size) * frac));
    const long long readable = open_damaged(cut, written);
    std::printf("[          ] cut at %.1f %%: %lld samples readable\n", frac * 100, readable);
    if (HasFatalFailure()) return;
    if (readable >= 0) {
      ++opened;
      // Roughly what lies before the cut is kept (the samples are most of the file).
      if (frac >= 0.3) {
        EXPECT_GE(static_cast<double>(readable), (frac - 0.3) * static_cast<double>(written.size())) << frac;
      }
    }
  }
  EXPECT_GE(opened, 4) << "a cut in the samples should leave the file readable";
}

TEST_F(RecordingTest, Hdf5FlippedBytesAreAnErrorNeverWrongNumbers) {
  const fs::path dir = root_ / "run";
  const auto written = write_mpu_run(dir, 300'000);
  const auto size = fs::file_size(dir / "run.h5");
  int detected = 0;
  for (int k = 1; k <= 9; ++k) {
    const fs::path bad = root_ / ("flip" + std::to_string(k));
    fs::copy(dir, bad);
    std::string bytes = read_text(bad / "run.h5");
    const std::size_t at = size * static_cast<std::size_t>(k) / 10;
    for (std::size_t i = at; i < at + 16 && i < bytes.size(); ++i) bytes[i] = static_cast<char>(~bytes[i]);
    write_text(bad / "run.h5", bytes);
    const long long readable = open_damaged(bad, written);
    if (HasFatalFailure()) return;
    detected += readable < static_cast<long long>(written.size());
  }
  EXPECT_GE(detected, 7) << "flipped bytes in the samples should be reported";
}

TEST_F(RecordingTest, Hdf5RunReadsWithH5pyAlone) {
  // Debian's python3 (h5py and numpy are Debian packages), else the first python3 on PATH.
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  if (stend::testing::run_command(python + " -c 'import h5py, numpy' 2>&1").code != 0)
    GTEST_SKIP() << "python3-h5py / python3-numpy are not installed (scripts/install-deps.sh installs them)";
  const fs::path dir = root_ / "run";
  auto written = write_mpu_run(dir, 150'000);
  // The reading recipe of docs/recording-format.md: counts·lsb + offset, then the exceptions.
  const std::string script = R"(
import json, sys, h5py, numpy as np
names = ["ax", "ay", "az", "gx", "gy", "gz", "temp"]
with h5py.File(sys.argv[1], "r", swmr=True) as f:
    g = f["samples"]
    print(f["status"][()].decode(), g["t_s"].shape[0])
    header = json.loads(f.attrs["header_json"])
    print(f.attrs["format"].decode(), int(f.attrs["format_version"]), header["sensor"]["info"]["output_rate_hz"])
    for k, name in enumerate(names):
        d = g[name + "_counts"]
        v = d[:] * d.attrs["lsb"] + d.attrs["offset"]
        for i, ch, c, x in g["exceptions"][:]:
            if int(ch) == k: v[int(i)] = x
        print(name, repr(float(np.sum(v))), repr(float(v[-1])))
    print("t_s", repr(float(np.sum(g["t_s"][:]))))
)";
  write_text(root_ / "read.py", script);
  const auto out = stend::testing::run_command(python + " " + (root_ / "read.py").string() + " " +
                                               (dir / "run.h5").string() + " 2>&1");
  ASSERT_EQ(out.code, 0) << out.text;
  std::istringstream in(out.text);
  std::string status, name;
  std::uint64_t n = 0;
  in >> status >> n;
  EXPECT_EQ(status, "complete");
  std::string format;
  int version = 0;
  double rate_hz = 0.0;
  in >> format >> version >> rate_hz;  // the string attributes as the recipe reads them
  EXPECT_EQ(format, "stend-run");
  EXPECT_EQ(version, 2);
  EXPECT_EQ(rate_hz, make_header().info.output_rate_hz);
  const Recording r = Recording::open(dir, stend::SampleLoading::kStream);
  ASSERT_EQ(n, r.sample_count());
  for (auto c : {stend::Channel::kAx, stend::Channel::kAy, stend::Channel::kAz, stend::Channel::kGx,
                 stend::Channel::kGy, stend::Channel::kGz, stend::Channel::kTemperature}) {
    const auto col = stend::read_column(r.sample_source(), c, 0, n);
    double sum = 0.0;
    for (double v : col) sum += v;
    double py_sum = 0.0, py_last = 0.0;
    in >> name >> py_sum >> py_last;
    EXPECT_NEAR(py_sum, sum, 1e-9 * std::abs(sum) + 1e-9) << name;
    EXPECT_EQ(py_last, col.back()) << name;  // the same formula, bit for bit
  }
  double py_t = 0.0, t = 0.0;
  in >> name >> py_t;
  for (double v : stend::read_column(r.sample_source(), stend::Channel::kTime, 0, n)) t += v;
  EXPECT_NEAR(py_t, t, 1e-9 * t);
}

TEST_F(RecordingTest, Hdf5SmallReadsFromHeldChunksGiveTheSamplesAndTruthWritten) {
  // Small reads are served from whole chunks kept by the source (hdf5_sources.cpp): reads of every
  // size, inside a chunk and across chunk boundaries, from four threads at once, give what was
  // written; so do truth rows and the time searches over them.
  const fs::path dir = root_ / "run";
  constexpr std::uint64_t kN = 3 * 65'536 + 1'000;
  std::vector<ImuSample> s;
  for (std::uint64_t k = 1; k <= kN; ++k) s.push_back(mpu_sample(k));
  RecordingHeader h = make_header();
  h.truth_columns = {"a", "b"};
  constexpr std::uint64_t kTruthRows = 20'000;  // 10 Hz, many chunks of /truth
  {
    RecordingWriter w(dir, h, "name: small reads\n");
    w.add_samples(s.data(), s.size());
    for (std::uint64_t i = 0; i < kTruthRows; ++i) w.add_truth(0.1 * static_cast<double>(i), {static_cast<double>(i), -static_cast<double>(i)});
    w.finish(stend::RunStatus::kComplete);
  }
  const Recording r = Recording::open(dir, stend::SampleLoading::kStream, stend::TruthLoading::kStream);
  ASSERT_TRUE(r.source && r.truth_store);
  std::atomic<int> wrong{0};
  auto reader = [&](std::uint64_t seed) {
    std::uint64_t x = seed;
    std::vector<ImuSample> got;
    std::vector<double> col;
    for (int k = 0; k < 400; ++k) {
      x = splitmix(x);
      const std::size_t count = 1 + static_cast<std::size_t>(x % (k % 4 == 0 ? 40'000 : 300));
      const std::uint64_t first = splitmix(x) % (kN - count);
      got.resize(count);
      col.resize(count);
      r.source->read(first, count, got.data());
      r.source->read_column(stend::Channel::kTime, first, count, col.data());
      for (std::size_t i = 0; i < count; ++i) {
        const ImuSample& w = s[static_cast<std::size_t>(first) + i];
        wrong += got[i].t_s != w.t_s || col[i] != w.t_s || got[i].accel_counts[2] != w.accel_counts[2] ||
                 got[i].gyro_radps[1] != w.gyro_radps[1] || got[i].temperature_c != w.temperature_c;
      }
      const double t = 0.1 * static_cast<double>(splitmix(x + 1) % (kTruthRows - 3));
      const stend::TruthRows rows = stend::truth_rows_in(*r.truth_store, t, t + 0.25);
      wrong += rows.lo != static_cast<std::uint64_t>(std::llround(t / 0.1)) || rows.hi - rows.lo != 3;
      wrong += r.truth_store->time(rows.lo) != 0.1 * static_cast<double>(rows.lo);
    }
  };
  std::vector<std::thread> threads;
  for (std::uint64_t t = 1; t <= 4; ++t) threads.emplace_back(reader, t);
  for (auto& t : threads) t.join();
  EXPECT_EQ(wrong.load(), 0);
}

// Stend's Fletcher-32 (eight words at a time) is HDF5's word-by-word H5_checksum_fletcher32 for
// every length — odd, shorter than one step, across 360-word blocks — and for the largest words.
TEST(Hdf5Fletcher32, EqualsTheWordByWordChecksumForEveryLength) {
  const auto word_by_word = [](const unsigned char* p, std::size_t size) {  // H5checksum.c
    std::uint32_t sum1 = 0, sum2 = 0;
    for (std::size_t len = size / 2; len > 0;) {
      std::size_t block = std::min<std::size_t>(len, 360);
      len -= block;
      for (; block > 0; --block, p += 2) {
        sum1 += static_cast<std::uint32_t>(p[0]) << 8 | p[1];
        sum2 += sum1;
      }
      sum1 = (sum1 & 0xffff) + (sum1 >> 16);
      sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    }
    if (size % 2 != 0) {
      sum1 += static_cast<std::uint32_t>(p[0]) << 8;
      sum2 += sum1;
      sum1 = (sum1 & 0xffff) + (sum1 >> 16);
      sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    }
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
    return sum2 << 16 | sum1;
  };
  std::mt19937 rng(32);
  std::vector<unsigned char> random(5000), ones(5000, 0xff);
  for (auto& b : random) b = static_cast<unsigned char>(rng());
  for (std::size_t size = 0; size <= random.size(); size += size < 1500 ? 1 : 97) {
    ASSERT_EQ(stend::detail::hdf5_fletcher32(random.data(), size), word_by_word(random.data(), size)) << size;
    ASSERT_EQ(stend::detail::hdf5_fletcher32(ones.data(), size), word_by_word(ones.data(), size)) << size;
  }
}

TEST_F(RecordingTest, Hdf5ChunksEncodedByStendAreStandardShuffleDeflateFletcher32) {
  // Whole sample chunks are encoded by the writer itself (hdf5_chunks.hpp); any HDF5 reader must
  // decode them as its own: h5py reads every column (libhdf5 checks each chunk's Fletcher-32), and
  // each chunk's stored bytes are the dataset's values shuffled and deflated, all filters applied.
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  if (stend::testing::run_command(python + " -c 'import h5py, numpy' 2>&1").code != 0)
    GTEST_SKIP() << "python3-h5py / python3-numpy are not installed (scripts/install-deps.sh installs them)";
  constexpr std::uint64_t kN = 3 * 65'536 + 777;  // three whole chunks and a partial one
  RecordingHeader si_only = make_header();        // an import: SI values, compressed float64
  si_only.info.accel_lsb_mps2 = si_only.info.gyro_lsb_radps = si_only.info.temperature_lsb_c = 0.0;
  for (const auto& [name, header] : {std::pair{"counts", make_header()}, std::pair{"si", si_only}}) {
    const fs::path dir = root_ / name;
    std::vector<ImuSample> s;
    for (std::uint64_t k = 1; k <= kN; ++k) s.push_back(mpu_sample(k));
    for (auto& x : s) {  // an import's SI values come without counts: chunks of zeros beside them
      if (name != std::string("si")) break;
      std::fill(std::begin(x.accel_counts), std::end(x.accel_counts), 0);
      std::fill(std::begin(x.gyro_counts), std::end(x.gyro_counts), 0);
      x.temperature_counts = 0;
    }
    {
      RecordingWriter w(dir, header, "name: chunks\n");
      w.add_samples(s.data(), 1000);
      w.flush();  // mid-chunk: the next chunks are still written whole, at their boundaries
      w.add_samples(s.data() + 1000, s.size() - 1000);
      w.finish(stend::RunStatus::kComplete);
    }
    expect_streams_back(dir, s);
    if (HasFatalFailure()) return;
    const std::string script = R"(
import sys, zlib, h5py, numpy as np
with h5py.File(sys.argv[1], "r") as f:
    for name, d in f["samples"].items():
        if d.shape[0] < 65536: continue
        values = d[:]  # libhdf5 decodes every chunk and checks its Fletcher-32
        chunks = d.id.get_num_chunks()
        assert chunks == -(-d.shape[0] // 65536), (name, chunks)
        for i in range(chunks - 1):  # the whole chunks
            info = d.id.get_chunk_info(i)
            mask, raw = d.id.read_direct_chunk(info.chunk_offset)
            assert mask == 0, (name, i, mask)  # every filter applied
            body = raw[:-4] if d.fletcher32 else raw
            want = values[info.chunk_offset[0]:info.chunk_offset[0] + 65536]
            if d.compression == "gzip":
                assert d.shuffle, name
                plain = np.frombuffer(zlib.decompress(body), np.uint8)
                body = plain.reshape(d.dtype.itemsize, -1).T.tobytes()  # unshuffled
                assert len(raw) < want.nbytes, (name, len(raw), want.nbytes)
            assert body == want.tobytes(), (name, i)
        print(name, chunks, d.compression)
)";
    write_text(root_ / "chunks.py", script);
    const auto out = stend::testing::run_command(python + " " + (root_ / "chunks.py").string() + " " +
                                                 (dir / "run.h5").string() + " 2>&1");
    ASSERT_EQ(out.code, 0) << name << ": " << out.text;
    EXPECT_NE(out.text.find("t_s 4 gzip"), std::string::npos) << out.text;
    EXPECT_NE(out.text.find(std::string("ax_") + (name == std::string("si") ? "mps2 4 gzip" : "counts 4 None")),
              std::string::npos)
        << out.text;
  }
}

TEST_F(RecordingTest, Hdf5ExportsToTheCsvLayoutAndBack) {
  // HDF5 → CSV (what `stend export --to csv` does) → HDF5: the same recording at every step.
  const fs::path h5 = root_ / "h5";
  Written w = write_small(root_ / "csv0");
  {
    RecordingWriter writer(h5, w.header, w.yaml);
    writer.add_samples(w.samples.data(), w.samples.size());
    for (std::size_t i = 0; i < w.truth.size(); ++i) writer.add_truth(w.truth_t[i], w.truth[i]);
    for (const auto& s : w.segments) writer.add_segment(s);
    for (const auto& ev : w.events) writer.add_event(ev);
    writer.finish(stend::RunStatus::kInterrupted, "operator");
  }
  stend::write_recording(Recording::open(h5, stend::SampleLoading::kStream), root_ / "csv", kCsv);
  for (const char* f : {"run.json", "experiment.yaml", "imu.csv", "truth.csv", "segments.csv", "events.csv"})
    EXPECT_TRUE(fs::exists(root_ / "csv" / f)) << f;
  EXPECT_EQ(read_text(root_ / "csv" / "segments.csv"), read_text(root_ / "csv0" / "segments.csv"));
  EXPECT_EQ(read_text(root_ / "csv" / "imu.csv"), read_text(root_ / "csv0" / "imu.csv"));
  const Recording c = Recording::open(root_ / "csv");
  EXPECT_EQ(c.format, stend::RecordingFormat::kCsv);
  EXPECT_EQ(c.header.status, stend::RunStatus::kInterrupted);
  expect_same_recording(c, w);
  stend::write_recording(c, root_ / "h5again", kHdf5);
  expect_same_recording(Recording::open(root_ / "h5again"), w);
}

// --- Strict reading: quoting, column counts, rows and bytes against run.json -------------------

namespace {
// Position of the first byte of `line` (1-based) in `s`.
std::size_t line_start(const std::string& s, int line) {
  std::size_t p = 0;
  for (int i = 1; i < line; ++i) p = s.find('\n', p) + 1;
  return p;
}
}  // namespace

TEST_F(RecordingTest, UnterminatedQuoteIsAnErrorWhereItOpened) {
  const fs::path dir = root_ / "run";
  write_small(dir);
  const std::string seg = read_text(dir / "segments.csv");
  // A quote opening the label of the first segment (line 2) is never closed: the rest of the file
  // would be one field. The file still ends with its line feed, so this is not a cut write.
  std::string bad = seg;
  const auto label = bad.find(",set_temperature,", line_start(bad, 2)) + 17;
  bad.insert(label, "\"");
  ASSERT_EQ(std::count(bad.begin(), bad.end(), '"') % 2, 1);
  write_text(dir / "segments.csv", bad);
  expect_open_error(dir, {"segments.csv:2:", "double quote"});
  // Alone in the file, the quote runs to the end.
  write_text(dir / "segments.csv", seg.substr(0, line_start(seg, 2)) +
                                       "0,0,record,\"a,0,-1,0,1,2,1,1,,,\n1,0,record,b,0,-1,0,2,3,1,1,,,\n");
  expect_open_error(dir, {"segments.csv:2:", "unterminated double quote"});
  // The same quote in events.csv.
  write_text(dir / "segments.csv", seg);
  const std::string ev = read_text(dir / "events.csv");
  write_text(dir / "events.csv", ev.substr(0, line_start(ev, 3)) + "0.5,info,\"runner,x\n" +
                                     ev.substr(line_start(ev, 3)));
  expect_open_error(dir, {"events.csv:3:"});
}

TEST_F(RecordingTest, ExtraOrMissingColumnsNameFileLineAndCount) {
  const fs::path dir = root_ / "run";
  write_small(dir);
  const std::string imu = read_text(dir / "imu.csv");
  std::string bad = imu;
  bad.insert(bad.find('\n', line_start(bad, 40)), ",7");
  write_text(dir / "imu.csv", bad);
  expect_open_error(dir, {"imu.csv:40:", "expected 16", "found 17"});
  write_text(dir / "imu.csv", imu);
  const std::string seg = read_text(dir / "segments.csv");
  write_text(dir / "segments.csv", seg + "7,1,record,x,0,-1,0,1,2,1,1,,,,extra\n");
  expect_open_error(dir, {"segments.csv:", "expected 14 fields, found 15"});
  write_text(dir / "segments.csv", seg);
  const std::string ev = read_text(dir / "events.csv");
  write_text(dir / "events.csv", ev + "4,info,runner\n");
  expect_open_error(dir, {"events.csv:", "expected 4 fields, found 3"});
}

TEST_F(RecordingTest, LongLinesAreCutInMessages) {
  const fs::path dir = root_ / "run";
  write_small(dir);
  const std::string imu = read_text(dir / "imu.csv");
  std::string bad = imu;
  bad.insert(line_start(bad, 5), std::string(1'000'000, '7') + "x");
  write_text(dir / "imu.csv", bad);
  try {
    (void)Recording::open(dir);
    ADD_FAILURE() << "a garbage row was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("imu.csv:5:"), std::string::npos) << e.what();
    EXPECT_LT(std::strlen(e.what()), 400u);
    EXPECT_NE(std::string(e.what()).find("bytes)"), std::string::npos) << e.what();
  }
}

TEST_F(RecordingTest, RunJsonRecordsRowsAndBytesOfEveryFile) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir);
  const auto j = nlohmann::json::parse(read_text(dir / "run.json"));
  EXPECT_EQ(j.at("sample_count").get<std::uint64_t>(), w.samples.size());
  for (const char* name : {"imu.csv", "truth.csv", "segments.csv", "events.csv"})
    EXPECT_EQ(j.at("file_bytes").at(name).get<std::uint64_t>(), fs::file_size(dir / name)) << name;
  const Recording r = Recording::open(dir);
  EXPECT_TRUE(r.damage.empty()) << r.damage;
  EXPECT_EQ(r.written_samples, w.samples.size());
}

TEST_F(RecordingTest, TruncatedFinishedRunIsDamagedAndSaysWhatIsReadable) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir);
  const std::string imu = read_text(dir / "imu.csv");
  // Cut at 56 % on a line boundary: every line left is whole, only the counts can tell.
  const std::size_t cut = imu.rfind('\n', imu.size() * 56 / 100) + 1;
  const auto whole = static_cast<std::size_t>(std::count(imu.begin(), imu.begin() + static_cast<std::ptrdiff_t>(cut), '\n')) - 1;
  write_text(dir / "imu.csv", imu.substr(0, cut));
  Recording r = Recording::open(dir);
  EXPECT_EQ(r.sample_count(), whole);
  EXPECT_EQ(r.written_samples, w.samples.size());
  EXPECT_NE(r.damage.find("imu.csv:" + std::to_string(whole + 1) + ":"), std::string::npos) << r.damage;
  EXPECT_NE(r.damage.find("run.json records 2000 rows, " + std::to_string(whole) + " whole rows found"),
            std::string::npos) << r.damage;
  EXPECT_NE(r.damage.find("bytes"), std::string::npos) << r.damage;
  // Cut mid-line: the cut line is named.
  write_text(dir / "imu.csv", imu.substr(0, cut + 20));
  r = Recording::open(dir);
  EXPECT_EQ(r.sample_count(), whole);
  EXPECT_NE(r.damage.find("imu.csv:" + std::to_string(whole + 2) + ": the last line is cut mid-line"),
            std::string::npos) << r.damage;
  // Rows appended after finish are damage too.
  write_text(dir / "imu.csv", imu + imu.substr(line_start(imu, 2), line_start(imu, 3) - line_start(imu, 2)));
  r = Recording::open(dir, stend::SampleLoading::kStream, stend::TruthLoading::kSkip);
  EXPECT_EQ(r.sample_count(), w.samples.size() + 1);
  EXPECT_NE(r.damage.find("run.json records 2000 rows, 2001"), std::string::npos) << r.damage;
  // A missing file that run.json says holds rows.
  write_text(dir / "imu.csv", imu);
  fs::remove(dir / "segments.csv");
  r = Recording::open(dir);
  EXPECT_NE(r.damage.find("segments.csv: missing; run.json records 2 rows"), std::string::npos) << r.damage;
}

TEST_F(RecordingTest, RunFoldersWithoutCountsStillRead) {
  const fs::path dir = root_ / "run";
  const Written w = write_small(dir);
  // run.json as the writer of earlier versions left it: no byte lengths; and with no counts at all.
  auto j = nlohmann::json::parse(read_text(dir / "run.json"));
  j.erase("file_bytes");
  write_text(dir / "run.json", j.dump(2));
  Recording r = Recording::open(dir);
  EXPECT_TRUE(r.damage.empty()) << r.damage;
  EXPECT_EQ(r.samples.size(), w.samples.size());
  for (const char* key : {"sample_count", "truth_count", "segment_count", "event_count"}) j.erase(key);
  write_text(dir / "run.json", j.dump(2));
  const std::string imu = read_text(dir / "imu.csv");
  write_text(dir / "imu.csv", imu.substr(0, line_start(imu, 1001)));
  r = Recording::open(dir);
  EXPECT_TRUE(r.damage.empty()) << r.damage;
  EXPECT_EQ(r.samples.size(), 999u);
  // A killed run (status running) keeps tolerating a cut last line.
  const fs::path killed = root_ / "killed";
  write_small(killed, false);
  const std::string kimu = read_text(killed / "imu.csv");
  write_text(killed / "imu.csv", kimu.substr(0, kimu.size() - 3));
  r = Recording::open(killed);
  EXPECT_TRUE(r.damage.empty()) << r.damage;
  EXPECT_EQ(r.dropped_partial_lines, 1u);
}

TEST_F(RecordingTest, Hdf5SummaryBeyondTheSamplesIsDamage) {
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  if (stend::testing::run_command(python + " -c 'import h5py, numpy' 2>&1").code != 0)
    GTEST_SKIP() << "python3-h5py / python3-numpy are not installed (scripts/install-deps.sh installs them)";
  const fs::path dir = root_ / "run";
  const auto written = write_mpu_run(dir, 70'000);
  EXPECT_TRUE(Recording::open(dir, stend::SampleLoading::kStream).damage.empty());
  // /summary claims more samples than the datasets hold.
  const auto edit = stend::testing::run_command(
      python + " -c 'import sys, h5py\nwith h5py.File(sys.argv[1], \"r+\") as f: f[\"summary\"][0] = 80000' " +
      (dir / "run.h5").string() + " 2>&1");
  ASSERT_EQ(edit.code, 0) << edit.text;
  {
    const Recording rec = Recording::open(dir, stend::SampleLoading::kStream);
    EXPECT_EQ(rec.sample_count(), written.size());
    EXPECT_EQ(rec.written_samples, 80000u);
    EXPECT_NE(rec.damage.find("dataset /samples holds 70000 rows, dataset /summary records 80000 written"),
              std::string::npos) << rec.damage;
  }  // closed: the edit below opens the file for writing
  // A value that is no count (the fuzz target found 4.2e207, cast to an integer: UBSan) is damage
  // too, and the counts are then unknown.
  const auto huge = stend::testing::run_command(
      python + " -c 'import sys, h5py\nwith h5py.File(sys.argv[1], \"r+\") as f: f[\"summary\"][0] = 4.2e207' " +
      (dir / "run.h5").string() + " 2>&1");
  ASSERT_EQ(huge.code, 0) << huge.text;
  const Recording bad = Recording::open(dir, stend::SampleLoading::kStream);
  EXPECT_EQ(bad.sample_count(), written.size());
  EXPECT_EQ(bad.written_samples, written.size());
  EXPECT_NE(bad.damage.find("dataset /summary holds 4.2e+207, 0 and 0 where counts of samples, gaps and irregular "
                            "intervals belong"),
            std::string::npos) << bad.damage;
}

// --- run.h5 string attributes and the global heap (format 1 → 2) -------------------------------

namespace {

// A format 1 run folder: the run_h5 fuzz seed (run.h5 written by `stend import` before format 2,
// its string attributes variable-length in a global heap collection) with its run.json and
// experiment.yaml, or with `h5` in place of its run.h5.
fs::path format1_run(const fs::path& dir, const std::string& h5 = "") {
  fs::copy(stend::testing::source_path("fuzz/run_template/h5"), dir, fs::copy_options::recursive);
  fs::copy_file(stend::testing::source_path("fuzz/corpus/run_h5/seed_format1_latest.h5"), dir / "run.h5");
  if (!h5.empty()) write_text(dir / "run.h5", h5);
  return dir;
}

// Byte offset of the (first) global heap collection and of its objects' headers.
struct Collection {
  std::size_t at = std::string::npos;
  std::vector<std::size_t> objects;  // offsets of the object headers, free space last
};
Collection walk_collection(const std::string& h5) {
  Collection c;
  c.at = h5.find("GCOL");
  if (c.at == std::string::npos) return c;
  auto u64 = [&](std::size_t p) {
    std::uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(h5[p + static_cast<std::size_t>(i)]);
    return v;
  };
  const std::size_t end = c.at + u64(c.at + 8);
  for (std::size_t p = c.at + 16; p + 16 <= end;) {
    c.objects.push_back(p);
    const bool free_space = h5[p] == 0 && h5[p + 1] == 0;
    if (free_space) break;
    p += 16 + (u64(p + 8) + 7) / 8 * 8;
  }
  return c;
}
void put_u64(std::string& s, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s[at + static_cast<std::size_t>(i)] = static_cast<char>(v >> (8 * i));
}

}  // namespace

TEST_F(RecordingTest, Hdf5StringAttributesAreFixedLengthWithoutAGlobalHeap) {
  // Format 2 keeps no global heap (the structure libhdf5 1.10 loops on when damaged); a long
  // experiment (beyond HDF5's 64 KiB object header message) still round-trips.
  Written x = write_small(root_ / "csv");
  std::string yaml = "name: long\nsteps:\n";
  while (yaml.size() < 200'000) yaml += "  - {dwell_s: 1.0, note: \"ünïcode line " + std::to_string(yaml.size()) + "\"}\n";
  const fs::path dir = root_ / "run";
  {
    RecordingWriter writer(dir, x.header, yaml);
    writer.add_samples(x.samples.data(), x.samples.size());
    writer.finish(stend::RunStatus::kComplete);
  }
  EXPECT_EQ(read_text(dir / "run.h5").find("GCOL"), std::string::npos) << "run.h5 holds a global heap collection";
  const Recording r = Recording::open(dir, stend::SampleLoading::kStream);
  EXPECT_EQ(r.experiment_yaml, yaml);
  EXPECT_EQ(r.header.experiment_name, x.header.experiment_name);
  EXPECT_EQ(r.sample_count(), x.samples.size());
  EXPECT_TRUE(r.damage.empty()) << r.damage;
}

// The lookup3 checksum of the version 2 object header at `at` recomputed (after an edit).
void fix_header_checksum(std::string& h5, std::size_t at) {
  const unsigned flags = static_cast<unsigned char>(h5[at + 5]);
  const std::size_t size_at = at + 6 + ((flags & 0x20) ? 16 : 0) + ((flags & 0x10) ? 4 : 0);
  const unsigned size_bytes = 1u << (flags & 3);
  const auto* bytes = reinterpret_cast<const unsigned char*>(h5.data());
  const std::size_t end = size_at + size_bytes + stend::detail::hdf5::little_endian(bytes + size_at, size_bytes);
  const std::uint32_t sum = stend::detail::hdf5::lookup3(bytes + at, end - at);
  for (int i = 0; i < 4; ++i) h5[end + static_cast<std::size_t>(i)] = static_cast<char>(sum >> (8 * i));
}

TEST_F(RecordingTest, Hdf5MetadataLibhdf5WouldMisreadIsRefusedBeforeItOpensTheFile) {
  // Fuzzing found libhdf5 1.10 asking malloc for 2^64 − 1 bytes (a continuation's declared length),
  // reading freed memory (an attribute message of a damaged version 1 header) and leaking a header
  // whose chunk failed its checksum. Stend reads run stores in the layout its writer makes, whose
  // metadata carries checksums, and checks each object header before libhdf5 loads it. Cases from
  // the format 1 seed (superblock 3; the root's "OHDR" at byte 48, a dataset's at 8983 with a
  // continuation chunk of 127 bytes at 9339, another's at 1431):
  const std::string seed = read_text(stend::testing::source_path("fuzz/corpus/run_h5/seed_format1_latest.h5"));
  ASSERT_EQ(seed.substr(48, 4), "OHDR");
  ASSERT_EQ(seed.substr(1431, 4), "OHDR");
  ASSERT_EQ(seed.substr(8983, 4), "OHDR");
  ASSERT_EQ(seed.substr(9339, 4), "OCHK");
  std::string flipped = seed;
  flipped[48 + 100] = static_cast<char>(flipped[48 + 100] ^ 0x10);
  const std::string cut = seed.substr(0, 48 + 592);
  std::string not_v2 = seed;
  not_v2.replace(1431, 4, "OHDX");
  // The continuation message (the 9th message: 16 bytes of data after a 4-byte header) declares
  // 2^40 bytes, with the header's checksum made right again, so only the size is wrong.
  std::string continuation = seed;
  const std::size_t cont = continuation.find(std::string("\x10\x10\x00", 3), 8983);
  ASSERT_LT(cont, 9339u);
  put_u64(continuation, cont + 4 + 8, std::uint64_t{1} << 40);
  fix_header_checksum(continuation, 8983);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {read_text(stend::testing::source_path("fuzz/regressions/run_h5/run_h5_h5c_protect_alloc_size_max.h5")),
       "its superblock is of version 0, the layout of HDF5 1.6 (what h5repack writes without -L)"},
      {flipped, "the object header at byte 48: its first chunk (" + std::to_string(24 + 577 + 4) +
                    " bytes at byte 48) does not match its checksum"},
      {cut, "the object header at byte 48: its first chunk (605 bytes at byte 48) runs past the end of the file"},
      {not_v2, ": the object header at byte 1431 is not a version 2 object header"},
      {continuation, ": the object header at byte 8983: its continuation chunk at byte 9339 declares "
                     "1099511627776 bytes, more than the whole file"},
      // Stend's own check read a header's version byte past a 4-byte "OHDR" at the end (ASan).
      {read_text(stend::testing::source_path("fuzz/regressions/run_h5/run_h5_header_prefix_past_end.h5")),
       ": the object header at byte 1431 is cut short by the end of the file"},
      // A group whose link points back to itself: libhdf5's link visit recursed until the stack
      // overflowed (it tracks only objects with more than one link).
      {read_text(stend::testing::source_path("fuzz/regressions/run_h5/run_h5_group_links_to_itself.h5")),
       "/end_time_utc/end_time_utc: links to the object at byte 1431, which an earlier link or the root "
       "already reached (a second link or a loop: damaged)"}};
  int n = 0;
  for (const auto& [bytes, expected] : cases) {
    SCOPED_TRACE(expected);
    const fs::path dir = format1_run(root_ / ("case" + std::to_string(n++)), bytes);
    try {
      (void)Recording::open(dir, stend::SampleLoading::kStream);
      ADD_FAILURE() << "opened";
    } catch (const stend::InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind((dir / "run.h5").string() + ": cannot be opened as an HDF5 run store: ", 0), 0u) << what;
      EXPECT_NE(what.find(expected), std::string::npos) << what;
    }
  }
  // The seed itself opens, and so does a file as Stend's writer makes it.
  EXPECT_GT(Recording::open(format1_run(root_ / "seed"), stend::SampleLoading::kStream).sample_count(), 0u);
  Written x = write_small(root_ / "csv");
  const fs::path dir = root_ / "written";
  {
    RecordingWriter writer(dir, x.header, "name: x\n");
    writer.add_samples(x.samples.data(), x.samples.size());
    writer.finish(stend::RunStatus::kComplete);
  }
  EXPECT_EQ(Recording::open(dir, stend::SampleLoading::kStream).sample_count(), x.samples.size());
}

TEST_F(RecordingTest, Hdf5Format1WithVariableLengthAttributesStaysReadable) {
  const fs::path dir = format1_run(root_ / "v1");
  const std::string h5 = read_text(dir / "run.h5");
  ASSERT_NE(walk_collection(h5).at, std::string::npos) << "the seed should be a format 1 file (global heap)";
  const Recording r = Recording::open(dir, stend::SampleLoading::kStream);
  EXPECT_TRUE(r.damage.empty()) << r.damage;
  EXPECT_EQ(r.header.experiment_name, "import:imucal");
  EXPECT_EQ(r.header.identity.model, "imucal example session");
  EXPECT_GT(r.sample_count(), 0u);
  EXPECT_EQ(r.sample_count(), r.written_samples);
  EXPECT_NE(r.experiment_yaml.find("stend import"), std::string::npos) << r.experiment_yaml;
}

TEST_F(RecordingTest, Hdf5DamagedGlobalHeapIsAnErrorNeverAHang) {
  // fuzz/regressions/run_h5/run_h5_global_heap_loop.h5 (on which libhdf5 1.10.8 looped for ever),
  // and the class it belongs to, made from the format 1 seed: a free-space object of size 0 (the
  // loop) and an object running past its collection.
  const std::string seed = read_text(stend::testing::source_path("fuzz/corpus/run_h5/seed_format1_latest.h5"));
  const Collection c = walk_collection(seed);
  ASSERT_GE(c.objects.size(), 3u);
  std::string zero_free_space = seed;
  put_u64(zero_free_space, c.objects.back() + 8, 0);
  std::string past_the_end = seed;
  put_u64(past_the_end, c.objects[1] + 8, 1u << 20);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"zero_free_space", zero_free_space},
      {"past_the_end", past_the_end}};
  {
    // The regression input (superblock version 0, cut short as well: 7 KB of 43) is refused before
    // libhdf5 reads it.
    const fs::path dir = format1_run(root_ / "regression", read_text(stend::testing::source_path(
                                                                "fuzz/regressions/run_h5/run_h5_global_heap_loop.h5")));
    try {
      (void)Recording::open(dir, stend::SampleLoading::kStream);
      ADD_FAILURE() << "the regression input opened";
    } catch (const stend::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("its superblock is of version 0"), std::string::npos) << what;
    }
  }
  for (const auto& [name, bytes] : cases) {
    SCOPED_TRACE(name);
    const fs::path dir = format1_run(root_ / name, bytes);
    // With run.json beside it the header comes from there; the samples stay readable, the damage is named.
    const Recording r = Recording::open(dir, stend::SampleLoading::kStream);
    EXPECT_NE(r.damage.find((dir / "run.h5").string() + ": the global heap collection at byte " +
                            std::to_string(c.at)),
              std::string::npos)
        << r.damage;
    EXPECT_NE(r.damage.find("is damaged"), std::string::npos) << r.damage;
    EXPECT_EQ(r.header.experiment_name, "import:imucal");
    const Recording whole = Recording::open(format1_run(root_ / (name + "_ok")), stend::SampleLoading::kStream);
    EXPECT_EQ(r.sample_count(), whole.sample_count()) << "the samples are not in the global heap";
    EXPECT_GT(r.sample_count(), 0u);
    EXPECT_THROW(stend::require_whole(r), stend::InputError);
    // Without it the run cannot be read: an InputError (exit 2) naming the file and the damage.
    fs::remove(dir / "run.json");
    try {
      (void)Recording::open(dir, stend::SampleLoading::kStream);
      ADD_FAILURE() << "opened without run.json";
    } catch (const stend::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("global heap collection at byte"), std::string::npos) << what;
      EXPECT_NE(what.find("run.json is missing"), std::string::npos) << what;
    }
  }
}

// Which instruments a recording holds round-trips through both stores (run.json, and run.h5's
// header), and the values of an absent one are NaN (counts 0) whatever the writer was given.
TEST_F(RecordingTest, AbsentInstrumentsAreNaNBothWays) {
  for (const auto format : {stend::RecordingFormat::kHdf5, stend::RecordingFormat::kCsv}) {
    for (const bool accel : {false, true}) {
      const fs::path dir = root_ / (std::string(stend::to_string(format)) + (accel ? "_accel_only" : "_gyro_only"));
      RecordingHeader h = make_header();
      h.info.has_accel = accel;
      h.info.has_gyro = !accel;
      h.info.has_temperature = false;
      std::vector<ImuSample> s;
      for (std::uint64_t k = 1; k <= 3000; ++k) s.push_back(make_sample(k));
      {
        RecordingWriter w(dir, h, "name: one instrument\n", stend::RecordingWriterOptions{format});
        w.add_samples(s.data(), s.size());
        w.finish(stend::RunStatus::kComplete);
      }
      const auto run_json = nlohmann::json::parse(read_text(dir / "run.json"));
      EXPECT_EQ(run_json.at("sensor").at("info").at("has_accel").get<bool>(), accel) << dir;
      for (auto loading : {stend::SampleLoading::kInMemory, stend::SampleLoading::kStream}) {
        const Recording r = Recording::open(dir, loading);
        EXPECT_EQ(r.header.info.has_accel, accel) << dir;
        EXPECT_EQ(r.header.info.has_gyro, !accel) << dir;
        EXPECT_FALSE(r.header.info.has_temperature) << dir;
        ASSERT_EQ(r.sample_count(), s.size());
        std::vector<ImuSample> got(s.size());
        r.sample_source().read(0, got.size(), got.data());
        for (std::size_t i = 0; i < got.size(); ++i) {
          ImuSample want = s[i];
          stend::blank_absent(h.info, want);
          expect_same_sample(got[i], want, i);
          if (HasFatalFailure()) return;
        }
        const ImuSample& x = got[7];
        EXPECT_EQ(x.accel_mps2.allFinite(), accel) << dir;
        EXPECT_EQ(x.gyro_radps.allFinite(), !accel) << dir;
        EXPECT_TRUE(std::isnan(x.temperature_c)) << dir;
      }
    }
  }
}

// A run folder written before has_accel existed (run.json without the key) holds an accelerometer.
TEST_F(RecordingTest, RunsWrittenBeforeHasAccelHoldAnAccelerometer) {
  const fs::path dir = root_ / "run";
  write_small(dir);
  auto j = nlohmann::json::parse(read_text(dir / "run.json"));
  ASSERT_TRUE(j["sensor"]["info"].contains("has_accel"));
  j["sensor"]["info"].erase("has_accel");
  write_text(dir / "run.json", j.dump(2) + "\n");
  const Recording r = Recording::open(dir);
  EXPECT_TRUE(r.header.info.has_accel);
  EXPECT_TRUE(stend::has_instrument(r.header.info, stend::model::Instrument::kAccelerometer));
}

TEST(Instruments, OneRuleSaysWhatARecordingHolds) {
  stend::SensorInfo info;
  EXPECT_EQ(stend::instruments_text(info), "accelerometer, gyroscope, temperature");
  info.has_accel = false;
  info.has_temperature = false;
  EXPECT_EQ(stend::instruments_text(info), "gyroscope (no accelerometer, no temperature)");
  EXPECT_FALSE(stend::has_channel(info, stend::Channel::kAy));
  EXPECT_TRUE(stend::has_channel(info, stend::Channel::kGy));
  EXPECT_TRUE(stend::has_channel(info, stend::Channel::kTime));
  EXPECT_EQ(stend::present_channels(info),
            (std::vector<stend::Channel>{stend::Channel::kGx, stend::Channel::kGy, stend::Channel::kGz}));
  EXPECT_EQ(stend::absent_text(stend::model::Instrument::kAccelerometer),
            "the recording has no accelerometer (its source holds no accelerometer data)");
}
