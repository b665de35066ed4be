// Chunked reading of samples: chunks cover the range once in order, time search and intervals
// agree with a linear scan, a Recording's sample_source() follows its samples.
#include <stend/recording/recording.hpp>
#include <stend/recording/samples.hpp>

#include <gtest/gtest.h>

namespace stend {
namespace {

std::vector<ImuSample> ramp(std::size_t n, double dt) {
  std::vector<ImuSample> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    v[i].t_s = 1.0 + dt * static_cast<double>(i);
    v[i].accel_mps2 = {static_cast<double>(i), 2.0 * static_cast<double>(i), -1.0};
    v[i].gyro_radps = {0.5, 0.25, static_cast<double>(i)};
    v[i].temperature_c = 25.0;
  }
  return v;
}

TEST(Samples, ChunksCoverTheRangeOnceInOrder) {
  const MemorySamples src(ramp(1000, 0.01));
  std::uint64_t next = 10;
  double sum = 0.0;
  for_each_chunk(src, 10, 995, [&](const ImuSample* p, std::size_t n, std::uint64_t first) {
    EXPECT_EQ(first, next);
    EXPECT_LE(n, 64u);
    for (std::size_t i = 0; i < n; ++i) sum += p[i].accel_mps2.x();
    next = first + n;
  }, 64);
  EXPECT_EQ(next, 995u);
  EXPECT_DOUBLE_EQ(sum, (10.0 + 994.0) * 985.0 / 2.0);
}

// A source that holds nothing in memory: each read copies from a vector it owns.
class CopyingSource final : public SampleSource {
 public:
  explicit CopyingSource(std::vector<ImuSample> v) : v_(std::move(v)) {}
  std::uint64_t size() const override { return v_.size(); }
  void read(std::uint64_t first, std::size_t count, ImuSample* out) const override {
    std::copy_n(v_.begin() + static_cast<std::ptrdiff_t>(first), count, out);
  }

 private:
  std::vector<ImuSample> v_;
};

TEST(Samples, AViewIsTheHeldSamplesThemselvesElseACopy) {
  const std::vector<ImuSample> v = ramp(300, 0.01);
  const MemorySamples held(v);
  std::vector<ImuSample> storage;
  const std::span<const ImuSample> view = samples_view(held, 20, 100, storage);
  EXPECT_EQ(view.data(), v.data() + 20);  // no copy
  EXPECT_EQ(view.size(), 100u);
  EXPECT_TRUE(storage.empty());
  const CopyingSource read(v);
  const std::span<const ImuSample> copy = samples_view(read, 20, 100, storage);
  EXPECT_EQ(copy.data(), storage.data());
  ASSERT_EQ(copy.size(), 100u);
  for (std::size_t i = 0; i < copy.size(); ++i) EXPECT_EQ(copy[i].t_s, v[20 + i].t_s);
  EXPECT_THROW(samples_view(held, 250, 100, storage), std::out_of_range);
}

TEST(Samples, TimeSearchAndIntervalsMatchALinearScan) {
  const std::vector<ImuSample> v = ramp(777, 0.01);
  const MemorySamples src(v);
  for (double t : {0.0, 1.0, 1.005, 3.333, 8.76, 100.0}) {
    std::uint64_t linear = 0;
    while (linear < v.size() && v[linear].t_s < t) ++linear;
    EXPECT_EQ(lower_bound_time(src, t), linear) << t;
  }
  const auto part = read_interval(src, 2.0, 3.0);
  ASSERT_FALSE(part.empty());
  EXPECT_GE(part.front().t_s, 2.0);
  EXPECT_LT(part.back().t_s, 3.0);
  EXPECT_NEAR(static_cast<double>(part.size()), 100.0, 1.0);
  const auto gz = read_column(src, Channel::kGz, 5, 9);
  EXPECT_EQ(gz, (std::vector<double>{5, 6, 7, 8}));
  std::vector<double> ay(3);
  src.SampleSource::read_column(Channel::kAy, 4, 3, ay.data());  // the generic path
  EXPECT_EQ(ay, (std::vector<double>{8, 10, 12}));
}

TEST(Samples, RecordingSourceFollowsItsSamples) {
  Recording r;
  r.samples = ramp(10, 0.1);
  EXPECT_EQ(r.sample_source().size(), 10u);
  Recording copy = r;
  copy.samples.resize(4);
  EXPECT_EQ(copy.sample_source().size(), 4u);
  EXPECT_EQ(r.sample_source().size(), 10u);
  r.source = std::make_shared<MemorySamples>(ramp(3, 0.1));
  EXPECT_EQ(r.sample_source().size(), 3u);
  EXPECT_EQ(r.sample_count(), 3u);
}

}  // namespace
}  // namespace stend
