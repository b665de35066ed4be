// The vector kernels of the deviation streams (allan_stream.cpp, deviation_stream.cpp), private to
// stend_noise: inline here so that each stream's .cpp compiles them into its own loops. On x86-64
// with GCC they are cloned for AVX2 and AVX-512 and picked at run time.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define STEND_NOISE_KERNEL \
  __attribute__((target_clones("default", "avx2", "arch=x86-64-v4"), optimize("fp-contract=fast")))
#else
#define STEND_NOISE_KERNEL
#endif

namespace stend::noise::detail {

using v8d = double __attribute__((vector_size(64)));

// Unaligned 8-double load and store. memcpy, not a pointer cast to an under-aligned vector type:
// clang keeps a vector typedef's 64-byte alignment (its UBSan reported a misaligned store, the
// fuzz target's find); both compilers make one unaligned vector move of it.
inline void load8(v8d& out, const double* p) { std::memcpy(&out, p, sizeof out); }
inline void store8(double* p, const v8d& v) { std::memcpy(p, &v, sizeof v); }

// x[i] = carry + Σ_{t≤i} (y[t] − offset) for i < n (n a multiple of 8); returns Σ (y − offset)
// (pairwise, independent of carry).
STEND_NOISE_KERNEL
inline double prefix_scan8(const double* y, double* x, std::size_t n, double carry, double offset) {
  // 4-wide: an 8-wide generic vector's cross-half shuffles went through the stack on AVX2.
  using v4d = double __attribute__((vector_size(32)));
  const v4d zero = {};
  v4d c = zero + carry;
  v4d total = zero;
  for (std::size_t i = 0; i < n; i += 4) {
    v4d v;
    std::memcpy(&v, y + i, sizeof v);
    v -= offset;
    total += v;
    v += __builtin_shufflevector(zero, v, 0, 4, 5, 6);
    v += __builtin_shufflevector(zero, v, 0, 1, 4, 5);
    v += c;
    std::memcpy(x + i, &v, sizeof v);
    c = __builtin_shufflevector(v, v, 3, 3, 3, 3);
  }
  return (total[0] + total[1]) + (total[2] + total[3]);
}

// For g < G: out[g] += Σ_{i<n} (c[i] − 2·lag[g][i] + lag[g+1][i])², where lag[g] points at
// x_{k − m·2^g} for the k of c[i]. Written as d = 2u − w with u = c − lag[g], w = c − lag[g+1],
// so each lag stream is loaded once for the two octaves that use it.
template <int G>
STEND_NOISE_KERNEL inline void fused_octaves(const double* c, const double* const* lag,
                                             std::size_t n, double* out) {
  // 4-wide: G accumulators and the temporaries stay in the 16 AVX2 registers (8-wide ones spilled
  // to the stack for G = 8).
  using v4d = double __attribute__((vector_size(32)));
  v4d acc[G];
  for (int g = 0; g < G; ++g) acc[g] = v4d{};
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    v4d cv, a;
    std::memcpy(&cv, c + i, sizeof cv);
    std::memcpy(&a, lag[0] + i, sizeof a);
    v4d u = cv - a;
#pragma GCC unroll 8
    for (int g = 0; g < G; ++g) {
      v4d b;
      std::memcpy(&b, lag[g + 1] + i, sizeof b);
      const v4d w = cv - b;
      const v4d d = 2.0 * u - w;
      acc[g] += d * d;
      u = w;
    }
  }
  for (int g = 0; g < G; ++g) {
    const v4d& v = acc[g];
    double s = (v[0] + v[1]) + (v[2] + v[3]);
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


// Allocator on cache lines, so that 8-double loads at positions ≡ 0 mod 8 never straddle two,
// and on huge pages for the large rings (allocate_big).
template <class T>
struct CacheLineAllocator {
  using value_type = T;
  CacheLineAllocator() = default;
  template <class U>
  CacheLineAllocator(const CacheLineAllocator<U>&) {}
  T* allocate(std::size_t n) { return allocate_big<T>(n).release(); }
  void deallocate(T* p, std::size_t) { std::free(p); }
  bool operator==(const CacheLineAllocator&) const { return true; }
};
using AlignedDoubles = std::vector<double, CacheLineAllocator<double>>;

// Over i < n with d2_i = c_i − 2a_i + b_i, d3_i = d2_i − (a_i − 2b_i + e_i) (c, a, b, e the
// phase at k, k−m, k−2m, k−3m): sums[0] += Σ d2², sums[1] += Σ d3², and with the running sum
// w_i = w + Σ_{t≤i} d3_t, sums[2] += Σ w². Returns the last w. One pass, 16 points a step: the
// running sum is an in-register prefix scan of each 8 lanes plus a carry, and the carry is
// advanced by the two vectors' totals (computed off the carry), so the only loop-carried chain
// is one add per 16 points.
STEND_NOISE_KERNEL
inline double steady_sums(const double* c, const double* a, const double* b, const double* e,
                          std::size_t n, double w, double* sums) {
  const v8d zero = {};
  v8d s2{}, s3{}, sw{};
  v8d carry = zero + w;
  auto step = [&](std::size_t i, v8d& u) {  // u ← d3 scanned within its 8 lanes
    v8d vc, va, vb, ve;
    load8(vc, c + i);
    load8(va, a + i);
    load8(vb, b + i);
    load8(ve, e + i);
    const v8d d2 = vc - 2.0 * va + vb;
    u = d2 - (va - 2.0 * vb + ve);
    s2 += d2 * d2;
    s3 += u * u;
    u += __builtin_shufflevector(zero, u, 0, 8, 9, 10, 11, 12, 13, 14);
    u += __builtin_shufflevector(zero, u, 0, 1, 8, 9, 10, 11, 12, 13);
    u += __builtin_shufflevector(zero, u, 0, 1, 2, 3, 8, 9, 10, 11);
  };
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    v8d u1, u2;
    step(i, u1);
    step(i + 8, u2);
    const v8d t1 = __builtin_shufflevector(u1, u1, 7, 7, 7, 7, 7, 7, 7, 7);
    const v8d t2 = __builtin_shufflevector(u2, u2, 7, 7, 7, 7, 7, 7, 7, 7);
    const v8d w1 = u1 + carry;
    const v8d w2 = (u2 + t1) + carry;
    sw += w1 * w1;
    sw += w2 * w2;
    carry += t1 + t2;
  }
  auto hsum = [](const v8d& v) {
    return ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]));
  };
  double t2 = hsum(s2), t3 = hsum(s3), tw = hsum(sw);
  w = carry[0];
  for (std::size_t t = i; t < n; ++t) {
    const double d2 = c[t] - 2.0 * a[t] + b[t];
    const double d3 = d2 - (a[t] - 2.0 * b[t] + e[t]);
    t2 += d2 * d2;
    t3 += d3 * d3;
    w += d3;
    tw += w * w;
  }
  sums[0] += t2;
  sums[1] += t3;
  sums[2] += tw;
  return w;
}

