// Logs written in bursts (stend/io/timestamps.hpp, find_bursts): the rate is the mean rate, never
// the rate inside a burst; the pattern is stated in a warning event; gaps are lost bursts, not
// every burst's start; the samples' own times are kept unless they repeat. A clean or jittery log
// is never called bursty. Both timestamp paths: the repair (text logs) and the log stream (EuRoC,
// ROS bags, ULog, DataFlash).
#include <gtest/gtest.h>

#include <stend/io/logs.hpp>
#include <stend/io/sample_sink.hpp>
#include <stend/io/timestamps.hpp>
#include <stend/testing/files.hpp>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;

namespace {

constexpr double kRateHz = 100.0;    // the sensor's rate: the mean rate of every log below
constexpr int kPerBurst = 4;         // samples per burst
constexpr double kInsideS = 0.002;   // apart inside a burst [s]
constexpr double kCycleS = kPerBurst / kRateHz;  // one burst every 40 ms
// The mean rate fitted through a few thousand staircase times: within 1e-5 of the sensor's.
constexpr double kRateTolHz = 1e-3;

// Time of sample i of a bursty log: bursts of kPerBurst, kInsideS apart (0: the same stamp).
double burst_time(std::size_t i, double inside_s = kInsideS) {
  return static_cast<double>(i / kPerBurst) * kCycleS + static_cast<double>(i % kPerBurst) * inside_s;
}

std::vector<ImuSample> samples_at(const std::vector<double>& t) {
  std::vector<ImuSample> s(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) s[i].t_s = t[i];
  return s;
}

std::vector<double> bursty_times(std::size_t n, double inside_s = kInsideS) {
  std::vector<double> t;
  for (std::size_t i = 0; i < n; ++i) t.push_back(burst_time(i, inside_s));
  return t;
}

// A recording of the given sample times, repaired as every text importer does.
Recording repaired(const std::vector<double>& t, TimestampRepair* out = nullptr) {
  Recording rec;
  rec.samples = samples_at(t);
  const TimestampRepair r = repair_timestamps(rec);
  if (out) *out = r;
  return rec;
}

std::string warnings(const Recording& rec) {
  std::string all;
  for (const auto& e : rec.events)
    if (e.level == "warning") all += e.message + "\n";
  return all;
}

std::size_t gaps(const Recording& rec) {
  std::size_t n = 0;
  for (const auto& s : rec.samples) n += (s.flags & kGapBefore) ? 1 : 0;
  return n;
}

}  // namespace

TEST(Bursts, BurstyLogKeepsItsTimesAtTheMeanRate) {
  const std::vector<double> t = bursty_times(4000);
  TimestampRepair r;
  const Recording rec = repaired(t, &r);
  ASSERT_TRUE(r.bursts.has_value());
  EXPECT_NEAR(r.bursts->samples, kPerBurst, 0.01);
  EXPECT_NEAR(r.bursts->inside_s, kInsideS, 1e-12);
  EXPECT_NEAR(rec.header.info.output_rate_hz, kRateHz, kRateTolHz);  // not 1 / 2 ms = 500 Hz
  for (std::size_t i = 0; i < t.size(); ++i) ASSERT_EQ(rec.samples[i].t_s, t[i]) << i;
  EXPECT_EQ(gaps(rec), 0u);
  const std::string w = warnings(rec);
  EXPECT_NE(w.find("timestamps come in bursts of ~4 samples every 40 ms"), std::string::npos) << w;
  EXPECT_NE(w.find("mean rate 100 Hz"), std::string::npos) << w;
  EXPECT_NE(w.find("the samples' own times are kept"), std::string::npos) << w;
}

// One time stamp per burst (a FIFO read stamped once): the times repeat, so they are rebuilt evenly
// at the mean rate; before, bursts of four were each taken for a gap.
TEST(Bursts, RepeatedStampsAreRebuiltEvenlyAtTheMeanRate) {
  const std::vector<double> t = bursty_times(4000, 0.0);
  TimestampRepair r;
  const Recording rec = repaired(t, &r);
  ASSERT_TRUE(r.bursts.has_value());
  EXPECT_NEAR(rec.header.info.output_rate_hz, kRateHz, kRateTolHz);
  EXPECT_EQ(gaps(rec), 0u);
  for (std::size_t i = 1; i < rec.samples.size(); ++i)
    ASSERT_NEAR(rec.samples[i].t_s - rec.samples[i - 1].t_s, 1.0 / kRateHz, 1e-7) << i;
  EXPECT_NE(warnings(rec).find("the times repeat inside a burst"), std::string::npos) << warnings(rec);
}

