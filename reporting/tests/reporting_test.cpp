// Unit tests of the reporting library: SVG plotting, procedure fingerprint, results database,
// comparison statistics and refusal, the run report drawing each results file through its registry entry.
#include "stend/estimation/registry.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/recording/recording.hpp"
#include "stend/reporting/compare.hpp"
#include "stend/reporting/fingerprint.hpp"
#include "stend/reporting/results.hpp"
#include "stend/reporting/results_db.hpp"
#include "stend/reporting/run_report.hpp"
#include "stend/reporting/svg_plot.hpp"
#include "stend/testing/files.hpp"
#include "../src/gap_section.hpp"

#include "stend/testing/plot_layout.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <regex>

namespace rp = stend::reporting;
namespace fs = std::filesystem;
namespace figure = stend::estimation::figure;

TEST(Svg, LinearTicksAreNiceAndCoverTheRange) {
  const auto t = rp::svg::nice_ticks(-0.013, 0.047, false);
  ASSERT_GE(t.size(), 4u);
  const double step = t[1] - t[0];
  for (std::size_t i = 1; i < t.size(); ++i) EXPECT_NEAR(t[i] - t[i - 1], step, 1e-12);
  const double mant = step / std::pow(10.0, std::floor(std::log10(step)));
  EXPECT_TRUE(std::abs(mant - 1) < 1e-9 || std::abs(mant - 2) < 1e-9 || std::abs(mant - 5) < 1e-9) << step;
  EXPECT_GE(t.front(), -0.013);
  EXPECT_LE(t.back(), 0.047);
  EXPECT_LE(t.front() - step, -0.013);  // no nice tick left out at either end
  EXPECT_GE(t.back() + step, 0.047);
}

TEST(Svg, LogTicksAreDecades) {
  const auto t = rp::svg::nice_ticks(0.01, 1000.0, true);
  ASSERT_EQ(t.size(), 6u);
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(std::log10(t[i]), -2.0 + static_cast<double>(i), 1e-12);
  const auto narrow = rp::svg::nice_ticks(1.0, 30.0, true);  // < 2 decades: 1, 2, 5 steps
  EXPECT_EQ(narrow, (std::vector<double>{1, 2, 5, 10, 20}));
}

// Every legend entry has a drawn mark: a line of one point (the gap's noise floor after one step) is
// drawn as a marker, a named series with nothing drawable gets no entry; and the check sees a legend
// entry whose mark is gone.
TEST(Svg, EveryLegendEntryHasADrawnMark) {
  figure::Plot p;
  p.title = "legend";
  p.series = {{"held-out RMS", figure::Style::kLinePoints, {0}, {0.11}, {}, {}, "", false, 1.0},
              {"noise floor", figure::Style::kLine, {0}, {0.13}, {}, {}, "", true, 1.0},
              {"nothing to draw", figure::Style::kLine, {0, 1}, {NAN, NAN}, {}, {}, "", false, 1.0}};
  const std::string svg = rp::svg::render(p);
  const auto plots = stend::testing::check_plot_layout(svg);
  ASSERT_EQ(plots.size(), 1u);
  EXPECT_EQ(plots[0].legend_entries, 2u);
  EXPECT_EQ(stend::testing::plot_layout_violations(svg), "");
  EXPECT_NE(svg.find(">noise floor</text>"), std::string::npos);
  EXPECT_EQ(svg.find("nothing to draw"), std::string::npos);
  // The noise floor's marker removed: its legend entry names nothing drawn.
  const auto marker = svg.find("<circle class=\"d\" data-series=\"1\"");
  ASSERT_NE(marker, std::string::npos);
  const std::string without = svg.substr(0, marker) + svg.substr(svg.find('\n', marker) + 1);
  EXPECT_NE(stend::testing::plot_layout_violations(without).find("legend entry 'noise floor' has no drawn mark"),
            std::string::npos)
      << stend::testing::plot_layout_violations(without);
}

