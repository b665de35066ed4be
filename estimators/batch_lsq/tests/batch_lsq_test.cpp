// batch_lsq: model spec parsing, the procedure on synthetic recordings (in memory and through
// the recording files), identifiability in the results, refusals, reports.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <sstream>

#include "stend/batch_lsq/batch_lsq.hpp"
#include "stend/core/experiment.hpp"
#include "stend/physics/geometry.hpp"
#include "stend/testing/files.hpp"

using namespace stend;
using namespace stend::batch_lsq;
namespace fs = std::filesystem;

namespace {

const char* kSpec = R"(instrument: accelerometer
axes: [x, y, z]
terms:
  - bias
  - scale
  - cross_axis: {}
extraction: {filter_order: 6, cutoff_hz: 0.5, settle_s: 2.0}
)";

std::string parse_error(const std::string& yaml) {
  try {
    estimation::parse_model_spec(yaml, "spec.yaml");
  } catch (const ExperimentError& e) {
    return e.what();
  }
  return "";
}

// Orientations through the paper's turntable: several tilts h and rotations δ.
std::vector<Eigen::Vector3d> table_forces(double g) {
  std::vector<Eigen::Vector3d> f;
  for (double h : {0.0, 50.0, -60.0})
    for (double d : {0.0, 90.0, 180.0, 270.0})
      f.push_back(physics::paper_table(h * physics::kDegToRad, d * physics::kDegToRad) *
                  Eigen::Vector3d(0, 0, g));
  return f;
}

struct SynthOptions {
  double fs = 100.0;
  double dwell_s = 12.0;
  double noise = 0.02;       // per-sample white noise [m/s²]
  double vibration = 0.05;   // 17 Hz vibration amplitude [m/s²]
  double die_c = 25.0;
};

// An in-memory recording: each orientation a segment of kind "orientation" preceded by a 3 s
// "wait" (table moving); truth snapshots at 10 Hz.
Recording synth_recording(const model::ErrorModel& m, const Eigen::VectorXd& theta,
                          const std::vector<Eigen::Vector3d>& forces, std::mt19937& rng,
                          const SynthOptions& o = {}) {
  std::normal_distribution<double> n(0.0, 1.0);
  Recording rec;
  rec.dir = "memory://synthetic";
  rec.header.status = stend::RunStatus::kComplete;
  rec.header.experiment_name = "synthetic";
  rec.header.gravity_mps2 = 9.80665;
  rec.header.truth_columns = {"f_x_mps2", "f_y_mps2", "f_z_mps2", "w_x_radps", "w_y_radps",
                              "w_z_radps", "air_c", "die_c", "table.angle.cmd_deg"};
  double t = 0.0;
  int id = 0;
  for (std::size_t k = 0; k < forces.size(); ++k) {
    Segment wait;
    wait.id = id++;
    wait.kind = stend::SegmentKind::kWait;
    wait.t_start_s = t;
    t += 3.0;
    wait.t_end_s = t;
    rec.segments.push_back(wait);
    Segment s;
    s.id = id++;
    s.kind = stend::SegmentKind::kOrientation;
    s.orientation = static_cast<int>(k);
    s.orientation_count = static_cast<int>(forces.size());
    s.t_start_s = t;
    const double t_end = t + o.dwell_s;
    model::Stimulus<double> st;
    st.input = st.specific_force = forces[k];
    st.temperature_c = o.die_c;
    const Eigen::Vector3d y = m.measure<double>(theta.data(), st);
    for (; t < t_end; t += 1.0 / o.fs) {
      ImuSample smp;
      smp.t_s = t;
      for (int a = 0; a < 3; ++a)
        smp.accel_mps2[a] = y[a] + o.noise * n(rng) + o.vibration * std::sin(2 * std::numbers::pi * 17.0 * t + a);
      smp.temperature_c = o.die_c + 0.1;
      rec.samples.push_back(smp);
    }
    s.t_end_s = t;
    rec.segments.push_back(s);
    for (double tt = s.t_start_s; tt <= s.t_end_s; tt += 0.1)
    {
      rec.truth_t.push_back(tt);
      rec.truth.push_back({forces[k][0], forces[k][1], forces[k][2], 0, 0, 0, 25.0, o.die_c,
                           static_cast<double>(k)});
    }
  }
  return rec;
}