// One octave level of the pyramid over n points (see DeviationStream): with V = V^m at k (v),
// k − 1 (v1), k − m (q), k − m − 1 (q1) and k − 2m (r),
//   d2 = V_k − V_{k−1},  e = V_k − V_{k−m},  d3 = e − (V_{k−1} − V_{k−m−1}),
// sums[0] += Σ d2², sums[1] += Σ d3², sums[2] += Σ e²; with kMasked also
// sums[3] += Σ mask·d2², sums[4] += Σ mask·d3² (mask[i mod 8]: 1 where k ≡ 0 mod m, m ≤ 8);
// with kNext the next level's V^{2m}_k = V_k + 2V_{k−m} + V_{k−2m} into vn. Two sets of
// accumulators, 8 points a step, so that no add waits on the previous one.
template <bool kMasked, bool kNext>
STEND_NOISE_KERNEL inline void level_sums(const double* v, const double* v1, const double* q,
                                          const double* q1, const double* r, double* vn,
                                          std::size_t n, const double* mask, double* sums) {
  // 4-wide (8-wide generic vectors spilled to the stack on AVX2): two steps of 4 points cover the
  // mask's period of 8.
  using v4d = double __attribute__((vector_size(32)));
  v4d acc[2][5] = {};
  v4d mk[2] = {};
  if constexpr (kMasked) {
    std::memcpy(&mk[0], mask, sizeof mk[0]);
    std::memcpy(&mk[1], mask + 4, sizeof mk[1]);
  }
  // V_{k−1} and V_{k−m−1}: lane 3 of the previous vector shifted in (an aligned load and a
  // lane shift instead of a load across two cache lines).
  const v4d zero{};
  v4d pa = zero + v1[0], pb = zero + q1[0];
  auto step = [&](std::size_t i, v4d* s, const v4d& m) {
    v4d a, b;
    std::memcpy(&a, v + i, sizeof a);
    std::memcpy(&b, q + i, sizeof b);
    const v4d a1 = __builtin_shufflevector(pa, a, 3, 4, 5, 6);
    const v4d b1 = __builtin_shufflevector(pb, b, 3, 4, 5, 6);
    pa = a;
    pb = b;
    if constexpr (kNext) {
      v4d c;
      std::memcpy(&c, r + i, sizeof c);
      const v4d next = (a + c) + 2.0 * b;
      std::memcpy(vn + i, &next, sizeof next);
    }
    const v4d d2 = a - a1;
    const v4d e = a - b;
    const v4d d3 = e - (a1 - b1);
    s[0] += d2 * d2;
    s[1] += d3 * d3;
    s[2] += e * e;
    if constexpr (kMasked) {
      s[3] += (m * d2) * d2;
      s[4] += (m * d3) * d3;
    }
  };
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    step(i, acc[0], mk[0]);
    step(i + 4, acc[1], mk[1]);
  }
  double t[5];
  for (int j = 0; j < 5; ++j) {
    const v4d w = acc[0][j] + acc[1][j];
    t[j] = (w[0] + w[1]) + (w[2] + w[3]);
  }
  for (; i < n; ++i) {
    const double d2 = v[i] - v1[i];
    const double e = v[i] - q[i];
    const double d3 = e - (v1[i] - q1[i]);
    t[0] += d2 * d2;
    t[1] += d3 * d3;
    t[2] += e * e;
    if constexpr (kMasked) {
      t[3] += mask[i % 8] * d2 * d2;
      t[4] += mask[i % 8] * d3 * d3;
    }
    if constexpr (kNext) vn[i] = (v[i] + r[i]) + 2.0 * q[i];
  }
  for (int j = 0; j < 5; ++j) sums[j] += t[j];
}

}  // namespace stend::noise::detail
