// analyze_recording reads through the recording's sample source (a store's, not `samples`) and
// gives per channel what analyze() gives on that channel's column; a constant or too-short
// signal is a failed fit with a message, never a table of zeros or NaN.
#include <stend/allan/allan.hpp>

#include <stend/testing/files.hpp>

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <vector>

namespace {

using namespace stend;
using namespace stend::allan;

std::vector<ImuSample> noisy_samples(std::size_t n, double rate_hz) {
  std::mt19937_64 gen(11);
  std::normal_distribution<double> normal;
  std::vector<ImuSample> s(n);
  for (std::size_t i = 0; i < n; ++i) {
    s[i].t_s = static_cast<double>(i) / rate_hz;
    for (int a = 0; a < 3; ++a) {
      s[i].accel_mps2[a] = 0.01 * normal(gen) + (a == 2 ? 9.81 : 0.0);
      s[i].gyro_radps[a] = 0.002 * normal(gen) + 0.001 * a;
    }
  }
  return s;
}

TEST(AllanRecording, ReadsTheSampleSourceAndMatchesAnalyzePerChannel) {
  constexpr double rate = 200.0;
  auto samples = noisy_samples(50000, rate);
  Recording rec;
  rec.header.info.output_rate_hz = rate;
  rec.header.info.has_gyro = true;
  rec.source = std::make_shared<MemorySamples>(std::vector<ImuSample>(samples));  // store, no `samples`
  ASSERT_TRUE(rec.samples.empty());
  const AllanReport report = analyze_recording(rec);
  ASSERT_EQ(report.channels.size(), 6u);
  EXPECT_EQ(report.samples, samples.size());
  EXPECT_DOUBLE_EQ(report.rate_hz, rate);
  EXPECT_DOUBLE_EQ(report.t_end_s, samples.back().t_s);
  for (int ch = 0; ch < 6; ++ch) {
    std::vector<double> column(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i) {
      column[i] = ch < 3 ? samples[i].accel_mps2[ch] : samples[i].gyro_radps[ch - 3];
    }
    const ChannelResult direct = analyze(column.data(), column.size(), 1, rate, report.channels[static_cast<std::size_t>(ch)].curve.channel);
    const auto& got = report.channels[static_cast<std::size_t>(ch)].curve.points;
    ASSERT_EQ(got.size(), direct.curve.points.size());
    for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].avar, direct.curve.points[i].avar);
    EXPECT_TRUE(report.channels[static_cast<std::size_t>(ch)].model.ok);
  }
}

// A finished run.h5 states its gap and irregular-interval counts; the analysis of the whole run
// takes them from there instead of scanning the time stamps, and reports what a scan reports.
TEST(AllanRecording, StoreSummaryGivesTheSamplingAScanGives) {
  constexpr double rate = 200.0;
  auto samples = noisy_samples(40000, rate);
  for (std::size_t i = 1000; i < samples.size(); ++i) samples[i].t_s += 0.02;  // one 5-period gap
  samples[1000].flags |= kGapBefore;
  samples[7000].t_s -= 0.004;  // a short interval, then a long one
  std::uint64_t irregular = 0;
  for (std::size_t i = 1; i < samples.size(); ++i)
    irregular += interval_irregular(samples[i].t_s - samples[i - 1].t_s, rate);
  ASSERT_EQ(irregular, 3u);

  const stend::testing::TempDir tmp("allan-summary");
  RecordingHeader header;
  header.info.output_rate_hz = rate;
  header.info.has_gyro = true;
  {
    RecordingWriter writer(tmp / "run", header, "name: summary\n");
    writer.add_samples(samples.data(), samples.size());
    writer.finish(RunStatus::kComplete, "done");
  }
  const Recording stored = Recording::open(tmp / "run", SampleLoading::kStream);
  EXPECT_EQ(stored.gap_count, 1);
  EXPECT_EQ(stored.irregular_count, 3);
  Recording scanned;  // the same samples with nothing stated about them
  scanned.header = header;
  scanned.samples = samples;
  const AllanReport a = analyze_recording(stored), b = analyze_recording(scanned);
  EXPECT_EQ(a.warnings, b.warnings);
  EXPECT_EQ(a.warnings.size(), 2u);
  EXPECT_EQ(a.t_begin_s, b.t_begin_s);
  EXPECT_EQ(a.t_end_s, b.t_end_s);
  EXPECT_EQ(a.rate_hz, b.rate_hz);
  ASSERT_EQ(a.channels.size(), b.channels.size());
  for (std::size_t ch = 0; ch < a.channels.size(); ++ch) {
    ASSERT_EQ(a.channels[ch].curve.points.size(), b.channels[ch].curve.points.size());
    for (std::size_t i = 0; i < a.channels[ch].curve.points.size(); ++i)
      EXPECT_EQ(a.channels[ch].curve.points[i].avar, b.channels[ch].curve.points[i].avar);
  }
}

TEST(AllanRecording, TimeWindowSelectsTheSamplesInside) {
  constexpr double rate = 100.0;
  Recording rec;
  rec.header.info.output_rate_hz = rate;
  rec.samples = noisy_samples(20000, rate);
  AllanOptions opt;
  opt.t_begin_s = 10.0;
  opt.t_end_s = 110.0;  // inclusive: 10.00 … 110.00 s
  const AllanReport report = analyze_recording(rec, opt);
  EXPECT_EQ(report.samples, 10001u);
  EXPECT_DOUBLE_EQ(report.t_begin_s, 10.0);
  EXPECT_DOUBLE_EQ(report.t_end_s, 110.0);
}

TEST(AllanFailure, ConstantSignalIsAFailedFitWithAMessage) {
  const std::vector<double> y(10000, 0.25);
  ChannelInfo info;
  info.name = "gz";
  info.instrument = Instrument::kGyroscope;
  const ChannelResult r = analyze(y.data(), y.size(), 1, 100.0, info);
  EXPECT_FALSE(r.model.ok);
  EXPECT_NE(r.model.message.find("constant"), std::string::npos) << r.model.message;
}

TEST(AllanFailure, TooShortSignalIsAFailedFitWithAMessage) {
  const std::vector<double> y = {0.1, 0.3, 0.2};
  ChannelInfo info;
  info.name = "ax";
  info.instrument = Instrument::kAccelerometer;
  const ChannelResult r = analyze(y.data(), y.size(), 1, 100.0, info);
  EXPECT_FALSE(r.model.ok);
  EXPECT_FALSE(r.model.message.empty());
}

}  // namespace
