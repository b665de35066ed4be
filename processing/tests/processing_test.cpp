// The processing stage: options (ranges, YAML keys, the experiment's section as fallback), truth
// means, the sliding-variance detector, and Recording → static points with its skip rules.
#include <gtest/gtest.h>
#include <stend/testing/files.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <string>

#include "stend/processing/options.hpp"
#include "stend/processing/static_detector.hpp"
#include "stend/processing/static_points.hpp"
#include "stend/processing/truth.hpp"

using namespace stend;
using namespace stend::processing;

namespace {

constexpr double kRateHz = 100.0;

// 100 Hz samples over [t0, t1): accelerometer `f` [m/s^2] plus white noise of `sigma`, gyro 0,
// sensor temperature 30 degC.
void add_samples(Recording& rec, double t0, double t1, const Eigen::Vector3d& f, double sigma,
                 std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, sigma);
  const auto count = static_cast<int>(std::lround((t1 - t0) * kRateHz));
  for (int i = 0; i < count; ++i) {
    ImuSample s;
    s.t_s = t0 + i / kRateHz;
    s.accel_mps2 = f + Eigen::Vector3d(n(rng), n(rng), n(rng));
    s.gyro_radps.setZero();
    s.temperature_c = 30.0;
    rec.samples.push_back(s);
  }
}

// A recording of still poses of 10 s, each a segment of kind orientation, with truth snapshots
// (f_x_mps2, f_y_mps2, f_z_mps2, die_c) at 10 Hz; die_c ramps 20 → 21 degC over each pose.
Recording poses(const std::vector<Eigen::Vector3d>& forces, double sigma = 0.01) {
  Recording rec;
  rec.header.truth_columns = {"f_x_mps2", "f_y_mps2", "f_z_mps2", "die_c"};
  std::mt19937_64 rng(4);
  double t = 0.0;
  for (std::size_t k = 0; k < forces.size(); ++k, t += 10.0) {
    add_samples(rec, t, t + 10.0, forces[k], sigma, rng);
    for (int j = 0; j < 100; ++j) {
      const double tt = t + 0.1 * j;
      rec.truth_t.push_back(tt);
      rec.truth.push_back({forces[k][0], forces[k][1], forces[k][2], 20.0 + 0.1 * (tt - t)});
    }
    Segment s;
    s.id = static_cast<int>(k);
    s.kind = stend::SegmentKind::kOrientation;
    s.orientation = static_cast<int>(k);
    s.orientation_count = static_cast<int>(forces.size());
    s.t_start_s = t;
    s.t_end_s = t + 10.0 - 1.0 / kRateHz;
    rec.segments.push_back(s);
  }
  return rec;
}

const std::vector<Eigen::Vector3d> kSix = {{0, 0, 9.8}, {0, 0, -9.8}, {9.8, 0, 0},
                                           {-9.8, 0, 0}, {0, 9.8, 0}, {0, -9.8, 0}};

Request accel_with_force() {
  Request r;
  r.gyro = false;
  r.truth_columns = {"f_x_mps2", "f_y_mps2", "f_z_mps2"};
  return r;
}

ProcessingOptions from_yaml(const std::string& text, const std::set<std::string>& keep = {}) {
  ProcessingOptions o;
  read_options(yaml::MapReader(YAML::Load(text), "p.yaml", "", "processing", kOptionKeys), o, keep);
  return o;
}

std::string yaml_error(const std::string& text) {
  try {
    from_yaml(text);
  } catch (const ExperimentError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Options

TEST(ProcessingOptions, DefaultsAreValidAndRangesNameTheKey) {
  ProcessingOptions o;
  EXPECT_TRUE(o.IsValid());
  EXPECT_EQ(o.intervals, IntervalSource::kAuto);
  o.extraction.cutoff_hz = -1.0;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("extraction.cutoff_hz"), std::string::npos) << why;
  o = ProcessingOptions{};
  o.extraction.filter = Filter::kNone;
  o.extraction.cutoff_hz = -1.0;  // no filter: the cutoff is not used
  EXPECT_TRUE(o.IsValid());
  o.segment_kinds = {"orientaton"};
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("segments"), std::string::npos) << why;
}

