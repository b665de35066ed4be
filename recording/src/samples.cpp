// Chunked reading of a recording's samples (samples.hpp).
#include "stend/recording/samples.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <memory>
#include <stdexcept>

namespace stend {

const char* to_string(Channel c) {
  switch (c) {
    case Channel::kTime: return "t_s";
    case Channel::kAx: return "ax";
    case Channel::kAy: return "ay";
    case Channel::kAz: return "az";
    case Channel::kGx: return "gx";
    case Channel::kGy: return "gy";
    case Channel::kGz: return "gz";
    case Channel::kTemperature: return "temp_c";
    case Channel::kFlags: return "flags";
  }
  return "?";
}

double value_of(const ImuSample& s, Channel c) {
  switch (c) {
    case Channel::kTime: return s.t_s;
    case Channel::kAx: return s.accel_mps2.x();
    case Channel::kAy: return s.accel_mps2.y();
    case Channel::kAz: return s.accel_mps2.z();
    case Channel::kGx: return s.gyro_radps.x();
    case Channel::kGy: return s.gyro_radps.y();
    case Channel::kGz: return s.gyro_radps.z();
    case Channel::kTemperature: return s.temperature_c;
    case Channel::kFlags: return static_cast<double>(s.flags);
  }
  return 0.0;
}

void SampleSource::read_column(Channel c, std::uint64_t first, std::size_t count,
                               double* out) const {
  std::vector<ImuSample> buf(std::min(count, kDefaultChunkSamples));
  std::size_t done = 0;
  while (done < count) {
    const std::size_t n = std::min(buf.size(), count - done);
    read(first + done, n, buf.data());
    for (std::size_t i = 0; i < n; ++i) out[done + i] = value_of(buf[i], c);
    done += n;
  }
}

namespace {
void check_range(const SampleSource& src, std::uint64_t first, std::size_t count) {
  if (first + count > src.size())
    throw std::out_of_range("sample range beyond the end of the recording");
}
}  // namespace

void MemorySamples::read(std::uint64_t first, std::size_t count, ImuSample* out) const {
  check_range(*this, first, count);
  std::copy_n(data_->begin() + static_cast<std::ptrdiff_t>(first), count, out);
}

void MemorySamples::read_column(Channel c, std::uint64_t first, std::size_t count,
                                double* out) const {
  check_range(*this, first, count);
  for (std::size_t i = 0; i < count; ++i) out[i] = value_of((*data_)[first + i], c);
}

namespace {

// A pass's chunk of samples, its memory kept on the thread for the next pass (a fresh one is up to
// 6.8 MB of pages for the kernel to map and zero, once per pass); a pass inside a pass takes another.
class ChunkBuffer {
 public:
  explicit ChunkBuffer(std::size_t n) : size_(n) {
    if (!kept_.empty()) {
      samples_ = std::move(kept_.back());
      kept_.pop_back();
    }
    if (samples_.size() < n) samples_.resize(n);
  }
  ~ChunkBuffer() {
    if (kept_.size() < 2) kept_.push_back(std::move(samples_));
  }
  ChunkBuffer(const ChunkBuffer&) = delete;
  ChunkBuffer& operator=(const ChunkBuffer&) = delete;
  std::size_t size() const { return size_; }
  ImuSample* data() const { return samples_.data(); }

 private:
  static thread_local std::vector<std::vector<ImuSample>> kept_;
  std::size_t size_;
  mutable std::vector<ImuSample> samples_;
};
thread_local std::vector<std::vector<ImuSample>> ChunkBuffer::kept_;

}  // namespace

const ImuSample* held_samples(const SampleSource& src) {
  const auto* memory = dynamic_cast<const MemorySamples*>(&src);
  return memory != nullptr ? memory->samples().data() : nullptr;
}

void for_each_chunk(const SampleSource& src, std::uint64_t first, std::uint64_t last,
                    const ChunkFn& fn, std::size_t chunk_samples) {
  last = std::min(last, src.size());
  if (first >= last) return;
  chunk_samples = std::max<std::size_t>(chunk_samples, 1);
  if (const ImuSample* data = held_samples(src)) {  // the same chunks, not copied
    for (std::uint64_t i = first; i < last; i += chunk_samples)
      fn(data + i, static_cast<std::size_t>(std::min<std::uint64_t>(chunk_samples, last - i)), i);
    return;
  }
  const ChunkBuffer buf(static_cast<std::size_t>(std::min<std::uint64_t>(chunk_samples, last - first)));
  for (std::uint64_t i = first; i < last;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), last - i));
    src.read(i, n, buf.data());
    fn(buf.data(), n, i);
    i += n;
  }
}

