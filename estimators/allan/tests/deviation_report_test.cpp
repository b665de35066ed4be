// `stend fit` with an allan model that asks for deviations: allan.json holds a "deviations"
// member per channel whose values are DeviationStream's on that channel's column, the table
// lists them, and bad `deviations` / `tau` values are errors naming file:line:column.
#include <stend/allan/deviation_report.hpp>
#include <stend/allan/estimator.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

namespace {

using namespace stend;
using namespace stend::allan;
namespace fs = std::filesystem;

// Six axes at 100 Hz: white noise plus a random walk on the gyroscope (a slope the kinds see).
std::vector<ImuSample> simulated(std::size_t n, double rate_hz) {
  std::mt19937_64 gen(5);
  std::normal_distribution<double> normal;
  std::vector<ImuSample> s(n);
  double walk = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    s[i].t_s = static_cast<double>(i) / rate_hz;
    walk += 1e-5 * normal(gen);
    for (int a = 0; a < 3; ++a) {
      s[i].accel_mps2[a] = 0.02 * normal(gen) + (a == 2 ? 9.81 : 0.0);
      s[i].gyro_radps[a] = 0.003 * normal(gen) + walk;
    }
  }
  return s;
}

// A JSON number equals v exactly; null stands for NaN.
bool same(const nlohmann::json& j, double v) {
  return j.is_null() ? std::isnan(v) : j.get<double>() == v;
}

// A model file in a temporary folder removed with the object.
struct ModelFile {
  fs::path dir = fs::temp_directory_path() / ("stend_deviation_report_" + std::to_string(::getpid()));
  fs::path path;
  explicit ModelFile(const std::string& text) : path(dir / "allan.yaml") {
    fs::create_directories(dir);
    std::ofstream(path) << text;
  }
  ~ModelFile() { fs::remove_all(dir); }
};

TEST(DeviationReport, FitWritesEveryRequestedDeviationEqualToTheStream) {
  constexpr double rate = 100.0;
  const auto samples = simulated(30000, rate);
  Recording rec;
  rec.header.info.output_rate_hz = rate;
  rec.header.info.has_gyro = true;
  rec.source = std::make_shared<MemorySamples>(std::vector<ImuSample>(samples));
  const ModelFile model("allan:\n  deviations: [oadev, mdev, hdev, ohdev, totdev, tdev]\n  tau: octave\n");
  AllanEstimator estimator;
  const EstimatorResult r = estimator.fit({&rec, "sim", model.path.string(), {}});
  ASSERT_TRUE(r.ok) << r.message;
  const auto doc = nlohmann::json::parse(r.json);
  ASSERT_TRUE(doc.contains("channels")) << "the fit's own members stay";
  ASSERT_TRUE(doc.contains("deviations"));
  const auto& devs = doc["deviations"];
  ASSERT_EQ(devs.size(), 6u);
  const std::vector<DeviationKind> kinds = {DeviationKind::kOadev, DeviationKind::kMdev, DeviationKind::kHdev,
                                            DeviationKind::kOhdev, DeviationKind::kTotdev, DeviationKind::kTdev};
  for (int ch = 0; ch < 6; ++ch) {
    const auto& got = devs[static_cast<std::size_t>(ch)];
    EXPECT_EQ(got["channel"], std::string(ch < 3 ? "a" : "g") + "xyz"[ch % 3]);
    EXPECT_EQ(got["unit"], ch < 3 ? "m/s^2" : "rad/s");
    EXPECT_EQ(got["tau_spacing"], "octave");
    std::vector<double> column(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i) {
      column[i] = ch < 3 ? samples[i].accel_mps2[ch] : samples[i].gyro_radps[ch - 3];
    }
    // The stream by hand: octave factors up to (N + 1) / 2, τ0 = 1 / rate.
    DeviationOptions o;
    o.factors = {};
    o.max_m = (samples.size() + 1) / 2;
    o.tau0_s = 1.0 / rate;
    DeviationStream stream(o);
    stream.add_rate(column.data(), column.size());
    for (DeviationKind k : kinds) {
      const auto want = stream.result(k);
      const auto& rows = got["kinds"][to_string(k)];
      ASSERT_EQ(rows.size(), want.size()) << to_string(k);
      ASSERT_GE(want.size(), 10u);
      for (std::size_t i = 0; i < want.size(); ++i) {
        EXPECT_EQ(rows[i]["m"].get<std::uint64_t>(), want[i].m);
        EXPECT_DOUBLE_EQ(rows[i]["tau_s"].get<double>(), want[i].tau_s);
        EXPECT_TRUE(same(rows[i]["value"], want[i].dev)) << to_string(k) << " m " << want[i].m;
        EXPECT_TRUE(same(rows[i]["edf"], want[i].edf));
        EXPECT_TRUE(same(rows[i]["lo"], want[i].lo));
        EXPECT_TRUE(same(rows[i]["hi"], want[i].hi));
        EXPECT_EQ(rows[i]["alpha"].get<int>(), want[i].alpha);
        if (std::isfinite(want[i].edf)) {
          EXPECT_LT(want[i].lo, want[i].dev);
          EXPECT_GT(want[i].hi, want[i].dev);
        }
      }
    }
    EXPECT_FALSE(got["kinds"].contains("adev")) << "only the requested kinds";
  }
  // White gyro noise at 1 s: OADEV ≈ 0.003 / √100 (random walk negligible there).
  const auto& gx1s = devs[3]["kinds"]["oadev"][6];  // m = 64 → τ = 0.64 s
  EXPECT_NEAR(gx1s["value"].get<double>(), 0.003 / std::sqrt(64.0), 0.15 * 0.003 / std::sqrt(64.0));
  EXPECT_NE(r.text.find("deviations of gz"), std::string::npos) << r.text;
  EXPECT_NE(r.text.find("totdev"), std::string::npos);
}

