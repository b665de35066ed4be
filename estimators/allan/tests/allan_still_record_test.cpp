// Allan needs a still record (issue 36, stend/processing/stationarity.hpp): `stend fit … allan.yaml`
// on a log the test writes with a hand turn, or with a temperature sweep, fails (exit 3, FAILED, no
// numbers) naming the stretch that moves or the drift; the model's window (t_begin_s, t_end_s) over
// the still part fits. The hand-turned MPU-6050 session of ../shared/data is refused the same way
// and fits over its still start.
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

namespace fs = std::filesystem;
using stend::testing::shell_quote;

namespace {

constexpr double kRateHz = 100.0, kSeconds = 300.0;
constexpr double kG = 9.80665;
constexpr double kTurnStartS = 120.0, kTurnEndS = 126.0;  // 90° about x at 15 deg/s
const std::string kAllanModel = stend::testing::source_path("estimators/allan/example/allan.yaml").string();

// A still MPU-6050-like sensor (white noise 400 µg/√Hz, 0.005 deg/s/√Hz), logged as
// t,ax,ay,az,gx,gy,gz,temp (s, m/s², rad/s, °C); `turn` adds the hand turn, `sweep` a temperature
// rising 20 → 40 °C.
void write_log(const fs::path& file, bool turn, bool sweep) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> accel(0.0, 400e-6 * kG * std::sqrt(kRateHz)),
      gyro(0.0, 0.005 * M_PI / 180.0 * std::sqrt(kRateHz));
  std::string text = "t,ax,ay,az,gx,gy,gz,temp\n";
  for (int i = 0; i < static_cast<int>(kSeconds * kRateHz); ++i) {
    const double t = i / kRateHz;
    const double angle = turn ? std::clamp((t - kTurnStartS) / (kTurnEndS - kTurnStartS), 0.0, 1.0) * M_PI / 2 : 0.0;
    const double wx = turn && t >= kTurnStartS && t < kTurnEndS ? 15.0 * M_PI / 180.0 : 0.0;
    const double temp = sweep ? 20.0 + 20.0 * t / kSeconds : 25.0;
    text += fmt::format("{:.4f},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.3f}\n", t, accel(rng),
                        kG * std::sin(angle) + accel(rng), kG * std::cos(angle) + accel(rng), wx + gyro(rng), gyro(rng),
                        gyro(rng), temp);
  }
  stend::testing::write_text(file, text);
}

// Imports dir/log.csv into dir/run.
void import_log(const fs::path& dir) {
  const auto o = stend::testing::run_stend("import " + shell_quote((dir / "log.csv").string()) +
                                           " --time t --accel ax,ay,az --gyro gx,gy,gz --temperature temp -o " +
                                           shell_quote((dir / "run").string()));
  ASSERT_EQ(o.code, 0) << o.text;
}

stend::testing::ProgramOutput fit(const fs::path& run, const std::string& model, const fs::path& dir) {
  return stend::testing::run_stend("fit " + shell_quote(run.string()) + " -m " + shell_quote(model),
                                   {{"STEND_RESULTS_DB", (dir / "results.sqlite").string()}});
}

// A model file of the shipped options with the window [t0, t1] [s].
std::string window_model(const fs::path& dir, double t0, double t1) {
  const fs::path m = dir / "window.yaml";
  stend::testing::write_text(m, fmt::format("allan:\n  t_begin_s: {}\n  t_end_s: {}\n", t0, t1));
  return m.string();
}

