// Damaged CSV run folders through the stend program: `info` says what is damaged and what is still
// readable; the analyses refuse the run unless --accept-damaged; malformed rows name file:line.
#include <gtest/gtest.h>

#include "stend/testing/files.hpp"
#include "stend/testing/program.hpp"

#include <filesystem>
#include <string>

namespace fs = std::filesystem;
using stend::testing::ProgramOutput;
using stend::testing::read_text;
using stend::testing::run_stend;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

const std::string src = STEND_SOURCE_DIR;
const std::string model = src + "/estimators/batch_lsq/examples/paper_z_channel.yaml";

// The paper experiment recorded as a CSV run folder `dir/name`.
fs::path record_csv_run(const TempDir& dir, const std::string& name) {
  const ProgramOutput o = run_stend("run " + src + "/configs/paper_mpu6050_z.yaml --quiet --store csv --output " +
                                    dir.str() + " --name " + name);
  EXPECT_EQ(o.code, 0) << o.text;
  return dir / name;
}

}  // namespace

TEST(DamagedRunCli, TruncatedImuCsvIsNamedByInfoAndRefusedByTheAnalyses) {
  const TempDir dir("cli-damaged");
  const fs::path run = record_csv_run(dir, "run");
  ASSERT_EQ(run_stend("fit " + run.string() + " --model " + model + " --out " + (dir / "whole.json").string()).code, 0);
  const std::string imu = read_text(run / "imu.csv");
  write_text(run / "imu.csv", imu.substr(0, imu.rfind('\n', imu.size() * 56 / 100) + 1));

  const ProgramOutput info = run_stend("info " + run.string());
  EXPECT_EQ(info.code, 0) << info.text;
  EXPECT_NE(info.text.find("damaged:"), std::string::npos) << info.text;
  EXPECT_NE(info.text.find("imu.csv:"), std::string::npos) << info.text;
  EXPECT_NE(info.text.find("whole rows found (the last good line is"), std::string::npos) << info.text;

  const ProgramOutput fit = run_stend("fit " + run.string() + " --model " + model + " --out " + (dir / "fit.json").string());
  EXPECT_NE(fit.code, 0) << fit.text;
  EXPECT_NE(fit.text.find("the run is damaged"), std::string::npos) << fit.text;
  EXPECT_NE(fit.text.find("--accept-damaged"), std::string::npos) << fit.text;
  EXPECT_FALSE(fs::exists(dir / "fit.json"));
  const ProgramOutput accepted =
      run_stend("fit " + run.string() + " --accept-damaged --model " + model + " --out " + (dir / "fit.json").string());
  EXPECT_EQ(accepted.text.find("the run is damaged"), std::string::npos) << accepted.text;

  const ProgramOutput gap = run_stend("gap " + run.string() + " --model " + model + " --out " + (dir / "gap.json").string());
  EXPECT_NE(gap.code, 0) << gap.text;
  EXPECT_NE(gap.text.find("the run is damaged"), std::string::npos) << gap.text;

  const ProgramOutput exported = run_stend("export " + run.string() + " --to csv -o " + (dir / "copy").string());
  EXPECT_NE(exported.code, 0) << exported.text;
  EXPECT_FALSE(fs::exists(dir / "copy"));
  EXPECT_EQ(run_stend("export " + run.string() + " --to csv --accept-damaged -o " + (dir / "copy").string()).code, 0);
}

TEST(DamagedRunCli, StrayQuoteInSegmentsCsvNamesItsLine) {
  const TempDir dir("cli-quote");
  const fs::path run = record_csv_run(dir, "run");
  std::string seg = read_text(run / "segments.csv");
  const auto line2 = seg.find('\n') + 1;
  const auto third_field = seg.find(',', seg.find(',', line2) + 1) + 1;  // kind of the first segment
  seg.insert(third_field, "\"");
  write_text(run / "segments.csv", seg);
  for (const std::string& command : {"info " + run.string(), "fit " + run.string() + " --model " + model}) {
    const ProgramOutput o = run_stend(command);
    EXPECT_NE(o.code, 0) << command << "\n" << o.text;
    EXPECT_NE(o.text.find("segments.csv:2:"), std::string::npos) << command << "\n" << o.text;
  }
}

TEST(DamagedRunCli, DamagedGlobalHeapOfAFormat1RunH5IsNamedNeverAHang) {
  // libhdf5 1.10.8 looped for ever on this run.h5 (docs/fuzzing.md): now `info` names the damage,
  // reads the header from run.json and says how many samples are readable; without run.json, exit 2.
  const TempDir dir("cli-gcol");
  const fs::path run = dir / "run";
  fs::copy(src + "/fuzz/run_template/h5", run, fs::copy_options::recursive);
  std::string h5 = read_text(src + "/fuzz/corpus/run_h5/seed_format1_latest.h5");
  // The collection's last object (its free space) declared 0 bytes long: the loop.
  const std::size_t gcol = h5.find("GCOL");
  ASSERT_NE(gcol, std::string::npos);
  auto u64 = [&](std::size_t at) {
    std::uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(h5[at + static_cast<std::size_t>(i)]);
    return v;
  };
  std::size_t p = gcol + 16;
  while (h5[p] != 0 || h5[p + 1] != 0) p += 16 + (u64(p + 8) + 7) / 8 * 8;
  h5.replace(p + 8, 8, std::string(8, '\0'));
  write_text(run / "run.h5", h5);

  const ProgramOutput info = run_stend("info " + run.string());
  EXPECT_EQ(info.code, 0) << info.text;
  EXPECT_NE(info.text.find("damaged:    42 of 42 samples are readable: " + (run / "run.h5").string() +
                           ": the global heap collection at byte " + std::to_string(gcol)),
            std::string::npos)
      << info.text;
  const ProgramOutput fit = run_stend("fit " + run.string() + " --model " + model);
  EXPECT_EQ(fit.code, 2) << fit.text;
  EXPECT_NE(fit.text.find("the run is damaged"), std::string::npos) << fit.text;

  fs::remove(run / "run.json");
  const ProgramOutput bare = run_stend("info " + run.string());
  EXPECT_EQ(bare.code, 2) << bare.text;
  EXPECT_NE(bare.text.find("global heap collection at byte"), std::string::npos) << bare.text;
  EXPECT_NE(bare.text.find("run.json is missing"), std::string::npos) << bare.text;
}
