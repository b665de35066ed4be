// Streaming overlapping Allan variance at octave-spaced averaging factors (m = 1, 2, 4, …).
//
// Header-only so that anything linking stend_core (benchmarks, plugins) can use it; the noise
// model fit, reports and writers live in the stend_allan library (stend/allan/allan.hpp).
//
// Definition (N rate samples y_0 … y_{N−1}, phase x_0 = 0, x_k = Σ_{i<k} y_i, k = 0 … N):
//     AVAR(m) = Σ_{k=2m}^{N} (x_k − 2 x_{k−m} + x_{k−2m})² / (2 m² (N + 1 − 2m))
// in the squared unit of y (τ = m / rate is applied by the caller). Every second difference is
// used (fully overlapping estimator), for every octave m ≤ min(max_m, N/2).
//
// One pass, bounded memory. The phase is kept as a history of the last 2·max_m values (plus one
// block): octave m needs x_{k−m} and x_{k−2m}, and all octaves share the same history, so memory
// is 8·(2·max_m + 2·kBlock) bytes whatever N is — 64 MiB for the default cap max_m = 2^22
// (τ_max = 2^22 / rate, 11.6 h at 100 Hz). Pass expected_samples when N is known to shrink it to
// what N/2 needs. The history is allocated uninitialised, so only the part reached is resident.
//
// Speed: samples are processed in blocks of kBlock. Per block the phase is formed by a vector
// prefix scan, written straight into the history, and the second differences of up to 8
// octaves are accumulated in one fused vector loop (each distinct lag is loaded once for all
// octaves that use it). The cost is O(N · octaves) with ~3 vector operations per sample and
// octave; on x86-64 the kernels are compiled for AVX2 and AVX-512 as well and picked at run time.
//
// Precision: a constant offset (the mean of the first block) is subtracted before integrating,
// so the phase stays a random walk rather than a ramp; the running phase between blocks is a
// long double, inside a block it is a pairwise (vector) prefix sum; per-block sums of squares are
// double (≤ kBlock terms) and are accumulated in long double. On records of 10^4–10^5 samples the
// result matches a direct long-double evaluation of the formula above to ~1e-14 relative.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define STEND_ALLAN_KERNEL \
  __attribute__((target_clones("default", "avx2", "arch=x86-64-v4"), optimize("fp-contract=fast")))
#else
#define STEND_ALLAN_KERNEL
#endif

namespace stend::allan {

// Raw result for one octave.
struct OctaveVariance {
  std::uint64_t m = 0;      // averaging factor (samples)
  std::uint64_t terms = 0;  // number of second differences used, N + 1 − 2m
  double avar = 0.0;        // Allan variance, squared unit of the input
};

namespace detail {

using v8d = double __attribute__((vector_size(64)));

// Unaligned 8-double load and store. memcpy, not a pointer cast to an under-aligned vector type:
// clang keeps a vector typedef's 64-byte alignment (its UBSan reported a misaligned store, the
// fuzz target's find); both compilers make one unaligned vector move of it.
inline void load8(v8d& out, const double* p) { std::memcpy(&out, p, sizeof out); }
inline void store8(double* p, const v8d& v) { std::memcpy(p, &v, sizeof v); }

// x[i] = carry + Σ_{t≤i} (y[t] − offset) for i < n (n a multiple of 8); returns Σ (y − offset)
// (pairwise, independent of carry).
STEND_ALLAN_KERNEL
inline double prefix_scan8(const double* y, double* x, std::size_t n, double carry, double offset) {
  const v8d zero = {};
  v8d c = zero + carry;
  v8d total = zero;
  for (std::size_t i = 0; i < n; i += 8) {
    v8d v;
    load8(v, y + i);
    v -= offset;
    total += v;
    v += __builtin_shufflevector(zero, v, 0, 8, 9, 10, 11, 12, 13, 14);
    v += __builtin_shufflevector(zero, v, 0, 1, 8, 9, 10, 11, 12, 13);
    v += __builtin_shufflevector(zero, v, 0, 1, 2, 3, 8, 9, 10, 11);
    v += c;
    store8(x + i, v);
    c = __builtin_shufflevector(v, v, 7, 7, 7, 7, 7, 7, 7, 7);
  }
  const double a = (total[0] + total[1]) + (total[2] + total[3]);
  const double b = (total[4] + total[5]) + (total[6] + total[7]);
  return a + b;
}

// For g < G: out[g] += Σ_{i<n} (c[i] − 2·lag[g][i] + lag[g+1][i])², where lag[g] points at
// x_{k − m·2^g} for the k of c[i]. Written as d = 2u − w with u = c − lag[g], w = c − lag[g+1],
// so each lag stream is loaded once for the two octaves that use it.
template <int G>
STEND_ALLAN_KERNEL inline void fused_octaves(const double* c, const double* const* lag,
                                             std::size_t n, double* out) {
  v8d acc[G];
  for (int g = 0; g < G; ++g) acc[g] = v8d{};
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    v8d cv, a;
    load8(cv, c + i);
    load8(a, lag[0] + i);
    v8d u = cv - a;
#pragma GCC unroll 8
    for (int g = 0; g < G; ++g) {
      v8d b;
      load8(b, lag[g + 1] + i);
      const v8d w = cv - b;
      const v8d d = 2.0 * u - w;
      acc[g] += d * d;
      u = w;
    }
  }
  for (int g = 0; g < G; ++g) {
    const v8d& v = acc[g];
    double s = ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]));
    for (std::size_t j = i; j < n; ++j) {
      const double d = c[j] - 2.0 * lag[g][j] + lag[g + 1][j];
      s += d * d;
    }
    out[g] += s;
  }
}

