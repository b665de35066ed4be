// Raw-sample access shared by the diagnosis' input and noise-stage evidence: a segment's window
// read from the recording's store a chunk at a time, and running sums over its blocks, so that
// memory does not grow with the window's length. Internal to stend_diagnosis.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "stend/recording/recording.hpp"

namespace stend::diagnosis {

// The index range of the samples with t_start_s ≤ t_s ≤ t_end_s [s] (one segment) in the store.
inline IndexRange window_range(const Recording& rec, double t_start_s, double t_end_s) {
  return index_range(rec.sample_source(), t_start_s, std::nextafter(t_end_s, std::numeric_limits<double>::infinity()));
}

// fn(sample) for every sample of window w, in time order, read a chunk at a time.
template <class Fn>
void for_each_sample(const Recording& rec, IndexRange w, Fn&& fn) {
  for_each_chunk(rec.sample_source(), w.first, w.last, [&](const ImuSample* c, std::size_t n, std::uint64_t) {
    for (std::size_t i = 0; i < n; ++i) fn(c[i]);
  });
}

// Axis a of the instrument's reading: specific force [m/s²] or angular rate [rad/s].
inline double axis_value(const ImuSample& s, bool accel, int a) { return accel ? s.accel_mps2[a] : s.gyro_radps[a]; }

// Sums of one value over a window of n samples cut into `blocks` blocks (block b: samples
// [n·b/blocks, n·(b+1)/blocks)), fed a sample at a time in window order.
class BlockSums {
 public:
  BlockSums(std::size_t n, int blocks) : n_(n), sums_(static_cast<std::size_t>(blocks), 0.0) {}
  void add(double v) {
    while (b_ + 1 < sums_.size() && k_ >= begin(b_ + 1)) ++b_;
    sums_[b_] += v;
    ++k_;
  }
  double sum(int b) const { return sums_[static_cast<std::size_t>(b)]; }
  // Samples in block b.
  std::size_t size(int b) const { return begin(static_cast<std::size_t>(b) + 1) - begin(static_cast<std::size_t>(b)); }

 private:
  std::size_t begin(std::size_t b) const { return n_ * b / sums_.size(); }
  std::size_t n_, b_ = 0, k_ = 0;
  std::vector<double> sums_;
};

}  // namespace stend::diagnosis
