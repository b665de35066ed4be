// `stend deviations FILE`: a plain time series from a text file as Stable32 reads it. On Stable32's
// own sample PHASE.DAT (../shared/data/stable32) the command's JSON agrees with Stable32's results
// for every kind at octave τ (value 1e-4, bounds 1 %, terms and noise type exactly); the same data
// as frequency values (a column of a CSV) give the same deviations; bad input is a clear error with
// the right exit code and no numbers.
#include <gtest/gtest.h>

#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;
using stend::testing::read_number_rows;
using stend::testing::run_command;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::TempDir;

namespace {

const std::string src = STEND_SOURCE_DIR;

struct Outcome {
  int code;
  json doc;         // stdout (--json), null when not JSON
  std::string err;  // stderr
};

Outcome deviations(const TempDir& dir, const std::string& args) {
  const fs::path out = dir / "out.json", err = dir / "err.txt";
  const auto o = run_stend("deviations " + args + " --json > " + shell_quote(out.string()) + " 2> " +
                           shell_quote(err.string()));
  return {o.code, json::parse(stend::testing::read_text(out), nullptr, false), stend::testing::read_text(err)};
}

void expect_schema_valid(const fs::path& file) {
  const auto v = run_command("python3 " + shell_quote(src + "/tests/check_json_schema.py") + " " +
                             shell_quote(src + "/docs/schemas/deviations.schema.json") + " " + shell_quote(file.string()));
  if (v.code == 77) return;  // python3-jsonschema absent: the schema check is skipped, not the test
  EXPECT_EQ(v.code, 0) << v.text;
}

}  // namespace

TEST(DeviationsCli, Stable32PhaseDatEveryKindAsStable32Computes) {
  const fs::path phase = stend::testing::shared_data("stable32/PHASE.DAT");
  STEND_SKIP_IF_ABSENT(phase);
  const TempDir dir("deviations-cli");
  const Outcome r = deviations(dir, shell_quote(phase.string()) + " --phase --tau0 1");
  ASSERT_EQ(r.code, 0) << r.err;
  expect_schema_valid(dir / "out.json");
  ASSERT_TRUE(r.doc["ok"].get<bool>());
  EXPECT_EQ(r.doc["values"], 1001);
  const json& kinds = r.doc["deviations"][0]["kinds"];
  for (const char* kind : {"adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev"}) {
    const fs::path ref = stend::testing::shared_data(std::string("stable32/phase_dat_") + kind + "_octave.txt");
    STEND_SKIP_IF_ABSENT(ref);
    const auto rows = read_number_rows(ref);  // AF Tau # Alpha Min Sigma Max
    ASSERT_FALSE(rows.empty()) << kind;
    for (const auto& row : rows) {
      SCOPED_TRACE(std::string(kind) + " AF " + std::to_string(row[0]));
      const json* p = nullptr;
      for (const json& q : kinds[kind])
        if (q["m"].get<double>() == row[0]) p = &q;
      ASSERT_NE(p, nullptr) << "no value at this factor";
      EXPECT_EQ((*p)["terms"].get<double>(), row[2]);
      EXPECT_EQ((*p)["alpha"].get<double>(), row[3]);
      EXPECT_NEAR((*p)["value"].get<double>() / row[5], 1.0, 1e-4);
      EXPECT_NEAR((*p)["lo"].get<double>() / row[4], 1.0, 0.01);
      EXPECT_NEAR((*p)["hi"].get<double>() / row[6], 1.0, 0.01);
    }
  }
  // The table on stderr (stdout holds the JSON) names the kinds.
  EXPECT_NE(r.err.find("totdev"), std::string::npos) << r.err;
}

