// The stationarity rule of a noise analysis (see stationarity.hpp).
#include "stend/processing/stationarity.hpp"

#include "stend/model/terms.hpp"
#include "stend/physics/units.hpp"
#include "stend/recording/instruments.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

namespace stend::processing {

namespace {

constexpr int kChannels = 7;  // ax ay az gx gy gz temperature
constexpr double kMadToSigma = 1.4826;

// One block of samples: its times [s], and per channel its mean and the standard deviation of its
// samples (SI).
struct Block {
  double t_start_s = 0.0, t_end_s = 0.0;
  std::array<double, kChannels> mean{}, sd{};
};

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The robust spread of channel c's increments at the scale of `scale` blocks of `per_block` samples:
// 1.4826 × their median absolute value, never less than the white spread √2·σ/√(scale·per_block)
// (σ the median spread of a block's samples).
double increment_spread(const std::vector<double>& abs_increments, const std::vector<Block>& blocks, int c,
                        std::size_t scale, std::size_t per_block) {
  std::vector<double> sds;
  sds.reserve(blocks.size());
  for (const auto& b : blocks) sds.push_back(b.sd[c]);
  const double white = std::sqrt(2.0 / static_cast<double>(scale * per_block)) * median(sds);
  return std::max(kMadToSigma * median(abs_increments), white);
}

// Block windows [first, last) whose increment of channel c at the scale of `scale` blocks is an
// event: beyond kMaxIncrementSigmas robust spreads of that scale's increments.
std::vector<std::pair<std::size_t, std::size_t>> events_at_scale(const std::vector<Block>& blocks, int c,
                                                                 std::size_t scale, std::size_t per_block) {
  const std::size_t means = blocks.size() / scale;
  std::vector<double> m(means, 0.0);
  for (std::size_t j = 0; j < means; ++j)
    for (std::size_t k = 0; k < scale; ++k) m[j] += blocks[j * scale + k].mean[c] / static_cast<double>(scale);
  std::vector<double> abs_d(means - 1);
  for (std::size_t j = 0; j + 1 < means; ++j) abs_d[j] = std::abs(m[j + 1] - m[j]);
  const double spread = increment_spread(abs_d, blocks, c, scale, per_block);
  std::vector<std::pair<std::size_t, std::size_t>> events;
  if (!(spread > 0.0)) return events;  // a constant channel: nothing moves (its noise fit says why it fails)
  for (std::size_t j = 0; j + 1 < means; ++j)
    if (abs_d[j] > kMaxIncrementSigmas * spread) events.emplace_back(j * scale, (j + 2) * scale);
  return events;
}

// The blocks where an instrument (channels first … first + 2) moves: at each scale, finest first,
// the events of its three channels, each kept unless a finer scale already marked a block of it.
std::vector<char> moving_blocks(const std::vector<Block>& blocks, int first, std::size_t per_block) {
  std::vector<char> moving(blocks.size(), 0);
  for (std::size_t scale = 1; blocks.size() / scale >= kMinStationarityIncrements + 1; scale *= 2) {
    std::vector<std::pair<std::size_t, std::size_t>> events;
    for (int c = first; c < first + 3; ++c) {
      const auto e = events_at_scale(blocks, c, scale, per_block);
      events.insert(events.end(), e.begin(), e.end());
    }
    std::vector<char> marked = moving;
    for (const auto& [b0, b1] : events) {
      const auto end = std::min(b1, blocks.size());
      if (std::any_of(moving.begin() + static_cast<std::ptrdiff_t>(b0), moving.begin() + static_cast<std::ptrdiff_t>(end),
                      [](char m) { return m != 0; }))
        continue;
      std::fill(marked.begin() + static_cast<std::ptrdiff_t>(b0), marked.begin() + static_cast<std::ptrdiff_t>(end), 1);
    }
    moving = std::move(marked);
  }
  return moving;
}

// The norm over the instrument's three axes of the difference of two blocks' means.
double mean_change(const Block& a, const Block& b, int first) {
  double s = 0.0;
  for (int c = first; c < first + 3; ++c) s += (a.mean[c] - b.mean[c]) * (a.mean[c] - b.mean[c]);
  return std::sqrt(s);
}

// The spread of the instrument's (channels first … first + 2) block-to-block change, the norm over
// its axes of each channel's increment spread at the scale of one block.
double block_change_spread(const std::vector<Block>& blocks, int first, std::size_t per_block) {
  double s2 = 0.0;
  for (int c = first; c < first + 3; ++c) {
    std::vector<double> abs_d(blocks.size() - 1);
    for (std::size_t i = 0; i + 1 < blocks.size(); ++i) abs_d[i] = std::abs(blocks[i + 1].mean[c] - blocks[i].mean[c]);
    const double s = increment_spread(abs_d, blocks, c, 1, per_block);
    s2 += s * s;
  }
  return std::sqrt(s2);
}

// The runs [first, last) of moving blocks; two runs become one where the mean stands away between
// them and comes back after the second (a turn's start and end, a tilt and its return): every block
// between farther than kMaxIncrementSigmas spreads from the block before the first run, the block
// after the second within that.
std::vector<std::pair<std::size_t, std::size_t>> moving_runs(const std::vector<Block>& blocks,
                                                             const std::vector<char>& moving, int first,
                                                             double spread) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t i = 0; i < blocks.size();) {
    if (!moving[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < blocks.size() && moving[j]) ++j;
    runs.emplace_back(i, j);
    i = j;
  }
  const double far = kMaxIncrementSigmas * spread;
  std::vector<std::pair<std::size_t, std::size_t>> merged;
  for (const auto& run : runs) {
    if (!merged.empty() && merged.back().first > 0 && run.second < blocks.size()) {
      const Block& before = blocks[merged.back().first - 1];
      bool away = true;
      for (std::size_t k = merged.back().second; k < run.first && away; ++k) away = mean_change(blocks[k], before, first) > far;
      if (away && mean_change(blocks[run.second], before, first) <= far) {
        merged.back().second = run.second;
        continue;
      }
    }
    merged.push_back(run);
  }
  return merged;
}

// The runs of moving blocks as stretches, each with how far the instrument's mean goes from the
// block before it (the block after, for a stretch at the start); the blocks of merged runs are
// marked moving.
void add_stretches(const std::vector<Block>& blocks, std::vector<char>& moving, Mover mover, int first,
                   std::size_t per_block, std::vector<MovingStretch>& out) {
  for (const auto& [i, j] : moving_runs(blocks, moving, first, block_change_spread(blocks, first, per_block))) {
    std::fill(moving.begin() + static_cast<std::ptrdiff_t>(i), moving.begin() + static_cast<std::ptrdiff_t>(j), 1);
    const std::size_t ref = i > 0 ? i - 1 : j < blocks.size() ? j : i;
    MovingStretch s{mover, blocks[i].t_start_s, blocks[j - 1].t_end_s, 0.0};
    for (std::size_t k = i; k < j; ++k) s.change = std::max(s.change, mean_change(blocks[k], blocks[ref], first));
    out.push_back(s);
  }
}

// A temperature drift over the record: the range of its block means, from the block of the lowest
// to that of the highest (in time order); nothing when it stays within kMaxTemperatureDriftC or a
// block has no temperature (NaN: not measured).
void add_temperature_drift(const std::vector<Block>& blocks, std::vector<MovingStretch>& out) {
  constexpr int t = 6;
  if (std::any_of(blocks.begin(), blocks.end(), [](const Block& b) { return !std::isfinite(b.mean[t]); })) return;
  const auto [lo, hi] = std::minmax_element(blocks.begin(), blocks.end(),
                                            [](const Block& a, const Block& b) { return a.mean[t] < b.mean[t]; });
  const double drift = hi->mean[t] - lo->mean[t];
  if (!(drift > kMaxTemperatureDriftC)) return;
  const Block& first = lo < hi ? *lo : *hi;
  const Block& last = lo < hi ? *hi : *lo;
  out.push_back({Mover::kTemperature, first.t_start_s, last.t_end_s, drift});
}

// The longest run of blocks where neither instrument moves.
void longest_still(const std::vector<Block>& blocks, const std::vector<char>& moving, Stationarity& s) {
  std::size_t best = 0, best_first = 0;
  for (std::size_t i = 0; i < blocks.size();) {
    std::size_t j = i;
    while (j < blocks.size() && !moving[j]) ++j;
    if (j - i > best) {
      best = j - i;
      best_first = i;
    }
    i = j + 1;
  }
  if (best == 0) return;
  s.still_start_s = blocks[best_first].t_start_s;
  s.still_end_s = blocks[best_first + best - 1].t_end_s;
}

const char* verb(Mover m) {
  switch (m) {
    case Mover::kAccelerometer: return "the accelerometer moves";
    case Mover::kGyroscope: return "the gyroscope turns";
    case Mover::kTemperature: return "the temperature drifts";
  }
  return "";
}

// "(a changes by 40.2 mg)", "(up to 35.1 deg/s)", "(by 12.3 °C)".
std::string change_text(const MovingStretch& s) {
  switch (s.mover) {
    case Mover::kAccelerometer: return fmt::format("a changes by {:.4g} mg", s.change / physics::kMilliG);
    case Mover::kGyroscope: return fmt::format("by up to {:.4g} deg/s", s.change / physics::kDegPerSecond);
    case Mover::kTemperature: return fmt::format("by {:.3g} °C", s.change);
  }
  return "";
}

}  // namespace

