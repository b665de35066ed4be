// The stend program as a user runs it: exit codes and what it prints.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

struct Output {
  int code = -1;
  std::string text;  // stdout and stderr
};

Output stend(const std::string& args) {
  const std::string cmd = std::string(STEND_BINARY_DIR) + "/bin/stend " + args + " 2>&1";
  Output out;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return out;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), static_cast<int>(buf.size()), pipe)) out.text += buf.data();
  const int status = pclose(pipe);
  out.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

const std::string src = STEND_SOURCE_DIR;

}  // namespace

TEST(Cli, PluginsListsTheSimulatedBench) {
  const Output o = stend("plugins");
  EXPECT_EQ(o.code, 0) << o.text;
  for (const char* name : {"sim_imu", "sim_one_axis_table", "sim_three_axis_table", "sim_thermochamber", "sim_vibration"})
    EXPECT_NE(o.text.find(name), std::string::npos) << name << "\n" << o.text;
  EXPECT_NE(o.text.find("Refused (0)"), std::string::npos) << o.text;
}

TEST(Cli, ValidateAcceptsThePaperExperiment) {
  const Output o = stend("validate " + src + "/configs/paper_mpu6050_z.yaml");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("23 orientation(s)"), std::string::npos) << o.text;
}

TEST(Cli, ValidateReportsFileLineColumnAndExitsTwo) {
  const fs::path dir = fs::temp_directory_path() / ("stend-cli-" + std::to_string(getpid()));
  fs::create_directories(dir);
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
  const Output o = stend("validate " + bad.string());
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_NE(o.text.find(bad.string() + ":5:"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("duration_s"), std::string::npos) << "did-you-mean hint expected\n" << o.text;
  fs::remove_all(dir);
}

TEST(Cli, RunFitsThePaperModelAndWritesResults) {
  const fs::path dir = fs::temp_directory_path() / ("stend-cli-run-" + std::to_string(getpid()));
  const Output o = stend("run " + src + "/configs/paper_mpu6050_z.yaml --quiet --output " + dir.string() + " --name paper");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("status:     complete"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("cross_zx"), std::string::npos) << o.text;
  EXPECT_TRUE(fs::exists(dir / "paper" / "fit.json"));
  EXPECT_TRUE(fs::exists(dir / "paper" / "fit.txt"));
  const Output info = stend("info " + (dir / "paper").string());
  EXPECT_EQ(info.code, 0) << info.text;
  EXPECT_NE(info.text.find("status:     complete"), std::string::npos) << info.text;
  fs::remove_all(dir);
}

TEST(Cli, FitImportsTheMpu6050StaticDataset) {
  const fs::path data = fs::path(STEND_SHARED_DATA_DIR) / "mpu6050_multipos" / "static_449s.csv";
  if (!fs::exists(data)) GTEST_SKIP() << "../shared/data is absent: " << data;
  const fs::path json = fs::temp_directory_path() / ("stend-cli-allan-" + std::to_string(getpid()) + ".json");
  const Output o = stend("fit " + data.string() + " --model " + src + "/estimators/allan/example/allan.yaml --json " + json.string());
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(fs::exists(json));
  fs::remove(json);
  fs::path txt = json;
  fs::remove(txt.replace_extension(".txt"));
}