inline void fused_octaves_n(int groups, const double* c, const double* const* lag, std::size_t n,
                            double* out) {
  switch (groups) {
    case 1: return fused_octaves<1>(c, lag, n, out);
    case 2: return fused_octaves<2>(c, lag, n, out);
    case 3: return fused_octaves<3>(c, lag, n, out);
    case 4: return fused_octaves<4>(c, lag, n, out);
    case 5: return fused_octaves<5>(c, lag, n, out);
    case 6: return fused_octaves<6>(c, lag, n, out);
    case 7: return fused_octaves<7>(c, lag, n, out);
    default: return fused_octaves<8>(c, lag, n, out);
  }
}

// Uninitialised storage for n values of T, 64-byte aligned; from 2 MiB on, 2 MiB-aligned and
// advised as transparent huge pages (Linux). The lag streams reach far back into a long history,
// each on its own pages: with 4 KiB pages their TLB misses cost a fifth of the stream's time
// (10^8 samples, max_m = 2^22: 0.50 → 0.40 s CPU).
struct FreeDeleter {
  void operator()(void* p) const { std::free(p); }
};
template <class T>
using BigArray = std::unique_ptr<T[], FreeDeleter>;

template <class T>
BigArray<T> allocate_big(std::size_t n) {
  constexpr std::size_t kHugePage = std::size_t{2} << 20;
  const std::size_t bytes = std::max<std::size_t>(n * sizeof(T), 1);
  const std::size_t align = bytes >= kHugePage ? kHugePage : 64;
  const std::size_t size = (bytes + align - 1) / align * align;
  void* p = std::aligned_alloc(align, size);
  if (!p) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (align == kHugePage) madvise(p, size, MADV_HUGEPAGE);  // advice only: ignored where THP is off
#endif
  return BigArray<T>(static_cast<T*>(p));
}

inline std::uint64_t floor_pow2(std::uint64_t v) {
  std::uint64_t p = 1;
  while (p <= v / 2) p *= 2;
  return p;
}

}  // namespace detail

class OverlappingAllanStream {
 public:
  static constexpr std::size_t kBlock = 4096;           // samples per processing block
  static constexpr std::uint64_t kDefaultMaxM = 1ull << 22;
  static constexpr int kMaxOctaves = 63;

  // max_m: largest averaging factor (rounded down to a power of two, ≥ 1); it fixes the memory.
  // expected_samples: N when known in advance (0 = unknown); the cap is then also ≤ N/2.
  explicit OverlappingAllanStream(std::uint64_t max_m = kDefaultMaxM,
                                  std::uint64_t expected_samples = 0) {
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

  // Back to no samples, keeping the history's memory (a new record of the same length and cap
  // costs no page faults). Only history written since is ever read.
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

  OverlappingAllanStream(const OverlappingAllanStream&) = delete;
  OverlappingAllanStream& operator=(const OverlappingAllanStream&) = delete;
  OverlappingAllanStream(OverlappingAllanStream&&) noexcept = default;
  OverlappingAllanStream& operator=(OverlappingAllanStream&&) noexcept = default;

  void add(double y) {
    ybuf_[fill_++] = y;
    if (fill_ == kBlock) {
      commit_block(ybuf_.get());
      fill_ = 0;
    }
  }

  // n samples y[0], y[stride], y[2·stride], … (stride > 1 reads one channel of interleaved data).
  void add(const double* y, std::size_t n, std::size_t stride = 1) {
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
  // Bytes held by this object (history, block buffer, sums); does not depend on N.
  std::size_t state_bytes() const {
    return sizeof(*this) + (slots_ + 1) * kBlock * sizeof(double) + kBlock * sizeof(double);
  }

  // AVAR for m = 1, 2, 4, … while m ≤ max_m and 2m ≤ N (at least one second difference).
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

}  // namespace stend::allan
