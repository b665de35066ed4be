// The streaming overlapping Allan variance. See stend/noise/allan_stream.hpp.
#include "stend/noise/allan_stream.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>

#include "kernels.hpp"

namespace stend::noise {

class OverlappingAllanStream::State {
 public:
  State(std::uint64_t max_m, std::uint64_t expected_samples) {
    if (max_m == 0) throw std::invalid_argument("OverlappingAllanStream: max_m must be ≥ 1");
    std::uint64_t cap = detail::floor_pow2(max_m);
    if (expected_samples >= 2) cap = std::min(cap, detail::floor_pow2(expected_samples / 2));
    max_m_ = cap;
    const std::uint64_t history_blocks = std::max<std::uint64_t>(1, (2 * cap) / kBlock);
    slots_ = history_blocks + 1;  // +1: the block being written never overlaps a lag window
    // Uninitialised on purpose: pages of the history are only made resident when reached.
    memory_ = detail::allocate_big<double>((slots_ + 1) * kBlock);
    ybuf_ = detail::allocate_big<double>(kBlock);
    reset();
  }

  void reset() {
    fill_ = 0;
    blocks_ = 0;
    offset_set_ = false;
    offset_ = 0.0;
    phase_ = 0.0L;
    sums_ = {};
    // x_0 = 0 is "element kBlock−1 of block −1": in the mirror and in the last slot.
    mirror()[kBlock - 1] = 0.0;
    slot(slots_ - 1)[kBlock - 1] = 0.0;
  }

  void add(double y) {
    ybuf_[fill_++] = y;
    if (fill_ == kBlock) {
      commit_block(ybuf_.get());
      fill_ = 0;
    }
  }

  void add(const double* y, std::size_t n, std::size_t stride) {
    std::size_t i = 0;
    while (i < n) {
      if (fill_ == 0 && stride == 1 && n - i >= kBlock) {
        commit_block(y + i);
        i += kBlock;
        continue;
      }
      const std::size_t take = std::min(kBlock - fill_, n - i);
      if (stride == 1) {
        std::memcpy(ybuf_.get() + fill_, y + i, take * sizeof(double));
      } else {
        for (std::size_t t = 0; t < take; ++t) ybuf_[fill_ + t] = y[(i + t) * stride];
      }
      fill_ += take;
      i += take;
      if (fill_ == kBlock) {
        commit_block(ybuf_.get());
        fill_ = 0;
      }
    }
  }

  std::uint64_t samples() const { return blocks_ * kBlock + fill_; }
  std::uint64_t max_m() const { return max_m_; }
  std::size_t state_bytes() const {
    return sizeof(OverlappingAllanStream) + sizeof(*this) + (slots_ + 1) * kBlock * sizeof(double) +
           kBlock * sizeof(double);
  }

  std::vector<OctaveVariance> octaves() const {
    std::array<long double, kMaxOctaves> sums = sums_;
    const std::uint64_t n = samples();
    if (fill_ > 0) {
      // The pending partial block: phase into a temporary [previous block | partial block].
      std::vector<double> tmp(2 * kBlock + 8, 0.0);
      std::memcpy(tmp.data(), previous_block(blocks_), kBlock * sizeof(double));
      const double offset = offset_set_ ? offset_ : mean(ybuf_.get(), fill_);
      scan(ybuf_.get(), fill_, offset, tmp.data() + kBlock);
      std::array<double, kMaxOctaves> block_sums{};
      accumulate(tmp.data() + kBlock, fill_, blocks_, block_sums.data());
      for (int o = 0; o < kMaxOctaves; ++o) sums[o] += block_sums[o];
    }
    std::vector<OctaveVariance> out;
    for (int o = 0; o < kMaxOctaves; ++o) {
      const std::uint64_t m = 1ull << o;
      if (m > max_m_ || 2 * m > n) break;
      OctaveVariance v;
      v.m = m;
      v.terms = n + 1 - 2 * m;
      const long double md = static_cast<long double>(m);
      v.avar = static_cast<double>(sums[o] / (2.0L * md * md * static_cast<long double>(v.terms)));
      out.push_back(v);
    }
    return out;
  }

 private:
  double* mirror() const { return memory_.get(); }
  double* slot(std::uint64_t s) const { return memory_.get() + (s + 1) * kBlock; }
  // Block j (phase indices jB+1 … jB+B) lives in slot j mod slots_.
  const double* block_ptr(std::int64_t j) const {
    const auto s = static_cast<std::int64_t>(slots_);
    return slot(static_cast<std::uint64_t>(((j % s) + s) % s));
  }
  const double* previous_block(std::uint64_t j) const {
    return (j % slots_ == 0) ? mirror() : slot(j % slots_ - 1);
  }