std::string Stationarity::describe() const {
  std::string out;
  for (std::size_t i = 0; i < stretches.size();) {
    const MovingStretch& s = stretches[i];
    std::size_t j = i;
    while (j < stretches.size() && stretches[j].mover == s.mover) ++j;
    out += fmt::format("{}{} at {:.1f}–{:.1f} s ({})", out.empty() ? "" : "; ", verb(s.mover), s.t_start_s, s.t_end_s,
                       change_text(s));
    if (j - i > 1)
      out += fmt::format(" and in {} more stretch{} up to {:.1f} s", j - i - 1, j - i > 2 ? "es" : "",
                         stretches[j - 1].t_end_s);
    i = j;
  }
  return out;
}

BlockSummary::BlockSummary(std::uint64_t samples, double rate_hz)
    : per_block_(std::max(kMinStationarityBlockSamples, static_cast<std::size_t>(std::llround(kStationarityBlockS * rate_hz)))),
      blocks_(static_cast<std::size_t>(samples / per_block_)) {}

void BlockSummary::add(Channel c, std::uint64_t offset, const double* x, std::size_t n) {
  Column& col = columns_[static_cast<std::size_t>(c)];
  if (!col.added) {
    for (auto* v : {&col.mean, &col.sd, &col.first, &col.last}) v->assign(blocks_, kNaN);
    col.added = true;
  }
  // Run by run within one block each: one division per run, not per sample.
  for (std::size_t i = 0; i < n;) {
    const std::uint64_t at = offset + i;
    const auto block = static_cast<std::size_t>(at / per_block_);
    if (block >= blocks_) return;  // the tail shorter than a block
    const auto in_block = static_cast<std::size_t>(at % per_block_);
    const std::size_t run = std::min(n - i, per_block_ - in_block);
    add_run(col, block, in_block, x + i, run);
    i += run;
  }
}