// The layout rule by construction: points where the old in-plot legend sat (top right), a legend
// too wide for the right side (then below), forced ranges narrower than the data, and long tick,
// axis and category labels — every point inside the axes and none under the legend.
TEST(Svg, LegendStaysOffTheDataAndEveryPointInsideTheAxes) {
  for (const std::string& name : {std::string("short"), std::string(120, 'w')}) {
    figure::Plot p;
    p.title = "layout";
    p.y_label = "a rather long label of the y axis that would not fit otherwise [m/s^2]";
    figure::Series s{name, figure::Style::kPoints, {}, {}, {}, {}, "", false, 1.0};
    for (int i = 0; i <= 20; ++i) {
      s.x.push_back(i);
      s.y.push_back(1e-4 * i * i);  // the largest values at the top right
    }
    s.y_lo = s.y;
    s.y_hi = s.y;
    for (auto& v : s.y_hi) v += 0.002;
    p.series = {s, {"a curve", figure::Style::kLine, s.x, s.y, {}, {}, "", true, 1.0}};
    p.fixed_x = p.fixed_y = true;
    p.x_min = 2;
    p.x_max = 10;  // narrower than the data: widened to contain it
    p.y_min = 0;
    p.y_max = 0.01;
    const std::string svg = rp::svg::render(p);
    const auto plots = stend::testing::check_plot_layout(svg);
    ASSERT_EQ(plots.size(), 1u);
    EXPECT_TRUE(plots[0].has_legend);
    EXPECT_EQ(plots[0].points, 21u + 21u * 2 + 21u);  // markers, error bars (2 ends), line vertices
    EXPECT_EQ(stend::testing::plot_layout_violations(svg), "") << name;
    if (name.size() > 100) EXPECT_GT(plots[0].legend[1], plots[0].box[3]) << "a wide legend goes below the plot";
    else EXPECT_GT(plots[0].legend[0], plots[0].box[2]) << "a narrow legend goes to the right of the plot";
  }
}

TEST(Svg, RenderEscapesTextAndSkipsBadData) {
  figure::Plot p;
  p.title = "a < b & \"c\"";
  p.x_log = p.y_log = true;
  figure::Series s;
  s.name = "curve<1>";
  s.style = figure::Style::kLinePoints;
  s.x = {0.1, 1.0, -1.0, 10.0, NAN};
  s.y = {1.0, 0.5, 2.0, 0.0, 1.0};  // x<0, y=0 and NaN are unusable on log axes
  p.series.push_back(s);
  const std::string out = rp::svg::render(p);
  EXPECT_NE(out.find("a &lt; b &amp; &quot;c&quot;"), std::string::npos);
  EXPECT_NE(out.find("curve&lt;1&gt;"), std::string::npos);
  EXPECT_EQ(out.find("nan"), std::string::npos);
  EXPECT_EQ(out.find("inf"), std::string::npos);
  // Exactly the two usable points are drawn.
  const std::regex circle("<circle ");
  EXPECT_EQ(std::distance(std::sregex_iterator(out.begin(), out.end(), circle), std::sregex_iterator()), 2);
  figure::Plot empty;
  EXPECT_NE(rp::svg::render(empty).find("no data"), std::string::npos);
}