TEST(ProcessingOptions, ReadsTheKeysGivenAndRecordsThem) {
  const ProcessingOptions o = from_yaml(
      "intervals: detect\nsegments: [orientation, rate]\n"
      "extraction: {filter: none, settle_s: 0.5}\ndetector: {window_s: 0.5, max_gyro_dps: 3}\n");
  EXPECT_EQ(o.intervals, IntervalSource::kDetect);
  EXPECT_EQ(o.segment_kinds, (std::vector<std::string>{"orientation", "rate"}));
  EXPECT_EQ(o.extraction.filter, Filter::kNone);
  EXPECT_EQ(o.extraction.settle_s, 0.5);
  EXPECT_EQ(o.extraction.cutoff_hz, 1.0);  // default kept
  EXPECT_EQ(o.detector.window_s, 0.5);
  EXPECT_NEAR(o.detector.max_gyro_radps, 3.0 * M_PI / 180.0, 1e-15);
  EXPECT_EQ(o.stated, (std::set<std::string>{"intervals", "segments", "extraction.filter", "extraction.settle_s",
                                             "detector.window_s", "detector.max_gyro_dps"}));
  // `keep`: those keys are left alone.
  const ProcessingOptions k = from_yaml("extraction: {settle_s: 0.5, cutoff_hz: 2}\n", {"extraction.settle_s"});
  EXPECT_EQ(k.extraction.settle_s, 2.0);
  EXPECT_EQ(k.extraction.cutoff_hz, 2.0);
}

