// The format registry (detection by content), the import options (flags and YAML share keys;
// errors name file:line:col) and the timestamp repair every importer calls.
#include <gtest/gtest.h>

#include <stend/core/experiment.hpp>
#include <stend/io/formats.hpp>
#include <stend/io/importers.hpp>
#include <stend/io/timestamps.hpp>
#include <stend/physics/units.hpp>
#include <stend/testing/files.hpp>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

// A 200 Hz log of t, ax, ay, az (counts around an unsigned 16-bit offset) with times printed at
// `decimals` decimals; `gap_at` (≥ 0): samples from that index on are 0.5 s later. Returns the true
// times.
std::vector<double> write_log(const fs::path& file, int decimals, long gap_at = -1, std::size_t n = 4000) {
  std::vector<double> truth;
  std::string text = "t,ax,ay,az,temp\n";
  const double t0 = 12.3456;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = t0 + static_cast<double>(i) / 200.0 + (gap_at >= 0 && static_cast<long>(i) >= gap_at ? 0.5 : 0.0);
    truth.push_back(t);
    char line[128];
    std::snprintf(line, sizeof line, "%.*f,%d,%d,%d,25.37\n", decimals, t, 32768 + 5, 32768 - 3, 32768 + 16384);
    text += line;
  }
  write_text(file, text);
  return truth;
}

ImportOptions log_options() {
  ImportOptions o;
  o.set("time", "t");
  o.set("accel", "ax,ay,az");
  o.set("accel_lsb", "1/16384g");
  o.set("accel_offset", "32768");
  o.set("temperature", "temp");  // in degC beside the counts
  return o;
}

}  // namespace

// Times printed with two decimals at 200 Hz: consecutive samples share a time. The import rebuilds
// them within half a sample of the truth and says so; counts are kept, SI = (count − offset)·LSB.
TEST(TimestampRepair, RoundedTimesAt200HzAreRebuiltWithinHalfASample) {
  TempDir dir("repair");
  const auto truth = write_log(dir / "log.csv", 2);
  const Recording rec = open_dataset({dir / "log.csv"}, "auto", log_options());
  ASSERT_EQ(rec.samples.size(), truth.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) worst = std::max(worst, std::abs(rec.samples[i].t_s - truth[i]));
  EXPECT_LT(worst, 0.5 / 200.0);
  EXPECT_NEAR(rec.header.info.output_rate_hz, 200.0, 0.01);
  for (std::size_t i = 1; i < rec.samples.size(); ++i) EXPECT_FALSE(rec.samples[i].flags & kGapBefore) << i;
  EXPECT_EQ(rec.samples[0].accel_counts[2], 32768 + 16384);
  EXPECT_NEAR(rec.samples[0].accel_mps2[2], physics::kStandardGravity, 1e-12);
  EXPECT_NEAR(rec.samples[0].accel_mps2[1], -3 * physics::kStandardGravity / 16384, 1e-12);
  EXPECT_DOUBLE_EQ(rec.samples[0].temperature_c, 25.37);
  bool warned = false;
  for (const auto& e : rec.events) warned = warned || (e.level == "warning" && e.message.find("rebuilt") != std::string::npos);
  EXPECT_TRUE(warned);
}

// A real 0.5 s gap in rounded times: flagged at its sample, not filled; times stay within half a
// sample on both sides.
TEST(TimestampRepair, RealGapIsFlaggedNotFilled) {
  TempDir dir("gap");
  const auto truth = write_log(dir / "log.csv", 2, 1500);
  const Recording rec = open_dataset({dir / "log.csv"}, "csv", log_options());
  ASSERT_EQ(rec.samples.size(), truth.size());
  std::size_t flagged = 0;
  for (std::size_t i = 1; i < rec.samples.size(); ++i)
    if (rec.samples[i].flags & kGapBefore) {
      ++flagged;
      EXPECT_EQ(i, 1500u);
    }
  EXPECT_EQ(flagged, 1u);
  for (std::size_t i = 0; i < truth.size(); ++i) ASSERT_NEAR(rec.samples[i].t_s, truth[i], 0.5 / 200.0) << i;
}

// Clean times are kept as logged; a gap is flagged the way it always was (> 1.5 intervals).
TEST(TimestampRepair, CleanTimesAreKept) {
  TempDir dir("clean");
  const auto truth = write_log(dir / "log.csv", 9, 100, 400);
  const Recording rec = open_dataset({dir / "log.csv"}, "csv", log_options());
  for (std::size_t i = 0; i < truth.size(); ++i) ASSERT_NEAR(rec.samples[i].t_s, truth[i], 1e-9);
  EXPECT_TRUE(rec.samples[100].flags & kGapBefore);
  for (const auto& e : rec.events) EXPECT_EQ(e.message.find("rebuilt"), std::string::npos) << e.message;
}

