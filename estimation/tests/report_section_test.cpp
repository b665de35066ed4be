// The run report's sections as data: the shared parameter table, the generic section of an
// estimator without its own, and print/equals of sections and plots.
#include <gtest/gtest.h>

#include <stend/estimation/fit_report.hpp>
#include <stend/estimation/report_section.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <sstream>

namespace se = stend::estimation;

namespace {

se::ParameterEstimate parameter(const std::string& name, const std::string& unit, double value, double se_) {
  se::ParameterEstimate p;
  p.name = name;
  p.unit = unit;
  p.identifiable = true;
  p.value = value;
  p.std_error = se_;
  p.lower = value - 2 * se_;
  p.upper = value + 2 * se_;
  return p;
}

se::FitSummary summary() {
  se::FitSummary s;
  s.estimator = "toy";
  s.version = "0.3";
  s.status = se::FitStatus::kOk;
  s.confidence = 0.95;
  s.parameters.push_back(parameter("bias_z", "m/s^2", 0.0981, 0.000981));  // 10 mg ± 0.1 mg
  se::ParameterEstimate scale = parameter("scale_z", "1", 2e-3, 5e-4);
  scale.verdict = se::Verdict::kImprecise;
  scale.reason = "std error 500 ppm over the 100 ppm tolerance";
  s.parameters.push_back(scale);
  se::ParameterEstimate cross;
  cross.name = "cross_zx";
  cross.unit = "1";
  cross.reason = "not excited";
  s.parameters.push_back(cross);
  s.notes.push_back("axis x: not fitted");
  return s;
}

}  // namespace

TEST(ParameterTable, DisplayUnitsVerdictsAndUnidentifiedRows) {
  const se::Table t = se::parameter_table(summary());
  EXPECT_EQ(t.kind, se::Table::Kind::kParameters);
  EXPECT_EQ(t.header, (std::vector<std::string>{"parameter", "value", "unit", "std error", "95 % interval", "verdict"}));
  ASSERT_EQ(t.rows.size(), 3u);
  const auto text = [&](std::size_t r, std::size_t c) { return t.rows[r].cells[c].text; };
  // m/s² in mg, a dimensionless factor in ppm.
  EXPECT_EQ(text(0, 1), "10.0034");
  EXPECT_EQ(text(0, 2), "mg");
  EXPECT_EQ(text(0, 4), "[9.80335, 10.2035]");
  EXPECT_EQ(text(0, 5), "determined");
  EXPECT_EQ(text(1, 2), "ppm");
  EXPECT_EQ(text(1, 5), "imprecise: std error 500 ppm over the 100 ppm tolerance");
  // Not identified: marked, no value, no interval, and why.
  EXPECT_EQ(t.rows[2].mark, se::Row::Mark::kNotIdentified);
  EXPECT_EQ(text(2, 1), "not estimated");
  EXPECT_EQ(text(2, 3), "—");
  EXPECT_EQ(text(2, 4), "—");
  EXPECT_EQ(text(2, 5), "NO: not excited");
  EXPECT_EQ(t.rows[0].mark, se::Row::Mark::kNone);
}

TEST(GenericSection, ParameterTableAndNotesOrTheFailureWithoutNumbers) {
  se::FitResult r;
  r.summary = summary();
  r.results_file = "toy.json";
  se::ReportSection s = se::generic_report_section(r);
  EXPECT_EQ(s.heading, "Fit — toy 0.3");
  EXPECT_EQ(s.file, "toy.json");
  ASSERT_EQ(s.blocks.size(), 2u);
  ASSERT_TRUE(std::holds_alternative<se::Table>(s.blocks[0]));
  EXPECT_EQ(std::get<se::Table>(s.blocks[0]), se::parameter_table(r.summary));
  EXPECT_EQ(std::get<se::Paragraph>(s.blocks[1]).text(), "note: axis x: not fitted");

  r.summary.status = se::FitStatus::kFailed;
  r.summary.message = "k < p";
  s = se::generic_report_section(r);
  ASSERT_EQ(s.blocks.size(), 1u);
  const auto& failure = std::get<se::Paragraph>(s.blocks[0]);
  EXPECT_EQ(failure.emphasis, se::Emphasis::kFailure);
  EXPECT_EQ(failure.text(), "FIT FAILED: k < p — no numbers are reported.");
}