void BlockSummary::add_run(Column& col, std::size_t block, std::size_t in_block, const double* x, std::size_t n) {
  if (in_block == 0) {
    col.origin = col.first[block] = x[0];
    col.sum = col.sum2 = 0.0;
  }
  const double origin = col.origin;
  // Two SSE2 vectors of two lanes each (a 4-wide generic vector is kept on the stack without AVX).
  using v2d = double __attribute__((vector_size(16)));
  v2d sa{}, sb{}, qa{}, qb{};
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    v2d a, b;
    std::memcpy(&a, x + i, sizeof a);
    std::memcpy(&b, x + i + 2, sizeof b);
    a -= origin;  // about the block's first sample, against cancellation
    b -= origin;
    sa += a;
    sb += b;
    qa += a * a;
    qb += b * b;
  }
  double s = (sa[0] + sb[0]) + (sa[1] + sb[1]), s2 = (qa[0] + qb[0]) + (qa[1] + qb[1]);
  for (; i < n; ++i) {
    const double d = x[i] - origin;
    s += d;
    s2 += d * d;
  }
  col.sum += s;
  col.sum2 += s2;
  if (in_block + n < per_block_) return;
  const auto k = static_cast<double>(per_block_);
  const double m = col.sum / k;
  col.mean[block] = origin + m;
  col.sd[block] = std::sqrt(std::max(0.0, (col.sum2 - k * m * m) / (k - 1.0)));
  col.last[block] = x[n - 1];
}