model::ErrorModel bsc_model() {
  model::ErrorModel m;
  m.terms = {{model::TermKind::kBias}, {model::TermKind::kScale}, {model::TermKind::kCrossAxis}};
  return m;
}

Eigen::VectorXd theta_bsc() {
  Eigen::VectorXd th(12);
  th << 0.12, -0.08, 0.31,        // bias
      0.004, -0.0025, 0.0097,     // scale
      0.001, -0.002, 0.0015, 0.0005, -0.0055, 0.0008;  // cross xy xz yx yz zx zy
  return th;
}

}  // namespace

TEST(ModelSpec, ParsesTheDocumentedForm) {
  const ModelSpec s = estimation::parse_model_spec(R"(instrument: accelerometer
axes: [z]
terms: [bias, scale, {cross_axis: {}}, {bias_temperature: {order: 2, reference_c: 30}}]
extraction: {filter_order: 6, cutoff_hz: 0.25, settle_s: 4, zero_phase: false}
segments: [orientation, record]
weighting: segment_noise
confidence: 0.9
)",
                                       "m.yaml");
  EXPECT_EQ(s.model.instrument, model::Instrument::kAccelerometer);
  EXPECT_EQ(s.axes, std::vector<int>{2});
  ASSERT_EQ(s.model.terms.size(), 4u);
  EXPECT_EQ(s.model.terms[3].kind, model::TermKind::kBiasTemperature);
  EXPECT_EQ(s.model.terms[3].order, 2);
  EXPECT_EQ(s.model.terms[3].reference_c, 30.0);
  EXPECT_EQ(s.processing.extraction.cutoff_hz, 0.25);
  EXPECT_EQ(s.processing.extraction.settle_s, 4.0);
  EXPECT_FALSE(s.processing.extraction.zero_phase);
  EXPECT_EQ(s.processing.segment_kinds, (std::vector<std::string>{"orientation", "record"}));
  EXPECT_EQ(s.weighting, estimation::Weighting::kSegmentNoise);
  EXPECT_EQ(s.confidence, 0.9);
  // Round trip.
  const ModelSpec r = estimation::parse_model_spec(to_yaml(s), "again.yaml");
  EXPECT_EQ(to_yaml(r), to_yaml(s));
  EXPECT_EQ(r.model.size(), s.model.size());
}

TEST(ModelSpec, ExampleFileParses) {
  const ModelSpec s = estimation::load_model_spec(fs::path(STEND_SOURCE_DIR) / "estimators/batch_lsq/examples/paper_z_channel.yaml");
  EXPECT_EQ(s.axes, std::vector<int>{2});
  EXPECT_EQ(s.processing.extraction.filter_order, 6);
  const ModelSpec t = estimation::load_model_spec(fs::path(STEND_SOURCE_DIR) / "estimators/batch_lsq/examples/accelerometer_full.yaml");
  EXPECT_EQ(t.axes.size(), 3u);
}