TEST(ProcessingOptions, BadKeysAndValuesNameFileLineAndKey) {
  std::string e = yaml_error("extraction: {cutof_hz: 1}\n");
  EXPECT_NE(e.find("p.yaml:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("cutoff_hz"), std::string::npos) << e;  // did you mean
  e = yaml_error("extraction:\n  filter_order: 30\n");
  EXPECT_NE(e.find("p.yaml:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("outside 1..20"), std::string::npos) << e;
  e = yaml_error("segments: [orientaton]\n");
  EXPECT_NE(e.find("orientation"), std::string::npos) << e;
  e = yaml_error("intervals: segment\n");
  EXPECT_NE(e.find("segments"), std::string::npos) << e;
  e = yaml_error("detector: {window_s: -1}\n");  // 0 is allowed: chosen from the sample rate
  EXPECT_NE(e.find("window_s"), std::string::npos) << e;
  EXPECT_NE(e.find("must be >= 0"), std::string::npos) << e;
}

TEST(ProcessingOptions, RoundTripsThroughYaml) {
  ProcessingOptions o;
  o.intervals = IntervalSource::kSegments;
  o.segment_kinds = {"rate"};
  o.extraction.cutoff_hz = 0.25;
  o.detector.max_gyro_radps = 0.1;
  YAML::Emitter out;
  out << YAML::BeginMap;
  emit_options(out, o);
  out << YAML::EndMap;
  const ProcessingOptions r = from_yaml(out.c_str());
  EXPECT_EQ(r.intervals, o.intervals);
  EXPECT_EQ(r.segment_kinds, o.segment_kinds);
  EXPECT_EQ(r.extraction.cutoff_hz, 0.25);
  EXPECT_NEAR(r.detector.max_gyro_radps, 0.1, 1e-15);
}

TEST(ProcessingOptions, TheExperimentsSectionFillsWhatTheModelFileDoesNotState) {
  Recording rec;
  rec.dir = "runs/r1";
  rec.experiment_yaml = "name: x\nprocessing:\n  extraction: {settle_s: 3, cutoff_hz: 0.5}\n  segments: [record]\n";
  ProcessingOptions model;
  model.extraction.settle_s = 1.0;
  model.stated.insert("extraction.settle_s");  // the model file said settle_s: 1
  const ProcessingOptions used = resolve(model, rec);
  EXPECT_EQ(used.extraction.settle_s, 1.0);   // the model file's
  EXPECT_EQ(used.extraction.cutoff_hz, 0.5);  // the experiment's
  EXPECT_EQ(used.segment_kinds, std::vector<std::string>{"record"});
  EXPECT_EQ(resolve(used, rec).extraction.cutoff_hz, 0.5);  // idempotent

  rec.experiment_yaml = "name: x\nprocessing: {}\n";
  EXPECT_EQ(resolve(model, rec).extraction.cutoff_hz, 1.0);
  rec.experiment_yaml = "name: x\nprocessing:\n  extraction: {cutoff: 1}\n";
  try {
    resolve(model, rec);
    FAIL() << "a bad key in the experiment's processing section must be refused";
  } catch (const ExperimentError& e) {
    EXPECT_NE(std::string(e.what()).find("runs/r1/experiment.yaml:3:"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Truth

TEST(TruthMean, InsideTheWindowElseTheLastSnapshotBefore) {
  Recording rec;
  rec.header.truth_columns = {"a", "b"};
  rec.truth_t = {0.0, 1.0, 2.0, 3.0, 10.0};
  rec.truth = {{0, 0}, {1, 10}, {2, 20}, {3, 30}, {9, 90}};
  const int cols[2] = {1, 0};
  TruthMean m = truth_mean(rec, cols, 0.5, 3.0);
  ASSERT_TRUE(m.found);
  EXPECT_EQ(m.rows, 3u);
  EXPECT_DOUBLE_EQ(m.values[0], 20.0);
  EXPECT_DOUBLE_EQ(m.values[1], 2.0);
  m = truth_mean(rec, cols, 4.0, 5.0);  // nothing inside: the state held since t = 3
  ASSERT_TRUE(m.found);
  EXPECT_EQ(m.rows, 0u);
  EXPECT_DOUBLE_EQ(m.values[0], 30.0);
  EXPECT_FALSE(truth_mean(rec, cols, -2.0, -1.0).found);
  EXPECT_TRUE(std::isnan(truth_mean(rec, 0, -2.0, -1.0)));
  EXPECT_TRUE(std::isnan(truth_mean(rec, -1, 0.0, 5.0)));
  rec.truth[2] = {2};  // a truncated row is ignored
  EXPECT_DOUBLE_EQ(truth_mean(rec, 1, 0.5, 3.0), 20.0);
  EXPECT_DOUBLE_EQ(truth_slope(rec, 1, 0.0, 3.0), 10.0);
  EXPECT_DOUBLE_EQ(truth_slope(rec, 1, 3.0, 4.0), 0.0);  // one snapshot: no slope
}

// A long run's truth read from run.h5 a window at a time (TruthLoading::kStream: nothing loaded)
// gives the means and slopes of the truth held in memory, row for row.
TEST(TruthMean, StreamedFromTheStoreEqualsTheTruthInMemory) {
  const stend::testing::TempDir dir("truth-stream");
  RecordingHeader h;
  h.experiment_name = "truth";
  h.truth_columns = {"angle_deg", "air_c"};
  h.info.output_rate_hz = 100.0;
  {
    RecordingWriter w(dir / "run", h, "name: truth\n");
    std::vector<ImuSample> s(1);
    for (int i = 0; i < 20000; ++i) {  // 2000 s of 10 Hz truth rows: several read chunks
      const double t = 0.1 * i;
      w.add_truth(t, {std::floor(t / 100.0) * 15.0, 25.0 + 0.001 * i});
      s[0].t_s = t;
      w.add_samples(s.data(), 1);
    }
    w.finish(RunStatus::kComplete);
  }
  const Recording loaded = Recording::open(dir / "run", SampleLoading::kStream, TruthLoading::kLoad);
  const Recording streamed = Recording::open(dir / "run", SampleLoading::kStream, TruthLoading::kStream);
  ASSERT_EQ(loaded.truth_t.size(), 20000u);
  EXPECT_TRUE(streamed.truth_t.empty()) << "the truth rows are not loaded";
  ASSERT_NE(streamed.truth_store, nullptr);
  EXPECT_EQ(streamed.truth_rows, 20000u);
  const int cols[2] = {0, 1};
  for (const auto& [t0, t1] : {std::pair{0.0, 5.0}, {99.95, 500.0}, {1234.5, 1234.5}, {1999.0, 3000.0}, {-5.0, -1.0}}) {
    const TruthMean a = truth_mean(loaded, cols, t0, t1), b = truth_mean(streamed, cols, t0, t1);
    EXPECT_EQ(a.found, b.found) << t0;
    EXPECT_EQ(a.rows, b.rows) << t0;
    for (std::size_t c = 0; c < 2; ++c) {
      if (std::isnan(a.values[c])) EXPECT_TRUE(std::isnan(b.values[c])) << t0;
      else EXPECT_EQ(a.values[c], b.values[c]) << t0;
    }
    EXPECT_EQ(truth_slope(loaded, 1, t0, t1), truth_slope(streamed, 1, t0, t1)) << t0;
  }
  EXPECT_NEAR(truth_mean(streamed, 0, 100.0, 199.9), 15.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Detector

TEST(StaticDetector, FindsStillPosesBetweenMotionAndSplitsAtGaps) {
  Recording rec;
  std::mt19937_64 rng(1);
  double t = 0.0;
  for (int pose = 0; pose < 5; ++pose) {
    for (int k = 0; k < 200; ++k, t += 0.01) {  // shaking: 2 s
      ImuSample s;
      s.t_s = t;
      s.accel_mps2 = Eigen::Vector3d(0, 0, 9.8) + Eigen::Vector3d::Constant(2.0 * std::sin(25.0 * t));
      rec.samples.push_back(s);
    }
    add_samples(rec, t, t + 4.0, kSix[static_cast<std::size_t>(pose)], 0.01, rng);
    t += 4.0;
  }
  StaticDetectorOptions o;
  o.window_s = 0.5;
  o.min_duration_s = 2.0;
  const auto ivs = detect_static_intervals(rec, o);
  ASSERT_EQ(ivs.size(), 5u);
  EXPECT_NEAR(ivs[0].accel_mean_mps2.z(), 9.8, 0.01);
  EXPECT_NEAR(ivs[0].t_end_s - ivs[0].t_start_s, 3.7, 0.3);
  // A gap in the middle of the third pose splits it into two of ≥ 1.5 s.
  const std::size_t mid = (ivs[2].first + ivs[2].last) / 2;
  rec.samples[mid].flags |= kGapBefore;
  o.min_duration_s = 1.0;
  EXPECT_EQ(detect_static_intervals(rec, o).size(), 6u);
}

// A hand-held session at 100 Hz: a 10 s still start, then short poses in random directions
// joined by shaking; the gyro reads a zero-rate offset of several deg/s throughout. Pose 3 is a
// constant 10 deg/s turn about the vertical, pose 6 holds a saturated sample, pose 9 a gap.
struct HandSession {
  Recording rec;
  std::vector<std::pair<double, double>> poses;  // [t_start, t_end) of each pose
};

HandSession hand_session(std::uint64_t seed) {
  HandSession h;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> hold(1.0, 1.5);
  const Eigen::Vector3d offset = Eigen::Vector3d(4.0, -3.0, 2.5) * M_PI / 180.0;
  auto gyro = [&](const Eigen::Vector3d& w) { return Eigen::Vector3d(offset + w + 0.002 * Eigen::Vector3d(n(rng), n(rng), n(rng))); };
  double t = 0.0;
  auto still = [&](double duration, const Eigen::Vector3d& f, const Eigen::Vector3d& w) {
    const std::size_t first = h.rec.samples.size();
    add_samples(h.rec, t, t + duration, f, 0.02, rng);
    for (std::size_t i = first; i < h.rec.samples.size(); ++i) h.rec.samples[i].gyro_radps = gyro(w);
    t += duration;
  };
  still(10.0, Eigen::Vector3d(0.3, 0.2, 9.8), Eigen::Vector3d::Zero());
  for (int pose = 0; pose < 14; ++pose) {
    for (int k = 0; k < 80; ++k, t += 0.01) {  // shaking 0.8 s
      ImuSample s;
      s.t_s = t;
      s.accel_mps2 = Eigen::Vector3d(0, 0, 9.8) + Eigen::Vector3d(2.0 * std::sin(25.0 * t), std::cos(19.0 * t), 0.5);
      s.gyro_radps = gyro(Eigen::Vector3d(0.5, -0.3, 0.2));
      h.rec.samples.push_back(s);
    }
    const Eigen::Vector3d f = 9.8 * Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
    const double d = pose == 9 ? 3.0 : hold(rng);
    h.poses.emplace_back(t, t + d);
    const std::size_t first = h.rec.samples.size();
    still(d, f, pose == 3 ? Eigen::Vector3d(0.0, 0.0, 10.0 * M_PI / 180.0) : Eigen::Vector3d::Zero());
    const std::size_t mid = (first + h.rec.samples.size()) / 2;
    if (pose == 6) h.rec.samples[mid].flags |= kAccelSaturated;
    if (pose == 9) h.rec.samples[mid].flags |= kGapBefore;
  }
  return h;
}

TEST(StaticDetector, ChoosesFromTheDataAndCountsEveryRejection) {
  const HandSession h = hand_session(3);
  const Detection d = detect_static(h.rec);
  const DetectionSummary& s = d.summary;
  std::cout << s.print() << "\n";
  EXPECT_NEAR(s.rate_hz, 100.0, 0.1);
  EXPECT_NEAR(s.window_s, 0.2, 1e-12);  // kAutoWindowS at 100 Hz
  EXPECT_NEAR(s.min_duration_s, 0.5, 1e-12);
  EXPECT_EQ(s.multiplier_choice.rfind("scanned", 0), 0u) << s.multiplier_choice;
  EXPECT_EQ(s.scan.size(), kScanMultipliers.size());
  // The zero-rate offset (4, −3, 2.5) deg/s, from the stillest samples, and removed before the gate.
  EXPECT_NEAR(s.gyro_bias_radps.x() * 180.0 / M_PI, 4.0, 0.05);
  EXPECT_NEAR(s.gyro_bias_radps.y() * 180.0 / M_PI, -3.0, 0.05);
  EXPECT_EQ(s.count(Rejection::kSaturated), 1u);
  EXPECT_EQ(s.count(Rejection::kGap), 1u);
  EXPECT_GE(s.count(Rejection::kGyroRate), 1u);
  // Every pose of 1–1.5 s is found except the turning and the saturated ones; the gap splits one in two.
  EXPECT_EQ(d.intervals.size(), 1u + 14u - 2u + 1u);
  for (std::size_t k = 0; k < h.poses.size(); ++k) {
    const auto [t0, t1] = h.poses[k];
    const auto inside = std::count_if(d.intervals.begin(), d.intervals.end(),
                                      [&](const DetectedInterval& iv) { return iv.t_start_s >= t0 && iv.t_end_s < t1; });
    EXPECT_EQ(inside, k == 3 || k == 6 ? 0 : k == 9 ? 2 : 1) << "pose " << k;
  }
  // The importer's still start sets the noise and the gyro bias.
  Recording with_init = h.rec;
  Segment init;
  init.label = "initialization";
  init.t_start_s = 0.0;
  init.t_end_s = 10.0;
  with_init.segments.push_back(init);
  const DetectionSummary si = detect_static(with_init).summary;
  EXPECT_NEAR(si.init_duration_s, 10.0, 1e-12);
  EXPECT_NE(si.noise_source.find("first 10 s"), std::string::npos) << si.noise_source;
  EXPECT_NE(si.gyro_bias_source.find("first 10 s"), std::string::npos) << si.gyro_bias_source;
  EXPECT_NEAR(si.gyro_bias_radps.z() * 180.0 / M_PI, 2.5, 0.01);
  EXPECT_TRUE(si.equals(si));
  EXPECT_FALSE(si.equals(s));
}

// The recording with its samples behind a SampleSource instead of in `samples`.
Recording streamed(const Recording& rec) {
  Recording out = rec;
  out.source = std::make_shared<MemorySamples>(std::vector<ImuSample>(rec.samples));
  out.samples.clear();
  return out;
}

void expect_same(const Detection& a, const Detection& b) {
  EXPECT_TRUE(a.summary.equals(b.summary, 0.0)) << a.summary.print() << "\n" << b.summary.print();
  ASSERT_EQ(a.intervals.size(), b.intervals.size());
  for (std::size_t k = 0; k < a.intervals.size(); ++k) {
    EXPECT_EQ(a.intervals[k].first, b.intervals[k].first);
    EXPECT_EQ(a.intervals[k].last, b.intervals[k].last);
    EXPECT_EQ(a.intervals[k].accel_mean_mps2, b.intervals[k].accel_mean_mps2);
    EXPECT_EQ(a.intervals[k].gyro_mean_radps, b.intervals[k].gyro_mean_radps);
  }
}

// The detector reads its samples a chunk at a time carrying the window across chunks: the same
// numbers from samples in memory, behind a source, and in chunks smaller than the window.
TEST(StaticDetector, SameResultWhateverTheChunking) {
  HandSession h = hand_session(5);
  Segment init;
  init.label = "initialization";
  init.t_end_s = 10.0;
  for (bool with_init : {false, true}) {
    Recording rec = h.rec;
    if (with_init) rec.segments.push_back(init);
    const Detection ref = detect_static(rec);
    EXPECT_GT(ref.intervals.size(), 10u);
    expect_same(ref, detect_static(streamed(rec)));
    for (std::size_t chunk : {1u, 7u, 1000u}) expect_same(ref, detect_static(streamed(rec), {}, chunk));
  }
}

// Past a million samples the noise percentile and the gyro medians are selected over several
// passes instead of in memory; they are still the exact order statistics.
TEST(StaticDetector, ExactQuantilesOnALongRecord) {
  Recording rec;
  std::mt19937_64 rng(8);
  add_samples(rec, 0.0, 15000.0, Eigen::Vector3d(0, 0, 9.8), 0.01, rng);  // 1.5 M samples
  std::normal_distribution<double> n(0.0, 1e-3);
  for (auto& s : rec.samples) s.gyro_radps = Eigen::Vector3d(0.01 + n(rng), n(rng), n(rng));
  StaticDetectorOptions o;
  o.threshold_multiplier = 4.0;
  const Detection d = detect_static(rec, o);
  // The same statistics in memory: window variance of 2·half + 1 = 21 samples at 100 Hz, 0.2 s.
  const std::size_t N = rec.samples.size(), half = 10;
  std::vector<double> var(N);
  std::vector<Eigen::Vector3d> s1(N + 1, Eigen::Vector3d::Zero()), s2(N + 1, Eigen::Vector3d::Zero());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& s : rec.samples) mean += s.accel_mps2;
  mean /= static_cast<double>(N);
  for (std::size_t i = 0; i < N; ++i) {
    const Eigen::Vector3d x = rec.samples[i].accel_mps2 - mean;
    s1[i + 1] = s1[i] + x;
    s2[i + 1] = s2[i] + x.cwiseAbs2();
  }
  for (std::size_t i = 0; i < N; ++i) {
    const std::size_t a = i >= half ? i - half : 0, b = std::min(N, i + half + 1);
    const double m = static_cast<double>(b - a);
    const Eigen::Vector3d mu = (s1[b] - s1[a]) / m;
    var[i] = ((s2[b] - s2[a]) / m - mu.cwiseAbs2()).sum() * m / std::max(1.0, m - 1.0);
  }
  auto kth = [](std::vector<double> v, double q) {
    const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + k, v.end());
    return v[static_cast<std::size_t>(k)];
  };
  const double noise = kth(var, 0.10);
  EXPECT_EQ(d.summary.noise_variance, noise);
  std::vector<double> gx;
  for (std::size_t i = 0; i < N; ++i)
    if (var[i] <= 2.0 * noise) gx.push_back(rec.samples[i].gyro_radps.x());
  EXPECT_GT(gx.size(), std::size_t{1} << 20);
  EXPECT_EQ(d.summary.gyro_bias_radps.x(), kth(gx, 0.5));
}

// ---------------------------------------------------------------------------------------------
// Recording → static points

TEST(StaticPoints, MeansTruthAndTemperatureOverTheKeptWindow) {
  const Recording rec = poses(kSix);
  const Extraction ex = extract(rec, ProcessingOptions{}, accel_with_force());
  ASSERT_EQ(ex.points.size(), 6u);
  EXPECT_TRUE(ex.skipped.empty());
  const StaticPoint& p = ex.points[2];
  EXPECT_EQ(p.segment.id, 2);
  EXPECT_NEAR(p.t_start_s, 22.0, 1e-9);  // settle_s = 2 discarded at each end
  EXPECT_NEAR(p.t_end_s, 27.99, 0.011);
  EXPECT_NEAR(static_cast<double>(p.samples_used), 600.0, 1.0);
  EXPECT_EQ(p.last - p.first + 1, p.samples_used);
  EXPECT_DOUBLE_EQ(rec.samples[p.first].t_s, p.t_start_s);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(p.accel.mean[a], kSix[2][a], 5 * 0.01 / std::sqrt(600.0) + 1e-3);
    EXPECT_NEAR(p.accel.sample_std[a], 0.01, 0.002);
    EXPECT_NEAR(p.accel.std_error[a], p.accel.sample_std[a] / std::sqrt(static_cast<double>(p.samples_used)), 1e-15);
    EXPECT_TRUE(std::isnan(p.gyro.mean[a]));  // not requested
    EXPECT_DOUBLE_EQ(p.truth[static_cast<std::size_t>(a)], kSix[2][a]);
  }
  EXPECT_EQ(p.temperature_source, TemperatureSource::kDie);
  EXPECT_NEAR(p.stimulus.temperature_c, 20.0 + 0.1 * 5.0, 0.01);  // die ramp, mid-window
  EXPECT_NEAR(p.stimulus.temperature_rate_cps, 0.1, 1e-9);
}

TEST(StaticPoints, EveryRuleSkipsWithItsReasonAndANote) {
  Recording rec = poses(kSix);
  rec.segments[0].complete = false;
  rec.segments[1].settled = false;
  rec.samples[2 * 1000 + 500].flags |= kAccelSaturated;  // inside segment 2's kept window
  rec.samples[3 * 1000 + 500].flags |= kGyroSaturated;   // gyro not requested: kept
  rec.samples[3 * 1000 + 600].flags |= kGapBefore;       // noted, kept
  rec.segments[4].t_end_s = rec.segments[4].t_start_s + 0.05;  // 6 samples
  Segment early = rec.segments[5];  // before any truth snapshot
  early.id = 6;
  early.t_start_s = -20.0;
  early.t_end_s = -10.0;
  rec.samples.insert(rec.samples.begin(), rec.samples.begin(), rec.samples.begin() + 1000);
  for (std::size_t i = 0; i < 1000; ++i) rec.samples[i].t_s = -20.0 + 0.01 * static_cast<double>(i);
  rec.segments.push_back(early);
  const Extraction ex = extract(rec, ProcessingOptions{}, accel_with_force());
  ASSERT_EQ(ex.points.size(), 2u);
  EXPECT_EQ(ex.points[0].segment.id, 3);
  EXPECT_EQ(ex.points[0].gaps, 1u);
  EXPECT_EQ(ex.points[1].segment.id, 5);
  EXPECT_EQ(ex.count(SkipReason::kIncomplete), 1u);
  EXPECT_EQ(ex.count(SkipReason::kUnsettled), 1u);
  EXPECT_EQ(ex.count(SkipReason::kSaturated), 1u);
  EXPECT_EQ(ex.count(SkipReason::kTooFewSamples), 1u);
  EXPECT_EQ(ex.count(SkipReason::kNoTruth), 1u);
  ASSERT_EQ(ex.skipped.size(), 5u);
  EXPECT_EQ(ex.skipped[2].segment.id, 2);
  EXPECT_NE(ex.skipped[2].note.find("1 saturated sample(s)"), std::string::npos) << ex.skipped[2].note;
  EXPECT_EQ(ex.skipped[0].note,
            "skipped segment 0 (orientation, orientation 1/6, 0–9.99 s): incomplete (the run stopped inside it)");
  bool gap_noted = false;
  for (const auto& n : ex.notes) gap_noted = gap_noted || n.find("1 gap(s) in the kept window") != std::string::npos;
  EXPECT_TRUE(gap_noted);
  EXPECT_EQ(std::string(skip_reason_name(SkipReason::kNoTruth)), "no_truth");
}

TEST(StaticPoints, FilterNoneIsThePlainMeanOfTheKeptSamples) {
  const Recording rec = poses(kSix, 0.5);
  ProcessingOptions o;
  o.extraction.filter = Filter::kNone;
  o.extraction.settle_s = 1.0;
  const Extraction ex = extract(rec, o, Request{});
  ASSERT_EQ(ex.points.size(), 6u);
  const StaticPoint& p = ex.points[1];
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = p.first; i <= p.last; ++i) sum += rec.samples[i].accel_mps2;
  EXPECT_LT((p.accel.mean - sum / static_cast<double>(p.samples_used)).norm(), 1e-12);
  EXPECT_NEAR(static_cast<double>(p.samples_used), 800.0, 1.0);
  EXPECT_TRUE(p.truth.empty());
  EXPECT_EQ(p.gyro.mean, Eigen::Vector3d::Zero());
}

TEST(StaticPoints, DetectsWhenTheRecordingHasNoSegmentsAndTakesTheSensorTemperature) {
  Recording rec = poses(kSix);
  rec.segments.clear();
  rec.header.truth_columns = {"f_x_mps2", "f_y_mps2", "f_z_mps2"};
  for (auto& row : rec.truth) row.pop_back();
  // Motion between the poses for the detector.
  for (auto& s : rec.samples) {
    const double phase = std::fmod(s.t_s, 10.0);
    if (phase < 1.0 || phase > 9.0) s.accel_mps2 += Eigen::Vector3d::Constant(3.0 * std::sin(30.0 * s.t_s));
  }
  ProcessingOptions o;
  o.extraction.settle_s = 0.5;
  const Extraction ex = extract(rec, o, accel_with_force());
  ASSERT_EQ(ex.points.size(), 6u);
  EXPECT_EQ(ex.points[0].segment.kind, stend::SegmentKind::kDetected);
  EXPECT_EQ(ex.points[3].segment.label, "static_3");
  EXPECT_NEAR(ex.points[3].accel.mean.x(), -9.8, 0.01);
  EXPECT_EQ(ex.points[3].temperature_source, TemperatureSource::kSensor);
  EXPECT_DOUBLE_EQ(ex.points[3].stimulus.temperature_c, 30.0);
  ASSERT_GE(ex.notes.size(), 2u);
  EXPECT_NE(ex.notes[0].find("no 'die_c' truth column"), std::string::npos);
  EXPECT_NE(ex.notes[1].find("6 static intervals detected"), std::string::npos) << ex.notes[1];
  // Segments asked for explicitly: none, said so.
  o.intervals = IntervalSource::kSegments;
  const Extraction none = extract(rec, o, accel_with_force());
  EXPECT_TRUE(none.points.empty());
  EXPECT_NE(none.notes.back().find("no segment of kind orientation (kinds present: none)"), std::string::npos);
}

// A recording without temperature (its samples reading 0, as run folders made before issue 36
// stored it): the points carry NaN, never 0 °C, and the note says so.
TEST(StaticPoints, NoTemperatureRecordedGivesNaNTemperature) {
  Recording rec = poses(kSix);
  rec.header.truth_columns = {"f_x_mps2", "f_y_mps2", "f_z_mps2"};
  for (auto& row : rec.truth) row.pop_back();
  rec.header.info.has_temperature = false;
  for (auto& s : rec.samples) s.temperature_c = 0.0;
  const Extraction ex = extract(rec, ProcessingOptions{}, accel_with_force());
  ASSERT_EQ(ex.points.size(), 6u);
  for (const auto& p : ex.points) EXPECT_TRUE(std::isnan(p.stimulus.temperature_c)) << p.stimulus.temperature_c;
  ASSERT_FALSE(ex.notes.empty());
  EXPECT_NE(ex.notes[0].find("no temperature recorded"), std::string::npos) << ex.notes[0];
}

TEST(StaticPoints, RefusesWhatItCannotProcess) {
  Recording rec = poses(kSix);
  Request r = accel_with_force();
  r.truth_columns.push_back("w_x_radps");
  EXPECT_THROW(extract(rec, ProcessingOptions{}, r), std::invalid_argument);
  ProcessingOptions bad;
  bad.extraction.settle_s = -1.0;
  EXPECT_THROW(extract(rec, bad, accel_with_force()), std::invalid_argument);
  rec.samples[10].t_s = rec.samples[9].t_s;
  EXPECT_THROW(extract(rec, ProcessingOptions{}, accel_with_force()), std::runtime_error);
}

TEST(StaticPoints, TheExperimentsSectionDrivesTheExtraction) {
  Recording rec = poses(kSix);
  rec.experiment_yaml = "processing:\n  extraction: {settle_s: 4}\n  segments: [record]\n";
  Extraction ex = extract(rec, ProcessingOptions{}, accel_with_force());
  EXPECT_TRUE(ex.points.empty());  // no record segments
  EXPECT_EQ(ex.options.segment_kinds, std::vector<std::string>{"record"});
  ProcessingOptions model;
  model.stated = {"segments"};  // the model file says [orientation]
  ex = extract(rec, model, accel_with_force());
  ASSERT_EQ(ex.points.size(), 6u);
  EXPECT_NEAR(static_cast<double>(ex.points[0].samples_used), 200.0, 1.0);  // settle_s = 4 from the experiment
}
