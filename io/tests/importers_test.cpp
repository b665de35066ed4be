// Importers: the public datasets in ../shared/data (skipped when absent), generic CSV, and the
// IMU-TK and MATLAB round trips on files this test writes.
#include <stend/io/importers.hpp>
#include <stend/io/logs.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>

#include "import_common.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <system_error>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::shared_data;
using stend::testing::TempDir;
using stend::testing::write_text;

// Seconds between integer timestamps: exact for times close together, and of the right sign for
// any two (a corrupt timestamp centuries off subtracted in int64 overflowed: the fuzzed ROS 2 bag
// fuzz/regressions/import_rosbag2_db3/timestamp_difference_overflows_int64.db3).
TEST(ImportTimes, DifferencesOfAnyTwoTimestampsKeepTheirSign) {
  EXPECT_DOUBLE_EQ(io::detail::seconds_since_ns(1'700'000'000'000'000'000, 1'700'000'000'000'000'001), 1e-9);
  EXPECT_DOUBLE_EQ(io::detail::seconds_since_ns(1'700'000'000'000'000'000, 1'699'999'999'000'000'000), -1.0);
  EXPECT_GT(io::detail::seconds_since_ns(INT64_MIN, INT64_MAX), 1.8e10);
  EXPECT_LT(io::detail::seconds_since_ns(1'700'000'000'006'000'000, -8'553'106'169'509'442'294), -1.0e10);
  EXPECT_DOUBLE_EQ(io::detail::seconds_since_us(5, 3), -2e-6);
  EXPECT_GT(io::detail::seconds_since_us(0, UINT64_MAX), 1.8e13);
  EXPECT_LT(io::detail::seconds_since_us(UINT64_MAX, 0), -1.8e13);
}

// A text log's numbers parse to the double std::from_chars gives, bit for bit, whether they take
// parse_double's plain-decimal path or not; what from_chars refuses is refused.
TEST(ImportNumbers, ParseDoubleIsFromCharsBitForBit) {
  const auto from_chars_of = [](const std::string& t, double& v) {
    const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    return ec == std::errc() && p == t.data() + t.size();
  };
  const auto same = [&](const std::string& t) {
    double ours = -1.0, theirs = -1.0;
    const bool ok = io::detail::parse_double(t, ours);
    ASSERT_EQ(ok, from_chars_of(t, theirs)) << "'" << t << "'";
    if (ok) {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(ours), std::bit_cast<std::uint64_t>(theirs)) << "'" << t << "'";
    }
  };
  for (const char* t : {"0", "-0", "0.0", "-0.000", "5.", ".5", "-.5", ".", "-", "--1", "1.2.3", "1e5", "-2.5E-3", "inf",
                        "nan", "0x10", "9007199254740991", "9007199254740993", "0.1", "0.3", "1234567890123456789",
                        "12345678901234567890", "0.0000000000000000000001", "0.00000000000000000000001",
                        "00000000000000000000001.5", "9.81", "-0.00123", "1 2", "1,5", "٣"})
    same(t);
  std::mt19937_64 rng(38);
  for (int i = 0; i < 200000; ++i) {  // up to 20 digits, the point anywhere, either sign
    const int digits = 1 + static_cast<int>(rng() % 20);
    std::string t = rng() % 2 ? "-" : "";
    const int point = static_cast<int>(rng() % static_cast<unsigned>(digits + 2)) - 1;  // -1: none
    for (int k = 0; k < digits; ++k) {
      if (k == point) t += '.';
      t += static_cast<char>('0' + rng() % 10);
    }
    if (point == digits) t += '.';
    same(t);
  }
}

namespace {

constexpr double kG = 9.80665;

// Mean |a| over the samples inside [t0, t1].
double mean_norm(const Recording& r, double t0, double t1) {
  double s = 0.0;
  int n = 0;
  for (const auto& x : r.samples) {
    if (x.t_s < t0 || x.t_s > t1) continue;
    s += x.accel_mps2.norm();
    ++n;
  }
  return n ? s / n : std::nan("");
}

// Integral of one gyro axis over [t0, t1] (rad), after removing the mean of the first `still_s`
// seconds before t0 … the turn segments have no still part, so plain integral.
double integral(const Recording& r, int axis, double t0, double t1) {
  double s = 0.0;
  const double dt = 1.0 / r.header.info.output_rate_hz;
  for (const auto& x : r.samples) {
    if (x.t_s >= t0 && x.t_s <= t1) s += x.gyro_radps[axis] * dt;
  }
  return s;
}

std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const ImportError& e) {
    return e.what();
  }
  return "(no ImportError)";
}

// The fuzz seed seed_ok.mat (fuzz/corpus/import_mat/: uncompressed MAT 5 with t, fs, acc, acc_counts,
// acc_lsb at byte 816, gyro, …, and a 2 x 1 segments struct at byte 1584) with one damage: the
// little-endian 32-bit words at the given byte offsets replaced. Each case damages one thing, so
// the check it is about is the one that refuses it.
fs::path damaged_mat_seed(const TempDir& dir, std::initializer_list<std::pair<std::size_t, std::uint32_t>> words) {
  std::string bytes = stend::testing::read_text(stend::testing::source_path("fuzz/corpus/import_mat/seed_ok.mat"));
  for (const auto& [at, value] : words)
    for (std::size_t k = 0; k < 4; ++k) bytes.at(at + k) = static_cast<char>((value >> (8 * k)) & 0xff);
  write_text(dir / "damaged.mat", bytes);
  return dir / "damaged.mat";
}