TEST(Fingerprint, Sha256KnownVectors) {
  EXPECT_EQ(rp::sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(rp::sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(rp::sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(rp::sha256_hex(std::string(1000000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Fingerprint, IndependentOfIdentityNameSeedKeyOrderAndNumberSpelling) {
  const std::string a = R"(
experiment: {name: unit_a, seed: 1, description: first}
bench:
  sensor: {plugin: sim_imu, config: {vendor: Acme, serial: A-1, accel_bias_mps2: [0.1, 0, 0]}}
  fixtures: [{id: table, plugin: sim_three_axis_table}]
  mounting: {on: table}
procedure:
  - set_temperature: {fixture: chamber, setpoint_c: 25, hold_s: 60, label: "warm"}
  - orientations: {fixture: table, list: [{tilt_deg: 0, rotation_deg: 0}], dwell_s: 5, record_s: 10}
)";
  const std::string b = R"(
procedure:
  - set_temperature: {hold_s: 60.0, setpoint_c: 2.5e1, fixture: chamber, label: "other words"}
  - orientations: {record_s: 10, dwell_s: 5, fixture: table, list: [{rotation_deg: 0, tilt_deg: 0}]}
experiment: {name: unit_b, seed: 99}
bench:
  mounting: {on: table}
  fixtures: [{plugin: sim_three_axis_table, id: table}]
  sensor: {plugin: sim_imu, config: {vendor: Borealis, serial: B-7, accel_bias_mps2: [-0.3, 0, 0]}}
)";
  EXPECT_EQ(rp::procedure_fingerprint(a), rp::procedure_fingerprint(b));
  std::string c = a;
  c.replace(c.find("dwell_s: 5"), 10, "dwell_s: 6");
  EXPECT_NE(rp::procedure_fingerprint(a), rp::procedure_fingerprint(c));
  std::string d = a;
  d.replace(d.find("sim_three_axis_table"), 20, "sim_one_axis_table");
  EXPECT_NE(rp::procedure_fingerprint(a), rp::procedure_fingerprint(d));
  EXPECT_EQ(rp::procedure_fingerprint(a).size(), 64u);
  EXPECT_THROW(rp::procedure_fingerprint("experiment: {name: x}\n"), std::runtime_error);
}

namespace {

rp::RunResults unit(const std::string& vendor, const std::string& serial, const std::string& fp, double v, double se) {
  rp::RunResults r;
  r.dir = "/runs/" + vendor + "-" + serial;
  r.run_name = vendor + "-" + serial;
  r.vendor = vendor;
  r.model = "M";
  r.serial = serial;
  r.procedure_fingerprint = fp;
  r.estimators.push_back({"temp_poly", "0.1.0", "temp_poly.json", "ok", ""});
  rp::ParameterResult p;
  p.estimator = "temp_poly";
  p.name = "bias_z";
  p.unit = "m/s^2";
  p.identifiable = true;
  p.value = v;
  p.std_error = se;
  p.lo = v - 2 * se;
  p.hi = v + 2 * se;
  p.confidence = 0.95;
  r.parameters.push_back(p);
  rp::ParameterResult q = p;
  q.name = "cross_zy";
  q.identifiable = false;
  q.value = q.std_error = q.lo = q.hi = NAN;
  q.reason = "not excited";
  r.parameters.push_back(q);
  return r;
}

}  // namespace

TEST(ResultsDb, RoundTripReplaceAndNull) {
  const stend::testing::TempDir d("reporting-db");
  {
    rp::ResultsDb db(d / "r.sqlite");
    db.add(unit("Acme", "1", "ff00", 0.01, 0.001));
    db.add(unit("Acme", "1", "ff00", 0.02, 0.001));  // same folder: replaced, not duplicated
    db.add(unit("Bor", "2", "ee11", -0.03, 0.002));
  }
  rp::ResultsDb db(d / "r.sqlite");
  const auto all = db.all();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].vendor, "Acme");
  EXPECT_DOUBLE_EQ(all[0].parameters[0].value, 0.02);
  EXPECT_DOUBLE_EQ(all[0].parameters[0].lo, 0.018);
  EXPECT_EQ(all[0].estimators.at(0).name, "temp_poly");
  EXPECT_EQ(all[0].estimators.at(0).version, "0.1.0");
  EXPECT_FALSE(all[0].parameters[1].identifiable);
  EXPECT_TRUE(std::isnan(all[0].parameters[1].value));  // stored as NULL, never a default
  EXPECT_EQ(all[0].parameters[1].reason, "not excited");
  EXPECT_EQ(db.with_fingerprint("ee11").size(), 1u);
  EXPECT_EQ(db.find_run("Bor-2").serial, "2");
}

TEST(Compare, VendorStatisticsAndRefusal) {
  std::vector<rp::RunResults> runs;
  const double a[] = {0.010, 0.012, 0.014}, b[] = {-0.020, -0.024};
  for (int i = 0; i < 3; ++i) runs.push_back(unit("Acme", std::to_string(i), "fp1", a[i], 0.001));
  for (int i = 0; i < 2; ++i) runs.push_back(unit("Bor", std::to_string(i), "fp1", b[i], 0.002));
  const rp::Comparison c = rp::compare_runs(runs);
  const auto* p = c.find("temp_poly", "bias_z");
  ASSERT_NE(p, nullptr);
  ASSERT_EQ(p->vendors.size(), 2u);
  EXPECT_NEAR(p->vendors[0].mean, 0.012, 1e-15);
  EXPECT_NEAR(p->vendors[0].spread_sd, 0.002, 1e-15);
  // t(0.975, 2) = 4.302652729911275: interval of the mean = mean ± t·SD/√3.
  EXPECT_NEAR(p->vendors[0].mean_hi - p->vendors[0].mean, 4.302652729911275 * 0.002 / std::sqrt(3.0), 1e-9);
  EXPECT_NEAR(p->vendors[1].mean, -0.022, 1e-15);
  EXPECT_NEAR(p->vendors[1].median_std_error, 0.002, 1e-15);
  const auto* nid = c.find("temp_poly", "cross_zy");
  ASSERT_NE(nid, nullptr);
  EXPECT_EQ(nid->vendors[0].identified, 0);
  EXPECT_TRUE(std::isnan(nid->vendors[0].mean));
  EXPECT_NE(rp::comparison_html(c).find("<svg"), std::string::npos);

  runs.push_back(unit("Corvid", "9", "fp2", 0.0, 0.001));
  try {
    rp::compare_runs(runs);
    FAIL() << "compared runs of different procedures";
  } catch (const rp::ComparisonRefused& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("fp1"), std::string::npos) << m;
    EXPECT_NE(m.find("fp2"), std::string::npos) << m;
    EXPECT_NE(m.find("Corvid-9"), std::string::npos) << m;
    EXPECT_NE(m.find("Acme-0"), std::string::npos) << m;
  }
}

// Three runs of one serial are one unit measured three times, not three units: counted by serial
// in the statistics, the text, the HTML and the JSON; a run without a serial is a unit of its own.
TEST(Compare, CountsDistinctUnitsBySerialAndSaysWhenRunsRepeatOne) {
  std::vector<rp::RunResults> runs;
  for (int i = 0; i < 3; ++i) {
    runs.push_back(unit("Acme", "7", "fp1", 0.010 + 0.001 * i, 0.001));
    runs.back().run_name += "-run" + std::to_string(i);
    runs.back().dir += "-run" + std::to_string(i);
  }
  rp::Comparison c = rp::compare_runs(runs);
  const auto* p = c.find("temp_poly", "bias_z");
  ASSERT_NE(p, nullptr);
  ASSERT_EQ(p->vendors.size(), 1u);
  EXPECT_EQ(p->vendors[0].runs, 3);
  EXPECT_EQ(p->vendors[0].units, 1);
  EXPECT_EQ(p->vendors[0].count_text(), "1 unit (3 runs)");
  const std::string text = rp::comparison_text(c);
  EXPECT_NE(text.find("1 unit (3 runs)"), std::string::npos) << text;
  EXPECT_EQ(text.find("3/3 units"), std::string::npos) << text;
  EXPECT_NE(rp::comparison_html(c).find("<td>1 unit (3 runs)</td>"), std::string::npos);
  const nlohmann::json j = rp::comparison_json(c);
  EXPECT_EQ(j["parameters"][0]["vendors"][0]["units"], 1);
  EXPECT_EQ(j["parameters"][0]["vendors"][0]["runs"], 3);

  runs.push_back(unit("Acme", "8", "fp1", 0.013, 0.001));
  runs.push_back(unit("Acme", "", "fp1", 0.011, 0.001));
  c = rp::compare_runs(runs);
  EXPECT_EQ(c.find("temp_poly", "bias_z")->vendors[0].count_text(), "3 units (5 runs)");
}

TEST(Results, JsonRoundTrip) {
  const rp::RunResults r = unit("Acme", "5", "abcd", 0.5, 0.01);
  const auto j = rp::to_json(r);
  EXPECT_EQ(j["schema"], "stend.results/1");
  EXPECT_TRUE(j["parameters"][1]["value"].is_null());
  const rp::RunResults back = rp::from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(back.serial, "5");
  EXPECT_EQ(back.procedure_fingerprint, "abcd");
  EXPECT_DOUBLE_EQ(back.parameters[0].value, 0.5);
  EXPECT_DOUBLE_EQ(back.parameters[0].hi, 0.52);
  EXPECT_FALSE(back.parameters[1].identifiable);
}

TEST(Results, ParametersOfEachEstimatorDocument) {
  // ceres_nonlinear: flat parameter list, "estimator" as a plain name, top-level confidence.
  const auto ceres = nlohmann::json::parse(R"json({"schema":"stend.ceres_nonlinear.results/1","estimator":"ceres_nonlinear",
    "confidence":0.95,"ok":true,"message":"","parameters":[
    {"name":"accel_bias_x","unit":"m/s^2","value":0.01,"std_error":0.001,"interval":[0.008,0.012],"identifiable":true},
    {"name":"accel_cross_zy","unit":"1","value":null,"std_error":null,"interval":[null,null],"identifiable":false,
     "reason":"fixed by the frame convention"}]})json");
  rp::EstimatorUse use;
  auto ps = rp::parameters_of(ceres, "ceres", stend::estimators::builtin(), &use);
  ASSERT_EQ(ps.size(), 2u);
  EXPECT_EQ(use.name, "ceres_nonlinear");
  EXPECT_EQ(use.status, "ok");
  EXPECT_DOUBLE_EQ(ps[0].confidence, 0.95);
  EXPECT_DOUBLE_EQ(ps[0].hi, 0.012);
  EXPECT_FALSE(ps[1].identifiable);
  EXPECT_TRUE(std::isnan(ps[1].value));
  EXPECT_EQ(ps[1].reason, "fixed by the frame convention");
  // A failed fit contributes no numbers.
  const auto failed = nlohmann::json::parse(
      R"json({"schema":"stend.fit/1","estimator":{"name":"batch_lsq","version":"0.1.0"},"status":"failed","message":"k < p"})json");
  EXPECT_TRUE(rp::parameters_of(failed, "fit", stend::estimators::builtin(), &use).empty());
  EXPECT_EQ(use.status, "failed");
  EXPECT_EQ(use.message, "k < p");
  // Allan: identified coefficients get value ± 1.96 σ; the others only an upper bound.
  const auto allan = nlohmann::json::parse(R"json({"channels":[{"channel":"gz","instrument":"gyroscope","model":{"ok":true,
    "N":{"identified":true,"value":1e-4,"sigma":1e-6,"unit":"rad/s/sqrt(Hz)","upper_bound":2e-4},
    "K":{"identified":false,"value":null,"sigma":null,"unit":"rad/s^2/sqrt(Hz)","upper_bound":3e-6},
    "B":{"identified":false,"value":null,"sigma":null,"unit":"rad/s","upper_bound":null}}}],"kalibr":{}})json");
  ps = rp::parameters_of(allan, "allan", stend::estimators::builtin(), &use);
  ASSERT_EQ(ps.size(), 3u);
  EXPECT_EQ(ps[0].name, "N_gz");
  EXPECT_NEAR(ps[0].hi - ps[0].value, 1.959963984540054e-6, 1e-18);
  EXPECT_FALSE(ps[1].identifiable);
  EXPECT_NE(ps[1].reason.find("upper bound 3e-06"), std::string::npos) << ps[1].reason;
}

