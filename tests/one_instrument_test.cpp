// Issue 42, part 4, through the program as a lab researcher runs it: a gyro-only log and an
// accelerometer-only log, written here as CSV with noise of known size, are imported by `stend
// import`, analysed by `stend fit` (Allan: only the channels present, the known angle random walk
// recovered within its interval), reported without the absent instrument's sections, and a model
// of the absent instrument is refused naming it — never fitted on values that were not measured.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "stend/testing/files.hpp"
#include "stend/testing/program.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;
using stend::testing::ProgramOutput;
using stend::testing::read_text;
using stend::testing::run_stend;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

const std::string src = STEND_SOURCE_DIR;
constexpr double kRateHz = 100.0;
constexpr double kDuration_s = 1200.0;
// The gyroscope's planted noise: angle random walk N [rad/s/√Hz] (≈ 0.69 deg/√h) and rate random
// walk K [rad/s²/√Hz], per axis; a constant bias [rad/s].
constexpr double kArw = 2.0e-4;
constexpr double kRrw = 1.0e-6;
constexpr double kGyroBias[3] = {0.004, -0.002, 0.001};
// The accelerometer's: velocity random walk [m/s²/√Hz], at rest with z up.
constexpr double kVrw = 1.0e-3;
constexpr double kG = 9.80665;

// One instrument's still log at kRateHz: white noise of density `white` plus a random walk of
// density `walk` on `bias` per axis, under the header "t,<names>"; rounded to whole numbers with
// `counts`.
std::string still_csv(const std::string& names, const double* bias, double white, double walk, unsigned seed,
                      bool counts = false) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const double sd_white = white * std::sqrt(kRateHz), sd_step = walk / std::sqrt(kRateHz);
  double drift[3] = {0, 0, 0};
  std::ostringstream out;
  out.precision(12);
  out << "t," << names << "\n";
  const auto samples = static_cast<int>(kDuration_s * kRateHz);
  for (int i = 0; i < samples; ++i) {
    out << i / kRateHz;
    for (int a = 0; a < 3; ++a) {
      drift[a] += sd_step * n(rng);
      const double v = bias[a] + drift[a] + sd_white * n(rng);
      out << "," << (counts ? std::round(v) : v);
    }
    out << "\n";
  }
  return out.str();
}

// An Allan model file.
fs::path allan_model(const TempDir& dir) {
  const fs::path f = dir / "allan.yaml";
  write_text(f, "allan:\n  confidence: 0.95\n  max_m: 65536\n");
  return f;
}

// Imports `log` with `columns` into RUN and returns RUN.
fs::path import_log(const TempDir& dir, const std::string& name, const std::string& csv, const std::string& columns) {
  const fs::path log = dir / (name + ".csv"), run = dir / name;
  write_text(log, csv);
  const ProgramOutput imp = run_stend("import " + log.string() + columns + " -o " + run.string());
  EXPECT_EQ(imp.code, 0) << imp.text;
  return run;
}

std::set<std::string> channels_of(const json& allan) {
  std::set<std::string> out;
  for (const auto& ch : allan.at("channels")) out.insert(ch.at("channel").get<std::string>());
  return out;
}

// A noise coefficient's estimate within 3.29 of its standard errors of the planted `truth` (99.9 %:
// six coefficients over two fixed seeds), its standard error below 5 % of the truth.
void expect_recovered(const json& coefficient, double truth, const json& channel) {
  const double value = coefficient.at("value").get<double>(), sigma = coefficient.at("sigma").get<double>();
  EXPECT_NEAR(value, truth, 3.29 * sigma) << channel << ": " << coefficient.dump();
  EXPECT_LT(sigma, 0.05 * truth) << channel << ": the estimate says little: " << coefficient.dump();
}

void expect_refused(const ProgramOutput& out, int code, const std::string& says) {
  EXPECT_EQ(out.code, code) << out.text;
  EXPECT_NE(out.text.find(says), std::string::npos) << out.text;
}

}  // namespace