TEST(DeviationsCli, FrequencyValuesInACsvColumnGiveThePhaseDataResults) {
  const fs::path phase = stend::testing::shared_data("stable32/PHASE.DAT");
  STEND_SKIP_IF_ABSENT(phase);
  const TempDir dir("deviations-cli");
  // y_i = (x_{i+1} − x_i) / τ0 with τ0 = 0.5 s, in the second column of a CSV with a header comment.
  const auto x = read_number_rows(phase);
  std::string csv = "% index, fractional frequency\n";
  for (std::size_t i = 0; i + 1 < x.size(); ++i) {
    std::ostringstream line;
    line.precision(17);
    line << i << ", " << (x[i + 1][0] - x[i][0]) / 0.5 << "\n";
    csv += line.str();
  }
  stend::testing::write_text(dir / "y.csv", csv);
  const Outcome f = deviations(dir, shell_quote((dir / "y.csv").string()) + " --column 2 --rate-hz 2 --kinds oadev,mdev");
  ASSERT_EQ(f.code, 0) << f.err;
  const Outcome p = deviations(dir, shell_quote(phase.string()) + " --phase --tau0 0.5 --kinds oadev,mdev");
  ASSERT_EQ(p.code, 0) << p.err;
  EXPECT_EQ(f.doc["input"], "frequency");
  for (const char* kind : {"oadev", "mdev"}) {
    const json& a = f.doc["deviations"][0]["kinds"][kind];
    const json& b = p.doc["deviations"][0]["kinds"][kind];
    ASSERT_EQ(a.size(), b.size()) << kind;
    ASSERT_EQ(a.size(), 8u) << kind;
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i]["tau_s"], b[i]["tau_s"]);
      EXPECT_NEAR(a[i]["value"].get<double>() / b[i]["value"].get<double>(), 1.0, 1e-9) << kind << " " << i;
    }
  }
}

TEST(DeviationsCli, BadInputIsAClearErrorAndAFailedSeriesPrintsNoNumbers) {
  const TempDir dir("deviations-cli");
  const fs::path file = dir / "series.txt";

  Outcome r = deviations(dir, shell_quote((dir / "missing.txt").string()) + " --tau0 1");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("missing.txt: cannot open it"), std::string::npos) << r.err;

  stend::testing::write_text(file, "# a comment\n1.5\n2.5\nabc\n4\n");
  r = deviations(dir, shell_quote(file.string()) + " --tau0 1");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("series.txt:4: column 1: 'abc' is not a finite number"), std::string::npos) << r.err;

  stend::testing::write_text(file, "1 2\n3\n");
  r = deviations(dir, shell_quote(file.string()) + " --tau0 1 --column 2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("series.txt:2: has 1 field(s); column 2 was asked for"), std::string::npos) << r.err;
  stend::testing::write_text(file, "t,gz\n0,1\n");
  r = deviations(dir, shell_quote(file.string()) + " --tau0 1 --column gy");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("series.txt:1: no column named 'gy' on the column-name line 't,gz'"), std::string::npos) << r.err;

  // Constant: every deviation would be 0 — a failure with its reason, ok false, no deviations.
  std::string constant;
  for (int i = 0; i < 100; ++i) constant += "3.25\n";
  stend::testing::write_text(file, constant);
  r = deviations(dir, shell_quote(file.string()) + " --tau0 1");
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.err.find("deviations failed: the values are all equal"), std::string::npos) << r.err;
  EXPECT_FALSE(r.doc["ok"].get<bool>());
  EXPECT_FALSE(r.doc.contains("deviations"));
  expect_schema_valid(dir / "out.json");
  // A phase ramp (constant frequency) likewise.
  stend::testing::write_text(file, "0\n2\n4\n6\n8\n10\n");
  r = deviations(dir, shell_quote(file.string()) + " --tau0 1 --phase");
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.err.find("the phase is a straight line"), std::string::npos) << r.err;

  // Too short for any averaging time.
  stend::testing::write_text(file, "1\n");
  r = deviations(dir, shell_quote(file.string()) + " --tau0 1");
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.err.find("too short: 1 frequency value(s)"), std::string::npos) << r.err;

  // Usage: no spacing, both spacings, an unknown kind.
  stend::testing::write_text(file, "1\n2\n3\n");
  EXPECT_EQ(run_stend("deviations " + shell_quote(file.string())).code, 1);
  EXPECT_EQ(run_stend("deviations " + shell_quote(file.string()) + " --tau0 1 --rate-hz 1").code, 1);
  EXPECT_EQ(run_stend("deviations " + shell_quote(file.string()) + " --tau0 1 --kinds adev,xdev").code, 1);
  EXPECT_EQ(run_stend("deviations " + shell_quote(file.string()) + " --tau0 -1").code, 1);
}
