// Issue 36, items 3 and 5, through the program as a user runs it: logs this test writes with the
// wrong units, bad samples or no temperature are refused (or read as absent) by `stend import`,
// `stend fit` and `stend gap` alike — never turned into numbers.
#include <gtest/gtest.h>

#include "stend/testing/files.hpp"
#include "stend/testing/program.hpp"

#include <cmath>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using stend::testing::ProgramOutput;
using stend::testing::run_stend;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

const std::string src = STEND_SOURCE_DIR;
const std::string kColumns = " --time t --accel ax,ay,az --gyro gx,gy,gz";

// A hand-held session at 100 Hz in ten orientations (the six faces and four diagonals): each
// still for 8 s, 2 s turns between them; the accelerometer reads `g_unit`·(the up vector, with a
// 0.3 % x scale error) + noise (whole counts when the noise is a count or more), the gyro
// `gyro_at_rest` when still and `turn_rate` when turning. No temperature column.
std::string faces_csv(double g_unit, double noise, double gyro_at_rest, double turn_rate = 1.5) {
  const double d = 1.0 / std::sqrt(3.0);
  const double faces[10][3] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0},  {-1, 0, 0},  {0, 1, 0},
                               {0, -1, 0}, {d, d, d}, {-d, d, -d}, {d, -d, -d}, {-d, -d, d}};
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  std::ostringstream out;
  out.precision(10);
  out << "t,ax,ay,az,gx,gy,gz\n";
  int i = 0;
  for (int f = 0; f < 10; ++f) {
    for (int k = 0; k < 1000; ++k, ++i) {
      const bool turning = f > 0 && k < 200;  // the first 2 s of every face after the first: a turn
      const double u = turning ? k / 200.0 : 1.0;
      out << i * 0.01;
      for (int a = 0; a < 3; ++a) {
        const double up = f > 0 ? (1 - u) * faces[f - 1][a] + u * faces[f][a] : faces[f][a];
        const double v = g_unit * up * (a == 0 ? 1.003 : 1.0) + noise * n(rng);
        out << "," << (noise >= 1.0 ? std::round(v) : v);  // counts are whole
      }
      for (int a = 0; a < 3; ++a) out << "," << (turning ? turn_rate : gyro_at_rest);
      out << "\n";
    }
  }
  return out.str();
}

void expect_refused(const ProgramOutput& out, int code, const std::string& says) {
  EXPECT_EQ(out.code, code) << out.text;
  EXPECT_NE(out.text.find(says), std::string::npos) << out.text;
}

}  // namespace

// Raw counts without --accel-lsb: import, fit and gap on the file say what the values look like
// (not "too few static intervals"), and nothing is written.
TEST(Plausibility, CountsWithoutLsbAreRefusedByEveryCommand) {
  const TempDir dir("plausible");
  const fs::path log = dir / "counts.csv";
  write_text(log, faces_csv(16384.0, 8.0, 0.0, 200.0));
  const std::string hint = "these look like raw counts — give --accel-lsb (e.g. 1/16384g)";
  expect_refused(run_stend("import " + log.string() + kColumns + " -o " + (dir / "run").string()), 2, hint);
  EXPECT_FALSE(fs::exists(dir / "run"));
  const ProgramOutput fit = run_stend("fit " + log.string() + kColumns + " --model " + src +
                                      "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml");
  expect_refused(fit, 2, hint);
  EXPECT_EQ(fit.text.find("static interval"), std::string::npos) << fit.text;
  expect_refused(run_stend("gap " + log.string() + kColumns + " --model " + src + "/diagnosis/examples/imucal_bias_scale.yaml"),
                 2, hint);
  // Stated, the same file imports.
  const ProgramOutput ok = run_stend("import " + log.string() + kColumns + " --accel-lsb 1/16384g -o " + (dir / "ok").string());
  EXPECT_EQ(ok.code, 0) << ok.text;
}