// A failed fit: exit 3, FAILED, no coefficient printed, nothing written as a result.
void expect_refused(const stend::testing::ProgramOutput& o, const fs::path& run) {
  EXPECT_EQ(o.code, 3) << o.text;
  EXPECT_NE(o.text.find("FAILED"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("the Allan deviation needs a still record"), std::string::npos) << o.text;
  EXPECT_EQ(o.text.find("rad/s/sqrt(Hz)"), std::string::npos) << "numbers printed for a refused record:\n" << o.text;
  EXPECT_FALSE(fs::exists(run / "allan.json") &&
               nlohmann::json::parse(stend::testing::read_text(run / "allan.json")).value("status", "") == "ok");
}

// The first "at A–B s" after `what` in the text, as {A, B}.
std::pair<double, double> stretch_after(const std::string& text, const std::string& what) {
  const auto at = text.find(what);
  if (at == std::string::npos) return {NAN, NAN};
  const auto a = text.find(" at ", at) + 4;
  const double t0 = std::atof(text.c_str() + a);
  const auto dash = text.find("–", a);
  return {t0, std::atof(text.c_str() + dash + std::string("–").size())};
}

}  // namespace

TEST(AllanStillRecord, AHandTurnIsRefusedNamingItsStretchAndTheStillPartFits) {
  stend::testing::TempDir dir("allan-turn");
  write_log(dir / "log.csv", true, false);
  import_log(dir.path());
  const auto o = fit(dir / "run", kAllanModel, dir.path());
  expect_refused(o, dir / "run");
  const auto [a0, a1] = stretch_after(o.text, "the accelerometer moves");
  EXPECT_LE(a0, kTurnStartS) << o.text;
  EXPECT_GE(a1, kTurnEndS - 0.1) << o.text;
  EXPECT_LT(a1 - a0, 12.0) << o.text;
  const auto [g0, g1] = stretch_after(o.text, "the gyroscope turns");
  EXPECT_LE(g0, kTurnStartS) << o.text;
  EXPECT_GE(g1, kTurnEndS - 0.1) << o.text;
  EXPECT_NE(o.text.find("by up to 15"), std::string::npos) << o.text;  // deg/s, the turn rate
  // The longest still stretch: after the turn (from ~127 s to the end, 173 s), not before (120 s).
  EXPECT_NE(o.text.find("t_begin_s: 12"), std::string::npos) << "the longest still stretch\n" << o.text;

  const auto w = fit(dir / "run", window_model(dir.path(), 130.0, kSeconds), dir.path());
  EXPECT_EQ(w.code, 0) << w.text;
  const auto doc = nlohmann::json::parse(stend::testing::read_text(dir / "run/allan.json"));
  EXPECT_EQ(doc["status"], "ok");
  EXPECT_EQ(doc["channels"].size(), 6u);
}

TEST(AllanStillRecord, ATemperatureSweepIsRefusedNamingTheDrift) {
  stend::testing::TempDir dir("allan-sweep");
  write_log(dir / "log.csv", false, true);
  import_log(dir.path());
  const auto o = fit(dir / "run", kAllanModel, dir.path());
  expect_refused(o, dir / "run");
  EXPECT_NE(o.text.find("the temperature drifts at 0.0–"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("(by 19."), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("a log at a steady temperature"), std::string::npos) << o.text;
}

TEST(AllanStillRecord, TheHandTurnedMpu6050SessionIsRefusedAndItsStillStartFits) {
  const fs::path csv = stend::testing::shared_data("mpu6050_multipos/calibration_session.csv");
  STEND_SKIP_IF_ABSENT(csv);
  stend::testing::TempDir dir("allan-mpu-session");
  const auto imported = stend::testing::run_stend("import " + shell_quote(csv.string()) + " -o " +
                                                  shell_quote((dir / "run").string()));
  ASSERT_EQ(imported.code, 0) << imported.text;
  const auto o = fit(dir / "run", kAllanModel, dir.path());
  expect_refused(o, dir / "run");
  EXPECT_NE(o.text.find("the accelerometer moves at"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("the gyroscope turns at"), std::string::npos) << o.text;
  // The session's README: held still for ~36 s, then turned by hand.
  const auto [a0, a1] = stretch_after(o.text, "the gyroscope turns");
  EXPECT_GT(a0, 30.0) << o.text;
  EXPECT_LT(a0, 40.0) << o.text;
  (void)a1;
  EXPECT_EQ(fit(dir / "run", window_model(dir.path(), 0.0, 30.0), dir.path()).code, 0);
}