TEST(ReportSection, PrintsAsPlainTextAndEqualsItsCopyOnly) {
  se::ReportSection s;
  s.heading = "Noise — toy";
  s.file = "toy.json";
  s.add_text("careful", se::Emphasis::kWarning);
  s.add(se::Subheading{"axis z"});
  s.add(se::Table{se::Table::Kind::kPlain, {"a", "b"}, {se::Row{{"1", se::Cell{"failed", 1, se::Emphasis::kFailure}}}}});
  se::figure::Plot p;
  p.title = "a plot";
  p.series.push_back({"points", se::figure::Style::kPoints, {1, 2}, {3, std::nan("")}, {}, {}, "", false, 1.0});
  s.add(p, "its caption");

  std::ostringstream os;
  os << s;
  EXPECT_EQ(os.str(), "Noise — toy (toy.json)\nwarning: careful\n-- axis z\na | b\n1 | failed\n[figure: a plot] its caption\n");

  se::ReportSection copy = s;
  EXPECT_TRUE(s.equals(copy));  // NaN equals NaN in a plot's data
  std::get<se::Figure>(copy.blocks[3]).plot.series[0].y[0] = 4;
  EXPECT_FALSE(s.equals(copy));
  copy = s;
  copy.topic = se::ReportSection::Topic::kNoise;
  EXPECT_FALSE(s.equals(copy));
}

TEST(ReportNumber, SixSignificantDigitsAndADashForNoNumber) {
  EXPECT_EQ(se::report_number(0.0123456789), "0.0123457");
  EXPECT_EQ(se::report_number(12345.678, 3), "1.23e+04");
  EXPECT_EQ(se::report_number(std::nan("")), "—");
  EXPECT_EQ(se::report_number(std::numeric_limits<double>::infinity()), "—");
}

TEST(DisplayUnit, ReportUnitsOfSiUnits) {
  EXPECT_EQ(se::display_unit("m/s^2").unit, "mg");
  EXPECT_NEAR(se::display_unit("m/s^2").scale * 9.80665e-3, 1.0, 1e-12);
  EXPECT_EQ(se::display_unit("rad/s").unit, "deg/s");
  EXPECT_NEAR(se::display_unit("rad/s").scale * M_PI / 180.0, 1.0, 1e-12);
  // g-sensitivity as the docs state it: 1 (deg/s)/g = (π/180 rad/s) / 9.80665 m/s².
  EXPECT_EQ(se::display_unit("rad/s/(m/s^2)").unit, "(deg/s)/g");
  EXPECT_NEAR(se::display_unit("rad/s/(m/s^2)").scale * (M_PI / 180.0) / 9.80665, 1.0, 1e-12);
  EXPECT_EQ(se::display_unit("1").unit, "ppm");
  EXPECT_EQ(se::display_unit("m/s^2/degC").unit, "mg/degC");
  EXPECT_EQ(se::display_unit("1/degC^2").unit, "ppm/degC^2");
  EXPECT_EQ(se::display_unit("s").unit, "s");
}

// The command line's parameter rows and a verdict's numbers are in the row's display unit (mg,
// ppm), as the report's table: the results file keeps SI.
TEST(DisplayUnit, ParameterRowsAndVerdictReasonsUseTheDisplayUnit) {
  se::ParameterEstimate bias;
  bias.name = "bias_x";
  bias.unit = "m/s^2";
  bias.identifiable = true;
  bias.value = 2.0 * 9.80665e-3;  // 2 mg
  bias.std_error = 9.80665e-3;    // 1 mg: a 95 % half-width of 1.96 mg > 1.96 × the 0.5 mg tolerance
  bias.lower = 0.0;
  bias.upper = 4.0 * 9.80665e-3;
  se::PrecisionTolerances tol;
  tol.accel_bias_mg = 0.5;
  se::judge(bias, tol, se::IntervalBasis{0.95, 1.959963984540054});
  ASSERT_EQ(bias.judged(), se::Verdict::kImprecise);
  EXPECT_NE(bias.reason.find("half-width 1.96 mg (1.96 × the standard error 1)"), std::string::npos) << bias.reason;
  std::ostringstream row;
  row << bias;
  EXPECT_NE(row.str().find(" 2 mg"), std::string::npos) << row.str();
  EXPECT_NE(row.str().find("[0, 4]"), std::string::npos) << row.str();
  EXPECT_EQ(row.str().find("m/s^2"), std::string::npos) << row.str();
}
