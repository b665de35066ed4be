// The proof that results are typed end to end: an estimator defined here, in the test — nothing
// of it in app/, reporting/, calibration/ or io/ — joins a copy of the built-in registry, fits a
// recording, is read back from its own results document, exported, applied and reported.
//
// The toy estimator, "mean_bias": the accelerometer bias of a recording held still with z up, the
// mean reading minus gravity along z, each axis with its standard error; its results document has
// its own schema (toy.mean_bias/1) that only its own reader knows.
#include <stend/calibration/calibration.hpp>
#include <stend/estimation/registry.hpp>
#include <stend/estimators/builtin.hpp>
#include <stend/reporting/exports.hpp>
#include <stend/reporting/run_report.hpp>
#include <stend/recording/recording.hpp>
#include <stend/recording/samples.hpp>
#include <stend/testing/files.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

namespace {

using namespace stend;
namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kToy = "mean_bias";
constexpr double kGravity = 9.80665;              // the recording's local gravity [m/s^2]
const Eigen::Vector3d kBias(0.12, -0.05, 0.08);  // planted accelerometer bias [m/s^2]
constexpr double kNoise = 0.02;                  // per-sample noise [m/s^2]

// ---- the toy estimator -----------------------------------------------------------------------

// Its one reader: the summary (three parameters), and a bias-only model of the three axes.
estimation::FitResult read_toy(const json& doc) {
  estimation::FitResult r;
  r.summary.estimator = kToy;
  r.summary.status = doc.value("ok", false) ? estimation::FitStatus::kOk : estimation::FitStatus::kFailed;
  r.summary.confidence = 0.95;
  estimation::InstrumentModel m;
  m.status = r.summary.status;
  m.model.instrument = model::Instrument::kAccelerometer;
  m.model.terms = {{model::TermKind::kBias}};
  m.covariance = Eigen::MatrixXd::Zero(3, 3);
  m.confidence = 0.95;
  for (int k = 0; k < 3; ++k) {
    estimation::ParameterEstimate p;
    p.name = std::string("bias_") + "xyz"[k];
    p.unit = "m/s^2";
    p.identifiable = true;
    p.value = doc.at("bias_mps2").at(static_cast<std::size_t>(k)).get<double>();
    p.std_error = doc.at("std_error_mps2").at(static_cast<std::size_t>(k)).get<double>();
    p.lower = p.value - 1.96 * p.std_error;
    p.upper = p.value + 1.96 * p.std_error;
    m.theta.push_back(p.value);
    m.covariance(k, k) = p.std_error * p.std_error;
    m.parameters.push_back(p);
    r.summary.parameters.push_back(p);
  }
  r.accelerometer = m;
  r.document = doc;
  return r;
}

// Its one writer and its fit: the mean of every sample minus (0, 0, g).
estimation::FitResult fit_toy(const EstimatorRequest& request) {
  const Recording& rec = *request.recording;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  std::uint64_t n = 0;
  for_each_chunk(rec.sample_source(), [&](const ImuSample* c, std::size_t count, std::uint64_t) {
    for (std::size_t i = 0; i < count; ++i) {
      sum += c[i].accel_mps2;
      sum2 += c[i].accel_mps2.cwiseAbs2();
    }
    n += count;
  });
  const Eigen::Vector3d mean = sum / static_cast<double>(n);
  const Eigen::Vector3d sd = ((sum2 / static_cast<double>(n) - mean.cwiseAbs2()) * (static_cast<double>(n) / (n - 1.0))).cwiseSqrt();
  const Eigen::Vector3d bias = mean - Eigen::Vector3d(0.0, 0.0, rec.header.gravity_mps2);
  const Eigen::Vector3d se = sd / std::sqrt(static_cast<double>(n));
  const json doc = {{"schema", "toy.mean_bias/1"},
                    {"estimator", {{"name", kToy}, {"version", "0.0.1"}}},
                    {"ok", true},
                    {"samples", n},
                    {"bias_mps2", {bias[0], bias[1], bias[2]}},
                    {"std_error_mps2", {se[0], se[1], se[2]}}};
  estimation::FitResult r = read_toy(doc);
  r.text = "mean_bias: " + std::to_string(n) + " samples\n";
  r.document_text = doc.dump(2);
  return r;
}

estimation::EstimatorEntry toy_entry() {
  estimation::EstimatorEntry e;
  e.name = kToy;
  e.version = "0.0.1";
  e.description = "Test estimator: the accelerometer bias of a still recording, z up";
  e.results_file = "mean_bias.json";
  e.claims = [](const YAML::Node& root) { return root.IsMap() && root["mean_bias"]; };
  e.fit = fit_toy;
  e.read = read_toy;
  e.reads_truth = false;
  return e;
}

// ---- the recording ----------------------------------------------------------------------------

// A still recording, z up, with the planted bias and white noise: 100 s at 100 Hz.
void write_still_run(const fs::path& dir) {
  RecordingHeader h;
  h.experiment_name = "still";
  h.gravity_mps2 = kGravity;
  h.info.output_rate_hz = 100.0;
  h.info.has_gyro = true;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01(0.0, 1.0);
  RecordingWriter w(dir, h, "name: still\n");
  std::vector<ImuSample> samples(10000);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    ImuSample& s = samples[i];
    s.t_s = 0.01 * static_cast<double>(i);
    s.accel_mps2 = Eigen::Vector3d(0.0, 0.0, kGravity) + kBias + kNoise * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    s.gyro_radps = Eigen::Vector3d::Zero();
    s.temperature_c = 25.0;
  }
  w.add_samples(samples.data(), samples.size());
  w.finish(RunStatus::kComplete);
}