void BlockSummary::add_column(const SampleSource& src, IndexRange range, Channel c) {
  std::vector<double> buf(std::min<std::uint64_t>(kDefaultChunkSamples, std::max<std::uint64_t>(range.size(), 1)));
  for (std::uint64_t i = range.first; i < range.last;) {
    const auto take = static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), range.last - i));
    src.read_column(c, i, take, buf.data());
    add(c, i - range.first, buf.data(), take);
    i += take;
  }
}

Stationarity BlockSummary::judge(const SensorInfo& info) const {
  const bool has_accel = has_instrument(info, model::Instrument::kAccelerometer);
  const bool has_gyro = has_instrument(info, model::Instrument::kGyroscope);
  Stationarity s;
  s.blocks = blocks_;
  if (!has_accel) s.basis = "still stretches from the gyroscope alone (the recording has no accelerometer)";
  if (!has_gyro) s.basis = "still stretches from the accelerometer alone (the recording has no gyroscope)";
  if (blocks_ < kMinStationarityIncrements + 1) return s;
  s.judged = true;
  std::vector<Block> blocks(blocks_);
  const auto& time = columns_[static_cast<std::size_t>(Channel::kTime)];
  for (std::size_t b = 0; b < blocks_; ++b) {
    blocks[b].t_start_s = time.first[b];
    blocks[b].t_end_s = time.last[b];
    for (int c = 0; c < kChannels; ++c) {
      const Column& col = columns_[static_cast<std::size_t>(c) + 1];  // kAx … kTemperature follow kTime
      blocks[b].mean[c] = col.added ? col.mean[b] : kNaN;
      blocks[b].sd[c] = col.added ? col.sd[b] : kNaN;
    }
  }
  std::vector<char> accel = has_accel ? moving_blocks(blocks, 0, per_block_) : std::vector<char>(blocks.size(), 0);
  std::vector<char> gyro = has_gyro ? moving_blocks(blocks, 3, per_block_) : std::vector<char>(blocks.size(), 0);
  if (has_accel) add_stretches(blocks, accel, Mover::kAccelerometer, 0, per_block_, s.stretches);
  if (has_gyro) add_stretches(blocks, gyro, Mover::kGyroscope, 3, per_block_, s.stretches);
  add_temperature_drift(blocks, s.stretches);
  std::vector<char> either(blocks.size());
  for (std::size_t i = 0; i < blocks.size(); ++i) either[i] = static_cast<char>(accel[i] || gyro[i]);
  longest_still(blocks, either, s);
  return s;
}

Stationarity check_stationarity(const SampleSource& src, IndexRange range, double rate_hz, const SensorInfo& info) {
  BlockSummary summary(range.size(), rate_hz);
  summary.add_column(src, range, Channel::kTime);
  for (Channel c : present_channels(info)) summary.add_column(src, range, c);
  return summary.judge(info);
}

}  // namespace stend::processing
