// `stend apply` as a user runs it, on simulated six-position runs: a batch_lsq result of one
// temperature whose biases alias with their temperature coefficients is refused (exit 2) naming
// them, and applied with --assume (the values recorded in the calibrated run); --validate PASSes
// (exit 0) with the same sensor's calibration and FAILs (exit 3) with another sensor's; a Ceres
// result with unknown orientations (cross-axis terms held by its frame convention) applies.
#include <stend/recording/recording.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>
#include <stend/testing/program.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

namespace {

namespace fs = std::filesystem;
using stend::testing::read_text;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::write_text;

// Bias and scale per axis, and a linear bias temperature term about 0 degC: at one temperature
// (the room's 25 degC) each bias and its coefficient alias.
const char* kAliasedModel = R"(instrument: accelerometer
axes: [x, y, z]
terms:
  - bias
  - scale
  - bias_temperature: {order: 1, reference_c: 0}
extraction: {filter_order: 6, cutoff_hz: 0.5, settle_s: 2.0}
segments: [orientation]
)";
const char* kBiasScaleModel = R"(instrument: accelerometer
axes: [x, y, z]
terms: [bias, scale]
extraction: {filter_order: 6, cutoff_hz: 0.5, settle_s: 2.0}
segments: [orientation]
)";

class ApplyCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tmp_ = std::make_unique<stend::testing::TempDir>("apply-cli");
    // The sensor (a), the same sensor recorded again (held out), another sensor (other): six
    // positions on a table in a room at one temperature.
    write_text(dir() / "a.yaml", six_positions(6, "[0.05, -0.03, 0.027]"));
    write_text(dir() / "held_out.yaml", six_positions(61, "[0.05, -0.03, 0.027]"));
    write_text(dir() / "other.yaml", six_positions(62, "[0.02, 0.01, -0.03]"));
    for (const char* name : {"a", "held_out", "other"})
      ASSERT_EQ(run_ok("run " + path(std::string(name) + ".yaml") + " -q -o " + path("") + " --name " + name).code, 0);
    write_text(dir() / "aliased.yaml", kAliasedModel);
    write_text(dir() / "bias_scale.yaml", kBiasScaleModel);
    ASSERT_EQ(run_ok("fit " + path("a") + " -m " + path("aliased.yaml") + " -o " + path("aliased.json")).code, 0);
    ASSERT_EQ(run_ok("fit " + path("a") + " -m " + path("bias_scale.yaml") + " -o " + path("bias_scale.json")).code, 0);
  }
  static void TearDownTestSuite() { tmp_.reset(); }

  static fs::path dir() { return tmp_->path(); }
  static std::string path(const std::string& name) { return shell_quote((dir() / name).string()); }
  // Six positions, 20 s each, of a sensor with accelerometer biases `bias` [m/s^2].
  static std::string six_positions(int seed, const std::string& bias) {
    return "experiment: {name: six, seed: " + std::to_string(seed) + R"(}
bench:
  gravity: {latitude_deg: 47.21, height_m: 40}
  sensor:
    plugin: sim_imu
    config: {output_rate_hz: 100, lowpass_hz: 40, accel_scale: [0.002, -0.001, 0.0007], accel_bias_mps2: )" +
           bias + R"(}
  fixtures:
    - {id: table, plugin: sim_three_axis_table}
  mounting: {on: table}
procedure:
  - orientations:
      fixture: table
      list:
        - {tilt_deg: 0, rotation_deg: 0}
        - {tilt_deg: 0, rotation_deg: 180}
        - {tilt_deg: 0, rotation_deg: -90}
        - {tilt_deg: 0, rotation_deg: 90}
        - {tilt_deg: 90, rotation_deg: 0}
        - {tilt_deg: -90, rotation_deg: 0}
      dwell_s: 3
      record_s: 20
)";
  }
  static stend::testing::ProgramOutput run_ok(const std::string& args) {
    auto o = run_stend(args);
    if (o.code != 0) std::cerr << "stend " << args << " (exit " << o.code << "):\n" << o.text << "\n";
    return o;
  }
  static inline std::unique_ptr<stend::testing::TempDir> tmp_;
};