void for_each_chunk(const SampleSource& src, const ChunkFn& fn, std::size_t chunk_samples) {
  for_each_chunk(src, 0, src.size(), fn, chunk_samples);
}

std::span<const ImuSample> samples_view(const SampleSource& src, std::uint64_t first, std::size_t count,
                                        std::vector<ImuSample>& storage) {
  if (const ImuSample* data = held_samples(src)) {
    check_range(src, first, count);
    return {data + first, count};
  }
  storage.resize(count);
  src.read(first, count, storage.data());
  return storage;
}

ImuSample sample_at(const SampleSource& src, std::uint64_t i) {
  ImuSample s;
  src.read(i, 1, &s);
  return s;
}

double time_at(const SampleSource& src, std::uint64_t i) {
  double t = 0.0;
  src.read_column(Channel::kTime, i, 1, &t);
  return t;
}

std::uint64_t lower_bound_time(const SampleSource& src, double t_s) {
  std::uint64_t lo = 0, hi = src.size();
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    if (time_at(src, mid) < t_s) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

IndexRange index_range(const SampleSource& src, double t0_s, double t1_s) {
  IndexRange r;
  r.first = lower_bound_time(src, t0_s);
  r.last = std::max(r.first, lower_bound_time(src, t1_s));
  return r;
}

std::vector<ImuSample> read_interval(const SampleSource& src, double t0_s, double t1_s) {
  const IndexRange r = index_range(src, t0_s, t1_s);
  std::vector<ImuSample> out(static_cast<std::size_t>(r.size()));
  if (!out.empty()) src.read(r.first, out.size(), out.data());
  return out;
}

std::vector<double> read_column(const SampleSource& src, Channel c, std::uint64_t first,
                                std::uint64_t last) {
  last = std::min(last, src.size());
  std::vector<double> out(static_cast<std::size_t>(last > first ? last - first : 0));
  if (!out.empty()) src.read_column(c, first, out.size(), out.data());
  return out;
}

// --- truth --------------------------------------------------------------------------------

namespace {
constexpr std::size_t kTruthChunkRows = 4096;
}

std::uint64_t RecordedTruth::lower_bound(double t_s) const {
  std::uint64_t lo = 0, hi = rows();
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    if (time(mid) < t_s) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

std::uint64_t RecordedTruth::upper_bound(double t_s) const {
  std::uint64_t lo = 0, hi = rows();
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    if (time(mid) <= t_s) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

double RecordedTruth::time(std::uint64_t i) const {
  double t = 0.0;
  std::vector<double> values(columns());
  bool whole = true;
  read(i, 1, &t, values.data(), &whole);
  return t;
}

void MemoryTruth::read(std::uint64_t first, std::size_t count, double* t, double* values, bool* whole) const {
  if (first > rows() || count > rows() - first)
    throw std::out_of_range(fmt::format("truth rows {}..{} requested, {} held", first, first + count, rows()));
  for (std::size_t i = 0; i < count; ++i) {
    const std::vector<double>& row = (*rows_)[first + i];
    t[i] = (*t_)[first + i];
    whole[i] = row.size() == columns_;
    for (std::size_t c = 0; c < columns_; ++c)
      values[i * columns_ + c] = whole[i] ? row[c] : std::numeric_limits<double>::quiet_NaN();
  }
}

std::uint64_t MemoryTruth::lower_bound(double t_s) const {
  return static_cast<std::uint64_t>(std::lower_bound(t_->begin(), t_->end(), t_s) - t_->begin());
}

std::uint64_t MemoryTruth::upper_bound(double t_s) const {
  return static_cast<std::uint64_t>(std::upper_bound(t_->begin(), t_->end(), t_s) - t_->begin());
}

TruthRows truth_rows_in(const RecordedTruth& truth, double t0_s, double t1_s) {
  return {truth.lower_bound(t0_s), truth.upper_bound(t1_s)};
}

void for_each_truth_row(const RecordedTruth& truth, std::uint64_t first, std::uint64_t last, const TruthRowFn& fn) {
  last = std::min(last, truth.rows());
  if (first >= last) return;
  const std::size_t cols = truth.columns();
  // Buffers of the rows asked for, up to a chunk (a short window's rows, not a chunk's, are cleared).
  const std::size_t rows = static_cast<std::size_t>(std::min<std::uint64_t>(kTruthChunkRows, last - first));
  std::vector<double> t(rows), values(rows * cols);
  std::unique_ptr<bool[]> whole(new bool[rows]);
  for (std::uint64_t at = first; at < last;) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(rows, last - at));
    truth.read(at, n, t.data(), values.data(), whole.get());
    for (std::size_t i = 0; i < n; ++i) fn(t[i], values.data() + i * cols, whole[i]);
    at += n;
  }
}

}  // namespace stend
