// `stend fit` with the ceres_nonlinear estimator on a simulated run of configs/multi_position_38.yaml
// (38 positions, rate steps about three axes, planted accelerometer and gyro errors, table tilt
// offset 0.2°), the estimator plugins listed by `stend plugins`, and an out-of-tree estimator
// plugin reached through `--estimator NAME`.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "stend/testing/files.hpp"
#include "stend/testing/program.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;
using stend::testing::ProgramOutput;
using stend::testing::run_stend;
using stend::testing::TempDir;

namespace {

const std::string src = STEND_SOURCE_DIR;

// One simulated run shared by the tests (about 55,000 samples).
const fs::path& run_dir() {
  static const TempDir out("ceres-cli");
  static const fs::path dir = [] {
    const ProgramOutput o = run_stend("run " + src + "/configs/multi_position_38.yaml --quiet --output " + out.str() + " --name mp38");
    EXPECT_EQ(o.code, 0) << o.text;
    return out / "mp38";
  }();
  return dir;
}

json read_json(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

std::map<std::string, json> by_name(const json& params) {
  std::map<std::string, json> m;
  for (const auto& p : params) m[p["name"].get<std::string>()] = p;
  return m;
}

// Planted values of configs/multi_position_38.yaml.
const std::map<std::string, double> kAccelTruth = {
    {"bias_x", 0.05},      {"bias_y", -0.03},     {"bias_z", 0.027},    {"scale_x", 0.002},
    {"scale_y", -0.001},   {"scale_z", 0.0007},   {"cross_xy", 0.001},  {"cross_xz", -0.002},
    {"cross_yx", 0.0015},  {"cross_yz", 0.003},   {"cross_zx", 0.0055}, {"cross_zy", 0.0002}};
const std::map<std::string, double> kGyroTruth = {
    {"bias_x", 0.01},      {"bias_y", -0.015},    {"bias_z", 0.02},     {"scale_x", 0.01},
    {"scale_y", -0.008},   {"scale_z", 0.012},    {"cross_xy", 0.004},  {"cross_xz", -0.003},
    {"cross_yx", 0.005},   {"cross_yz", 0.002},   {"cross_zx", -0.004}, {"cross_zy", 0.006},
    {"gsens_xx", 1e-4},    {"gsens_xy", 0},       {"gsens_xz", 0},      {"gsens_yx", 0},
    {"gsens_yy", -1e-4},   {"gsens_yz", 0},       {"gsens_zx", 5e-5},   {"gsens_zy", 0},
    {"gsens_zz", 1e-4}};

// |value − truth| within 4 standard errors (a 95 % check on 35 numbers would fail by chance).
void expect_near_truth(const json& p, double truth) {
  ASSERT_TRUE(p["value"].is_number()) << p.dump();
  const double v = p["value"].get<double>(), se = p["std_error"].get<double>();
  EXPECT_TRUE(p["identifiable"].get<bool>()) << p.dump();
  EXPECT_NEAR(v, truth, 4.0 * se) << p["name"] << " " << v << " ± " << se;
}

}  // namespace

TEST(CeresCli, KnownOrientationsRateTableRecoversThePlantedErrors) {
  const fs::path run = run_dir();
  const ProgramOutput o = run_stend("fit " + run.string() + " --model " + src + "/estimators/ceres_nonlinear/examples/known_orientations.yaml");
  EXPECT_EQ(o.code, 0) << o.text;
  for (const char* s : {"options:", "table offsets: tilt", "std error", "95% lower", "verdict", "determined", "mg", "deg/s",
                        "condition number", "ceres_nonlinear: ok"})
    EXPECT_NE(o.text.find(s), std::string::npos) << s << "\n" << o.text;
  ASSERT_TRUE(fs::exists(run / "ceres.json"));
  ASSERT_TRUE(fs::exists(run / "ceres.txt"));
  const json j = read_json(run / "ceres.json");
  EXPECT_EQ(j["schema"], "stend.ceres_nonlinear.results/1");
  EXPECT_EQ(j["status"], "ok") << j["message"];  // every results document: "status"
  const auto acc = by_name(j["accelerometer"]["parameters"]);
  for (const auto& [name, truth] : kAccelTruth) expect_near_truth(acc.at(name), truth);
  expect_near_truth(acc.at("table_offset_tilt"), 0.2);
  const auto gyr = by_name(j["gyroscope"]["parameters"]);
  for (const auto& [name, truth] : kGyroTruth) expect_near_truth(gyr.at(name), truth);
  EXPECT_EQ(j["accelerometer"]["rms_axis_after_mg"].size(), 3u);
}

// rate_legs.yaml: the gyro alone from the rate legs and stills, g-sensitivity not modelled (the
// run plants some: the scale and cross-axis terms still come out within a few 1e-4).
TEST(CeresCli, RateLegsExampleFitsTheGyroAlone) {
  const fs::path run = run_dir();
  const fs::path out = run / "ceres_rate_legs.json";
  const ProgramOutput o = run_stend("fit " + run.string() + " --model " + src +
                                    "/estimators/ceres_nonlinear/examples/rate_legs.yaml --out " + out.string());
  EXPECT_EQ(o.code, 0) << o.text;
  const json j = read_json(out);
  ASSERT_EQ(j["status"], "ok") << j["message"];
  EXPECT_FALSE(j.contains("accelerometer"));
  EXPECT_EQ(j["gyroscope"]["method"], "rate_table");
  const auto gyr = by_name(j["gyroscope"]["parameters"]);
  EXPECT_EQ(gyr.size(), 12u);
  for (const char* name : {"scale_x", "scale_y", "scale_z", "cross_xy", "cross_xz", "cross_yx", "cross_yz", "cross_zx", "cross_zy"})
    EXPECT_NEAR(gyr.at(name)["value"].get<double>(), kGyroTruth.at(name), 1e-3) << name;
}

TEST(CeresCli, UnknownOrientationsIntegrationCalibratesWithoutTruth) {
  const fs::path run = run_dir();
  const fs::path out = run / "ceres_unknown.json";
  const ProgramOutput o = run_stend("fit " + run.string() + " --model " + src +
                         "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml --out " + out.string());
  EXPECT_EQ(o.code, 0) << o.text;
  const json j = read_json(out);
  ASSERT_EQ(j["status"], "ok") << j["message"];
  EXPECT_GE(j["accelerometer"]["intervals"].size(), 38u);
  EXPECT_LT(j["accelerometer"]["rms_norm_after_mps2"].get<double>(), 0.2 * j["accelerometer"]["rms_norm_before_mps2"].get<double>());
  EXPECT_LT(j["gyroscope"]["rms_direction_after_rad"].get<double>(), 0.2 * j["gyroscope"]["rms_direction_before_rad"].get<double>());
  // Scale factors do not depend on the frame convention: within 4σ plus 3e-4 (the accelerometer
  // frame is the sensor's only to ~1e-3 rad here).
  const auto gyr = by_name(j["gyroscope"]["parameters"]);
  for (const char* name : {"scale_x", "scale_y", "scale_z"}) {
    const double v = gyr.at(name)["value"].get<double>(), se = gyr.at(name)["std_error"].get<double>();
    EXPECT_NEAR(v, kGyroTruth.at(name), 4.0 * se + 3e-4) << name;
  }
  // The bias holds Earth rotation projected on the axes (≤ 7.3e-5 rad/s) beside the planted one.
  for (const char* name : {"bias_x", "bias_y", "bias_z"})
    EXPECT_NEAR(gyr.at(name)["value"].get<double>(), kGyroTruth.at(name), 2e-4) << name;
}

TEST(CeresCli, BadOptionNamesFileLineAndExitsTwo) {
  const TempDir dir("ceres-bad");
  const fs::path model = dir / "bad.yaml";
  std::ofstream(model) << "ceres_nonlinear:\n  accelerometer: unknown_orientations\n  detector: {window_s: 1, trim: 0.5}\n";
  const ProgramOutput o = run_stend("fit " + run_dir().string() + " --model " + model.string());
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_NE(o.text.find(model.string() + ":3:"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("trim_s"), std::string::npos) << o.text;
}

TEST(CeresCli, TooFewPositionsFailsWithExitThreeAndNoNumbers) {
  const TempDir dir("ceres-few");
  const ProgramOutput r = run_stend("run " + src + "/configs/six_position.yaml --quiet --output " + dir.str() + " --name six");
  ASSERT_EQ(r.code, 0) << r.text;
  const ProgramOutput o = run_stend("fit " + (dir / "six").string() + " --model " + src +
                         "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml");
  EXPECT_EQ(o.code, 3) << o.text;
  EXPECT_NE(o.text.find("too few static intervals"), std::string::npos) << o.text;
  const json j = read_json(dir / "six" / "ceres.json");
  EXPECT_EQ(j["status"], "failed");
  for (const auto& p : j["accelerometer"]["parameters"])
    if (!p["fixed"].get<bool>()) {
      EXPECT_TRUE(p["value"].is_null()) << p.dump();
    }
}

// The run's samples as a CSV with the accelerometer only (no gyro columns mapped: the recording
// has no gyroscope), fitted with the shipped unknown_orientations.yaml, which covers both
// instruments: the accelerometer's numbers, the gyroscope not applicable, exit 0.
TEST(CeresCli, AccelerometerOnlyDataGivesTheAccelerometerAndAGyroscopeNotApplicable) {
  const TempDir dir("ceres-accel-only");
  const ProgramOutput exported = run_stend("export " + run_dir().string() + " --to csv -o " + (dir / "csv").string());
  ASSERT_EQ(exported.code, 0) << exported.text;
  const fs::path out = dir / "ceres.json";
  const ProgramOutput o = run_stend("fit " + (dir / "csv" / "imu.csv").string() +
                                    " --format csv --time t_s --accel ax_mps2,ay_mps2,az_mps2 --model " + src +
                                    "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml --out " + out.string());
  EXPECT_EQ(o.code, 0) << o.text;
  for (const char* s : {"Ceres gyroscope calibration\nstatus: not applicable — the recording has no gyroscope",
                        "ceres_nonlinear: ok\nnote: gyroscope: not applicable", "results:    " })
    EXPECT_NE(o.text.find(s), std::string::npos) << s << "\n" << o.text;
  EXPECT_EQ(o.text.find("FAILED"), std::string::npos) << o.text;
  const json j = read_json(out);
  EXPECT_EQ(j["status"], "ok") << j["message"];
  EXPECT_EQ(j["accelerometer"]["status"], "ok");
  EXPECT_EQ(j["gyroscope"]["status"], "not_applicable");
  EXPECT_FALSE(j["gyroscope"].contains("parameters"));
  ASSERT_EQ(j["notes"].size(), 1u);
  const auto acc = by_name(j["accelerometer"]["parameters"]);
  for (const char* name : {"scale_x", "scale_y", "scale_z"}) {
    const double v = acc.at(name)["value"].get<double>(), se = acc.at(name)["std_error"].get<double>();
    EXPECT_NEAR(v, kAccelTruth.at(name), 4.0 * se + 3e-4) << name;
  }
  for (const auto& p : j["parameters"]) EXPECT_EQ(p["name"].get<std::string>().rfind("gyro_", 0), std::string::npos) << p;
}

// The same samples logged in bursts (4 samples 2 ms apart every 40 ms; the sensor sampled every
// 10 ms): the import takes the mean rate and keeps the samples' times, and the gyro integration over
// those times gives the calibration of the evenly timed log within two of its standard errors
// (seen: 1.4 at most; taken at the rate inside a burst, every scale would be off by a factor 5).
TEST(CeresCli, BurstyTimesGiveTheSameGyroCalibration) {
  const TempDir dir("ceres-bursty");
  const ProgramOutput exported = run_stend("export " + run_dir().string() + " --to csv -o " + (dir / "csv").string());
  ASSERT_EQ(exported.code, 0) << exported.text;
  std::ifstream in(dir / "csv" / "imu.csv");
  std::ofstream out(dir / "bursty.csv");
  std::string line;
  std::getline(in, line);
  out << line << "\n";  // t_s first
  for (std::size_t i = 0; std::getline(in, line); ++i)
    out << std::to_string(0.01 + static_cast<double>(i / 4) * 0.04 + static_cast<double>(i % 4) * 0.002)
        << line.substr(line.find(',')) << "\n";
  out.close();
  const auto fit = [&](const fs::path& csv, const fs::path& results) {
    return run_stend("fit " + csv.string() + " --format csv --time t_s --accel ax_mps2,ay_mps2,az_mps2 --gyro " +
                     "gx_radps,gy_radps,gz_radps --model " + src +
                     "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml --out " + results.string());
  };
  const ProgramOutput even = fit(dir / "csv" / "imu.csv", dir / "even.json");
  ASSERT_EQ(even.code, 0) << even.text;
  const ProgramOutput bursty = fit(dir / "bursty.csv", dir / "bursty.json");
  ASSERT_EQ(bursty.code, 0) << bursty.text;
  EXPECT_NE(bursty.text.find("timestamps come in bursts of ~4 samples every 40 ms"), std::string::npos) << bursty.text;
  const auto a = by_name(read_json(dir / "even.json")["gyroscope"]["parameters"]);
  const auto b = by_name(read_json(dir / "bursty.json")["gyroscope"]["parameters"]);
  for (const char* name : {"scale_x", "scale_y", "scale_z", "cross_xy", "cross_xz", "cross_yx", "cross_yz", "cross_zx",
                           "cross_zy"}) {
    const double se = a.at(name)["std_error"].get<double>();
    EXPECT_NEAR(b.at(name)["value"].get<double>(), a.at(name)["value"].get<double>(), 2.0 * se) << name;
  }
}

// A failed fit never silently replaces a good results file: the good one stays byte for byte, the
// failure goes beside it (failed-ceres.json), and the message names both.
TEST(CeresCli, AFailedFitKeepsAGoodResultsFileAndSaysWhereTheFailureWent) {
  const TempDir dir("ceres-keep-good");
  const fs::path good = dir / "ceres.json", failed = dir / "failed-ceres.json";
  const ProgramOutput first = run_stend("fit " + run_dir().string() + " --model " + src +
                                        "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml --out " + good.string());
  ASSERT_EQ(first.code, 0) << first.text;
  const std::string good_bytes = stend::testing::read_text(good), good_text = stend::testing::read_text(dir / "ceres.txt");
  std::ofstream(dir / "strict.yaml") << "ceres_nonlinear:\n  accelerometer: unknown_orientations\n  gyroscope: none\n"
                                        "  detector: {min_duration_s: 100}\n";
  const ProgramOutput o = run_stend("fit " + run_dir().string() + " --model " + (dir / "strict.yaml").string() +
                                    " --out " + good.string());
  EXPECT_EQ(o.code, 3) << o.text;
  EXPECT_EQ(stend::testing::read_text(good), good_bytes);
  EXPECT_EQ(stend::testing::read_text(dir / "ceres.txt"), good_text);
  ASSERT_TRUE(fs::exists(failed)) << o.text;
  EXPECT_EQ(read_json(failed)["status"], "failed");
  EXPECT_TRUE(fs::exists(dir / "failed-ceres.txt"));
  EXPECT_NE(o.text.find("warning: the fit failed; " + good.string() + " (and ceres.txt) holds an earlier good result "
                        "and is kept unchanged; this failed result is written beside it, to " + failed.string()),
            std::string::npos)
      << o.text;
  EXPECT_NE(o.text.find("results:    none — the fit failed (" + failed.string()), std::string::npos) << o.text;
  // A second failure replaces the first failure's file, never the good one.
  const ProgramOutput again = run_stend("fit " + run_dir().string() + " --model " + (dir / "strict.yaml").string() +
                                        " --out " + good.string());
  EXPECT_EQ(again.code, 3) << again.text;
  EXPECT_EQ(stend::testing::read_text(good), good_bytes);
}

TEST(CeresCli, PluginsListTheFourEstimators) {
  const ProgramOutput o = run_stend("plugins");
  EXPECT_EQ(o.code, 0) << o.text;
  for (const char* name : {"batch_lsq", "temp_poly", "allan", "ceres_nonlinear"})
    EXPECT_NE(o.text.find(name), std::string::npos) << name << "\n" << o.text;
  EXPECT_NE(o.text.find("estimator"), std::string::npos) << o.text;
}

TEST(CeresCli, UnknownEstimatorNameRoutesToAnEstimatorPlugin) {
  const fs::path run = run_dir();
  const stend::testing::Environment env = {{"STEND_PLUGIN_PATH", STEND_CERES_TEST_PLUGIN_DIR}};
  const fs::path out = run / "mean.json";
  const ProgramOutput o = run_stend("fit " + run.string() + " --model " + src +
                         "/estimators/ceres_nonlinear/examples/known_orientations.yaml --estimator mean_accel --out " +
                         out.string(), env);
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("mean_accel:"), std::string::npos) << o.text;
  const json j = read_json(out);
  EXPECT_EQ(j["schema"], "test.mean_accel/1");
  EXPECT_GT(j["samples"].get<int>(), 50000);
  const ProgramOutput missing = run_stend("fit " + run.string() + " --model " + src +
                               "/estimators/ceres_nonlinear/examples/known_orientations.yaml --estimator no_such_estimator");
  EXPECT_NE(missing.code, 0);
  EXPECT_NE(missing.text.find("no estimator 'no_such_estimator'"), std::string::npos) << missing.text;
}
