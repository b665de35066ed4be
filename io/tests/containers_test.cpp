// Containers read by naming what is inside (issue 42): .mat variables under any name — v4, v5
// (Octave's save), 7.3 (matio's HDF5 writer) —, N×3, N×4 [t x y z] and 3×N arrays, struct fields,
// columns of a wide array, one file per sensor joined by rows or on time, and a CSV with the
// accelerometer in counts beside a gyroscope in rad/s. Each file is written here by another tool
// and the samples read back must equal what was written.
#include <gtest/gtest.h>

#include <stend/io/formats.hpp>
#include <stend/io/import_options.hpp>
#include <stend/io/importers.hpp>
#include <stend/physics/units.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/program.hpp>

#include <matio.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::TempDir;

namespace {

constexpr double kG = physics::kStandardGravity;
constexpr double kDeg = physics::kDegPerSecond;

bool have_octave() { return stend::testing::run_command("command -v octave-cli").code == 0; }

// Runs an Octave script in `dir` (the files it saves land there).
void octave(const fs::path& dir, const std::string& script) {
  const auto out = stend::testing::run_command("cd " + stend::testing::shell_quote(dir.string()) +
                                               " && octave-cli --no-gui --norc --eval " +
                                               stend::testing::shell_quote(script));
  ASSERT_EQ(out.code, 0) << out.text;
}

ImportOptions options(std::initializer_list<std::pair<const char*, const char*>> keys) {
  ImportOptions o;
  for (const auto& [k, v] : keys) o.set(k, v);
  return o;
}

std::string import_message(const Recording& rec) {
  for (const Event& e : rec.events)
    if (e.source == "import" && e.message.rfind("imported ", 0) == 0) return e.message;
  return "";
}

// A value of sample i, axis c: a different, exactly representable number for each.
double accel_g(std::size_t i, int c) { return (c == 2 ? 1.0 : 0.0) + 0.001 * static_cast<double>(i % 97) * (c + 1); }
double gyro_dps(std::size_t i, int c) { return 0.01 * static_cast<double>(i % 31) - 0.1 * c; }

// Octave's row vector expression for accel_g / gyro_dps over i = 0 … n−1 (same arithmetic).
std::string octave_series(const char* fn, int c, std::size_t n) {
  const std::string i = "mod((0:" + std::to_string(n - 1) + ")'";
  if (std::string(fn) == "accel")
    return "(" + std::string(c == 2 ? "1" : "0") + " + 0.001 * " + i + ", 97) * " + std::to_string(c + 1) + ")";
  return "(0.01 * " + i + ", 31) - 0.1 * " + std::to_string(c) + ")";
}

TEST(Containers, MatV5VariablesOfAnyNameAndDifferentLengthsWithoutTimeJoinedByRow) {
  if (!have_octave()) GTEST_SKIP() << "octave-cli not installed (scripts/install-deps.sh installs Debian's octave)";
  TempDir dir("containers");
  const std::size_t n = 500, m = 495;  // the gyroscope stopped 5 samples earlier
  std::string s = "A_xyz = [";
  for (int c = 0; c < 3; ++c) s += octave_series("accel", c, n) + (c < 2 ? ", " : "];");
  s += " W_xyz = [";
  for (int c = 0; c < 3; ++c) s += octave_series("gyro", c, m) + (c < 2 ? ", " : "];");
  s += " results.bias = [1 2 3]; results.note = 'fit'; save('-v7', 'session.mat', 'A_xyz', 'W_xyz', 'results');";
  ASSERT_NO_FATAL_FAILURE(octave(dir.path(), s));

  const auto o = options({{"accel", "A_xyz"}, {"gyro", "W_xyz"}, {"accel_unit", "g"}, {"gyro_unit", "deg/s"}, {"rate_hz", "100"}});
  std::string used;
  const Recording rec = open_dataset({dir / "session.mat"}, "auto", o, &used);
  EXPECT_EQ(used, "mat");
  ASSERT_EQ(rec.samples.size(), m);
  for (std::size_t i = 0; i < m; i += 7)
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(rec.samples[i].accel_mps2[c], accel_g(i, c) * kG, 1e-12) << i << c;
      EXPECT_NEAR(rec.samples[i].gyro_radps[c], gyro_dps(i, c) * kDeg, 1e-14) << i << c;
    }
  EXPECT_DOUBLE_EQ(rec.samples[10].t_s, 0.1);
  const std::string msg = import_message(rec);
  EXPECT_NE(msg.find("MAT v5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("joined row by row"), std::string::npos) << msg;
  EXPECT_NE(msg.find("495 vs 500"), std::string::npos) << msg;
}

TEST(Containers, AnUnknownNameListsTheVariablesPresent) {
  if (!have_octave()) GTEST_SKIP() << "octave-cli not installed (scripts/install-deps.sh installs Debian's octave)";
  TempDir dir("containers");
  ASSERT_NO_FATAL_FAILURE(octave(dir.path(), "A_xyz = ones(20, 3); fs = 50; save('-v6', 'a.mat', 'A_xyz', 'fs');"));
  try {
    open_dataset({dir / "a.mat"}, "auto", options({{"accel", "acc"}, {"rate_hz", "50"}}));
    FAIL() << "an absent variable was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("no array named 'acc'"), std::string::npos) << what;
    EXPECT_NE(what.find("A_xyz (20x3 float64)"), std::string::npos) << what;
  }
  // Sensors of very different lengths without times are refused, not joined row by row.
  ASSERT_NO_FATAL_FAILURE(octave(dir.path(), "A = ones(100, 3); W = ones(50, 3); save('-v7', 'b.mat', 'A', 'W');"));
  EXPECT_THROW(open_dataset({dir / "b.mat"}, "auto", options({{"accel", "A"}, {"gyro", "W"}, {"rate_hz", "50"}})),
               InputError);
}

// Crafted .mat files (Octave's -v7): 2000 variables beside the IMU's (each found by name from the
// file's start, twice: 28 s), 200 one-field structs (each opened and walked as a file of its own:
// 45 s), each read within 5 s; a compressed 250×250 matrix read a column at a time would inflate
// it from its start for each of the 250: refused, saying why.
TEST(Containers, CraftedMatFilesAreLinearInTime) {
  if (!have_octave()) GTEST_SKIP() << "octave-cli not installed (scripts/install-deps.sh installs Debian's octave)";
  TempDir dir("containers");
  ASSERT_NO_FATAL_FAILURE(octave(dir.path(),
                                 "t = (0:199)' * 10; acc = [zeros(200, 2), ones(200, 1)]; gyro = zeros(200, 3); "
                                 "for k = 1:2000, eval(sprintf('v%d = k;', k)); end; save('-v7', 'many.mat'); clear v*; "
                                 "for k = 1:200, eval(sprintf('s%d.f = k;', k)); end; "
                                 "save('-v7', 'structs.mat', 't', 'acc', 'gyro', 's*'); "
                                 "tw = (0:249)' * 10; wide = zeros(250); save('-v7', 'wide.mat', 'wide', 'tw');"));
  const ImportOptions imu = options({{"accel", "acc"}, {"accel_unit", "g"}, {"gyro", "gyro"}, {"time", "t"}, {"time_unit", "ms"}});
  for (const char* name : {"many.mat", "structs.mat"}) {
    const auto start = std::chrono::steady_clock::now();
    const Recording r = open_dataset({dir / name}, "auto", imu);
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5)) << name;
    EXPECT_EQ(r.samples.size(), 200u) << name;
  }
  try {
    open_dataset({dir / "wide.mat"}, "auto", options({{"accel", "wide:0,wide:1,wide:2"}, {"time", "tw"}, {"time_unit", "ms"}}));
    FAIL() << "a compressed 250-component matrix was read a column at a time";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("at most 64 are read so"), std::string::npos) << e.what();
  }
}