// A gyro-only log: imported without --accel, its header says so (run.json, stend info); Allan
// analyses the three gyro axes alone and recovers the planted angle random walk within its 95 %
// interval; the report has no accelerometer plot; accelerometer models are refused naming it.
TEST(OneInstrument, GyroOnlyLogImportsAndAnalyses) {
  const TempDir dir("gyro_only");
  const fs::path run = import_log(dir, "gyro", still_csv("gx,gy,gz", kGyroBias, kArw, kRrw, 42),
                                  " --time t --gyro gx,gy,gz");
  ASSERT_TRUE(fs::exists(run / "run.json"));
  const json header = json::parse(read_text(run / "run.json"));
  EXPECT_FALSE(header.at("sensor").at("info").at("has_accel").get<bool>());
  EXPECT_TRUE(header.at("sensor").at("info").at("has_gyro").get<bool>());

  const ProgramOutput info = run_stend("info " + run.string());
  ASSERT_EQ(info.code, 0) << info.text;
  EXPECT_NE(info.text.find("measures:   gyroscope (no accelerometer, no temperature)"), std::string::npos) << info.text;
  const fs::path info_file = dir / "info.json";
  const ProgramOutput info_json = run_stend("info " + run.string() + " --json > " + info_file.string() + " 2>/dev/null");
  ASSERT_EQ(info_json.code, 0) << info_json.text;
  EXPECT_FALSE(json::parse(read_text(info_file)).at("sensor").at("has_accel").get<bool>()) << read_text(info_file);

  const ProgramOutput fit = run_stend("fit " + run.string() + " --model " + allan_model(dir).string());
  ASSERT_EQ(fit.code, 0) << fit.text;
  EXPECT_NE(fit.text.find("still stretches from the gyroscope alone"), std::string::npos) << fit.text;
  const json allan = json::parse(read_text(run / "allan.json"));
  EXPECT_EQ(channels_of(allan), (std::set<std::string>{"gx", "gy", "gz"})) << allan.dump().substr(0, 500);
  for (const auto& ch : allan.at("channels")) {
    const json& n = ch.at("model").at("N");
    ASSERT_TRUE(n.at("identified").get<bool>()) << ch.at("channel") << ": " << n.dump();
    expect_recovered(n, kArw, ch.at("channel"));
  }
  EXPECT_TRUE(allan.at("kalibr").at("accelerometer_noise_density").is_null());

  const ProgramOutput report = run_stend("report " + run.string() + " --no-db");
  ASSERT_EQ(report.code, 0) << report.text;
  const std::string html = read_text(run / "report.html");
  EXPECT_NE(html.find("gyroscope, raw"), std::string::npos);
  EXPECT_NE(html.find("gyroscope Allan deviation"), std::string::npos);
  EXPECT_EQ(html.find("accelerometer, raw"), std::string::npos) << "an empty accelerometer plot";
  EXPECT_EQ(html.find("accelerometer Allan deviation"), std::string::npos);
  EXPECT_EQ(html.find("accelerometer_noise_density"), std::string::npos);
  EXPECT_NE(html.find("no accelerometer"), std::string::npos);

  // Models of the accelerometer: not applicable, exit 2 (docs/errors.md), nothing written.
  const std::string no_accel = "not applicable — the recording has no accelerometer (its source holds no accelerometer data)";
  expect_refused(run_stend("fit " + run.string() + " --model " + src + "/estimators/batch_lsq/examples/accelerometer_full.yaml"),
                 2, no_accel);
  EXPECT_FALSE(fs::exists(run / "fit.json"));
  const ProgramOutput ceres =
      run_stend("fit " + run.string() + " --model " + src + "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml");
  expect_refused(ceres, 2, "the recording has no accelerometer");
  EXPECT_NE(ceres.text.find("'integration' needs the accelerometer"), std::string::npos) << ceres.text;
  expect_refused(run_stend("gap " + run.string() + " --model " + src + "/diagnosis/examples/bias_scale.yaml"), 2,
                 no_accel);

  // Exports: Kalibr's imu.yaml needs both sensors' noise, so it is refused naming the absent one.
  expect_refused(run_stend("export " + run.string() + " --to kalibr"), 2, "the recording has no accelerometer");
  EXPECT_FALSE(fs::exists(run / "export" / "imu.yaml"));
}

// An accelerometer-only log: the three accelerometer axes alone, the gyroscope models refused.
TEST(OneInstrument, AccelerometerOnlyLogImportsAndAnalyses) {
  const TempDir dir("accel_only");
  const double rest[3] = {0.0, 0.0, kG};
  const fs::path run =
      import_log(dir, "accel", still_csv("ax,ay,az", rest, kVrw, 0.0, 7), " --rate-hz 100 --accel ax,ay,az");
  const ProgramOutput info = run_stend("info " + run.string());
  EXPECT_NE(info.text.find("measures:   accelerometer (no gyroscope, no temperature)"), std::string::npos) << info.text;
  const ProgramOutput fit = run_stend("fit " + run.string() + " --model " + allan_model(dir).string());
  ASSERT_EQ(fit.code, 0) << fit.text;
  const json allan = json::parse(read_text(run / "allan.json"));
  EXPECT_EQ(channels_of(allan), (std::set<std::string>{"ax", "ay", "az"}));
  for (const auto& ch : allan.at("channels")) {
    const json& n = ch.at("model").at("N");
    ASSERT_TRUE(n.at("identified").get<bool>()) << n.dump();
    expect_recovered(n, kVrw, ch.at("channel"));
  }
  const ProgramOutput report = run_stend("report " + run.string() + " --no-db");
  ASSERT_EQ(report.code, 0) << report.text;
  const std::string html = read_text(run / "report.html");
  EXPECT_EQ(html.find("gyroscope, raw"), std::string::npos);
  EXPECT_EQ(html.find("gyroscope Allan deviation"), std::string::npos);
  EXPECT_EQ(html.find("gyroscope_noise_density"), std::string::npos);
}

