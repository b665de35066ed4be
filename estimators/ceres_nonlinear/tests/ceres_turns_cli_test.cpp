// `stend fit` with the turns and earth_rate gyro methods on run folders written from the generator
// (turn_recording.hpp: planted gyro errors, segments and held truth as an aligned recording has
// them): the shipped example model files fit and write ceres.json; a singular design (turns about
// two axes) exits 3 naming what it cannot see, with no numbers.
#include "turn_recording.hpp"

#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/physics/units.hpp>

#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>
#include <stend/testing/program.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace stend;
namespace tr = stend::ceres_nonlinear::turn_record;
using stend::testing::ProgramOutput;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::TempDir;

namespace {

// Planted gyro errors with g-sensitivity (gyroscope_model(true)'s order).
std::vector<double> planted() {
  return {0.01, -0.015, 0.02, 0.01, -0.008, 0.012, 0.004, -0.003, 0.005, 0.002, -0.004, 0.006,
          1e-4, 2e-5, 0,    0,    -1e-4,  3e-5,  5e-5,  0,      1e-4};
}

fs::path write_run(const TempDir& dir, const std::string& name, const Recording& rec) {
  const fs::path run = dir / name;
  write_recording(rec, run, RecordingWriterOptions{});
  return run;
}

ProgramOutput fit(const fs::path& run, const std::string& example) {
  const fs::path model = stend::testing::source_path("estimators/ceres_nonlinear/examples/" + example);
  return run_stend("fit " + shell_quote(run.string()) + " --model " + shell_quote(model.string()));
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

}  // namespace

TEST(CeresTurnsCli, FerrarisExampleFitsTheTurnsAndWritesCeresJson) {
  const TempDir dir("ceres-turns");
  tr::Spec spec;
  spec.gyro_theta = planted();
  spec.turn_error_deg = 0.5;
  const fs::path run = write_run(dir, "ferraris", tr::make(spec, tr::ferraris_steps()));
  const ProgramOutput o = fit(run, "ferraris.yaml");
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("Ceres gyroscope calibration (turns)"), std::string::npos) << o.text;
  const json doc = read_json(run / "ceres.json");
  EXPECT_EQ(doc["status"], "ok");
  EXPECT_EQ(doc["gyroscope"]["method"], "turns");
  EXPECT_EQ(doc["gyroscope"]["turns"].size(), 3u);
  const auto p = by_name(doc["parameters"]);
  const auto names = ceres_nonlinear::gyroscope_model(true).params();
  for (std::size_t i = 0; i < names.size(); ++i) {
    const json& q = p.at("gyro_" + names[i].name);
    EXPECT_NEAR(q["value"].get<double>(), spec.gyro_theta[i], 5.0 * q["std_error"].get<double>()) << names[i].name;
  }
  bool stated = false;
  for (const auto& n : doc["notes"]) stated = stated || n.get<std::string>().find("a-priori sigmas") != std::string::npos;
  EXPECT_TRUE(stated) << doc["notes"].dump();
}

TEST(CeresTurnsCli, TurnsAboutTwoAxesExitThreeNamingTheUnseenCombination) {
  const TempDir dir("ceres-turns");
  tr::Spec spec;
  spec.gyro_theta = planted();
  const fs::path run = write_run(dir, "two_axes", tr::make(spec, tr::ferraris_steps(/*turn_x=*/false)));
  const ProgramOutput o = fit(run, "ferraris.yaml");
  EXPECT_EQ(o.code, 3) << o.text;
  EXPECT_NE(o.text.find("not identifiable"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("scale_x"), std::string::npos) << o.text;
  const json doc = read_json(run / "ceres.json");
  EXPECT_EQ(doc["status"], "failed");
  for (const auto& q : doc["gyroscope"]["parameters"]) EXPECT_TRUE(q["value"].is_null()) << q["name"];
}

TEST(CeresTurnsCli, EarthRateExampleOnAnMpu6050GradeGyroIsImprecise) {
  const TempDir dir("ceres-turns");
  tr::Spec spec;
  spec.gyro_theta.assign(12, 0.0);
  spec.gyro_theta[5] = 0.005;  // scale_z
  spec.rate_hz = 10.0;
  spec.gyro_noise_radps = 0.005 * physics::kDegToRad * std::sqrt(spec.rate_hz);  // 0.005 deg/s/√Hz
  spec.latitude_deg = 47.0;
  const fs::path run = write_run(dir, "updown", tr::make(spec, tr::six_face_steps(300.0)));  // three axes up/down
  const ProgramOutput o = fit(run, "earth_rate.yaml");
  ASSERT_EQ(o.code, 0) << o.text;
  const json doc = read_json(run / "ceres.json");
  EXPECT_EQ(doc["gyroscope"]["method"], "earth_rate");
  EXPECT_EQ(doc["gyroscope"]["dof"], 0);
  const auto p = by_name(doc["parameters"]);
  for (const char* axis : {"x", "y", "z"}) {
    EXPECT_EQ(p.at(std::string("gyro_scale_") + axis)["verdict"], "imprecise") << axis;
    EXPECT_EQ(p.at(std::string("gyro_bias_") + axis)["verdict"], "determined") << axis;
  }
  EXPECT_TRUE(p.at("gyro_cross_xy")["fixed"].get<bool>());
}
