// Plausibility on the way in (stend/io/plausibility.hpp): logs this test writes with the wrong
// units, bad samples and no temperature, read through the format registry as `stend import`,
// `fit` and `gap` read them.
#include <stend/io/formats.hpp>
#include <stend/io/plausibility.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <random>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

constexpr double kG = 9.80665;

// A still log at 100 Hz for `seconds`: columns t,ax,ay,az,gx,gy,gz, the accelerometer reading
// `accel` (+ noise of `noise` in its unit; whole counts when the noise is a count or more), the
// gyroscope `gyro`.
std::string still_csv(double seconds, const Eigen::Vector3d& accel, double noise, const Eigen::Vector3d& gyro) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  std::ostringstream out;
  out.precision(10);
  out << "t,ax,ay,az,gx,gy,gz\n";
  for (int i = 0; i < static_cast<int>(seconds * 100); ++i) {
    out << i * 0.01;
    for (int k = 0; k < 3; ++k) {
      const double a = accel[k] + noise * n(rng);
      out << "," << (noise >= 1.0 ? std::round(a) : a);
    }
    for (int k = 0; k < 3; ++k) out << "," << gyro[k];
    out << "\n";
  }
  return out.str();
}

ImportOptions mapped(std::initializer_list<std::pair<std::string, std::string>> keys = {}) {
  ImportOptions o;
  o.set("time", "t");
  o.set("accel", "ax,ay,az");
  o.set("gyro", "gx,gy,gz");
  for (const auto& [k, v] : keys) o.set(k, v);
  return o;
}

std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

bool has_event(const Recording& rec, const std::string& text) {
  for (const auto& e : rec.events)
    if (e.message.find(text) != std::string::npos) return true;
  return false;
}

}  // namespace

// Raw MPU-6050 counts (16384 per g) read without --accel-lsb: refused saying they look like counts.
TEST(Plausibility, CountsWithoutLsbAreRefusedWithTheHint) {
  TempDir dir;
  const fs::path f = dir.path() / "counts.csv";
  write_text(f, still_csv(5.0, {120, -340, 16384}, 8.0, {0.0, 0.0, 0.0}));
  const std::string why = error_of([&] { open_dataset({f}, "auto", mapped()); });
  EXPECT_NE(why.find("counts.csv"), std::string::npos) << why;
  EXPECT_NE(why.find("these look like raw counts — give --accel-lsb"), std::string::npos) << why;
  // With the LSB stated the same file is 1 g.
  const Recording rec = open_dataset({f}, "auto", mapped({{"accel_lsb", "1/16384g"}}));
  EXPECT_NEAR(rec.samples[100].accel_mps2.norm(), kG, 0.05);
  // And a centrifuge's log is imported as it is when the user says so.
  EXPECT_NO_THROW(open_dataset({f}, "auto", mapped({{"accept_implausible", "true"}})));
}

// Values in g read as m/s²: "these look like g"; given --accel-unit g they are 1 g.
TEST(Plausibility, GValuesWithoutTheUnitAreRefused) {
  TempDir dir;
  const fs::path f = dir.path() / "g.csv";
  write_text(f, still_csv(5.0, {0.01, -0.02, 0.999}, 0.001, {0.001, 0.0, 0.0}));
  const std::string why = error_of([&] { open_dataset({f}, "auto", mapped()); });
  EXPECT_NE(why.find("these look like g — give --accel-unit g"), std::string::npos) << why;
  const Recording rec = open_dataset({f}, "auto", mapped({{"accel_unit", "g"}}));
  EXPECT_NEAR(rec.samples[100].accel_mps2.norm(), kG, 0.05);
}

// Values in m/s² declared as g: 9.8 g at rest is refused.
TEST(Plausibility, MetresPerSecondSquaredGivenAsGAreRefused) {
  TempDir dir;
  const fs::path f = dir.path() / "mps2.csv";
  write_text(f, still_csv(5.0, {0.1, -0.2, 9.79}, 0.01, {0.001, 0.0, 0.0}));
  const std::string why = error_of([&] { open_dataset({f}, "auto", mapped({{"accel_unit", "g"}})); });
  EXPECT_NE(why.find("these look like m/s^2 read as g — drop --accel-unit g"), std::string::npos) << why;
  EXPECT_NO_THROW(open_dataset({f}, "auto", mapped()));
}

// Gyro counts (a bias of tens of counts) read as rad/s: more than any MEMS gyroscope reads at rest.
TEST(Plausibility, GyroCountsWithoutLsbAreRefused) {
  TempDir dir;
  const fs::path f = dir.path() / "gyro_counts.csv";
  write_text(f, still_csv(5.0, {0.1, -0.2, 9.79}, 0.01, {-60, 40, 35}));
  const std::string why = error_of([&] { open_dataset({f}, "auto", mapped()); });
  EXPECT_NE(why.find("these look like raw counts — give --gyro-lsb"), std::string::npos) << why;
  EXPECT_NO_THROW(open_dataset({f}, "auto", mapped({{"gyro_lsb", "1/131deg/s"}})));
}

// A log moving throughout has no still stretch: the rule does not judge it (whatever its scale).
TEST(Plausibility, ALogWithoutAStillStretchIsNotJudged) {
  TempDir dir;
  const fs::path f = dir.path() / "moving.csv";
  std::ostringstream out;
  out << "t,ax,ay,az\n";
  for (int i = 0; i < 1000; ++i) {
    const double t = i * 0.01;
    out << t << "," << 15000 * std::sin(7 * t) << "," << 15000 * std::cos(5 * t) << "," << 3000 * std::sin(11 * t) << "\n";
  }
  write_text(f, out.str());
  ImportOptions o;
  o.set("time", "t");
  o.set("accel", "ax,ay,az");
  EXPECT_NO_THROW(open_dataset({f}, "auto", o));
}

