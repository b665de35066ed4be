// analyze_recording reads through the recording's sample source (a store's, not `samples`) and
// gives per channel what analyze() gives on that channel's column; a constant or too-short
// signal is a failed fit with a message, never a table of zeros or NaN.
#include <stend/allan/allan.hpp>

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