json read_json(const fs::path& f) {
  std::ifstream in(f);
  return json::parse(in);
}

}  // namespace

TEST(ToyEstimator, FitsIsReadBackExportedAndAppliedThroughTheRegistryAlone) {
  const stend::testing::TempDir tmp("toy-estimator");
  const fs::path run = tmp / "run";
  write_still_run(run);
  estimation::Registry registry = estimators::builtin();
  registry.add(toy_entry());

  // Fit through the registry entry, as `stend fit` does, and write the document into the run.
  stend::testing::write_text(tmp / "model.yaml", "mean_bias: {}\n");
  const estimation::EstimatorEntry& entry =
      registry.for_model(YAML::LoadFile((tmp / "model.yaml").string()), (tmp / "model.yaml").string());
  ASSERT_EQ(entry.name, kToy);
  const Recording rec = Recording::open(run, SampleLoading::kStream, TruthLoading::kSkip);
  EstimatorRequest request;
  request.recording = &rec;
  request.input = run.string();
  request.model_file = (tmp / "model.yaml").string();
  request.output_dir = run.string();
  const estimation::FitResult fitted = estimation::fit(entry, request);
  ASSERT_TRUE(fitted.ok()) << fitted.FullReport();
  EXPECT_EQ(fitted.results_file, "mean_bias.json");
  stend::testing::write_text(run / fitted.results_file, fitted.written_document() + "\n");
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(fitted.accelerometer->theta[static_cast<std::size_t>(k)], kBias[k], 5 * kNoise / 100.0);

  // Read back: its own reader, found by the document's estimator name.
  const estimation::FitResult back = registry.read(read_json(run / "mean_bias.json"), "mean_bias.json");
  EXPECT_TRUE(back.equals(fitted)) << back.FullReport() << "\n" << fitted.FullReport();

  // Exported: the model of the three axes is the run's only accelerometer calibration.
  const reporting::ExportResult imutk = reporting::export_run(run, "imutk", tmp / "imutk", registry);
  ASSERT_EQ(imutk.files.size(), 1u);  // no gyroscope calibration
  std::ifstream acc(tmp / "imutk_acc.calib");
  double v[21];
  for (double& x : v) ASSERT_TRUE(acc >> x);
  for (int k = 0; k < 3; ++k) EXPECT_DOUBLE_EQ(v[18 + k], fitted.accelerometer->theta[static_cast<std::size_t>(k)]);
  std::string notes;
  for (const auto& n : imutk.notes) notes += n + "\n";
  EXPECT_NE(notes.find("accelerometer calibration from mean_bias.json (--from auto)"), std::string::npos) << notes;
  const reporting::ExportResult named = reporting::export_run(run, "px4", tmp / "px4.params", registry,
                                                              reporting::ExportOptions{.from = kToy});
  EXPECT_NE(stend::testing::read_text(tmp / "px4.params").find("CAL_ACC0_XOFF"), std::string::npos);
  ASSERT_FALSE(named.notes.empty());
  EXPECT_EQ(named.notes.front(), "accelerometer calibration from mean_bias.json (--from mean_bias)");
  EXPECT_THROW(reporting::export_run(run, "imutk", tmp / "x", registry, reporting::ExportOptions{.from = "batch_lsq"}),
               InputError);

  // Applied: the calibrated still recording reads gravity along z, within the noise of its mean.
  const calibration::Calibration cal = calibration::load_calibration(run / "mean_bias.json", registry);
  EXPECT_EQ(cal.estimator, kToy);
  ASSERT_TRUE(cal.accel.present());
  EXPECT_FALSE(cal.gyro.present());
  EXPECT_TRUE(cal.notes.empty());
  const Recording calibrated = calibration::apply_calibration(rec, cal);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for_each_chunk(calibrated.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t) {
    for (std::size_t i = 0; i < n; ++i) mean += c[i].accel_mps2;
  });
  mean /= static_cast<double>(calibrated.sample_count());
  EXPECT_LT((mean - Eigen::Vector3d(0.0, 0.0, kGravity)).norm(), 1e-9);

  // The run report: without a `report` hook the entry gets the generic section (its parameter
  // table, read back through its reader); with one, its own section, placed by its topic.
  const std::string generic = reporting::run_report_html(run, registry);
  EXPECT_NE(generic.find("mean_bias"), std::string::npos);
  EXPECT_NE(generic.find("bias_x"), std::string::npos);
  EXPECT_NE(generic.find("bias_z"), std::string::npos);
  estimation::Registry with_section = estimators::builtin();
  estimation::EstimatorEntry hooked = toy_entry();
  hooked.report = [](const estimation::FitResult& r) {
    estimation::ReportSection s;
    s.heading = "Mean bias — the toy estimator";
    s.add_text("z bias " + estimation::report_number(r.accelerometer->theta[2] / 9.80665e-3, 3) + " mg from " +
               std::to_string(r.document.at("samples").get<int>()) + " samples");
    return s;
  };
  with_section.add(hooked);
  const std::string own = reporting::run_report_html(run, with_section);
  EXPECT_NE(own.find("Mean bias — the toy estimator"), std::string::npos);
  EXPECT_NE(own.find("from 10000 samples"), std::string::npos);
}