// NaN in a value, NaN and backwards times: refused at FILE:LINE; --drop-bad-samples drops and counts.
TEST(Plausibility, BadCsvLinesAreRefusedAtTheirLineOrDroppedAndCounted) {
  TempDir dir;
  const std::string text = still_csv(3.0, {0.1, -0.2, 9.79}, 0.01, {0.001, 0.0, 0.0});
  const auto replace_line = [](std::string s, int line, const std::string& with) {
    std::size_t a = 0;
    for (int i = 1; i < line; ++i) a = s.find('\n', a) + 1;
    return s.replace(a, s.find('\n', a) - a, with);
  };
  const fs::path nan_value = dir.path() / "nan_value.csv", nan_time = dir.path() / "nan_time.csv",
                 back = dir.path() / "back.csv";
  write_text(nan_value, replace_line(text, 5, "0.03,0.1,nan,9.79,0,0,0"));
  write_text(nan_time, replace_line(text, 7, "nan,0.1,-0.2,9.79,0,0,0"));
  write_text(back, replace_line(text, 9, "0.01,0.1,-0.2,9.79,0,0,0"));
  EXPECT_NE(error_of([&] { open_dataset({nan_value}, "auto", mapped()); }).find("nan_value.csv:5: an accelerometer value is not a finite number"),
            std::string::npos);
  EXPECT_NE(error_of([&] { open_dataset({nan_time}, "auto", mapped()); }).find("nan_time.csv:7: time nan is not a finite number"),
            std::string::npos);
  EXPECT_NE(error_of([&] { open_dataset({back}, "auto", mapped()); }).find("back.csv:9: time 0.01 s goes back"),
            std::string::npos);
  for (const fs::path& f : {nan_value, nan_time, back}) {
    const Recording rec = open_dataset({f}, "auto", mapped({{"drop_bad_samples", "true"}}));
    EXPECT_EQ(rec.samples.size(), 299u) << f;
    EXPECT_TRUE(has_event(rec, "1 bad sample(s) dropped (--drop-bad-samples), the first: " + f.string() + ":"))
        << f;
  }
}

// A format without line numbers at the gate: the sample is named by its index.
TEST(Plausibility, BadSamplesOfOtherFormatsAreNamedBySampleIndex) {
  TempDir dir;
  const fs::path f = dir.path() / "acc.txt";
  std::ostringstream out;
  for (int i = 0; i < 300; ++i) out << i * 0.01 << " " << (i == 41 ? std::string("inf") : "0.1") << " -0.2 9.79\n";
  write_text(f, out.str());
  const std::string why = error_of([&] { open_dataset({f}, "imutk", {}); });
  EXPECT_NE(why.find("acc.txt: sample 42: an accelerometer value is not a finite number"), std::string::npos) << why;
  ImportOptions drop;
  drop.set("drop_bad_samples", "true");
  EXPECT_EQ(open_dataset({f}, "imutk", drop).samples.size(), 299u);
}

// An LSB of zero or infinity is refused naming the key (the flag's usage error).
TEST(Plausibility, AZeroOrInfiniteLsbIsRefusedNamingTheKey) {
  ImportOptions o;
  EXPECT_NE(error_of([&] { o.set("accel_lsb", "1/0 g"); }).find("accel_lsb: '1/0 g' is not a positive, finite count size"),
            std::string::npos);
  EXPECT_NE(error_of([&] { o.set("gyro_lsb", "0 deg/s"); }).find("gyro_lsb"), std::string::npos);
  EXPECT_NE(error_of([&] { o.set("accel_lsb", "1e400 g"); }).find("accel_lsb"), std::string::npos);
}

// No temperature column: every sample reads NaN (never 0 °C), in memory and in both run stores.
TEST(Plausibility, AbsentTemperatureIsNaNAndRoundTrips) {
  TempDir dir;
  const fs::path f = dir.path() / "no_temp.csv";
  write_text(f, still_csv(3.0, {0.1, -0.2, 9.79}, 0.01, {0.001, 0.0, 0.0}));
  const Recording rec = open_dataset({f}, "auto", mapped());
  EXPECT_FALSE(rec.header.info.has_temperature);
  for (const auto& s : rec.samples) ASSERT_TRUE(std::isnan(s.temperature_c));
  for (const RecordingFormat store : {RecordingFormat::kHdf5, RecordingFormat::kCsv}) {
    const fs::path run = dir.path() / (store == RecordingFormat::kHdf5 ? "run_h5" : "run_csv");
    Recording streamed;
    RunSink sink(streamed, run, "name: x\n", {}, RecordingWriterOptions{store});
    import_dataset({f}, "auto", streamed, sink, mapped());
    sink.finish();
    const Recording back = Recording::open(run);
    ASSERT_EQ(back.samples.size(), rec.samples.size());
    for (const auto& s : back.samples) ASSERT_TRUE(std::isnan(s.temperature_c)) << run;
  }
}

// The real logs in ../shared/data are plausible as they are: none is refused (a log moving
// throughout is not judged).
TEST(Plausibility, TheSharedRealLogsPass) {
  for (const char* rel : {"logs/ulog/sample_log_small.ulg", "logs/dataflash/ardusub_small.BIN",
                          "logs/rosbag1/sparkfun_razor.bag", "logs/rosbag1/robot_localization_test2.bag",
                          "imucal/annotated_session.csv", "mpu6050_multipos/calibration_session.csv",
                          "mpu6050_multipos/static_449s.csv"}) {
    const fs::path file = stend::testing::shared_data(rel);
    STEND_SKIP_IF_ABSENT(file);
    EXPECT_NO_THROW(open_dataset({file}, "auto")) << rel;
  }
}
