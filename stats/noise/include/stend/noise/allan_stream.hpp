// Streaming overlapping Allan variance at octave-spaced averaging factors (m = 1, 2, 4, …).
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

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace stend::noise {

// Raw result for one octave.
struct OctaveVariance {
  std::uint64_t m = 0;      // averaging factor (samples)
  std::uint64_t terms = 0;  // number of second differences used, N + 1 − 2m
  double avar = 0.0;        // Allan variance, squared unit of the input
};

class OverlappingAllanStream {
 public:
  static constexpr std::size_t kBlock = 4096;           // samples per processing block
  static constexpr std::uint64_t kDefaultMaxM = 1ull << 22;
  static constexpr int kMaxOctaves = 63;

  // max_m: largest averaging factor (rounded down to a power of two, ≥ 1; 0 throws
  // std::invalid_argument); it fixes the memory. expected_samples: N when known in advance
  // (0 = unknown); the cap is then also ≤ N/2.
  explicit OverlappingAllanStream(std::uint64_t max_m = kDefaultMaxM, std::uint64_t expected_samples = 0);
  ~OverlappingAllanStream();
  OverlappingAllanStream(const OverlappingAllanStream&) = delete;
  OverlappingAllanStream& operator=(const OverlappingAllanStream&) = delete;
  OverlappingAllanStream(OverlappingAllanStream&&) noexcept;
  OverlappingAllanStream& operator=(OverlappingAllanStream&&) noexcept;

  // Back to no samples, keeping the history's memory (a new record of the same length and cap
  // costs no page faults). Only history written since is ever read.
  void reset();

  void add(double y);
  // n samples y[0], y[stride], y[2·stride], … (stride > 1 reads one channel of interleaved data).
  void add(const double* y, std::size_t n, std::size_t stride = 1);

  std::uint64_t samples() const;
  std::uint64_t max_m() const;
  // Bytes held by this object (history, block buffer, sums); does not depend on N.
  std::size_t state_bytes() const;

  // AVAR for m = 1, 2, 4, … while m ≤ max_m and 2m ≤ N (at least one second difference).
  std::vector<OctaveVariance> octaves() const;

 private:
  class State;
  std::unique_ptr<State> state_;
};

}  // namespace stend::noise
