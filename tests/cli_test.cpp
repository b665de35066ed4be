// The stend program as a user runs it: exit codes and what it prints.
#include <gtest/gtest.h>

#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <cstdio>
#include <filesystem>
#include <string>

namespace fs = std::filesystem;
using stend::testing::ProgramOutput;
using stend::testing::run_stend;
using stend::testing::TempDir;

namespace {

const std::string src = STEND_SOURCE_DIR;

}  // namespace

TEST(Cli, PluginsListsTheSimulatedBench) {
  const ProgramOutput o = run_stend("plugins");
  EXPECT_EQ(o.code, 0) << o.text;
  for (const char* name : {"sim_imu", "sim_one_axis_table", "sim_three_axis_table", "sim_thermochamber", "sim_vibration"})
    EXPECT_NE(o.text.find(name), std::string::npos) << name << "\n" << o.text;
  EXPECT_NE(o.text.find("Refused (0)"), std::string::npos) << o.text;
}

TEST(Cli, ValidateAcceptsThePaperExperiment) {
  const ProgramOutput o = run_stend("validate " + src + "/configs/paper_mpu6050_z.yaml");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("23 orientation(s)"), std::string::npos) << o.text;
}

TEST(Cli, ValidateReportsFileLineColumnAndExitsTwo) {
  const TempDir dir("cli");
  const fs::path bad = dir / "typo.yaml";
  FILE* f = fopen(bad.c_str(), "w");
  ASSERT_NE(f, nullptr);
  fputs("experiment: {name: typo}\n"
        "bench:\n"
        "  sensor: {plugin: sim_imu}\n"
        "procedure:\n"
        "  - record: {duraton_s: 10}\n",
        f);
  fclose(f);
  const ProgramOutput o = run_stend("validate " + bad.string());
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_NE(o.text.find(bad.string() + ":5:"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("duration_s"), std::string::npos) << "did-you-mean hint expected\n" << o.text;
}

TEST(Cli, RunFitsThePaperModelAndWritesResults) {
  const TempDir dir("cli-run");
  const ProgramOutput o = run_stend("run " + src + "/configs/paper_mpu6050_z.yaml --quiet --output " + dir.str() + " --name paper");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("status:     complete"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("cross_zx"), std::string::npos) << o.text;
  EXPECT_TRUE(fs::exists(dir / "paper" / "fit.json"));
  EXPECT_TRUE(fs::exists(dir / "paper" / "fit.txt"));
  const ProgramOutput info = run_stend("info " + (dir / "paper").string());
  EXPECT_EQ(info.code, 0) << info.text;
  EXPECT_NE(info.text.find("status:     complete"), std::string::npos) << info.text;
}

// The store is HDF5 by default; `--store csv` writes the CSV files; both fit to the same numbers.
TEST(Cli, RunStoresHdf5ByDefaultAndCsvOnRequest) {
  const TempDir dir("cli-store");
  const std::string cfg = src + "/configs/paper_mpu6050_z.yaml --quiet --output " + dir.str();
  const ProgramOutput h5 = run_stend("run " + cfg + " --name h5");
  const ProgramOutput csv = run_stend("run " + cfg + " --name csv --store csv");
  ASSERT_EQ(h5.code, 0) << h5.text;
  ASSERT_EQ(csv.code, 0) << csv.text;
  EXPECT_TRUE(fs::exists(dir / "h5" / "run.h5"));
  EXPECT_FALSE(fs::exists(dir / "h5" / "imu.csv"));
  EXPECT_TRUE(fs::exists(dir / "csv" / "imu.csv"));
  EXPECT_FALSE(fs::exists(dir / "csv" / "run.h5"));
  const auto fitted = [](const std::string& text) {  // the line of the fitted cross-axis term
    const auto at = text.find("cross_zx");
    return at == std::string::npos ? std::string() : text.substr(at, text.find('\n', at) - at);
  };
  EXPECT_FALSE(fitted(h5.text).empty()) << h5.text;
  EXPECT_EQ(fitted(h5.text), fitted(csv.text));
  EXPECT_NE(run_stend("run " + cfg + " --name bad --store parquet").code, 0);
}

TEST(Cli, FitImportsTheMpu6050StaticDataset) {
  const fs::path data = stend::testing::shared_data("mpu6050_multipos/static_449s.csv");
  STEND_SKIP_IF_ABSENT(data);
  const TempDir dir("cli-allan");
  const fs::path json = dir / "allan.json";
  const ProgramOutput o = run_stend("fit " + data.string() + " --model " + src + "/estimators/allan/example/allan.yaml --out " + json.string());
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(fs::exists(json));
}

// A fit that fails (a constant signal: nothing to fit) exits non-zero, says so, and its results
// file states the failure with no numbers — replacing, not keeping, an earlier file's results.
// A model of only an instrument the recording lacks (a gyroscope model, a CSV without gyro columns)
// is not applicable: said so, not a fit failure, exit 2 (the inputs do not go together), nothing
// written.
TEST(Cli, ModelOfAnAbsentInstrumentIsNotApplicableAndWritesNothing) {
  const TempDir dir("cli-not-applicable");
  std::string csv = "t,ax,ay,az\n";
  for (int i = 0; i < 2000; ++i) csv += std::to_string(i * 0.01) + ",0.01,-0.02,9.81\n";
  stend::testing::write_text(dir / "accel.csv", csv);
  stend::testing::write_text(dir / "gyro.yaml", "instrument: gyroscope\nterms: [bias]\n");
  const fs::path json = dir / "fit-gyroscope.json";
  const ProgramOutput o = run_stend("fit " + (dir / "accel.csv").string() + " --time t --accel ax,ay,az --model " +
                                    (dir / "gyro.yaml").string() + " --out " + json.string());
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_NE(o.text.find(": not applicable — the recording has no gyroscope"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("results:    none — not applicable"), std::string::npos) << o.text;
  EXPECT_EQ(o.text.find("FAILED"), std::string::npos) << o.text;
  EXPECT_FALSE(fs::exists(json));
}

// A failed fit writes its failure document: over an earlier failed one, which holds no result; beside
// an earlier good one (status ok), which it never replaces (failed-allan.json).
TEST(Cli, FailedFitWritesAFailureDocumentAndClaimsNoResults) {
  const TempDir dir("cli-failed-fit");
  std::string csv = "Fs,100\nLogging Type,1\nInitialization time,-1\nWaiting time,-1\nax,ay,az,gx,gy,gz\n";
  for (int i = 0; i < 5000; ++i) csv += "2508,-604,14684,-429,140,-53\n";
  stend::testing::write_text(dir / "constant.csv", csv);
  const fs::path json = dir / "allan.json", beside = dir / "failed-allan.json";
  const auto fit = [&] {
    return run_stend("fit " + (dir / "constant.csv").string() + " --format mpu6050_multipos --model " + src +
                     "/estimators/allan/example/allan.yaml --out " + json.string());
  };
  const auto expect_failure_document = [](const fs::path& file) {
    const std::string doc = stend::testing::read_text(file);
    EXPECT_NE(doc.find("\"status\": \"failed\""), std::string::npos) << doc;
    EXPECT_NE(doc.find("constant"), std::string::npos) << doc;
    EXPECT_EQ(doc.find("stale"), std::string::npos) << doc;
    EXPECT_EQ(doc.find("\"channels\""), std::string::npos) << doc;
  };
  stend::testing::write_text(json, "{\"status\": \"failed\", \"stale\": 1}\n");
  const ProgramOutput o = fit();
  EXPECT_EQ(o.code, 3) << o.text;
  EXPECT_NE(o.text.find("FAILED"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("results:    none"), std::string::npos) << o.text;
  expect_failure_document(json);
  EXPECT_FALSE(fs::exists(beside));

  const std::string good = "{\"status\": \"ok\", \"stale\": 1}\n";
  stend::testing::write_text(json, good);
  const ProgramOutput kept = fit();
  EXPECT_EQ(kept.code, 3) << kept.text;
  EXPECT_EQ(stend::testing::read_text(json), good);
  expect_failure_document(beside);
  EXPECT_NE(kept.text.find("warning: the fit failed; " + json.string()), std::string::npos) << kept.text;
  EXPECT_NE(kept.text.find("written beside it, to " + beside.string()), std::string::npos) << kept.text;
}