// The import options: one instrument is enough, none is refused saying what to give; an
// instrument's columns all three or none.
TEST(OneInstrument, ImportNeedsAtLeastOneInstrument) {
  const TempDir dir("no_instrument");
  const fs::path log = dir / "log.csv";
  write_text(log, "t,gx,gy,gz,temp\n0,0,0,0,25\n0.01,0,0,0,25\n");
  expect_refused(run_stend("import " + log.string() + " --time t --temperature temp -o " + (dir / "run").string()), 2,
                 "give --accel x,y,z, --gyro x,y,z or both");
  EXPECT_FALSE(fs::exists(dir / "run"));
}

// A gyro-only log with a temperature column and the gyro in counts: the counts are kept with the
// gyroscope's LSB, the rate check judges the gyroscope alone (counts without --gyro-lsb refused).
TEST(OneInstrument, GyroOnlyCountsAreJudgedOnTheirRate) {
  const TempDir dir("gyro_counts");
  const double bias_counts[3] = {600.0, -300.0, 450.0};  // ≈ 4.6, −2.3, 3.4 deg/s at 131 counts per deg/s
  const fs::path log = dir / "counts.csv";
  write_text(log, still_csv("gx,gy,gz", bias_counts, 0.3, 0.0, 3, true));
  // Without an LSB the counts are read as rad/s, far beyond any MEMS gyroscope.
  expect_refused(run_stend("import " + log.string() + " --time t --gyro gx,gy,gz -o " + (dir / "raw").string()), 2,
                 "these look like raw counts — give --gyro-lsb");
  const ProgramOutput ok =
      run_stend("import " + log.string() + " --time t --gyro gx,gy,gz --gyro-lsb 1/131deg/s -o " + (dir / "ok").string());
  ASSERT_EQ(ok.code, 0) << ok.text;
  const json header = json::parse(read_text(dir / "ok" / "run.json"));
  EXPECT_FALSE(header.at("sensor").at("info").at("has_accel").get<bool>());
  EXPECT_NEAR(header.at("sensor").at("info").at("gyro_lsb_radps").get<double>(), M_PI / 180.0 / 131.0, 1e-15);
}

// A gyro-only recording in a container (raw binary records t, gx, gy, gz as little-endian
// float64): the gyroscope leads the samples, its values arrive unchanged, the header says there is
// no accelerometer.
TEST(OneInstrument, GyroOnlyRecordsImport) {
  const TempDir dir("gyro_records");
  const fs::path log = dir / "gyro.bin", run = dir / "run";
  std::string bytes;
  const auto put = [&bytes](double v) { bytes.append(reinterpret_cast<const char*>(&v), sizeof v); };
  constexpr int kRecords = 2000;
  for (int i = 0; i < kRecords; ++i) {
    put(i / kRateHz);
    for (int a = 0; a < 3; ++a) put(kGyroBias[a] + 1e-4 * std::sin(0.01 * i + a));
  }
  write_text(log, bytes);
  const ProgramOutput imp = run_stend("import " + log.string() +
                                      " --record-layout t:f64,gx:f64,gy:f64,gz:f64 --time t --gyro gx,gy,gz -o " +
                                      run.string());
  ASSERT_EQ(imp.code, 0) << imp.text;
  EXPECT_NE(imp.text.find("no accelerometer"), std::string::npos) << imp.text;
  const json header = json::parse(read_text(run / "run.json"));
  EXPECT_FALSE(header.at("sensor").at("info").at("has_accel").get<bool>());
  EXPECT_TRUE(header.at("sensor").at("info").at("has_gyro").get<bool>());
  const fs::path csv = dir / "csv";
  const ProgramOutput exp = run_stend("export " + run.string() + " --to csv -o " + csv.string());
  ASSERT_EQ(exp.code, 0) << exp.text;
  std::istringstream lines(read_text(csv / "imu.csv"));
  std::string line;
  std::getline(lines, line);
  std::vector<std::string> names;
  for (std::istringstream h(line); std::getline(h, line, ',');) names.push_back(line);
  const auto column = [&names](const std::string& n) {
    return static_cast<std::size_t>(std::find(names.begin(), names.end(), n) - names.begin());
  };
  const std::size_t gx = column("gx_radps"), ax = column("ax_mps2");
  ASSERT_LT(gx, names.size());
  int rows = 0;
  while (std::getline(lines, line)) {
    std::vector<std::string> f;
    for (std::istringstream l(line); std::getline(l, line, ',');) f.push_back(line);
    ASSERT_GT(f.size(), gx);
    EXPECT_NEAR(std::stod(f[gx]), kGyroBias[0] + 1e-4 * std::sin(0.01 * rows), 1e-12) << "record " << rows;
    if (ax < f.size()) {
      EXPECT_TRUE(f[ax].empty() || std::isnan(std::stod(f[ax]))) << "an absent accelerometer read as " << f[ax];
    }
    ++rows;
  }
  EXPECT_EQ(rows, kRecords) << "every record is a sample";
}