  static double mean(const double* y, std::size_t n) {
    long double s = 0.0L;
    for (std::size_t i = 0; i < n; ++i) s += y[i];
    return n ? static_cast<double>(s / static_cast<long double>(n)) : 0.0;
  }

  // Phase of n samples continuing from phase_, into x (x[−1] is the previous phase value).
  void scan(const double* y, std::size_t n, double offset, double* x) const {
    const std::size_t n8 = n / 8 * 8;
    const double carry = static_cast<double>(phase_);
    const double total = detail::prefix_scan8(y, x, n8, carry, offset);
    long double run = phase_ + static_cast<long double>(total);
    for (std::size_t i = n8; i < n; ++i) {
      run += static_cast<long double>(y[i] - offset);
      x[i] = static_cast<double>(run);
    }
  }

  // Adds the squared second differences whose newest point lies in block j (first `len` points,
  // at c[0 … len); c[−kBlock … −1] is block j−1) to out[octave].
  void accumulate(const double* c, std::size_t len, std::uint64_t j, double* out) const {
    const std::uint64_t k_first = j * kBlock + 1;  // phase index of c[0]
    const std::uint64_t k_last = k_first + len - 1;
    auto lag_ptr = [&](std::uint64_t lag) -> const double* {
      if (lag <= kBlock) return c - lag;
      return block_ptr(static_cast<std::int64_t>(j) - static_cast<std::int64_t>(lag / kBlock));
    };
    int o = 0;
    while (o < kMaxOctaves) {
      const std::uint64_t m = 1ull << o;
      if (m > max_m_ || 2 * m > k_last) break;
      if (2 * m > k_first) {  // octave starts inside this block: only k ≥ 2m count
        const std::size_t s = static_cast<std::size_t>(2 * m - k_first);
        const double* lags[2] = {lag_ptr(m) + s, lag_ptr(2 * m) + s};
        detail::fused_octaves<1>(c + s, lags, len - s, out + o);
        ++o;
        continue;
      }
      // A group of fully active octaves o … o+g−1 (consecutive lags m·2^i, i = 0 … g).
      int g = 0;
      while (g < 8 && o + g < kMaxOctaves) {
        const std::uint64_t mg = m << g;
        if (mg > max_m_ || 2 * mg > k_first) break;
        ++g;
      }
      const double* lags[9];
      for (int i = 0; i <= g; ++i) lags[i] = lag_ptr(m << i);
      detail::fused_octaves_n(g, c, lags, len, out + o);
      o += g;
    }
  }

  void commit_block(const double* y) {
    if (!offset_set_) {
      offset_ = mean(y, kBlock);
      offset_set_ = true;
    }
    const std::uint64_t j = blocks_;
    double* x = slot(j % slots_);
    const double carry = static_cast<double>(phase_);
    const double total = detail::prefix_scan8(y, x, kBlock, carry, offset_);
    std::array<double, kMaxOctaves> block_sums{};
    accumulate(x, kBlock, j, block_sums.data());
    for (int o = 0; o < kMaxOctaves; ++o) sums_[o] += block_sums[o];
    if (j % slots_ == slots_ - 1) std::memcpy(mirror(), x, kBlock * sizeof(double));
    phase_ += static_cast<long double>(total);
    ++blocks_;
  }

  std::uint64_t max_m_ = 0;
  std::uint64_t slots_ = 0;
  detail::BigArray<double> memory_;  // [mirror of the last slot | slot 0 | slot 1 | …]
  detail::BigArray<double> ybuf_;    // pending samples of the current block
  std::size_t fill_ = 0;
  std::uint64_t blocks_ = 0;          // committed blocks
  bool offset_set_ = false;
  double offset_ = 0.0;
  long double phase_ = 0.0L;          // phase after the last committed block
  std::array<long double, kMaxOctaves> sums_{};
};

OverlappingAllanStream::OverlappingAllanStream(std::uint64_t max_m, std::uint64_t expected_samples)
    : state_(std::make_unique<State>(max_m, expected_samples)) {}
OverlappingAllanStream::~OverlappingAllanStream() = default;
OverlappingAllanStream::OverlappingAllanStream(OverlappingAllanStream&&) noexcept = default;
OverlappingAllanStream& OverlappingAllanStream::operator=(OverlappingAllanStream&&) noexcept = default;

void OverlappingAllanStream::reset() { state_->reset(); }
void OverlappingAllanStream::add(double y) { state_->add(y); }
void OverlappingAllanStream::add(const double* y, std::size_t n, std::size_t stride) { state_->add(y, n, stride); }
std::uint64_t OverlappingAllanStream::samples() const { return state_->samples(); }
std::uint64_t OverlappingAllanStream::max_m() const { return state_->max_m(); }
std::size_t OverlappingAllanStream::state_bytes() const { return state_->state_bytes(); }
std::vector<OctaveVariance> OverlappingAllanStream::octaves() const { return state_->octaves(); }

}  // namespace stend::noise