TEST(ModelSpec, ErrorsNameFileLineAndColumn) {
  std::string e = parse_error("instrument: accelerometer\naxes: [z]\nterms:\n  - bias\n  - scael\n");
  EXPECT_NE(e.find("spec.yaml:5:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown error-model term 'scael'"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'scale'"), std::string::npos) << e;

  e = parse_error("instrument: accelerometer\naxes: [z, w]\nterms: [bias]\n");
  EXPECT_NE(e.find("spec.yaml:2:11:"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown axis 'w'"), std::string::npos) << e;

  e = parse_error("instrument: accelerometer\nterms: [bias, g_sensitivity]\n");
  EXPECT_NE(e.find("spec.yaml:2:15:"), std::string::npos) << e;
  EXPECT_NE(e.find("gyroscopes only"), std::string::npos) << e;

  e = parse_error("instrument: accelerometer\nterms:\n  - bias_temperature: {order: 0}\n");
  EXPECT_NE(e.find("spec.yaml:3:31:"), std::string::npos) << e;

  e = parse_error("instrument: accelerometer\nterms: [bias]\nextraction: {cutof_hz: 1}\n");
  EXPECT_NE(e.find("spec.yaml:3:14:"), std::string::npos) << e;
  EXPECT_NE(e.find("cutoff_hz"), std::string::npos) << e;

  e = parse_error("instrument: acelerometer\nterms: [bias]\n");
  EXPECT_NE(e.find("spec.yaml:1:13:"), std::string::npos) << e;

  e = parse_error("instrument: accelerometer\nterms: [bias, bias]\n");
  EXPECT_NE(e.find("given twice"), std::string::npos) << e;

  e = parse_error("instrument: accelerometer\nterms: [bias\n");
  EXPECT_NE(e.find("spec.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("YAML syntax error"), std::string::npos) << e;

  e = parse_error("instrument: accelerometer\n");
  EXPECT_NE(e.find("missing required key 'terms'"), std::string::npos) << e;
}

TEST(BatchLsq, TheExperimentsProcessingSectionFillsWhatTheModelDoesNotState) {
  std::mt19937 rng(7);
  Recording rec = synth_recording(bsc_model(), theta_bsc(), table_forces(9.81), rng);
  rec.experiment_yaml = "name: synthetic\nprocessing:\n  extraction: {settle_s: 3, cutoff_hz: 0.25}\n";
  // kSpec states cutoff_hz 0.5 and settle_s 2: both win.
  FitResult fr = fit_recording(rec, estimation::parse_model_spec(kSpec));
  ASSERT_TRUE(fr.ok()) << fr.message;
  EXPECT_EQ(fr.spec.processing.extraction.settle_s, 2.0);
  EXPECT_EQ(fr.spec.processing.extraction.cutoff_hz, 0.5);
  // A spec that states neither: the experiment's settle_s (3 s at each end of a 12 s dwell).
  fr = fit_recording(rec, estimation::parse_model_spec("instrument: accelerometer\nterms: [bias, scale, cross_axis]\n"));
  ASSERT_TRUE(fr.ok()) << fr.message;
  EXPECT_EQ(fr.spec.processing.extraction.settle_s, 3.0);
  EXPECT_EQ(fr.spec.processing.extraction.cutoff_hz, 0.25);
  EXPECT_NEAR(fr.points[0].t_end_s - fr.points[0].t_start_s, 12.0 - 6.0, 0.02);
  EXPECT_EQ(nlohmann::json::parse(to_json(fr))["extraction"]["settle_s"], 3.0);
  // A bad key there fails the fit, naming the run's experiment.yaml.
  rec.experiment_yaml = "processing:\n  extraction: {settle: 3}\n";
  fr = fit_recording(rec, estimation::parse_model_spec(kSpec));
  EXPECT_FALSE(fr.ok());
  EXPECT_NE(fr.message.find("experiment.yaml:2:"), std::string::npos) << fr.message;
}

TEST(BatchLsq, FitsAnInMemoryRecording) {
  std::mt19937 rng(42);
  const model::ErrorModel m = bsc_model();
  const Eigen::VectorXd th = theta_bsc();
  Recording rec = synth_recording(m, th, table_forces(9.81), rng);
  // One more orientation segment the table never settled in: it must be skipped.
  Segment bad = rec.segments.back();
  bad.id = 999;
  bad.settled = false;
  rec.segments.push_back(bad);
  const ModelSpec spec = estimation::parse_model_spec(kSpec, "spec.yaml");
  const FitResult fr = fit_recording(rec, spec);
  ASSERT_TRUE(fr.ok()) << fr.message;
  EXPECT_EQ(fr.points.size(), 12u);
  EXPECT_EQ(fr.lsq.observations, 36);
  EXPECT_EQ(fr.lsq.rank, 12);
  bool skipped = false;
  for (const auto& n : fr.notes) skipped = skipped || n.find("segment 999") != std::string::npos;
  EXPECT_TRUE(skipped);
  for (int j = 0; j < 12; ++j) {
    const auto& e = fr.lsq.parameters[static_cast<std::size_t>(j)];
    EXPECT_TRUE(e.identifiable) << e.name;
    EXPECT_LT(std::abs(e.value - th[j]), 5 * e.std_error + 1e-9) << e.name;
  }
  // Each mean averages ~800 samples of 0.02 noise: residual RMS ≈ 1 mg or less.
  for (int a = 0; a < 3; ++a) {
    EXPECT_LT(fr.residual_rms[a], 0.003);
    EXPECT_NEAR(fr.residual_rms_display[a], fr.residual_rms[a] / 9.80665 * 1e3, 1e-12);
  }
  // Kept window excludes settle_s at each end.
  EXPECT_NEAR(fr.points[0].t_end_s - fr.points[0].t_start_s, 12.0 - 4.0, 0.02);

  // Reports.
  std::ostringstream os;
  print_table(os, fr);
  EXPECT_NE(os.str().find("Butterworth order 6, cutoff 0.5 Hz"), std::string::npos) << os.str();
  EXPECT_NE(os.str().find("residual RMS"), std::string::npos);
  const auto j = nlohmann::json::parse(to_json(fr));
  EXPECT_EQ(j["schema"], "stend.fit/1");
  EXPECT_EQ(j["status"], "ok");
  EXPECT_EQ(j["parameters"].size(), 12u);
  EXPECT_EQ(j["parameters"][2]["name"], "bias_z");
  EXPECT_NEAR(j["parameters"][2]["value"].get<double>(), fr.lsq.estimate[2], 0);
  EXPECT_EQ(j["solution"]["rank"], 12);
  EXPECT_EQ(j["points"].size(), 12u);
}

TEST(BatchLsq, RecordingWithoutTruthColumnsFailsLoudly) {
  std::mt19937 rng(1);
  Recording rec = synth_recording(bsc_model(), theta_bsc(), table_forces(9.81), rng);
  rec.header.truth_columns[1] = "force_y";
  const FitResult fr = fit_recording(rec, estimation::parse_model_spec(kSpec));
  EXPECT_FALSE(fr.ok());
  EXPECT_NE(fr.message.find("f_y_mps2"), std::string::npos) << fr.message;
  EXPECT_NE(fr.message.find("force_y"), std::string::npos) << fr.message;
  std::ostringstream os;
  print_table(os, fr);
  EXPECT_NE(os.str().find("FIT FAILED"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(to_json(fr))["status"], "failed");
  EXPECT_FALSE(nlohmann::json::parse(to_json(fr)).contains("parameters"));
}

TEST(BatchLsq, RotationAboutOneAxisLeavesCrossZyUnidentifiable) {
  // The paper's Table 2 geometry with h = 0: f_y ≡ 0.
  std::vector<processing::StaticPoint> pts;
  const model::ErrorModel m = bsc_model();
  const Eigen::VectorXd th = theta_bsc();
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 0.0005);
  for (double d = 0; d <= 44; d += 2) {
    processing::StaticPoint p;
    p.stimulus.input = p.stimulus.specific_force =
        physics::paper_table(0.0, d * physics::kDegToRad) * Eigen::Vector3d(0, 0, 9.81);
    p.accel.mean = m.measure<double>(th.data(), p.stimulus) + Eigen::Vector3d(n(rng), n(rng), n(rng));
    p.segment.label = std::to_string(d);
    pts.push_back(p);
  }
  ModelSpec spec = estimation::parse_model_spec("instrument: accelerometer\naxes: [z]\nterms: [bias, scale, cross_axis]\n");
  const FitResult fr = fit_points(pts, spec);
  ASSERT_TRUE(fr.ok()) << fr.message;
  ASSERT_EQ(fr.params.size(), 4u);  // bias_z scale_z cross_zx cross_zy; x/y-row parameters excluded
  EXPECT_EQ(fr.excluded.size(), 8u);
  const auto& zy = fr.lsq.parameter("cross_zy");
  EXPECT_FALSE(zy.identifiable);
  EXPECT_TRUE(std::isnan(zy.value));
  EXPECT_TRUE(std::isnan(fr.theta_full()[11]));
  EXPECT_TRUE(fr.lsq.parameter("cross_zx").identifiable);
  EXPECT_LT(std::abs(fr.lsq.parameter("cross_zx").value - th[10]), 5 * fr.lsq.parameter("cross_zx").std_error);
  const auto j = nlohmann::json::parse(to_json(fr));
  bool found = false;
  for (const auto& p : j["parameters"])
    if (p["name"] == "cross_zy") {
      found = true;
      EXPECT_TRUE(p["value"].is_null());
      EXPECT_TRUE(p["std_error"].is_null());
      EXPECT_FALSE(p["identifiable"].get<bool>());
      EXPECT_NE(p["reason"].get<std::string>().find("not excited"), std::string::npos);
    }
  EXPECT_TRUE(found);
  std::ostringstream os;
  print_table(os, fr);
  const std::string text = os.str();
  const auto at = text.find("\ncross_zy");
  ASSERT_NE(at, std::string::npos) << text;
  const std::string line = text.substr(at + 1, text.find('\n', at + 1) - at - 1);
  EXPECT_FALSE(std::regex_search(line, std::regex("[0-9]\\.[0-9]|[0-9]e[-+]"))) << line;
}

TEST(BatchLsq, BiasAndBiasTemperatureAtOneTemperatureAreAliased) {
  std::mt19937 rng(9);
  model::ErrorModel m = bsc_model();
  m.terms.push_back({model::TermKind::kBiasTemperature, 1, 25.0});
  Eigen::VectorXd th(15);
  th << theta_bsc(), 0.002, -0.001, 0.003;
  SynthOptions o;
  o.die_c = 40.0;
  const Recording rec = synth_recording(m, th, table_forces(9.81), rng, o);
  ModelSpec spec = estimation::parse_model_spec(
      "instrument: accelerometer\naxes: [z]\nterms: [bias, scale, cross_axis, "
      "{bias_temperature: {order: 1, reference_c: 25}}]\nextraction: {cutoff_hz: 0.5, settle_s: 2}\n");
  const FitResult fr = fit_recording(rec, spec);
  ASSERT_TRUE(fr.ok()) << fr.message;
  ASSERT_EQ(fr.lsq.aliases.size(), 1u);
  const auto& g = fr.lsq.aliases[0];
  ASSERT_EQ(g.identified.size(), 1u);
  EXPECT_EQ(g.identified[0].text, "bias_z + 15*bias_tc1_z");
  EXPECT_LT(std::abs(g.identified[0].value - (th[2] + 15 * th[14])), 5 * g.identified[0].std_error);
  EXPECT_FALSE(fr.lsq.parameter("bias_z").identifiable);
  EXPECT_FALSE(fr.lsq.parameter("bias_tc1_z").identifiable);
  const auto j = nlohmann::json::parse(to_json(fr));
  ASSERT_EQ(j["aliases"].size(), 1u);
  EXPECT_NEAR(j["aliases"][0]["identified_combinations"][0]["coefficients"]["bias_tc1_z"].get<double>(),
              15.0, 1e-12);
}

TEST(BatchLsq, SegmentNoiseWeighting) {
  std::mt19937 rng(21);
  const Recording rec = synth_recording(bsc_model(), theta_bsc(), table_forces(9.81), rng);
  ModelSpec spec = estimation::parse_model_spec(kSpec);
  const FitResult plain = fit_recording(rec, spec);
  spec.weighting = estimation::Weighting::kSegmentNoise;
  const FitResult weighted = fit_recording(rec, spec);
  ASSERT_TRUE(plain.ok() && weighted.ok()) << weighted.message;
  // Equal noise everywhere: the weights are nearly uniform, so the estimates barely move.
  for (int j = 0; j < 12; ++j)
    EXPECT_NEAR(weighted.lsq.estimate[j], plain.lsq.estimate[j], 0.2 * plain.lsq.parameters[static_cast<std::size_t>(j)].std_error);
  EXPECT_EQ(nlohmann::json::parse(to_json(weighted))["weighting"], "segment_noise");
  // Points without a noise estimate cannot be weighted: refused with a reason.
  std::vector<processing::StaticPoint> pts = weighted.points;
  pts[3].accel.std_error[1] = std::numeric_limits<double>::quiet_NaN();
  const FitResult bad = fit_points(pts, spec);
  EXPECT_FALSE(bad.ok());
  EXPECT_NE(bad.message.find("segment_noise"), std::string::npos) << bad.message;
  std::ostringstream os;
  os << bad;
  EXPECT_NE(os.str().find("FIT FAILED"), std::string::npos);
}

TEST(BatchLsq, RefusesTooFewOrientations) {
  std::mt19937 rng(2);
  const std::vector<Eigen::Vector3d> two = {Eigen::Vector3d(0, 0, 9.81), Eigen::Vector3d(0, 0, -9.81)};
  const Recording rec = synth_recording(bsc_model(), theta_bsc(), two, rng);
  const FitResult fr = fit_recording(rec, estimation::parse_model_spec(kSpec));  // k = 6 < p = 12
  EXPECT_FALSE(fr.ok());
  EXPECT_NE(fr.message.find("underdetermined"), std::string::npos) << fr.message;
  std::ostringstream os;
  print_table(os, fr);
  EXPECT_NE(os.str().find("FIT FAILED: underdetermined"), std::string::npos);
  EXPECT_EQ(os.str().find("bias_x "), std::string::npos) << os.str();
}

// Interval coverage through the whole procedure (samples → Butterworth extraction → LSQ) over 600
// synthetic recordings with known truth: 90–98% for every parameter.
TEST(BatchLsq, IntervalCoverageThroughTheProcedure) {
  const model::ErrorModel m = bsc_model();
  const ModelSpec spec = estimation::parse_model_spec(kSpec);
  const auto forces = table_forces(9.80665);
  SynthOptions o;
  o.dwell_s = 8.0;
  o.noise = 0.05;
  const int seeds = 600;
  std::vector<int> inside(12, 0);
  for (int seed = 0; seed < seeds; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(7000 + seed));
    std::normal_distribution<double> n(0.0, 1.0);
    Eigen::VectorXd th(12);
    for (int i = 0; i < 12; ++i) th[i] = (i < 3 ? 0.1 : 0.005) * n(rng);
    const FitResult fr = fit_recording(synth_recording(m, th, forces, rng, o), spec);
    ASSERT_TRUE(fr.ok()) << fr.message;
    for (int i = 0; i < 12; ++i) {
      const auto& e = fr.lsq.parameters[static_cast<std::size_t>(i)];
      if (th[i] >= e.lower && th[i] <= e.upper) ++inside[static_cast<std::size_t>(i)];
    }
  }
  for (int i = 0; i < 12; ++i) {
    const double c = inside[static_cast<std::size_t>(i)] / static_cast<double>(seeds);
    std::printf("procedure coverage %-9s %.3f\n", m.params()[static_cast<std::size_t>(i)].name.c_str(), c);
    EXPECT_GE(c, 0.90);
    EXPECT_LE(c, 0.98);
  }
}

// The same procedure through real run folders: RecordingWriter → Recording::open → fit.
TEST(BatchLsq, FitsARecordingReadFromDisk) {
  std::mt19937 rng(77);
  const Recording mem = synth_recording(bsc_model(), theta_bsc(), table_forces(9.81), rng);
  const stend::testing::TempDir tmp("batch-lsq");
  const fs::path dir = tmp / "run";
  {
    RecordingWriter w(dir, mem.header, "experiment: synthetic\n");
    w.add_samples(mem.samples.data(), mem.samples.size());
    for (std::size_t r = 0; r < mem.truth.size(); ++r) w.add_truth(mem.truth_t[r], mem.truth[r]);
    for (const auto& s : mem.segments) w.add_segment(s);
    w.finish(stend::RunStatus::kComplete);
  }
  const Recording rec = Recording::open(dir);
  ASSERT_EQ(rec.samples.size(), mem.samples.size());
  const ModelSpec spec = estimation::parse_model_spec(kSpec);
  const FitResult a = fit_recording(mem, spec);
  const FitResult b = fit_recording(rec, spec);
  ASSERT_TRUE(b.ok()) << b.message;
  EXPECT_EQ(b.points.size(), 12u);
  // The files carry the same numbers (to their text precision).
  EXPECT_TRUE(estimation::approx_equal(a.lsq, b.lsq, 1e-4, 1e-7));
  write_json(dir / "fit.json", b);
  std::ifstream in(dir / "fit.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["recording"]["status"], "complete");
}