// g read as m/s², and m/s² declared as g.
TEST(Plausibility, WrongAccelerometerUnitIsRefused) {
  const TempDir dir("plausible");
  const fs::path in_g = dir / "g.csv", in_mps2 = dir / "mps2.csv";
  write_text(in_g, faces_csv(1.0, 0.001, 0.0));
  write_text(in_mps2, faces_csv(9.80665, 0.01, 0.0));
  expect_refused(run_stend("import " + in_g.string() + kColumns + " -o " + (dir / "a").string()), 2,
                 "these look like g — give --accel-unit g");
  expect_refused(run_stend("import " + in_mps2.string() + kColumns + " --accel-unit g -o " + (dir / "b").string()), 2,
                 "these look like m/s^2 read as g — drop --accel-unit g");
  EXPECT_EQ(run_stend("import " + in_g.string() + kColumns + " --accel-unit g -o " + (dir / "c").string()).code, 0);
}

// Gyro counts at rest, and an LSB of zero.
TEST(Plausibility, GyroCountsAndAZeroLsbAreRefused) {
  const TempDir dir("plausible");
  const fs::path log = dir / "gyro_counts.csv";
  write_text(log, faces_csv(9.80665, 0.01, -45.0));
  expect_refused(run_stend("import " + log.string() + kColumns + " -o " + (dir / "a").string()), 2,
                 "these look like raw counts — give --gyro-lsb");
  expect_refused(run_stend("import " + log.string() + kColumns + " --accel-lsb 1/0g -o " + (dir / "b").string()), 1,
                 "--accel-lsb");
  expect_refused(run_stend("import " + log.string() + kColumns + " --gyro-lsb 0deg/s -o " + (dir / "c").string()), 1,
                 "--gyro-lsb");
}

// A NaN value and a time going back: refused at FILE:LINE; with --drop-bad-samples, dropped and counted.
TEST(Plausibility, BadSamplesAreRefusedAtTheirLineOrDroppedAndCounted) {
  const TempDir dir("plausible");
  std::string text = faces_csv(9.80665, 0.01, 0.0);
  std::size_t at = 0;
  for (int line = 1; line < 4; ++line) at = text.find('\n', at) + 1;  // line 4: t = 0.02 s
  text.replace(at, text.find('\n', at) - at, "0.02,0.01,nan,9.8,0,0,0");
  const fs::path log = dir / "nan.csv";
  write_text(log, text);
  expect_refused(run_stend("import " + log.string() + kColumns + " -o " + (dir / "a").string()), 2,
                 log.string() + ":4: an accelerometer value is not a finite number");
  const ProgramOutput dropped =
      run_stend("import " + log.string() + kColumns + " --drop-bad-samples -o " + (dir / "b").string());
  EXPECT_EQ(dropped.code, 0) << dropped.text;
  EXPECT_NE(dropped.text.find("1 bad sample(s) dropped (--drop-bad-samples), the first: " + log.string() + ":4:"),
            std::string::npos)
      << dropped.text;
}

// No temperature column: gap offers no temperature candidate and prints no temperature; a model
// with temperature terms is not applicable (exit 2, no coefficient).
TEST(Plausibility, ARecordingWithoutTemperatureHasNoTemperatureTerms) {
  const TempDir dir("plausible");
  const fs::path log = dir / "faces.csv";
  write_text(log, faces_csv(9.80665, 0.01, 0.0));
  const ProgramOutput gap =
      run_stend("gap " + log.string() + kColumns + " --model " + src + "/diagnosis/examples/imucal_bias_scale.yaml");
  ASSERT_EQ(gap.code, 0) << gap.text;
  EXPECT_EQ(gap.text.find("degC"), std::string::npos) << gap.text;
  EXPECT_NE(gap.text.find("temperature:  none recorded"), std::string::npos) << gap.text;
  EXPECT_EQ(gap.text.find("_temperature"), std::string::npos) << gap.text;
  EXPECT_EQ(gap.text.find("thermal"), std::string::npos) << gap.text;
  for (const std::string model : {"/estimators/batch_lsq/examples/accelerometer_full.yaml",
                                  "/estimators/temp_poly/examples/temp_poly.yaml"}) {
    const ProgramOutput fit = run_stend("fit " + log.string() + kColumns + " --model " + src + model);
    expect_refused(fit, 2, "not applicable — the recording has no temperature");
    EXPECT_EQ(fit.text.find("_tc1_"), std::string::npos) << fit.text;
  }
}