TEST(Containers, MatV4WideArrayColumnsAndStructFields) {
  if (!have_octave()) GTEST_SKIP() << "octave-cli not installed (scripts/install-deps.sh installs Debian's octave)";
  TempDir dir("containers");
  const std::size_t n = 300;
  // imu = [t gx gy gz ax ay az], t in ms; the same values in a struct's fields in another file.
  std::string s = "t = (0:" + std::to_string(n - 1) + ")' * 5; imu = [t";
  for (int c = 0; c < 3; ++c) s += ", " + octave_series("gyro", c, n);
  for (int c = 0; c < 3; ++c) s += ", " + octave_series("accel", c, n);
  s += "]; save('-v4', 'wide.mat', 'imu'); data.acc = imu(:, 5:7); data.t = t; data.other = 'x'; "
       "save('-v7', 'fields.mat', 'data');";
  ASSERT_NO_FATAL_FAILURE(octave(dir.path(), s));

  const Recording wide = open_dataset(
      {dir / "wide.mat"}, "auto",
      options({{"time", "imu:0"}, {"time_unit", "ms"}, {"accel", "imu:4,imu:5,imu:6"}, {"gyro", "imu:1,imu:2,imu:3"},
               {"accel_unit", "g"}, {"gyro_unit", "deg/s"}}));
  ASSERT_EQ(wide.samples.size(), n);
  EXPECT_NE(import_message(wide).find("MAT v4"), std::string::npos) << import_message(wide);
  const Recording fields =
      open_dataset({dir / "fields.mat"}, "auto",
                   options({{"time", "data.t"}, {"time_unit", "ms"}, {"accel", "data.acc"}, {"accel_unit", "g"}}));
  ASSERT_EQ(fields.samples.size(), n);
  EXPECT_FALSE(fields.header.info.has_gyro);
  for (std::size_t i = 0; i < n; i += 11) {
    EXPECT_NEAR(wide.samples[i].t_s, 0.005 * static_cast<double>(i), 1e-12);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(wide.samples[i].accel_mps2[c], accel_g(i, c) * kG, 1e-12);
      EXPECT_NEAR(wide.samples[i].gyro_radps[c], gyro_dps(i, c) * kDeg, 1e-14);
      EXPECT_DOUBLE_EQ(fields.samples[i].accel_mps2[c], wide.samples[i].accel_mps2[c]);
    }
  }
}