// A lost burst is a gap (flagged once, where it is); the start of every burst is not.
TEST(Bursts, ALostBurstIsTheOnlyGap) {
  std::vector<double> t;
  for (std::size_t i = 0; i < 4000; ++i)
    if (i / kPerBurst != 500) t.push_back(burst_time(i));
  const Recording rec = repaired(t);
  EXPECT_NEAR(rec.header.info.output_rate_hz, kRateHz, kRateTolHz);
  ASSERT_EQ(gaps(rec), 1u);
  EXPECT_TRUE(rec.samples[500 * kPerBurst].flags & kGapBefore);
}

// Clean, jittery (uniform ±45 % and Gaussian 20 % of a period) and rounded logs are not bursty.
TEST(Bursts, CleanJitteryAndRoundedLogsAreNotBursty) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-0.45, 0.45);
  std::normal_distribution<double> normal(0.0, 0.2);
  std::vector<double> clean, flat, gauss, rounded;
  for (std::size_t i = 0; i < 4000; ++i) {
    const double ti = static_cast<double>(i) / kRateHz;
    clean.push_back(ti);
    flat.push_back(ti + uniform(rng) / kRateHz);
    gauss.push_back(ti + normal(rng) / kRateHz);
    rounded.push_back(std::round(static_cast<double>(i) / 150.0 * 100.0) / 100.0);  // 150 Hz, 10 ms steps
  }
  for (const auto* t : {&clean, &flat, &gauss, &rounded}) {
    EXPECT_FALSE(find_bursts(samples_at(*t)).has_value());
    TimestampRepair r;
    const Recording rec = repaired(*t, &r);
    EXPECT_FALSE(r.bursts.has_value());
    EXPECT_EQ(warnings(rec).find("bursts"), std::string::npos) << warnings(rec);
  }
}

// Streamed a window at a time (stend import): the first window fixes the rule, every window keeps
// its times, and no window boundary is taken for a gap.
TEST(Bursts, StreamedOverSeveralWindows) {
  constexpr std::size_t n = 3 * kTimestampWindow + 124;
  Recording rec;
  std::vector<ImuSample> out;
  VectorSink sink(out);
  TimestampRepairStream stream(rec, sink);
  for (std::size_t i = 0; i < n; ++i) {
    ImuSample s;
    s.t_s = burst_time(i);
    stream.add_samples(&s, 1);
  }
  const TimestampRepair r = stream.finish();
  ASSERT_EQ(out.size(), n);
  EXPECT_EQ(r.gaps, 0u);
  EXPECT_EQ(r.repaired, 0u);
  EXPECT_NEAR(rec.header.info.output_rate_hz, kRateHz, kRateTolHz);
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(out[i].t_s, burst_time(i)) << i;
}

// The log formats' path (LogTimestampStream): a bursty EuRoC file gets the mean rate, no gaps, the
// warning, and its info event says where the rate came from.
TEST(Bursts, LogFormatsTakeTheMeanRate) {
  stend::testing::TempDir dir("bursts-euroc");
  std::string text = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                     "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  for (std::size_t i = 0; i < 2000; ++i) {
    char line[128];
    std::snprintf(line, sizeof line, "%lld,0,0,0,0,0,9.81\n",
                  static_cast<long long>(std::llround(burst_time(i) * 1e9)) + 1403636579758555392LL);
    text += line;
  }
  stend::testing::write_text(dir / "data.csv", text);
  const Recording rec = import_euroc(dir / "data.csv");
  EXPECT_NEAR(rec.header.info.output_rate_hz, kRateHz, kRateTolHz);
  EXPECT_EQ(gaps(rec), 0u);
  const std::string w = warnings(rec);
  EXPECT_NE(w.find("timestamps come in bursts of ~4 samples every 40 ms"), std::string::npos) << w;
  EXPECT_NE(w.find("the samples' own times are kept"), std::string::npos) << w;
  bool info = false;
  for (const auto& e : rec.events) info = info || e.message.find("the mean rate (the timestamps come in bursts)") != std::string::npos;
  EXPECT_TRUE(info);
}
