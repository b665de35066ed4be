// Acceptance: the simulated vendor study (configs/vendor_study/run.sh) — three vendors × five units,
// the same short temperature sweep — goes from `stend run` (15 runs) through the results database
// to `stend compare`; the vendors' fitted means differ as planted and the units' intervals cover
// their planted values.
#include "stend/reporting/compare.hpp"
#include "stend/reporting/results_db.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/plot_layout.hpp"
#include "stend/testing/program.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace fs = std::filesystem;
namespace rp = stend::reporting;
namespace st = stend::testing;

namespace {

std::vector<std::map<std::string, std::string>> read_csv(const fs::path& f) {
  std::ifstream in(f);
  std::vector<std::map<std::string, std::string>> rows;
  std::string line;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    std::vector<std::string> cols;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cols.push_back(c);
    if (header.empty()) {
      header = cols;
      continue;
    }
    std::map<std::string, std::string> r;
    for (std::size_t i = 0; i < header.size() && i < cols.size(); ++i) r[header[i]] = cols[i];
    rows.push_back(r);
  }
  return rows;
}

}  // namespace

TEST(VendorStudy, VendorsDifferAsPlantedAndIntervalsCoverTheUnits) {
  const st::TempDir tmp("vendor-study");
  const fs::path dir = tmp / "study";
  const st::ProgramOutput run =
      st::run_command(st::shell_quote(st::source_path("configs/vendor_study/run.sh").string()) + " " +
                          st::shell_quote(dir.string()) + " 5",
                      {{"STEND", st::stend_program().string()}});
  st::write_text(dir.string() + ".log", run.text);
  ASSERT_EQ(run.code, 0) << "run.sh failed; see " << dir.string() << ".log";

  rp::ResultsDb db(dir / "stend-results.sqlite");
  const auto runs = db.all();
  ASSERT_EQ(runs.size(), 15u);
  const rp::Comparison c = rp::compare_runs(runs);  // one procedure: no refusal

  const auto planted = read_csv(dir / "planted.csv");
  ASSERT_EQ(planted.size(), 15u);
  const std::vector<std::string> names = {"bias_x", "bias_y", "bias_z", "scale_x", "scale_y",
                                          "scale_z", "bias_tc1_x", "bias_tc1_y", "bias_tc1_z"};
  // Each unit's 95 % interval against its planted value.
  int covered = 0, total = 0;
  for (const auto& p : planted) {
    const rp::RunResults r = db.find_run(p.at("run"));
    ASSERT_FALSE(r.dir.empty()) << p.at("run");
    for (const auto& n : names) {
      const rp::ParameterResult* q = r.find("temp_poly", n);
      ASSERT_NE(q, nullptr) << n;
      ASSERT_TRUE(q->identifiable) << n;
      const double truth = std::stod(p.at(n));
      ++total;
      if (q->lo <= truth && truth <= q->hi) ++covered;
      EXPECT_LT(std::abs(q->value - truth), 6 * q->std_error) << p.at("run") << " " << n;
    }
  }
  EXPECT_GE(covered, static_cast<int>(0.9 * total)) << covered << " of " << total << " intervals cover the planted values";
  std::printf("unit intervals covering the planted values: %d of %d\n", covered, total);

  // Vendor means: ordered as planted, pairwise separated (disjoint intervals of the means), and
  // each vendor's interval covers the mean of its units' planted values.
  const auto vendors = read_csv(fs::path(STEND_SOURCE_DIR) / "configs/vendor_study/vendors.csv");
  const std::map<std::string, std::string> column = {
      {"bias_x", "bias_x"},   {"bias_y", "bias_y"},   {"bias_z", "bias_z"},   {"scale_x", "scale_x"}, {"scale_y", "scale_y"},
      {"scale_z", "scale_z"}, {"bias_tc1_x", "tc_x"}, {"bias_tc1_y", "tc_y"}, {"bias_tc1_z", "tc_z"}};
  for (const auto& n : names) {
    const rp::ParameterComparison* pc = c.find("temp_poly", n);
    ASSERT_NE(pc, nullptr) << n;
    ASSERT_EQ(pc->vendors.size(), 3u);
    std::map<std::string, double> nominal, fitted, lo, hi, planted_mean;
    for (const auto& v : vendors) nominal[v.at("vendor") + " " + v.at("model")] = std::stod(v.at(column.at(n)));
    for (const auto& s : pc->vendors) {
      EXPECT_EQ(s.units, 5) << s.vendor;
      fitted[s.vendor] = s.mean;
      lo[s.vendor] = s.mean_lo;
      hi[s.vendor] = s.mean_hi;
    }
    for (const auto& [vendor, nom] : nominal) {
      double sum = 0;
      int k = 0;
      for (const auto& p : planted)
        if (p.at("vendor") + " " + p.at("model") == vendor) {
          sum += std::stod(p.at(n));
          ++k;
        }
      ASSERT_EQ(k, 5);
      planted_mean[vendor] = sum / k;
      EXPECT_LE(lo.at(vendor), planted_mean[vendor]) << n << " " << vendor;
      EXPECT_GE(hi.at(vendor), planted_mean[vendor]) << n << " " << vendor;
    }
    for (const auto& [a, na] : nominal)
      for (const auto& [b, nb] : nominal) {
        if (!(na < nb)) continue;
        EXPECT_LT(fitted.at(a), fitted.at(b)) << n << ": " << a << " vs " << b;
        EXPECT_LT(hi.at(a), lo.at(b)) << n << ": the intervals of " << a << " and " << b << " overlap";
      }
  }
  // The comparison report shows one plot per parameter.
  const std::string html = st::read_text(dir / "compare.html");
  std::size_t plots = 0;
  for (auto p = html.find("<svg"); p != std::string::npos; p = html.find("<svg", p + 1)) ++plots;
  EXPECT_EQ(plots, names.size());
  // The layout rule: no unit's point under the vendors' legend, every point inside the axes.
  EXPECT_EQ(st::plot_layout_violations(html), "");
  // Every run also got its own report.
  for (const auto& p : planted) EXPECT_TRUE(fs::exists(dir / "runs" / p.at("run") / "report.html")) << p.at("run");
}