// A MAT 7.3 file (HDF5, through matio's writer) holding one K×N matrix (K rows of components, the
// samples along the columns: MATLAB's "transposed" buffers).
void write_mat73(const fs::path& file, const char* name, const std::vector<std::vector<double>>& rows) {
  const std::size_t k = rows.size(), n = rows[0].size();
  std::vector<double> column_major(k * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t r = 0; r < k; ++r) column_major[r + j * k] = rows[r][j];
  mat_t* mat = Mat_CreateVer(file.c_str(), nullptr, MAT_FT_MAT73);
  ASSERT_NE(mat, nullptr);
  std::size_t dims[2] = {k, n};
  matvar_t* v = Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, column_major.data(), 0);
  ASSERT_EQ(Mat_VarWrite(mat, v, MAT_COMPRESSION_NONE), 0);
  Mat_VarFree(v);
  Mat_Close(mat);
}

TEST(Containers, Mat73OneFilePerSensorJoinedOnTheirOwnTimes) {
  TempDir dir("containers");
  // accelerometer at 100 Hz, gyroscope at 250 Hz from 0.02 s, temperature at 2 Hz: each its own
  // [t; x; y; z] (resp. [t; T]) buffer in its own file. The gyroscope's and the temperature's values
  // are linear in time, so that interpolation at the accelerometer's times is exact.
  const std::size_t na = 1000, ng = 2500, nt = 21;
  auto gyro_at = [](double t, int c) { return 0.5 + 0.25 * t * (c + 1); };
  auto temp_at = [](double t) { return 20.0 + 0.5 * t; };
  std::vector<std::vector<double>> acc(4, std::vector<double>(na)), gyr(4, std::vector<double>(ng)),
      tmp(2, std::vector<double>(nt));
  for (std::size_t i = 0; i < na; ++i) {
    acc[0][i] = static_cast<double>(i) / 100.0;
    for (int c = 0; c < 3; ++c) acc[static_cast<std::size_t>(c) + 1][i] = accel_g(i, c);
  }
  for (std::size_t i = 0; i < ng; ++i) {
    gyr[0][i] = 0.02 + static_cast<double>(i) / 250.0;
    for (int c = 0; c < 3; ++c) gyr[static_cast<std::size_t>(c) + 1][i] = gyro_at(gyr[0][i], c);
  }
  for (std::size_t i = 0; i < nt; ++i) {
    tmp[0][i] = static_cast<double>(i) / 2.0;
    tmp[1][i] = temp_at(tmp[0][i]);
  }
  ASSERT_NO_FATAL_FAILURE(write_mat73(dir / "acc.mat", "accelBuffer", acc));
  ASSERT_NO_FATAL_FAILURE(write_mat73(dir / "gyro.mat", "gyroBuffer", gyr));
  ASSERT_NO_FATAL_FAILURE(write_mat73(dir / "temp.mat", "temperatureBuffer", tmp));

  const Recording rec =
      open_dataset({dir / "acc.mat", dir / "gyro.mat", dir / "temp.mat"}, "auto",
                   options({{"accel", "accelBuffer"}, {"gyro", "gyroBuffer"}, {"temperature", "temperatureBuffer"},
                            {"accel_unit", "g"}, {"gyro_unit", "rad/s"}}));
  // The accelerometer's samples inside the gyroscope's span (from 0.02 s): 2 before it dropped.
  ASSERT_EQ(rec.samples.size(), na - 2);
  for (const ImuSample& s : rec.samples) {
    const auto i = static_cast<std::size_t>(std::lround(s.t_s * 100.0));
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(s.accel_mps2[c], accel_g(i, c) * kG, 1e-12);
      EXPECT_NEAR(s.gyro_radps[c], gyro_at(s.t_s, c), 1e-12) << s.t_s;
    }
    EXPECT_NEAR(s.temperature_c, temp_at(s.t_s), 1e-12) << s.t_s;
  }
  const std::string msg = import_message(rec);
  EXPECT_NE(msg.find("MAT 7.3 (HDF5)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("gyro joined on its own time"), std::string::npos) << msg;
  EXPECT_NE(msg.find("2 sample(s) outside"), std::string::npos) << msg;
  EXPECT_TRUE(rec.header.info.has_temperature);
}

TEST(Containers, CsvWithAccelerometerCountsAndGyroscopeInRadiansPerSecond) {
  TempDir dir("containers");
  std::string text = "t,ax,ay,az,gx,gy,gz\n";
  for (int i = 0; i < 200; ++i) {
    char line[160];
    std::snprintf(line, sizeof line, "%.3f,%d,%d,%d,%.6f,%.6f,%.6f\n", i * 0.01, 12 + i % 5, -40, 16384 + i % 3,
                  0.001 * (i % 7), -0.002, 0.0125);
    text += line;
  }
  stend::testing::write_text(dir / "mixed.csv", text);
  const Recording rec = open_dataset({dir / "mixed.csv"}, "auto",
                                     options({{"time", "t"}, {"accel", "ax,ay,az"}, {"gyro", "gx,gy,gz"},
                                              {"accel_lsb", "1/16384 g"}, {"gyro_unit", "rad/s"}}));
  ASSERT_EQ(rec.samples.size(), 200u);
  EXPECT_EQ(rec.samples[3].accel_counts[0], 15);
  EXPECT_NEAR(rec.samples[3].accel_mps2[2], (16384.0 + 0.0) / 16384.0 * kG, 1e-12);
  EXPECT_NEAR(rec.samples[3].gyro_radps[0], 0.003, 1e-15);
  EXPECT_EQ(rec.samples[3].gyro_counts[0], 0);
  EXPECT_DOUBLE_EQ(rec.header.info.gyro_lsb_radps, 0.0);
  EXPECT_NEAR(rec.header.info.accel_lsb_mps2, kG / 16384.0, 1e-15);
}

TEST(Containers, StendImportStatesTheLayoutFound) {
  TempDir dir("containers");
  std::vector<std::vector<double>> acc(4, std::vector<double>(400));
  for (std::size_t i = 0; i < 400; ++i) {
    acc[0][i] = static_cast<double>(i) / 200.0;
    for (int c = 0; c < 3; ++c) acc[static_cast<std::size_t>(c) + 1][i] = accel_g(i, c);
  }
  ASSERT_NO_FATAL_FAILURE(write_mat73(dir / "acc.mat", "accelBuffer", acc));
  const auto out = stend::testing::run_stend("import " + (dir / "acc.mat").string() + " --accel accelBuffer --accel-unit g -o " +
                                             (dir / "run").string());
  ASSERT_EQ(out.code, 0) << out.text;
  EXPECT_NE(out.text.find("read:       imported 400 samples (acc.mat: MAT 7.3 (HDF5), 1 numeric array(s)): accel "
                          "'accelBuffer' with its own time (column 0) in g"),
            std::string::npos)
      << out.text;
}

}  // namespace
