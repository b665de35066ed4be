// One verdict per noise coefficient everywhere: `stend fit … allan.yaml`, then `stend report` and
// `stend export --to kalibr` on the same simulated run; allan.json's verdict of every channel's
// N, K, B and Gauss–Markov σ must be what the CLI table, the HTML report and Kalibr's imu.yaml say.
// A constant signal must fail with a non-zero exit and no numbers.
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <map>
#include <sstream>
#include <regex>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const fs::path kStend = stend::testing::stend_program();
const fs::path kSrc = STEND_SOURCE_DIR;

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }
// The stend command with its results database inside the test's folder.
std::string stend_in(const fs::path& dir) { return "STEND_RESULTS_DB=" + q(dir / "results.sqlite") + " " + q(kStend); }

// A static record of `duration_s` at 200 Hz with the sensor's 44 Hz low-pass and extra sensor keys.
void write_static(const fs::path& file, double duration_s, const std::string& extra) {
  std::string st = stend::testing::read_text(kSrc / "configs/long_static.yaml");
  st.replace(st.find("duration_s: 7200"), 16, fmt::format("duration_s: {:g}", duration_s));
  st.replace(st.find("{output_rate_hz: 100, lowpass_hz: 44}"), 37,
             "{output_rate_hz: 200, lowpass_hz: 44" + extra + "}");
  stend::testing::write_text(file, st);
}

// The CLI table's cell of coefficient `symbol` for a channel: the summary row, split on spaces.
std::vector<std::string> table_row(const std::string& text, const std::string& channel) {
  std::istringstream is(text);
  std::string line;
  while (std::getline(is, line)) {
    if (line.rfind(channel + " ", 0) == 0 && line.find('|') != std::string::npos) {
      std::vector<std::string> cells;
      std::istringstream ls(line);
      std::string c;
      while (ls >> c) cells.push_back(c);
      return cells;
    }
  }
  return {};
}