TEST_F(ApplyCli, AliasedBiasesAreRefusedNamingEachUnlessAssumed) {
  const auto refused = run_stend("apply " + path("aliased.json") + " " + path("held_out") + " --validate");
  EXPECT_EQ(refused.code, 2) << refused.text;
  for (const char* p : {"accelerometer bias_x [m/s^2]", "accelerometer bias_y [m/s^2]", "accelerometer bias_z [m/s^2]",
                        "accelerometer bias_tc1_x [m/s^2/degC]"})
    EXPECT_NE(refused.text.find(p), std::string::npos) << p << "\n" << refused.text;
  EXPECT_NE(refused.text.find("--assume bias_x=0,bias_y=0,bias_z=0,bias_tc1_x=0,bias_tc1_y=0,bias_tc1_z=0"),
            std::string::npos)
      << refused.text;
  EXPECT_EQ(refused.text.find("validation of"), std::string::npos) << refused.text;  // nothing checked, nothing written
  EXPECT_FALSE(fs::exists(dir() / "assumed"));

  // Stated (in two --assume, one comma-separated): applied, and recorded in the calibrated run.
  const auto applied = run_stend("apply " + path("aliased.json") + " " + path("held_out") + " -o " + path("assumed") +
                                 " --assume bias_x=0.05,bias_y=-0.03,bias_z=0.027 --assume bias_tc1_x=0,bias_tc1_y=0,"
                                 "bias_tc1_z=0 --json");
  ASSERT_EQ(applied.code, 0) << applied.text;
  const auto rec = stend::Recording::open(dir() / "assumed");
  bool recorded = false;
  for (const auto& e : rec.events)
    recorded = recorded || e.message.find("assumed by the user: accelerometer bias_x = 0.05 m/s^2") != std::string::npos;
  EXPECT_TRUE(recorded) << "no event records the assumption";
  EXPECT_NE(applied.text.find("\"accelerometer bias_tc1_z = 0 m/s^2/degC"), std::string::npos) << applied.text;

  // The silent 0 of old, now stated: the held-out poses are off by the sensor's bias, and the
  // validation says FAIL (exit 3).
  const auto zero = run_stend("apply " + path("aliased.json") + " " + path("held_out") + " --validate --assume "
                              "bias_x=0,bias_y=0,bias_z=0,bias_tc1_x=0,bias_tc1_y=0,bias_tc1_z=0");
  EXPECT_EQ(zero.code, 3) << zero.text;
  EXPECT_NE(zero.text.find("FAIL         static |a| - g: calibrated RMS"), std::string::npos) << zero.text;
}

TEST_F(ApplyCli, ValidatePassesWithTheSameSensorAndFailsWithAnother) {
  const auto same = run_stend("apply " + path("bias_scale.json") + " " + path("held_out") + " --validate");
  EXPECT_EQ(same.code, 0) << same.text;
  EXPECT_NE(same.text.find("validation of " + (dir() / "bias_scale.json").string() + ": PASS"), std::string::npos)
      << same.text;
  EXPECT_NE(same.text.find("PASS         static |a| - g: calibrated RMS"), std::string::npos) << same.text;
  EXPECT_NE(same.text.find("x the noise floor"), std::string::npos) << same.text;  // the limit, stated

  const auto other = run_stend("apply " + path("bias_scale.json") + " " + path("other") + " --validate --json");
  EXPECT_EQ(other.code, 3) << other.text;
  EXPECT_NE(other.text.find("\"verdict\": \"FAIL\""), std::string::npos) << other.text;
}

// The hand-turned MPU-6050 session with the shipped unknown-orientations model: its cross-axis
// terms held by the frame convention are applied as 0 without an assumption.
TEST_F(ApplyCli, UnknownOrientationsCeresResultApplies) {
  const fs::path csv = stend::testing::shared_data("mpu6050_multipos/calibration_session.csv");
  STEND_SKIP_IF_ABSENT(csv);
  ASSERT_EQ(run_ok("import " + shell_quote(csv.string()) + " -o " + path("mpu")).code, 0);
  ASSERT_EQ(run_ok("fit " + path("mpu") + " -m " +
                  shell_quote(stend::testing::source_path("estimators/ceres_nonlinear/examples/unknown_orientations.yaml").string()))
                .code,
            0);
  const auto applied = run_stend("apply " + path("mpu/ceres.json") + " " + path("mpu") + " -o " + path("mpu_cal"));
  EXPECT_EQ(applied.code, 0) << applied.text;
  EXPECT_EQ(applied.text.find("assumed"), std::string::npos) << applied.text;
}

}  // namespace