TEST(DeviationReport, NoRequestLeavesTheResultsAsBefore) {
  Recording rec;
  rec.header.info.output_rate_hz = 100.0;
  rec.samples = simulated(5000, 100.0);
  const ModelFile model("allan:\n  confidence: 0.9\n");
  AllanEstimator estimator;
  const EstimatorResult r = estimator.fit({&rec, "sim", model.path.string(), {}});
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_FALSE(nlohmann::json::parse(r.json).contains("deviations"));
}

TEST(DeviationReport, BadOptionsNameFileLineAndColumn) {
  auto error = [](const std::string& yaml) {
    try {
      const YAML::Node root = YAML::Load(yaml);
      options_from_yaml(root["allan"], "m.yaml");
      deviations_from_yaml(root["allan"], "m.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("allan:\n  deviations: [oadev, xdev]\n").find("m.yaml:2:23: allan option 'deviations': unknown kind 'xdev'"),
            std::string::npos)
      << error("allan:\n  deviations: [oadev, xdev]\n");
  EXPECT_NE(error("allan:\n  deviations: [mdev, mdev]\n").find("'mdev' is requested twice"), std::string::npos);
  EXPECT_NE(error("allan:\n  deviations: oadev\n").find("expected a list"), std::string::npos);
  EXPECT_NE(error("allan:\n  tau: decade\n").find("m.yaml:2:8: allan option 'tau': expected octave, log or all"),
            std::string::npos)
      << error("allan:\n  tau: decade\n");
  EXPECT_NE(error("allan:\n  deviation: [oadev]\n").find("unknown allan option 'deviation'"), std::string::npos);
  const auto ok = deviations_from_yaml(YAML::Load("allan:\n  deviations: [adev, totdev]\n  tau: log\n")["allan"]);
  EXPECT_EQ(ok.kinds, (std::vector<DeviationKind>{DeviationKind::kAdev, DeviationKind::kTotdev}));
  EXPECT_EQ(ok.tau, TauSpacing::kLog);
}

TEST(DeviationReport, FactorsOfEachSpacingStopAtHalfTheRecord) {
  EXPECT_EQ(deviation_factors(TauSpacing::kOctave, 99, 1u << 20), (std::vector<std::uint64_t>{1, 2, 4, 8, 16, 32}));
  EXPECT_EQ(deviation_factors(TauSpacing::kAll, 9, 1u << 20), (std::vector<std::uint64_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(deviation_factors(TauSpacing::kOctave, 1000, 8), (std::vector<std::uint64_t>{1, 2, 4, 8}));
  const auto log = deviation_factors(TauSpacing::kLog, 1000, 1u << 20);
  EXPECT_EQ(log.front(), 1u);
  EXPECT_EQ(log.back(), 398u);  // 10^2.6; 10^2.7 ≈ 501 > (1000 + 1) / 2
  EXPECT_EQ(log.size(), 24u);  // 1, 2, 3, 4, 5, 6, 8, 10, … (rounded factors that repeat once)
}

}  // namespace