TEST(ImportOptions, FlagsAndYamlShareKeysAndYamlErrorsNameTheLine) {
  TempDir dir("opts");
  write_text(dir / "map.yaml", "time: 0\naccel: [1, 2, 3]\naccel_lsb: 1/16384 g\naccel_offset: 32768\ngyro_unit: deg/s\n");
  ImportOptions o;
  read_import_mapping(dir / "map.yaml", o);
  EXPECT_EQ(o.time.index, 0);
  EXPECT_EQ(o.accel[2].index, 3);
  EXPECT_NEAR(o.accel_value.lsb, physics::kStandardGravity / 16384, 1e-15);
  EXPECT_EQ(o.accel_value.offset, 32768);
  EXPECT_NEAR(o.gyro_value.unit, physics::kDegPerSecond, 1e-15);
  EXPECT_TRUE(o.IsValid());

  write_text(dir / "bad.yaml", "time: t\naccel_lsb: sixteen\n");
  try {
    ImportOptions b;
    read_import_mapping(dir / "bad.yaml", b);
    FAIL() << "accepted a bad LSB";
  } catch (const ExperimentError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:2:"), std::string::npos) << e.what();
  }
  write_text(dir / "typo.yaml", "acel: [a, b, c]\n");
  try {
    ImportOptions b;
    read_import_mapping(dir / "typo.yaml", b);
    FAIL() << "accepted an unknown key";
  } catch (const ExperimentError& e) {
    EXPECT_NE(std::string(e.what()).find("typo.yaml:1:1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("accel"), std::string::npos) << e.what();
  }
  ImportOptions half;
  half.set("accel", "a,b,c");
  std::string why;
  EXPECT_TRUE(half.IsValid(&why)) << why;  // a container's N×4 array may hold the time
  write_text(dir / "abc.csv", "a,b,c\n0,0,9.8\n");
  try {
    open_dataset({dir / "abc.csv"}, "auto", half);
    FAIL() << "a CSV without time column or rate was imported";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rate_hz"), std::string::npos) << e.what();
  }
  EXPECT_THROW(half.set("accel_unit", "furlongs"), std::invalid_argument);
}

// Each key is declared once: a default-constructed ImportOptions holds the table's defaults and has
// stated nothing; the help a flag shows is made from the same row.
TEST(ImportOptions, DefaultsAndHelpComeFromTheKeyTable) {
  const ImportOptions o;
  EXPECT_TRUE(o.stated.empty());
  EXPECT_EQ(o.delimiter, ',');
  EXPECT_EQ(o.comment, "#");
  EXPECT_TRUE(o.column_names);
  EXPECT_EQ(o.time_scale_s, 1.0);
  EXPECT_EQ(o.accel_value.unit, 1.0);
  EXPECT_EQ(o.gyro_value.unit, 1.0);
  EXPECT_EQ(o.temperature_scale, 1.0);
  EXPECT_EQ(o.rate_hz, 0.0);  // no default: absent until given
  EXPECT_EQ(o.instance, -1);
  for (const ImportKey& k : import_keys()) {
    ImportOptions x;
    if (!k.fallback.empty()) {
      EXPECT_NO_THROW(x.set(k.key, k.fallback)) << k.key;
      EXPECT_NE(k.description().find("[" + k.fallback + "]"), std::string::npos) << k.description();
    }
    if (!k.unit.empty()) {
      EXPECT_NE(k.description().find(k.unit), std::string::npos) << k.description();
    }
    EXPECT_NE(std::string(k.type_name()), "") << k.key;
  }
  EXPECT_EQ(import_flag("temperature_offset_c"), "--temperature-offset-c");
}

// The options each importer takes are checked where it starts.
TEST(ImportOptions, EachImportersOptionsAreCheckedWhereItStarts) {
  ImucalOptions imucal;
  imucal.rate_hz = 0.0;
  std::string why;
  EXPECT_FALSE(imucal.IsValid(&why));
  EXPECT_NE(why.find("rate_hz"), std::string::npos) << why;
  EXPECT_THROW(import_imucal_session("/nonexistent.csv", imucal), std::invalid_argument);
  MatOptions mat;
  mat.time_scale_s = -1.0;
  EXPECT_FALSE(mat.IsValid());
  CsvMapping csv;
  csv.accel_scale = 0.0;
  EXPECT_FALSE(csv.IsValid(&why));
  EXPECT_NE(why.find("scales"), std::string::npos) << why;
  EXPECT_TRUE(ImuTkOptions{}.IsValid());
  EXPECT_TRUE(Mpu6050MultiposOptions{}.IsValid());
}

// IMU-TK text files named .mat (as IMU-TK ships them) go to the IMU-TK reader; real MAT headers
// to matio; a file nothing reads gets an error listing the formats.
TEST(Formats, DetectionIsByContentNotName) {
  TempDir dir("detect");
  std::string acc, gyr;
  for (int i = 0; i < 50; ++i) {
    acc += std::to_string(i * 0.01) + " 0.1 -0.2 9.8\n";
    gyr += std::to_string(i * 0.01) + " 0.001 0.002 -0.003\n";
  }
  write_text(dir / "acc.mat", acc);
  write_text(dir / "gyro.mat", gyr);
  EXPECT_EQ(detect_format({dir / "acc.mat"}).name, "imutk");
  EXPECT_EQ(detect_format({dir / "acc.mat", dir / "gyro.mat"}).name, "imutk");
  const Recording rec = open_dataset({dir / "acc.mat", dir / "gyro.mat"}, "auto");
  ASSERT_EQ(rec.samples.size(), 50u);
  EXPECT_DOUBLE_EQ(rec.samples[3].gyro_radps[2], -0.003);
  EXPECT_TRUE(rec.header.info.has_gyro);

  if (mat_supported()) {
    export_mat(rec, dir / "real.mat");
    EXPECT_TRUE(looks_like_mat(dir / "real.mat"));
    EXPECT_EQ(detect_format({dir / "real.mat"}).name, "mat");
  }
  write_text(dir / "notes.txt", "hello\nworld\n");
  try {
    detect_format({dir / "notes.txt"});
    FAIL();
  } catch (const std::runtime_error& e) {
    for (const auto& f : formats()) EXPECT_NE(std::string(e.what()).find(f.name + ": "), std::string::npos) << e.what();
  }
  EXPECT_THROW(find_format("nope"), std::invalid_argument);
}

// A table of static means becomes held orientation segments with truth.
TEST(Formats, StaticTableHoldsEachMeanWithItsTruth) {
  TempDir dir("table");
  write_text(dir / "t.csv", "# a table\nangle_deg,a_z_mps2\n0,9.9\n90,0.05\n");
  ASSERT_EQ(detect_format({dir / "t.csv"}).name, "static_table");
  ImportOptions o;
  o.set("gravity_mps2", "9.8");
  const Recording rec = open_dataset({dir / "t.csv"}, "auto", o);
  ASSERT_EQ(rec.segments.size(), 2u);
  EXPECT_DOUBLE_EQ(rec.samples.back().accel_mps2[2], 0.05);
  EXPECT_TRUE(std::isnan(rec.samples.back().accel_mps2[0]));
  const int fx = rec.truth_column("f_x_mps2"), fz = rec.truth_column("f_z_mps2");
  ASSERT_GE(fx, 0);
  EXPECT_NEAR(rec.truth.back()[static_cast<std::size_t>(fx)], -9.8, 1e-12);  // f = g·[−sin δ, 0, cos δ]
  EXPECT_NEAR(rec.truth.back()[static_cast<std::size_t>(fz)], 0.0, 1e-12);
}

// The LSB and offset keys replace a counts format's nominal LSB (here imucal's 2048 LSB/g); the
// counts are kept as logged, and the truth built from the annotations is unchanged.
TEST(Formats, LsbAndOffsetOverrideACountsFormat) {
  TempDir dir("imucal");
  std::string text = "part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\n";
  for (int i = 0; i < 20; ++i) text += "x_p," + std::to_string(i) + ",4196,100,100,100,100,100\n";
  write_text(dir / "s.csv", text);
  // The nominal LSB (2048 counts per g) reads 2 g at rest: refused as implausible, imported as
  // asked with --accept-implausible.
  try {
    open_dataset({dir / "s.csv"}, "auto");
    ADD_FAILURE() << "2 g at rest was imported";
  } catch (const ImportError& e) {
    EXPECT_NE(std::string(e.what()).find("not about 1 g: check --accel-lsb"), std::string::npos) << e.what();
  }
  ImportOptions odd;
  odd.set("accept_implausible", "true");
  const Recording nominal = open_dataset({dir / "s.csv"}, "auto", odd);
  EXPECT_NEAR(nominal.samples[0].accel_mps2[0], 4196 * physics::kStandardGravity / 2048, 1e-12);
  ImportOptions o;
  o.set("accel_lsb", "1/4096 g");
  o.set("accel_offset", "100");
  o.set("gyro_lsb", "1/32.8 deg/s");
  o.set("gyro_offset", "100");
  const Recording r = open_dataset({dir / "s.csv"}, "imucal", o);
  EXPECT_EQ(r.samples[0].accel_counts[0], 4196);
  EXPECT_NEAR(r.samples[0].accel_mps2[0], physics::kStandardGravity, 1e-12);
  EXPECT_NEAR(r.samples[0].accel_mps2[1], 0.0, 1e-15);
  EXPECT_NEAR(r.samples[0].gyro_radps[2], 0.0, 1e-15);
  const int fx = r.truth_column("f_x_mps2");
  ASSERT_GE(fx, 0);
  EXPECT_DOUBLE_EQ(r.truth[0][static_cast<std::size_t>(fx)], 9.81);  // imucal's expected_g
}
