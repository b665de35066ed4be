// A logger that writes in bursts (a FIFO drained every 40 ms, each sample stamped as it is read:
// 2 ms apart inside a burst): `stend import` states the pattern and takes the mean rate, so the
// Allan fit's white-noise density is the one planted — before, the run was rebuilt at the rate
// inside a burst (500 Hz) and N came out √5 too low. A jittery log of the same sensor is not
// called bursty and gives the same N.
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <random>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;
using stend::testing::shell_quote;

namespace {

constexpr double kRateHz = 100.0;          // the sensor's rate
constexpr std::size_t kSamples = 120000;  // 20 min: two of the import's timestamp windows
constexpr int kPerBurst = 4;
constexpr double kInsideS = 0.002;
// The planted gyro white noise: 0.01 deg/s/sqrt(Hz) [rad/s/sqrt(Hz)], per sample N·sqrt(rate).
const double kNoiseDensity = 0.01 * M_PI / 180.0;

enum class Times { kBursty, kJittery };

double time_of(std::size_t i, Times kind, std::mt19937_64& rng) {
  if (kind == Times::kBursty)
    return static_cast<double>(i / kPerBurst) * kPerBurst / kRateHz + static_cast<double>(i % kPerBurst) * kInsideS;
  std::uniform_real_distribution<double> jitter(-0.3 / kRateHz, 0.3 / kRateHz);
  return static_cast<double>(i) / kRateHz + jitter(rng);
}

// A still sensor with white gyro noise of kNoiseDensity, logged as t,ax,ay,az,gx,gy,gz (s, m/s², rad/s).
void write_log(const fs::path& file, Times kind) {
  std::mt19937_64 rng(kind == Times::kBursty ? 11 : 12);
  std::normal_distribution<double> gyro(0.0, kNoiseDensity * std::sqrt(kRateHz)), accel(0.0, 1e-3);
  std::string text = "t,ax,ay,az,gx,gy,gz\n";
  for (std::size_t i = 0; i < kSamples; ++i)
    text += fmt::format("{:.6f},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e}\n", time_of(i, kind, rng), accel(rng),
                        accel(rng), 9.80665 + accel(rng), gyro(rng), gyro(rng), gyro(rng));
  stend::testing::write_text(file, text);
}

// Imports the log into dir/run (its output returned) and fits the Allan model there.
std::string import_and_fit(const fs::path& dir, Times kind) {
  write_log(dir / "log.csv", kind);
  const auto imported = stend::testing::run_stend("import " + shell_quote((dir / "log.csv").string()) +
                                                  " --time t --accel ax,ay,az --gyro gx,gy,gz -o " +
                                                  shell_quote((dir / "run").string()));
  EXPECT_EQ(imported.code, 0) << imported.text;
  const auto fit = stend::testing::run_stend(
      "fit " + shell_quote((dir / "run").string()) + " -m " +
          shell_quote(stend::testing::source_path("estimators/allan/example/allan.yaml").string()),
      {{"STEND_RESULTS_DB", (dir / "results.sqlite").string()}});
  EXPECT_EQ(fit.code, 0) << fit.text;
  return imported.text;
}

// The planted density lies inside each gyro axis's 95 % interval of N.
void expect_planted_noise(const fs::path& run) {
  const json al = json::parse(stend::testing::read_text(run / "allan.json"));
  EXPECT_NEAR(al["rate_hz"].get<double>(), kRateHz, 1e-3);
  int gyro_axes = 0;
  for (const auto& ch : al["channels"]) {
    if (ch["instrument"] != "gyroscope") continue;
    ++gyro_axes;
    const json& n = ch["model"]["N"];
    ASSERT_EQ(n["verdict"], "identified") << ch["channel"];
    EXPECT_LE(n["interval95"][0].get<double>(), kNoiseDensity) << ch["channel"] << ": N = " << n["value"];
    EXPECT_GE(n["interval95"][1].get<double>(), kNoiseDensity) << ch["channel"] << ": N = " << n["value"];
  }
  EXPECT_EQ(gyro_axes, 3);
}

}  // namespace

TEST(AllanBurstyLog, MeanRateGivesThePlantedWhiteNoise) {
  stend::testing::TempDir dir("allan-bursty");
  const std::string out = import_and_fit(dir.path(), Times::kBursty);
  EXPECT_NE(out.find("warning:    timestamps come in bursts of ~4 samples every 40 ms (2 ms apart inside a burst"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("rate taken as the mean rate 100 Hz"), std::string::npos) << out;
  EXPECT_NE(out.find("the samples' own times are kept"), std::string::npos) << out;
  EXPECT_EQ(out.find("gap(s)"), std::string::npos) << out;
  expect_planted_noise(dir / "run");
}

TEST(AllanBurstyLog, JitteryLogIsNotBursty) {
  stend::testing::TempDir dir("allan-jittery");
  const std::string out = import_and_fit(dir.path(), Times::kJittery);
  EXPECT_EQ(out.find("bursts"), std::string::npos) << out;
  expect_planted_noise(dir / "run");
}
