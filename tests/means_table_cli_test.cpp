// A table of means without inputs through the program, as docs/log-importers.md ("Tables of means")
// runs it: `stend fit means.csv --model configs/models/accel_unknown_orientations.yaml --accel-unit g`
// on a 178-row table in g with n and sigma; the same table imported into a run folder (its rows' n and
// sigma kept in the held-mean truth columns) and fitted from there to the same numbers; a table with
// fewer rows than the fit needs refused (exit 2) saying how many; a table in g read as m/s^2 refused.
#include <gtest/gtest.h>

#include "stend/testing/files.hpp"
#include "stend/testing/program.hpp"

#include <cmath>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using stend::testing::ProgramOutput;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

const std::string src = STEND_SOURCE_DIR;
const std::string kModel = src + "/configs/models/accel_unknown_orientations.yaml";

// `rows` means in g at random orientations: (1 + scale)·up + bias, plus the error of a mean of n =
// 1000 samples of sigma 2 mg.
std::string table_in_g(int rows) {
  std::mt19937_64 rng(178);
  std::normal_distribution<double> n(0.0, 1.0);
  const double scale[3] = {0.01, -0.005, 0.003}, bias[3] = {0.012, -0.008, 0.02}, sigma = 0.002, count = 1000;
  std::ostringstream out;
  out.precision(9);
  out << "ax,ay,az,n,sigma\n";
  for (int k = 0; k < rows; ++k) {
    double up[3] = {n(rng), n(rng), n(rng)};
    const double norm = std::sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
    for (int a = 0; a < 3; ++a)
      out << (1 + scale[a]) * up[a] / norm + bias[a] + n(rng) * sigma / std::sqrt(count) << ",";
    out << count << "," << sigma << "\n";
  }
  return out.str();
}

// The parameter rows the fit printed (the lines naming a bias or a scale).
std::string parameter_lines(const std::string& text) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line))
    if (line.find("bias_") != std::string::npos || line.find("scale_") != std::string::npos) out += line + "\n";
  return out;
}

}  // namespace

TEST(MeansTableCli, TheWorkedExampleFitsAndAnImportedRunFolderGivesTheSameNumbers) {
  TempDir dir("means-cli");
  write_text(dir / "means.csv", table_in_g(178));
  const ProgramOutput direct =
      run_stend("fit " + shell_quote((dir / "means.csv").string()) + " --model " + shell_quote(kModel) + " --accel-unit g");
  ASSERT_EQ(direct.code, 0) << direct.text;
  for (const char* said : {"means_table", "178 rows", "sigma/sqrt(n) from the table", "bias_x", "a-priori sigmas"})
    EXPECT_NE(direct.text.find(said), std::string::npos) << said << " not in:\n" << direct.text;

  const fs::path run = dir / "runs" / "means";
  const ProgramOutput imported =
      run_stend("import " + shell_quote((dir / "means.csv").string()) + " -o " + shell_quote(run.string()) + " --accel-unit g");
  ASSERT_EQ(imported.code, 0) << imported.text;
  const ProgramOutput from_run = run_stend("fit " + shell_quote(run.string()) + " --model " + shell_quote(kModel));
  ASSERT_EQ(from_run.code, 0) << from_run.text;
  EXPECT_FALSE(parameter_lines(direct.text).empty()) << direct.text;
  EXPECT_EQ(parameter_lines(from_run.text), parameter_lines(direct.text)) << from_run.text;
}

TEST(MeansTableCli, ATooShortOrMisreadTableIsRefused) {
  TempDir dir("means-cli");
  write_text(dir / "short.csv", table_in_g(8));
  const ProgramOutput few =
      run_stend("fit " + shell_quote((dir / "short.csv").string()) + " --model " + shell_quote(kModel) + " --accel-unit g");
  EXPECT_EQ(few.code, 2) << few.text;
  EXPECT_NE(few.text.find("too few rows in the table of means: 8 for 9 accelerometer parameters; give at least 9 rows"),
            std::string::npos)
      << few.text;
  write_text(dir / "means.csv", table_in_g(40));
  const ProgramOutput unit = run_stend("fit " + shell_quote((dir / "means.csv").string()) + " --model " + shell_quote(kModel));
  EXPECT_EQ(unit.code, 2) << unit.text;
  EXPECT_NE(unit.text.find("these look like g — give --accel-unit g"), std::string::npos) << unit.text;
}