Recording synthetic(std::size_t n, double rate, bool with_counts) {
  Recording r;
  r.header.info.output_rate_hz = rate;
  r.header.info.has_gyro = true;
  r.header.info.accel_lsb_mps2 = kG / 2048.0;
  r.header.info.gyro_lsb_radps = std::numbers::pi / 180.0 / 16.4;
  std::mt19937_64 gen(5);
  std::normal_distribution<double> normal;
  for (std::size_t i = 0; i < n; ++i) {
    ImuSample s;
    s.t_s = 0.5 + static_cast<double>(i) / rate;
    for (int k = 0; k < 3; ++k) {
      if (with_counts) {
        s.accel_counts[k] = static_cast<std::int32_t>(std::lround(normal(gen) * 1000));
        s.gyro_counts[k] = static_cast<std::int32_t>(std::lround(normal(gen) * 100));
        s.accel_mps2[k] = s.accel_counts[k] * r.header.info.accel_lsb_mps2;
        s.gyro_radps[k] = s.gyro_counts[k] * r.header.info.gyro_lsb_radps;
      } else {
        s.accel_mps2[k] = normal(gen) * 3.0 + (k == 2 ? kG : 0.0);
        s.gyro_radps[k] = normal(gen) * 0.01;
      }
    }
    r.samples.push_back(s);
  }
  Segment a;
  a.kind = stend::SegmentKind::kOrientation;
  a.label = "z up";
  a.t_start_s = 0.5;
  a.t_end_s = 1.5;
  Segment b = a;
  b.kind = stend::SegmentKind::kRotation;
  b.label = "x_rot";
  b.t_start_s = 2.0;
  b.t_end_s = 3.25;
  r.segments = {a, b};
  return r;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// (c) MPU-6050 multi-position session

TEST(ImportMpu6050, CalibrationSession) {
  const auto file = shared_data("mpu6050_multipos/calibration_session.csv");
  STEND_SKIP_IF_ABSENT(file);
  const Recording r = import_mpu6050_multipos(file);
  EXPECT_EQ(r.samples.size(), 10245u);  // 10250 lines − the 5-line header (with column names)
  EXPECT_EQ(r.header.info.output_rate_hz, 100.0);
  EXPECT_DOUBLE_EQ(r.header.info.accel_lsb_mps2, kG / 16384.0);
  EXPECT_DOUBLE_EQ(r.header.info.gyro_lsb_radps, std::numbers::pi / 180.0 / 131.0);
  EXPECT_EQ(r.header.identity.model, "MPU-6050");
  EXPECT_TRUE(r.complete());
  EXPECT_DOUBLE_EQ(r.samples[1].t_s, 0.01);
  EXPECT_EQ(r.samples[0].accel_counts[2], 15032);
  EXPECT_EQ(r.samples[0].gyro_counts[0], -447);
  // The only annotation: the initial still interval from the header (36.5 s).
  ASSERT_EQ(r.segments.size(), 1u);
  EXPECT_EQ(r.segments[0].kind, stend::SegmentKind::kOrientation);
  EXPECT_EQ(r.segments[0].label, "initialization");
  EXPECT_DOUBLE_EQ(r.segments[0].t_end_s, 36.5);
  // Still: |a| ≈ g. This unit is uncalibrated (its reference calibration has a z offset of
  // ~1840 counts ≈ 0.11 g), so the nominal scale gives 0.91 g: within 12 %.
  EXPECT_NEAR(mean_norm(r, r.segments[0].t_start_s, r.segments[0].t_end_s) / kG, 1.0, 0.12);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_NE(r.events[0].message.find("Initialization time = 36.5"), std::string::npos);
}

TEST(ImportMpu6050, Static449s) {
  const auto file = shared_data("mpu6050_multipos/static_449s.csv");
  STEND_SKIP_IF_ABSENT(file);
  const Recording r = import_mpu6050_multipos(file);
  EXPECT_EQ(r.samples.size(), 44930u);
  EXPECT_EQ(r.header.info.output_rate_hz, 100.0);
  EXPECT_TRUE(r.segments.empty());  // Initialization time −1: no annotation
  EXPECT_NEAR(r.samples.back().t_s, 449.29, 1e-9);
  EXPECT_NEAR(mean_norm(r, 0, 1e9) / kG, 1.0, 0.12);
}

TEST(ImportMpu6050, MalformedInputNamesFileAndLine) {
  const TempDir dir("importers");
  const auto bad = dir / "bad.csv";
  write_text(bad, "Fs,100\nLogging Type,0\nInitialization time,2\nWaiting time,3\nax,ay,az,gx,gy,gz\n"
                  "1,2,3,4,5,6\n1,2,x3,4,5,6\n");
  const std::string e = error_of([&] { import_mpu6050_multipos(bad); });
  EXPECT_NE(e.find("bad.csv:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("'az'"), std::string::npos) << e;

  write_text(bad, "Logging Type,0\nax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n");
  EXPECT_NE(error_of([&] { import_mpu6050_multipos(bad); }).find("Fs"), std::string::npos);

  write_text(bad, "Fs,100\nax,ay,az,gx,gy\n1,2,3,4,5\n");
  EXPECT_NE(error_of([&] { import_mpu6050_multipos(bad); }).find("bad.csv:2: no column 'gz'"), std::string::npos);

  write_text(bad, "Fs,100\nax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n1,2,3,4,5\n");
  EXPECT_NE(error_of([&] { import_mpu6050_multipos(bad); }).find("bad.csv:4:"), std::string::npos);

  EXPECT_NE(error_of([&] { import_mpu6050_multipos(dir / "missing.csv"); }).find("missing.csv"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// (b) imucal annotated session

TEST(ImportImucal, AnnotatedSession) {
  const auto file = shared_data("imucal/annotated_session.csv");
  STEND_SKIP_IF_ABSENT(file);
  const Recording r = import_imucal_session(file);
  EXPECT_EQ(r.samples.size(), 9414u);
  EXPECT_DOUBLE_EQ(r.header.info.output_rate_hz, 204.8);
  EXPECT_DOUBLE_EQ(r.header.gravity_mps2, 9.81);
  // Time order, not file order (the file is grouped by part).
  for (std::size_t i = 1; i < r.samples.size(); ++i) {
    ASSERT_LT(r.samples[i - 1].t_s, r.samples[i].t_s);
    ASSERT_EQ(r.samples[i].flags & kGapBefore, 0u);
  }
  const char* expected[9] = {"x_p", "x_a", "y_p", "y_a", "z_p", "z_a", "x_rot", "y_rot", "z_rot"};
  ASSERT_EQ(r.segments.size(), 9u);
  int orientations = 0;
  for (std::size_t i = 0; i < 9; ++i) {
    const Segment& s = r.segments[i];
    EXPECT_EQ(s.label, expected[i]);
    const bool rot = i >= 6;
    EXPECT_EQ(s.kind, rot ? stend::SegmentKind::kRotation : stend::SegmentKind::kOrientation);
    if (!rot) {
      EXPECT_EQ(s.orientation, orientations++);
      EXPECT_EQ(s.orientation_count, 6);
      // Static positions: |a| ≈ g with the nominal 2048 LSB/g (uncalibrated: within 6 %).
      EXPECT_NEAR(mean_norm(r, s.t_start_s, s.t_end_s) / 9.81, 1.0, 0.06) << s.label;
      // The axis named by the part carries ±g: x_p → +x up (+g), x_a → x down (−g).
      const int axis = s.label[0] - 'x';
      double mean = 0.0;
      int n = 0;
      for (const auto& x : r.samples) {
        if (x.t_s >= s.t_start_s && x.t_s <= s.t_end_s) {
          mean += x.accel_mps2[axis];
          ++n;
        }
      }
      mean /= n;
      EXPECT_NEAR(mean / 9.81, s.label[2] == 'p' ? 1.0 : -1.0, 0.06) << s.label;
    } else {
      // 360° turns about the named axis with the nominal 16.4 LSB/(°/s) (within 3 %).
      const int axis = s.label[0] - 'x';
      const double turn = integral(r, axis, s.t_start_s, s.t_end_s) * 180.0 / std::numbers::pi;
      EXPECT_NEAR(turn / 360.0, 1.0, 0.03) << s.label;
    }
  }
  EXPECT_DOUBLE_EQ(r.segments[0].t_start_s, 0.0);
  EXPECT_DOUBLE_EQ(r.segments[0].t_end_s, 1027 / 204.8);
  EXPECT_DOUBLE_EQ(r.segments[8].t_end_s, 9413 / 204.8);
}

TEST(ImportImucal, MalformedInput) {
  const TempDir dir("importers");
  const auto bad = dir / "session.csv";
  write_text(bad, "part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\nx_p,0,1,2,3,4,5,6\nx_p,1,1,2,3.5,4,5,6\n");
  const std::string e = error_of([&] { import_imucal_session(bad); });
  EXPECT_NE(e.find("session.csv:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("not an integer count"), std::string::npos) << e;
  write_text(bad, "part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y\n");
  EXPECT_NE(error_of([&] { import_imucal_session(bad); }).find("no column 'gyr_z'"), std::string::npos);
  write_text(bad, "part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\nx_p,0,1,2,3,4,5,6\nx_a,0,1,2,3,4,5,6\n");
  EXPECT_NE(error_of([&] { import_imucal_session(bad); }).find("session.csv:3: sample index 0 also appears on line 2"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// (a) generic CSV

TEST(ImportCsv, MappingReproducesTheMpu6050Importer) {
  const auto file = shared_data("mpu6050_multipos/calibration_session.csv");
  STEND_SKIP_IF_ABSENT(file);
  CsvMapping m;
  m.skip_lines = 4;  // Fs, Logging Type, Initialization time, Waiting time
  m.rate_hz = 100.0;
  m.accel = {"ax", "ay", "az"};
  m.gyro = {"gx", "gy", "gz"};
  m.accel_counts = m.gyro_counts = true;
  m.accel_scale = kG / 16384.0;
  m.gyro_scale = std::numbers::pi / 180.0 / 131.0;
  const Recording a = import_csv(file, m);
  const Recording b = import_mpu6050_multipos(file);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t i = 0; i < a.samples.size(); i += 97) {
    EXPECT_EQ(a.samples[i].t_s, b.samples[i].t_s);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(a.samples[i].accel_counts[k], b.samples[i].accel_counts[k]);
      EXPECT_EQ(a.samples[i].gyro_radps[k], b.samples[i].gyro_radps[k]);
    }
  }
  EXPECT_EQ(a.header.info.accel_lsb_mps2, m.accel_scale);
}

// A column-name line or a field of megabytes is refused at its line, never held whole; the lines
// around it read as before, and detection looks at its beginning only.
TEST(ImportCsv, ALineLongerThanTheLimitIsRefusedAtItsNumber) {
  constexpr std::size_t kLimit = std::size_t{1} << 20;  // kMaxLineBytes, io/src/import_common.hpp [bytes]
  const TempDir dir("importers");
  const auto f = dir / "long.csv";
  CsvMapping s;
  s.time = "t";
  s.accel = {"ax", "ay", "az"};
  write_text(f, "t,ax,ay,az\n0,1,2,3\n0.01,1,2," + std::string(kLimit + 10, '7') + "\n0.02,1,2,3\n");
  const std::string e = error_of([&] { import_csv(f, s); });
  EXPECT_NE(e.find("long.csv:3: the line is longer than 1048576 bytes"), std::string::npos) << e.substr(0, 500);
  EXPECT_LT(e.size(), 1000u);
  write_text(f, "t,ax,ay,az," + std::string(3 * kLimit, 'c') + "\n0,1,2,3\n");
  const std::string h = error_of([&] { import_csv(f, s); });
  EXPECT_NE(h.find("long.csv:1: the line is longer than"), std::string::npos) << h.substr(0, 500);
  // A line of exactly the limit, and one without its final newline, read whole.
  write_text(f, "t,ax,ay,az\n0,1,2,3" + std::string(kLimit - 7, ' ') + "\n0.01,1,2,4");
  const Recording r = import_csv(f, s);
  ASSERT_EQ(r.samples.size(), 2u);
  EXPECT_DOUBLE_EQ(r.samples[1].accel_mps2.z(), 4.0);
}

TEST(ImportCsv, TimeColumnUnitsDelimiterAndErrors) {
  const TempDir dir("importers");
  const auto f = dir / "log.txt";
  write_text(f,
             "# exported by some logger\n"
             "time_ms; temp; wx; wy; wz; fx; fy; fz\n"
             "1000; 25.5; 0.1; 0.2; 0.3; 0; 0; 1\n"
             "# a comment inside the data\n"
             "1010; 25.5; 0.1; 0.2; 0.3; 0; 0; 1.01\n"
             "\n"
             "1020; 25.6; 0.1; 0.2; 0.3; 0; 0; 0.99\n"
             "1040; 25.6; 0.1; 0.2; 0.3; 0; 0; 1\n");
  CsvMapping m;
  m.delimiter = ';';
  m.skip_lines = 1;
  m.time = "time_ms";
  m.time_scale_s = 1e-3;
  m.accel = {5, 6, 7};  // by index
  m.gyro = {"wx", "wy", "wz"};
  m.temperature = "temp";
  m.accel_scale = kG;  // file in g
  m.gyro_scale = std::numbers::pi / 180.0;  // file in °/s
  const Recording r = import_csv(f, m);
  ASSERT_EQ(r.samples.size(), 4u);
  EXPECT_DOUBLE_EQ(r.samples[1].t_s, 1.01);
  EXPECT_DOUBLE_EQ(r.samples[1].accel_mps2.z(), 1.01 * kG);
  EXPECT_DOUBLE_EQ(r.samples[0].gyro_radps.y(), 0.2 * std::numbers::pi / 180.0);
  EXPECT_DOUBLE_EQ(r.samples[2].temperature_c, 25.6);
  EXPECT_NEAR(r.header.info.output_rate_hz, 100.0, 1e-9);  // median interval
  EXPECT_FALSE(r.samples[2].flags & kGapBefore);
  EXPECT_TRUE(r.samples[3].flags & kGapBefore);  // 20 ms at a 10 ms rate
  EXPECT_TRUE(r.header.info.has_temperature);

  // Errors name the file and line.
  write_text(f, "t,ax,ay,az\n0,1,2,3\n0.01,1,2\n");
  CsvMapping s;
  s.time = "t";
  s.accel = {"ax", "ay", "az"};
  std::string e = error_of([&] { import_csv(f, s); });
  EXPECT_NE(e.find("log.txt:3:"), std::string::npos) << e;
  write_text(f, "t,ax,ay,az\n0,1,2,3\n0.01,1,2,abc\n");
  e = error_of([&] { import_csv(f, s); });
  EXPECT_NE(e.find("log.txt:3: column 'az': 'abc' is not a number"), std::string::npos) << e;
  // A repeated time is repaired from the rate (stend/io/timestamps.hpp); a time that goes back is refused.
  write_text(f, "t,ax,ay,az\n0.01,1,2,3\n0,1,2,3\n");
  EXPECT_NE(error_of([&] { import_csv(f, s); }).find("log.txt:3: time 0 s goes back"), std::string::npos);
  s.accel = {"ax", "ay", "acc_z"};
  e = error_of([&] { import_csv(f, s); });
  EXPECT_NE(e.find("no column named 'acc_z'"), std::string::npos) << e;
  EXPECT_NE(e.find("t, ax, ay, az"), std::string::npos) << e;
  CsvMapping no_time;
  no_time.accel = {1, 2, 3};
  EXPECT_NE(error_of([&] { import_csv(f, no_time); }).find("rate_hz"), std::string::npos);
}

// A log of one instrument: the other's columns are not mapped, the header says it is absent and
// its values are NaN (never 0 read as data); a triad is mapped whole or not at all.
TEST(ImportCsv, OneInstrumentLogs) {
  const TempDir dir("importers");
  const auto f = dir / "one.csv";
  write_text(f, "t,gx,gy,gz,temp\n0,0.01,0.02,0.03,25\n0.01,0.01,0.02,0.03,25\n0.02,0.01,0.02,0.03,25\n");
  CsvMapping gyro_only;
  gyro_only.time = "t";
  gyro_only.gyro = {"gx", "gy", "gz"};
  gyro_only.temperature = "temp";
  const Recording g = import_csv(f, gyro_only);
  EXPECT_FALSE(g.header.info.has_accel);
  EXPECT_TRUE(g.header.info.has_gyro);
  EXPECT_TRUE(g.header.info.has_temperature);
  EXPECT_EQ(g.header.info.accel_lsb_mps2, 0.0);
  ASSERT_EQ(g.samples.size(), 3u);
  for (const auto& s : g.samples) {
    EXPECT_TRUE(s.accel_mps2.array().isNaN().all());
    EXPECT_EQ(s.accel_counts[0], 0);
    EXPECT_DOUBLE_EQ(s.gyro_radps.z(), 0.03);
    EXPECT_DOUBLE_EQ(s.temperature_c, 25.0);
  }
  write_text(f, "t,ax,ay,az\n0,0,0,9.8\n0.01,0,0,9.8\n");
  CsvMapping accel_only;
  accel_only.time = "t";
  accel_only.accel = {"ax", "ay", "az"};
  const Recording a = import_csv(f, accel_only);
  EXPECT_TRUE(a.header.info.has_accel);
  EXPECT_FALSE(a.header.info.has_gyro);
  EXPECT_TRUE(a.samples[1].gyro_radps.array().isNaN().all());
  EXPECT_TRUE(std::isnan(a.samples[1].temperature_c));
  CsvMapping none;
  none.time = "t";
  EXPECT_NE(error_of([&] { import_csv(f, none); }).find("neither accelerometer nor gyroscope columns"), std::string::npos);
  CsvMapping partial;
  partial.time = "t";
  partial.accel = {"ax", "ay", CsvColumn{}};
  EXPECT_NE(error_of([&] { import_csv(f, partial); }).find("only some accel columns"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// (d) IMU-TK

TEST(ImportImuTk, RoundTripSiAndCounts) {
  const TempDir dir("importers");
  const Recording src = synthetic(1000, 100.0, true);
  // Physical units: exact (shortest round-trip text).
  export_imutk(src, dir / "acc.txt", dir / "gyro.txt");
  const Recording si = import_imutk(dir / "acc.txt", dir / "gyro.txt");
  ASSERT_EQ(si.samples.size(), src.samples.size());
  for (std::size_t i = 0; i < src.samples.size(); ++i) {
    ASSERT_EQ(si.samples[i].t_s, src.samples[i].t_s);
    ASSERT_EQ(si.samples[i].accel_mps2, src.samples[i].accel_mps2);
    ASSERT_EQ(si.samples[i].gyro_radps, src.samples[i].gyro_radps);
  }
  EXPECT_NEAR(si.header.info.output_rate_hz, 100.0, 1e-6);
  EXPECT_TRUE(si.header.info.has_gyro);
  // Counts, with the LSBs as scales.
  export_imutk(src, dir / "acc_c.txt", dir / "gyro_c.txt", true);
  ImuTkOptions o;
  o.counts = true;
  o.accel_scale = src.header.info.accel_lsb_mps2;
  o.gyro_scale = src.header.info.gyro_lsb_radps;
  const Recording c = import_imutk(dir / "acc_c.txt", dir / "gyro_c.txt", o);
  ASSERT_EQ(c.samples.size(), src.samples.size());
  for (std::size_t i = 0; i < src.samples.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(c.samples[i].accel_counts[k], src.samples[i].accel_counts[k]);
      ASSERT_EQ(c.samples[i].gyro_counts[k], src.samples[i].gyro_counts[k]);
    }
    ASSERT_EQ(c.samples[i].accel_mps2, src.samples[i].accel_mps2);
  }
  EXPECT_EQ(c.header.info.accel_lsb_mps2, o.accel_scale);
  // Accelerometer only.
  const Recording a = import_imutk(dir / "acc.txt", {});
  EXPECT_FALSE(a.header.info.has_gyro);
  EXPECT_EQ(a.samples.size(), 1000u);
}

TEST(ImportImuTk, GyroOnOtherTimestampsIsInterpolated) {
  const TempDir dir("importers");
  // Accelerometer at 0, 0.01, …; gyro at 0.005, 0.015, … with a ramp ω = t.
  std::string acc, gyr;
  for (int i = 0; i < 100; ++i) {
    acc += std::to_string(i * 0.01) + " 0 0 9.81\n";
    const double t = 0.005 + i * 0.01;
    gyr += std::to_string(t) + "," + std::to_string(t) + "," + std::to_string(2 * t) + ",0\n";
  }
  write_text(dir / "a.txt", acc);
  write_text(dir / "g.txt", gyr);
  const Recording r = import_imutk(dir / "a.txt", dir / "g.txt");
  // t = 0 lies before the first gyro sample (dropped); the last accel sample (0.99) is inside.
  ASSERT_EQ(r.samples.size(), 99u);
  for (const auto& s : r.samples) {
    ASSERT_NEAR(s.gyro_radps.x(), s.t_s, 1e-9);
    ASSERT_NEAR(s.gyro_radps.y(), 2 * s.t_s, 1e-9);
  }
  EXPECT_NE(r.events[0].message.find("interpolated"), std::string::npos);
  EXPECT_NE(r.events[0].message.find("1 accelerometer sample(s)"), std::string::npos);
}

TEST(ImportImuTk, MalformedLineNamesFileAndLine) {
  const TempDir dir("importers");
  write_text(dir / "a.txt", "# IMU-TK\n0 1 2 3\n0.01 1 2\n");
  std::string e = error_of([&] { import_imutk(dir / "a.txt", {}); });
  EXPECT_NE(e.find("a.txt:3: expected 4 values"), std::string::npos) << e;
  write_text(dir / "a.txt", "0 1 2 3\n0.01 1 2 3\n0.005 1 2 3\n");
  e = error_of([&] { import_imutk(dir / "a.txt", {}); });
  EXPECT_NE(e.find("a.txt:3: timestamp"), std::string::npos) << e;
  write_text(dir / "a.txt", "0 1 2 3\n1e-2 1 2 three\n");
  e = error_of([&] { import_imutk(dir / "a.txt", {}); });
  EXPECT_NE(e.find("a.txt:2: column 'z'"), std::string::npos) << e;
}

// ---------------------------------------------------------------------------------------------
// (e) MATLAB .mat

TEST(ImportMat, RoundTripTopLevelAndStruct) {
  if (!mat_supported()) {
    GTEST_SKIP() << "MATLAB support unavailable: stend_core was built without matio "
                    "(io/CMakeLists.txt must link PkgConfig::MATIO and define STEND_HAVE_MATIO)";
  }
  const TempDir dir("importers");
  const Recording src = synthetic(500, 200.0, true);
  for (const std::string& st : {std::string(), std::string("imu")}) {
    const auto file = dir / ("r" + st + ".mat");
    export_mat(src, file, st);
    MatOptions o;
    o.struct_name = st;
    const Recording r = import_mat(file, o);
    ASSERT_EQ(r.samples.size(), src.samples.size()) << st;
    for (std::size_t i = 0; i < src.samples.size(); ++i) {
      ASSERT_EQ(r.samples[i].t_s, src.samples[i].t_s);
      ASSERT_EQ(r.samples[i].accel_mps2, src.samples[i].accel_mps2);
      ASSERT_EQ(r.samples[i].gyro_radps, src.samples[i].gyro_radps);
      for (int k = 0; k < 3; ++k) {
        ASSERT_EQ(r.samples[i].accel_counts[k], src.samples[i].accel_counts[k]);
        ASSERT_EQ(r.samples[i].gyro_counts[k], src.samples[i].gyro_counts[k]);
      }
    }
    EXPECT_EQ(r.header.info.output_rate_hz, 200.0);
    EXPECT_EQ(r.header.info.accel_lsb_mps2, src.header.info.accel_lsb_mps2);
    ASSERT_EQ(r.segments.size(), 2u);
    EXPECT_EQ(r.segments[1].kind, stend::SegmentKind::kRotation);
    EXPECT_EQ(r.segments[1].label, "x_rot");
    EXPECT_EQ(r.segments[1].t_end_s, 3.25);
  }
  // Without a struct name the first struct in the file is used.
  const Recording any = import_mat(dir / "rimu.mat");
  EXPECT_EQ(any.samples.size(), 500u);
}

TEST(ImportMat, ErrorsNameTheFile) {
  if (!mat_supported()) {
    GTEST_SKIP() << "MATLAB support unavailable: stend_core was built without matio";
  }
  const TempDir dir("importers");
  write_text(dir / "not.mat", "this is not a MATLAB file\n");
  EXPECT_NE(error_of([&] { import_mat(dir / "not.mat"); }).find("not.mat"), std::string::npos);
  Recording empty_gyro = synthetic(10, 100.0, false);
  export_mat(empty_gyro, dir / "ok.mat");
  MatOptions o;
  o.struct_name = "nothere";
  EXPECT_NE(error_of([&] { import_mat(dir / "ok.mat", o); }).find("no struct variable named 'nothere'"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Rows with extra or missing fields, in every text importer: refused with file, line and the count
// expected (an extra field would shift or add values silently).

TEST(ImportStrictRows, ExtraOrMissingFieldsAreRefusedWithTheExpectedCount) {
  const TempDir dir("importers");
  const auto f = dir / "rows.csv";
  auto expect = [&](const std::function<void()>& import, const std::string& needle) {
    const std::string e = error_of(import);
    EXPECT_NE(e.find(needle), std::string::npos) << e;
  };
  // Generic CSV with a column-name line: every row has its field count.
  CsvMapping named;
  named.time = "t";
  named.accel = {"ax", "ay", "az"};
  write_text(f, "t,ax,ay,az\n0,1,2,3\n0.01,1,2,3,9\n0.02,1,2,3\n");
  expect([&] { import_csv(f, named); }, "rows.csv:3: expected 4 fields as on the column-name line (line 1), found 5");
  // Without one: as many as the first data row.
  CsvMapping by_index;
  by_index.column_names = false;
  by_index.rate_hz = 100.0;
  by_index.accel = {0, 1, 2};
  write_text(f, "1,2,3,4\n1,2,3,4\n1,2,3,4,5\n");
  expect([&] { import_csv(f, by_index); }, "rows.csv:3: expected 4 fields as on the first data line (line 1), found 5");
  // imucal: the column-name line's count.
  write_text(f, "part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\nx_p,0,1,2,3,4,5,6\nx_p,1,1,2,3,4,5,6,7\n");
  expect([&] { import_imucal_session(f); }, "rows.csv:3: expected 8 fields as on the column-name line, found 9");
  // MPU-6050 text: likewise.
  write_text(f, "Fs,100\nax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n1,2,3,4,5,6,7\n");
  expect([&] { import_mpu6050_multipos(f); }, "rows.csv:4: expected 6 fields as on the column-name line, found 7");
  // EuRoC and IMU-TK have fixed layouts.
  write_text(f, "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
                "1000,0,0,0,0,0,9.8\n2000,0,0,0,0,0,9.8,1\n");
  expect([&] { import_euroc(f); }, "rows.csv:3: expected 7 fields");
  write_text(f, "0 1 2 3\n0.01 1 2 3 4\n");
  expect([&] { import_imutk(f, {}); }, "rows.csv:2: expected 4 values");
}

TEST(ImportStrictRows, LongFieldsAreCutInMessages) {
  const TempDir dir("importers");
  const auto f = dir / "rows.csv";
  write_text(f, "Fs,100\nax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n1,2," + std::string(100'000, '9') + "x,4,5,6\n");
  const std::string e = error_of([&] { import_mpu6050_multipos(f); });
  EXPECT_NE(e.find("rows.csv:4: column 'az'"), std::string::npos) << e;
  EXPECT_LT(e.size(), 400u) << e.size();
}

// Inputs the fuzz targets found (fuzz/regressions/, replayed by the fuzz ctests): each is a clear
// ImportError naming the place, not undefined behaviour or a multi-gigabyte allocation.
TEST(ImportImucal, SampleIndexBeyondExactIntegersIsAnError) {
  const fs::path csv = stend::testing::source_path("fuzz/regressions/import_imucal/samples_index_1e101.csv");
  const std::string msg = error_of([&] { import_imucal_session(csv); });
  EXPECT_NE(msg.find("samples_index_1e101.csv:19: 'samples' must be a non-negative integer index (at most 2^53)"),
            std::string::npos) << msg;
}

TEST(ImportMat, ElementDeclaredBeyondTheEndIsRefusedBeforeMatioReadsIt) {
  const fs::path mat = stend::testing::source_path("fuzz/regressions/import_mat/element_beyond_end.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  EXPECT_NE(msg.find("byte 264: a top-level element of data type 65536 declares 65536 bytes"), std::string::npos) << msg;
  EXPECT_NE(msg.find("ends at byte 1010"), std::string::npos) << msg;
}

// The fuzz target's next find: a matrix whose dimensions subelement declares 3.2 GB made matio's
// Mat_GetDir ask for 6.3 GB; the dimensions are checked (stored or inflated) before matio opens it.
TEST(ImportMat, DimensionsDeclaringGigabytesAreRefusedBeforeMatioListsTheVariables) {
  const fs::path mat = stend::testing::source_path("fuzz/regressions/import_mat/dimensions_declare_3GB.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  // The walk checks every subelement against its matrix: an earlier element of this input already
  // declares its dimensions of another MAT data type (and 264 bytes of them).
  EXPECT_NE(msg.find("byte 128: the matrix in this element declares dimensions"), std::string::npos) << msg;
  const TempDir seed_dir("importers");
  const std::string too_long = error_of([&] { import_mat(damaged_mat_seed(seed_dir, {{844, 264}})); });
  EXPECT_NE(too_long.find("byte 816: the matrix in this element declares 264 bytes of dimensions (at most 256 "
                          "dimensions of 4 bytes) where 40 are left"),
            std::string::npos)
      << too_long;
  // Its element at byte 624, alone after the header, is the 3 GB of dimensions.
  std::string bytes = stend::testing::read_text(mat);
  const TempDir dir("importers");
  const fs::path one = dir / "dimensions_3GB_alone.mat";
  const std::uint32_t len624 = static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[628])) |
                               static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[629])) << 8 |
                               static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[630])) << 16 |
                               static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[631])) << 24;
  stend::testing::write_text(one, bytes.substr(0, 128) + bytes.substr(624, 8 + len624));
  const std::string msg624 = error_of([&] { import_mat(one); });
  EXPECT_NE(msg624.find("byte 128: the matrix in this element declares 3172925448 bytes of dimensions"), std::string::npos)
      << msg624;
}

TEST(ImportMat, CharArrayDeclaringMoreThanItsDataIsDamageNamed) {
  // A segment's label whose dimensions declare 2052 characters where matio's buffer holds 4: the
  // text was copied from past the buffer (ASan, the fuzz target's find). Every char array and
  // numeric field is read only as far as its data holds its dimensions.
  // That input also has a label's data tag declaring 28494 bytes in a small (4-byte) element, which
  // the element walk refuses first now; the dimensions alone (1 x 2052 for "z up") are refused here.
  const fs::path mat = stend::testing::source_path("fuzz/regressions/import_mat/segment_label_longer_than_its_data.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  EXPECT_NE(msg.find("declares 28494 bytes of data in a 4-byte small element"), std::string::npos) << msg;
  const TempDir dir("importers");
  const std::string label = error_of([&] { import_mat(damaged_mat_seed(dir, {{1804, 2052}})); });
  EXPECT_NE(label.find("segments(1).label declares more characters than its data holds (damaged)"), std::string::npos)
      << label;
}

TEST(ImportMat, DataSubelementLongerThanItsMatrixIsRefusedBeforeMatioReadsIt) {
  // A segment label's UTF-8 data tag declared 1.8 GB inside a 56-byte matrix; matio sizes a char
  // array's buffer from that tag and calloc'ed 1.8 GB (the fuzz target found it). Every data
  // subelement's tag is now walked with the rest of the matrix.
  const fs::path mat = stend::testing::source_path("fuzz/regressions/import_mat/segment_label_data_tag_declares_1_8_GB.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  EXPECT_NE(msg.find("byte 1584: a matrix nested 1 deep in this element declares 1879048196 bytes of data where 8 are left"),
            std::string::npos) << msg;
}

// Files written by GNU Octave 7.3 (`save -v6` and `save -v7`, fuzz/corpus/import_mat/): beside the
// samples a complex, a sparse, a logical and a char matrix, and segment labels of one and two
// UTF-16 characters, which Octave packs into their tags (small data elements). The element walk
// checks every data subelement and must take all of these.
TEST(ImportMat, OctaveWrittenFilesWithEveryKindOfDataSubelementImport) {
  for (const char* name : {"octave_v6.mat", "octave_v7_compressed.mat"}) {
    SCOPED_TRACE(name);
    const Recording r = import_mat(stend::testing::source_path(std::string("fuzz/corpus/import_mat/") + name));
    ASSERT_EQ(r.samples.size(), 100u);
    EXPECT_DOUBLE_EQ(r.samples[41].accel_mps2.x(), 0.42);
    EXPECT_DOUBLE_EQ(r.samples[41].gyro_radps.z(), 0.003);
    ASSERT_EQ(r.segments.size(), 2u);
    EXPECT_EQ(r.segments[0].label, "a");
    EXPECT_EQ(r.segments[1].label, "bb");
    EXPECT_EQ(r.segments[1].t_end_s, 0.9);
  }
}

// A file without a MAT 5 header is one matio tries as MAT v4, allocating the name length and data
// its variable headers declare: 54 bytes of text made it allocate 1.8 GB (the fuzz target found
// it). Every v4 variable header is now checked first; a v4 file written by Octave still imports,
// one cut short is refused at the variable it cuts.
TEST(ImportMat, Mat4HeadersAreCheckedBeforeMatioAllocatesWhatTheyDeclare) {
  const fs::path found = stend::testing::source_path("fuzz/regressions/import_mat/mat4_name_length_is_text.mat");
  const std::string msg = error_of([&] { import_mat(found); });
  EXPECT_NE(msg.find("byte 0: the variable header declares 5 x 1698264147 with an imaginary flag of 1885692792 (not a "
                     "MATLAB file: no MAT 5 header, and not a valid MAT v4 variable)"),
            std::string::npos) << msg;

  const fs::path v4 = stend::testing::source_path("fuzz/corpus/import_mat/octave_v4.mat");
  const Recording r = import_mat(v4);
  ASSERT_EQ(r.samples.size(), 100u);
  EXPECT_DOUBLE_EQ(r.samples[41].accel_mps2.x(), 0.42);

  const TempDir dir("importers");
  const std::string bytes = stend::testing::read_text(v4);
  write_text(dir / "cut.mat", bytes.substr(0, bytes.size() - 10));  // into the last variable's data
  const std::string cut = error_of([&] { import_mat(dir / "cut.mat"); });
  EXPECT_NE(cut.find("does not fit in the"), std::string::npos) << cut;
}

// A compressed variable whose data the element walk could not reach (a damaged zlib stream in
// Octave's v7 seed): matio's Mat_VarReadData leaked its inflate state reading it (LeakSanitizer,
// the fuzz target's find). Little-endian MAT 5 variables are read by Stend alone now, and one the
// walk did not find is damage.
TEST(ImportMat, DamagedCompressedVariableIsRefusedNotHandedToMatio) {
  const fs::path mat =
      stend::testing::source_path("fuzz/regressions/import_mat/compressed_acc_damaged_matio_leaks_inflate_copy.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  EXPECT_NE(msg.find("'acc': its data element was not found where its matrix declares it (damaged)"), std::string::npos)
      << msg;
}

// A damaged segments struct array that matio read without its fields (a mutation of Octave's v7
// seed): Mat_VarGetStructFieldByName indexed them unchecked (SEGV, the fuzz target's find).
// The same damage in the struct taken as the one holding the variables (no top-level acc): the
// variables were looked up in it unchecked (SEGV, the fuzz target's next find). Every struct field
// goes through one checked lookup now.
TEST(ImportMat, SegmentsStructWithoutItsFieldsIsDamageNamed) {
  const fs::path mat = stend::testing::source_path("fuzz/regressions/import_mat/segments_struct_fields_unread_segv.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  EXPECT_NE(msg.find("segments: a struct array of 2 whose field names or fields matio could not read (damaged)"),
            std::string::npos) << msg;
  // The second input's damage (a name of MAT data type 771) is refused by the element walk now,
  // before matio reads the struct.
  const fs::path root = stend::testing::source_path("fuzz/regressions/import_mat/root_struct_fields_unread_segv.mat");
  const std::string root_msg = error_of([&] { import_mat(root); });
  EXPECT_NE(root_msg.find("byte 526: the matrix in this element declares name of MAT data type 771 (1 expected)"),
            std::string::npos) << root_msg;
}

// Array flags declaring 48 bytes: matio reads them as 8 whatever their tag says, so it took later
// bytes as the name's length and Mat_GetDir allocated 2 GB (the fuzz target's find,
// array_flags_48_bytes_matio_reads_8.mat) where the walk, following the tag, saw a sound name.
// Flags of any length but 8 are damage now (here acc_lsb's flags tag made 48 bytes).
TEST(ImportMat, ArrayFlagsOfAnotherLengthThanMatioReadsAreDamage) {
  const TempDir dir("importers");
  const std::string msg = error_of([&] { import_mat(damaged_mat_seed(dir, {{828, 48}})); });
  EXPECT_NE(msg.find("byte 816: the matrix in this element declares 48 bytes of array flags (8 expected)"),
            std::string::npos) << msg;
}

// A cell or struct declaring 2^28 elements in a few hundred bytes: matio's Mat_GetDir calloc'ed a
// pointer for each, 2 GB (the fuzz target's find). Each member is a matrix of at least 8 bytes.
TEST(ImportMat, CellOrStructDeclaringMoreMembersThanItsBytesHoldIsDamage) {
  // The fuzz target's input has an earlier damage (dimensions of MAT data type 15621) refused first
  // now; the segments struct's 2 x 1 made 268435464 x 1 (x 4 fields) alone is refused here.
  const fs::path mat = stend::testing::source_path("fuzz/regressions/import_mat/cell_declaring_2e28_elements.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  EXPECT_NE(msg.find("byte 888: the matrix in this element declares dimensions"), std::string::npos) << msg;
  const TempDir dir("importers");
  const std::string members = error_of([&] { import_mat(damaged_mat_seed(dir, {{1616, 268435464}})); });
  EXPECT_NE(members.find("byte 1584: the matrix in this element declares 1073741856 cell elements or struct fields "
                         "where 520 bytes hold at most 65"),
            std::string::npos) << members;
  // A function handle (class 16), whose parts matio reads like cell elements, a pointer each
  // allocated first: 10 x 67108865 of them (the fuzz target's find, 1.4 s after the cells' fix).
  const fs::path handle = stend::testing::source_path("fuzz/regressions/import_mat/function_handle_declaring_671088650_parts.mat");
  const std::string parts = error_of([&] { import_mat(handle); });
  EXPECT_NE(parts.find("byte 128: the matrix in this element declares 671088650 cell elements or struct fields where 88 "
                       "bytes hold at most 11"),
            std::string::npos) << parts;
}

// A compressed element's inflated length, which bounds every length inside it, declared past what
// its compressed bytes can inflate to (deflate: at most 1032 bytes from one). Inside one a name
// declared 3.6 GB and the element walk reserved that much (the fuzz target's find, Stend's own
// allocation; kept subelements grow only as their bytes arrive since); in another, 83 bytes declared
// 1 GB and array flags of 1 GB, and matio, reading 8 bytes of flags whatever their tag says,
// calloc'ed 4 GB for the dimensions (the next find). Both are refused from the element's tag.
TEST(ImportMat, CompressedElementDeclaringMoreThanItCanInflateToIsDamage) {
  struct Case {
    const char* file;
    const char* message;
  };
  for (const Case& c : {Case{"compressed_name_declares_3_6_GB.mat",
                             "byte 128: the matrix in this element declares 3607102288 bytes inflated from 390 compressed "
                             "bytes (deflate inflates at most 1032 bytes from one)"},
                        Case{"compressed_1_GB_declared_in_83_bytes.mat",
                             "byte 953: the matrix in this element declares 1074006416 bytes inflated from 83 compressed "
                             "bytes (deflate inflates at most 1032 bytes from one)"}}) {
    SCOPED_TRACE(c.file);
    const fs::path mat = stend::testing::source_path(std::string("fuzz/regressions/import_mat/") + c.file);
    const std::string msg = error_of([&] { import_mat(mat); });
    EXPECT_NE(msg.find(c.message), std::string::npos) << msg;
  }
}

// Dimensions whose tag was of MAT data type 512 (miINT32, 5, expected) before a name whose small
// element declared 59395 bytes (a small element holds at most 4): matio read those tags otherwise
// than the element walk and malloc'ed 3.9 GB in Mat_GetDir (the fuzz target's find). Every header
// subelement must be of the type matio reads it as, and no small element may declare more than 4.
// (dimensions_of_type_512_name_of_59395_bytes.mat; here acc_lsb's dimensions tag made type 512, its
// name a 59395-byte small element.)
TEST(ImportMat, HeaderSubelementOfAnotherTypeOrAnOversizeSmallElementIsDamage) {
  const TempDir dir("importers");
  const std::string msg = error_of([&] { import_mat(damaged_mat_seed(dir, {{840, 512}})); });
  EXPECT_NE(msg.find("byte 816: the matrix in this element declares dimensions (at most 256 dimensions of 4 bytes) of "
                     "MAT data type 512 (5 expected)"),
            std::string::npos) << msg;
  const std::string small = error_of([&] { import_mat(damaged_mat_seed(dir, {{856, 0xe8030001u}})); });
  EXPECT_NE(small.find("byte 816: the matrix in this element declares name of 59395 bytes in a 4-byte small element"),
            std::string::npos) << small;
  // A struct's field name length in a 1-byte small element: matio reads 4 bytes whatever the tag
  // says (10, so 4 fields) where the walk had 1 byte and no fields to count, and calloc'ed 2^53
  // bytes of field pointers for dimensions of 2^32 x 2^32 (the fuzz target's next find).
  const fs::path length1 = stend::testing::source_path("fuzz/regressions/import_mat/field_name_length_of_1_byte.mat");
  const std::string msg1 = error_of([&] { import_mat(length1); });
  EXPECT_NE(msg1.find("byte 1584: the matrix in this element declares 1 bytes of field name length (4 expected)"),
            std::string::npos) << msg1;
}

// A MATLAB object variable (class 17, "opaque": datetime, string, table, …) has no dimensions: its
// array flags are followed by its name, its type system ("MCOS") and its class name, then data only
// MATLAB reads. The element walk's strict header types must not refuse a file for holding one (the
// element below follows that layout; no MATLAB-written file was at hand).
TEST(ImportMat, FileWithAMatlabObjectVariableBesideTheSeriesImports) {
  const std::string opaque_hex =
      "0e0000008000000006000000080000001100000000000000010004007768656e010004004d434f5301000000080000006461746574696d650e"
      "0000004800000006000000080000000d000000000000000500000008000000060000000100000001000000000000000d000000180000000000"
      "00dd0200000001000000010000000100000001000000";
  std::string bytes = stend::testing::read_text(stend::testing::source_path("fuzz/corpus/import_mat/seed_ok.mat"));
  for (std::size_t i = 0; i + 1 < opaque_hex.size(); i += 2)
    bytes += static_cast<char>(std::stoi(opaque_hex.substr(i, 2), nullptr, 16));
  const TempDir dir("importers");
  write_text(dir / "with_datetime.mat", bytes);
  const Recording rec = import_mat(dir / "with_datetime.mat");
  EXPECT_EQ(rec.samples.size(), 10U);
  EXPECT_EQ(rec.segments.size(), 2U);
}

// A 'segments' variable that is no struct array (here the seed's made a char array) was ignored
// without a word: the import had no segments. A segment's kind that is not text (made an int8
// array of the same 11 bytes) was taken as no kind, a static position. Both are errors naming what
// they are.
TEST(ImportMat, SegmentsThatAreNoStructArrayOrKindsThatAreNoTextAreAnError) {
  const TempDir dir("importers");
  const std::string msg = error_of([&] { import_mat(damaged_mat_seed(dir, {{1600, 4}})); });
  EXPECT_NE(msg.find("'segments' is a char array; expected a struct array with fields kind, label, t_start_s, t_end_s"),
            std::string::npos) << msg;
  const std::string kind = error_of([&] { import_mat(damaged_mat_seed(dir, {{1712, 8}, {1744, 1}})); });
  EXPECT_NE(kind.find("segments(1).kind is not text (a char array)"), std::string::npos) << kind;
}

// A variable's data element of a type that is no numeric MAT type (here 7689) holding 0 bytes: its
// size per value counted as 0, so "0 bytes for 1 value" matched and a value was read from an empty
// buffer (the fuzz target's find, numeric_data_of_no_numeric_type.mat: UBSan, memcpy from null).
// And matio allocates a numeric matrix's values from its dimensions before reading them (a struct
// read whole, the segments): the element walk checks every numeric matrix's real part to be of a
// numeric type and to hold the values its dimensions declare.
TEST(ImportMat, NumericMatrixWhoseDataAreNoNumbersOrFewerThanItsDimensionsIsDamage) {
  const TempDir dir("importers");
  const std::string type = error_of([&] { import_mat(damaged_mat_seed(dir, {{872, 7689}, {876, 0}})); });
  EXPECT_NE(type.find("byte 816: the matrix in this element declares its values of MAT data type 7689, not a number"),
            std::string::npos) << type;
  const std::string fewer = error_of([&] { import_mat(damaged_mat_seed(dir, {{848, 100000}})); });
  EXPECT_NE(fewer.find("byte 816: the matrix in this element declares 100000 values where its data holds 1"),
            std::string::npos) << fewer;
}

// Every input the fuzz target found (fuzz/regressions/import_mat/) is refused, naming the file and
// the damage; most carry more than one damage, so which check refuses them first is not asserted
// here (the tests above each damage one thing in the seed).
TEST(ImportMat, EveryFuzzFindIsRefusedAsDamageNamingTheFile) {
  for (const auto& entry : fs::directory_iterator(stend::testing::source_path("fuzz/regressions/import_mat"))) {
    SCOPED_TRACE(entry.path().filename().string());
    const std::string msg = error_of([&] { import_mat(entry.path()); });
    EXPECT_NE(msg.find(entry.path().filename().string()), std::string::npos) << msg;
    EXPECT_TRUE(msg.find("damaged") != std::string::npos || msg.find("not a MATLAB file") != std::string::npos) << msg;
  }
}

TEST(ImportMat, NestedMatrixLongerThanItsStructIsRefusedBeforeMatioListsTheVariables) {
  // A struct's last field declared 1080 bytes in a struct of 624; matio's Mat_GetDir, reading the
  // fields' headers, asked for 2 GB (the fuzz target found it).
  const fs::path mat = stend::testing::source_path("fuzz/regressions/import_mat/struct_field_longer_than_its_struct.mat");
  const std::string msg = error_of([&] { import_mat(mat); });
  EXPECT_NE(msg.find("byte 1584: the matrix in this element holds a matrix of 1080 bytes where 376 are left"),
            std::string::npos)
      << msg;
}