// An estimator the program has never heard of reaches the run report through its registry entry
// alone: its own section when it gives one (placed by its topic), else the generic section with the
// parameter table of its summary.
TEST(RunReport, EveryResultsFileIsDrawnByItsRegistryEntry) {
  namespace se = stend::estimation;
  const stend::testing::TempDir d("reporting-toy");
  stend::Recording rec;
  rec.header.experiment_name = "toy run";
  rec.header.status = stend::RunStatus::kComplete;
  rec.header.info.output_rate_hz = 100.0;
  for (int i = 0; i < 200; ++i) {
    stend::ImuSample s;
    s.t_s = 0.01 * i;
    s.accel_mps2 = {0.0, 0.0, 9.81};
    s.temperature_c = 25.0;
    rec.samples.push_back(s);
  }
  stend::write_recording(rec, d / "run", stend::RecordingWriterOptions{stend::RecordingFormat::kCsv});

  se::Registry registry = stend::estimators::builtin();
  se::EstimatorEntry noise;
  noise.name = "toy_noise";
  noise.version = "0.2";
  noise.results_file = "toy_noise.json";
  noise.report = [](const se::FitResult& r) {
    se::ReportSection s;
    s.heading = "Toy noise";
    s.topic = se::ReportSection::Topic::kNoise;
    s.add_text("density " + r.document.value("density", std::string()) + " <per √Hz>");
    return s;
  };
  registry.add(noise);
  se::EstimatorEntry bias;
  bias.name = "toy_bias";
  bias.version = "1.0";
  bias.results_file = "toy_bias.json";
  registry.add(bias);

  se::FitSummary fit;
  fit.estimator = "toy_bias";
  fit.version = "1.0";
  fit.status = se::FitStatus::kOk;
  fit.confidence = 0.95;
  se::ParameterEstimate b;
  b.name = "bias_z";
  b.unit = "m/s^2";
  b.identifiable = true;
  b.value = 0.0981;
  b.std_error = 0.001;
  b.lower = 0.0961;
  b.upper = 0.1001;
  fit.parameters.push_back(b);
  stend::testing::write_text(d / "run/toy_bias.json", se::to_json(fit).dump());
  nlohmann::json noise_doc = se::to_json(fit);
  noise_doc["estimator"] = {{"name", "toy_noise"}, {"version", "0.2"}};
  noise_doc["density"] = "0.004";
  stend::testing::write_text(d / "run/toy_noise.json", noise_doc.dump());

  const std::string html = rp::run_report_html(d / "run", registry);
  const auto bias_at = html.find("<h2>Fit — toy_bias 1.0 <span class=\"file\">(toy_bias.json)</span></h2>");
  const auto noise_at = html.find("<h2>Toy noise <span class=\"file\">(toy_noise.json)</span></h2>");
  ASSERT_NE(bias_at, std::string::npos) << html;
  ASSERT_NE(noise_at, std::string::npos) << html;
  EXPECT_LT(bias_at, noise_at) << "an error model goes before noise, whatever the registry's order";
  EXPECT_NE(html.find("<p>density 0.004 &lt;per √Hz&gt;</p>"), std::string::npos) << "texts are escaped";
  EXPECT_NE(html.find("<table class=\"params\"><tr><th>parameter</th>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>bias_z</td><td>10.0034</td><td>mg</td>"), std::string::npos);
  EXPECT_NE(html.find("toy_bias 1.0 (toy_bias.json, ok)"), std::string::npos) << "listed among the run's estimators";
}