TEST(AllanVerdict, SameInCliJsonReportAndKalibr) {
  stend::testing::TempDir tmp("allan-verdict");
  const fs::path dir = tmp.path();
  write_static(dir / "static.yaml", 1800, "");
  const auto run = stend::testing::run_command(stend_in(dir) + " run " + q(dir / "static.yaml") + " -q -o " +
                                               q(dir) + " --name st");
  ASSERT_EQ(run.code, 0) << run.text;
  const fs::path rd = dir / "st";
  const auto fit = stend::testing::run_command(stend_in(dir) + " fit " + q(rd) + " -m " +
                                               q(kSrc / "estimators/allan/example/allan.yaml"));
  ASSERT_EQ(fit.code, 0) << fit.text;
  const auto rep = stend::testing::run_command(stend_in(dir) + " report " + q(rd));
  ASSERT_EQ(rep.code, 0) << rep.text;
  const auto exp = stend::testing::run_command(stend_in(dir) + " export " + q(rd) + " --to kalibr -o " +
                                               q(dir / "imu.yaml"));
  ASSERT_EQ(exp.code, 0) << exp.text;

  const json al = json::parse(stend::testing::read_text(rd / "allan.json"));
  const std::string html = stend::testing::read_text(rd / "report.html");
  const std::string imu = stend::testing::read_text(dir / "imu.yaml");
  ASSERT_FALSE(imu.empty()) << exp.text;

  // CLI table columns: axis N K B G Tc Q R | …
  const std::map<std::string, int> column = {{"N", 1}, {"K", 2}, {"B", 3}, {"G", 4}};
  for (const auto& ch : al["channels"]) {
    const std::string name = ch["channel"];
    const auto row = table_row(fit.text, name);
    ASSERT_GE(row.size(), 8u) << name << "\n" << fit.text;
    // The report's table row of this channel.
    const auto r0 = html.find("<tr><td>" + name + "</td>");
    ASSERT_NE(r0, std::string::npos) << name;
    const std::string hrow = html.substr(r0, html.find("</tr>", r0) - r0);
    std::vector<std::string> hcells;
    const std::regex td("<td>([^<]*)</td>");
    for (std::sregex_iterator it(hrow.begin(), hrow.end(), td), end; it != end; ++it)
      hcells.push_back((*it)[1]);
    ASSERT_GE(hcells.size(), 5u) << hrow;
    for (const auto& [sym, col] : column) {
      const json& c = ch["model"][sym];
      const std::string verdict = c["verdict"];
      const std::string cli = row[static_cast<std::size_t>(col)];
      const std::string rep_cell = hcells[static_cast<std::size_t>(col)];
      SCOPED_TRACE(name + " " + sym + ": " + verdict + ", CLI '" + cli + "', report '" + rep_cell + "'");
      if (verdict == "identified") {
        EXPECT_NE(cli.find("±"), std::string::npos);
        EXPECT_NEAR(std::stod(cli), c["value"].get<double>(), 1e-3 * c["value"].get<double>());
        EXPECT_NE(rep_cell.find("±"), std::string::npos);
        EXPECT_EQ(rep_cell.find("not identified"), std::string::npos);
      } else {
        ASSERT_EQ(verdict, "upper_bound");
        EXPECT_EQ(cli.rfind("<=", 0), 0u);
        EXPECT_NE(rep_cell.find("not identified"), std::string::npos);
        EXPECT_EQ(rep_cell.find("±"), std::string::npos);
      }
    }
    // The datasheet line (e.g. "bias instability") states the same verdicts.
    for (const char* sym : {"N", "B"}) {
      const json& c = ch["model"][sym];
      const std::regex re(name + " .*" + sym + " (<=)?[0-9.e+-]+(±)?");
      std::smatch m;
      ASSERT_TRUE(std::regex_search(fit.text, m, re)) << fit.text;
      EXPECT_EQ(m[1].matched, c["verdict"] == "upper_bound") << name << " " << sym << ": " << m.str();
    }
  }
  // Kalibr: the written density is the largest identified axis, or says it is a bound / read-off.
  for (const std::string inst : {"accelerometer", "gyroscope"}) {
    for (const std::string what : {"noise_density", "random_walk"}) {
      const std::string key = inst + "_" + what;
      const std::string sym = what == "noise_density" ? "N" : "K";
      double largest = NAN;
      for (const auto& ch : al["channels"])
        if (ch["instrument"] == inst && ch["model"][sym]["verdict"] == "identified")
          largest = std::isnan(largest) ? ch["model"][sym]["value"].get<double>()
                                        : std::max(largest, ch["model"][sym]["value"].get<double>());
      std::smatch m;
      ASSERT_TRUE(std::regex_search(imu, m, std::regex(key + ": ([^ ]+) *#([^\n]*)"))) << imu;
      SCOPED_TRACE(key + ": " + m.str());
      if (std::isfinite(largest)) {
        EXPECT_NEAR(std::stod(m[1]), largest, 1e-6 * largest);
      } else {
        EXPECT_TRUE(m[2].str().find("UPPER BOUND") != std::string::npos ||
                    m[2].str().find("read-off") != std::string::npos);
      }
    }
  }
}

TEST(AllanVerdict, ConstantSignalFailsWithNonZeroExitAndNoNumbers) {
  stend::testing::TempDir tmp("allan-constant");
  const fs::path dir = tmp.path();
  write_static(dir / "flat.yaml", 60,
               ", accel_noise_density: 0, gyro_noise_density: 0, accel_bias_instability_mps2: 0, "
               "gyro_bias_instability_radps: 0, accel_random_walk: 0, gyro_random_walk: 0");
  const auto run = stend::testing::run_command(stend_in(dir) + " run " + q(dir / "flat.yaml") + " -q -o " +
                                               q(dir) + " --name flat");
  ASSERT_EQ(run.code, 0) << run.text;
  const auto fit = stend::testing::run_command(stend_in(dir) + " fit " + q(dir / "flat") + " -m " +
                                               q(kSrc / "estimators/allan/example/allan.yaml"));
  EXPECT_NE(fit.code, 0) << fit.text;
  EXPECT_NE(fit.text.find("FAILED"), std::string::npos) << fit.text;
  EXPECT_EQ(fit.text.find("±"), std::string::npos) << fit.text;
  EXPECT_EQ(fit.text.find("nan"), std::string::npos) << fit.text;
}

}  // namespace