// A gyroscope gap is shown in the diagnosis' own display unit (deg/s), never as mg: the summary,
// the verdict's numbers and every plot's axis.
TEST(GapSection, AGyroscopeGapIsShownInItsOwnUnit) {
  const double dps = 180.0 / M_PI;  // deg/s per rad/s
  const nlohmann::json gap = {
      {"model", "gyro bias"},
      {"form", "axes"},
      {"units", {{"gap", "rad/s"}, {"display", "deg/s"}, {"display_per_unit", dps}}},
      {"noise_floor", {{"static_mean_mps2", {0.001, 0.001, 0.001}}, {"source", "segment scatter"}}},
      {"gap", {{"static_rms_mps2", {0.01, 0.02, 0.03}}, {"static_rms_over_floor", {10, 20, 30}}}},
      {"steps", {{{"step", 0}, {"added", nullptr}, {"heldout_rms_mps2", 0.02}, {"in_sample_rms_mps2", 0.018},
                  {"noise_floor_mps2", 0.001}},
                 {{"step", 1}, {"added", "scale_x"}, {"heldout_rms_mps2", 0.0011}, {"in_sample_rms_mps2", 0.001},
                  {"noise_floor_mps2", 0.001}}}},
      {"unexplained", {{"heldout_rms_mps2", 0.0011}, {"over_floor", 1.1}, {"at_noise_floor", true}, {"statement", "ok"}}}};
  const stend::estimation::ReportSection s = stend::reporting::detail::gap_section(gap, false);
  std::ostringstream text;
  s.print(text);
  EXPECT_NE(text.str().find("Static residual RMS [deg/s]: x 0.573, y 1.15, z 1.72"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("held-out RMS 0.063 deg/s = 1.1 × floor"), std::string::npos) << text.str();
  EXPECT_EQ(text.str().find("mg"), std::string::npos) << text.str();
  std::size_t figures = 0;
  for (const auto& b : s.blocks) {
    if (const auto* f = std::get_if<stend::estimation::Figure>(&b)) {
      EXPECT_EQ(f->plot.y_label, "RMS [deg/s]");
      ++figures;
    }
  }
  EXPECT_EQ(figures, 1u);  // the shrink plot
}
