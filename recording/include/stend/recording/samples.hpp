// A recording's samples, read a chunk at a time: what every analysis iterates, so that its memory
// does not grow with the length of the record.
//
// A SampleSource is random-access by sample index and ordered by time. The run store's reader
// (HDF5) implements it on the file; MemorySamples wraps samples already in memory (importers,
// tests, CSV run folders). Analyses take `const SampleSource&` and use for_each_chunk /
// read_interval / read_column; state that grows with positions or segments is fine, state that
// grows with samples is not.
#pragma once

#include <stend/sdk.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

namespace stend {

// One scalar column of the samples (SI: s, m/s², rad/s, °C; the SampleFlags bits as a number).
enum class Channel { kTime, kAx, kAy, kAz, kGx, kGy, kGz, kTemperature, kFlags };
// "t_s" | "ax" | "ay" | "az" | "gx" | "gy" | "gz" | "temp_c" | "flags".
const char* to_string(Channel c);
// The channel's SI value in a sample.
double value_of(const ImuSample& s, Channel c);

// Samples per chunk when a caller does not choose: 64 Ki samples (≈ 7 MiB of ImuSample).
inline constexpr std::size_t kDefaultChunkSamples = std::size_t{1} << 16;

// A sample interval dt_s [s] is irregular when it is off the nominal period 1/rate_hz [Hz] by more
// than half a period.
inline bool interval_irregular(double dt_s, double rate_hz) {
  const double periods = dt_s * rate_hz;
  return periods > 1.5 || periods < 0.5;
}

// read() and read_column() may be called from several threads at once (an implementation that
// holds state serialises itself), so that channels can be analysed in parallel.
class SampleSource {
 public:
  virtual ~SampleSource() = default;
  // Readable samples (a damaged tail is not counted).
  virtual std::uint64_t size() const = 0;
  // Samples [first, first + count) into out[0 .. count). Requires first + count ≤ size().
  // Throws InputError naming the file and what is damaged when the data cannot be read.
  virtual void read(std::uint64_t first, std::size_t count, ImuSample* out) const = 0;
  // One channel of samples [first, first + count) into out[0 .. count). The default reads whole
  // samples; a columnar store overrides it to read only that column.
  virtual void read_column(Channel c, std::uint64_t first, std::size_t count, double* out) const;
};

// Samples held in memory: a view of a vector owned elsewhere (valid while the vector lives and is
// not resized), or owning one.
class MemorySamples final : public SampleSource {
 public:
  explicit MemorySamples(const std::vector<ImuSample>& view) : data_(&view) {}
  explicit MemorySamples(std::vector<ImuSample>&& owned)
      : owned_(std::make_shared<std::vector<ImuSample>>(std::move(owned))), data_(owned_.get()) {}
  std::uint64_t size() const override { return data_->size(); }
  void read(std::uint64_t first, std::size_t count, ImuSample* out) const override;
  void read_column(Channel c, std::uint64_t first, std::size_t count, double* out) const override;
  // The samples themselves (no copy).
  const std::vector<ImuSample>& samples() const { return *data_; }

 private:
  std::shared_ptr<std::vector<ImuSample>> owned_;
  const std::vector<ImuSample>* data_;
};

// Calls fn(chunk, n, first_index) for consecutive chunks covering samples [first, last) in order;
// one buffer of `chunk_samples` is reused. last is clamped to size().
using ChunkFn = std::function<void(const ImuSample* chunk, std::size_t n, std::uint64_t first)>;
void for_each_chunk(const SampleSource& src, std::uint64_t first, std::uint64_t last,
                    const ChunkFn& fn, std::size_t chunk_samples = kDefaultChunkSamples);
// All samples.
void for_each_chunk(const SampleSource& src, const ChunkFn& fn,
                    std::size_t chunk_samples = kDefaultChunkSamples);

// The samples themselves where the source holds them in memory (MemorySamples; a pointer into
// them stays valid while the source lives), else null (a store: each read is a copy).
const ImuSample* held_samples(const SampleSource& src);

// Samples [first, first + count): a view of them where the source holds them in memory
// (MemorySamples), else read into `storage` and a view of that. Requires first + count ≤ size().
std::span<const ImuSample> samples_view(const SampleSource& src, std::uint64_t first, std::size_t count,
                                        std::vector<ImuSample>& storage);

// Sample i (one read: for the ends of an interval, not for loops).
ImuSample sample_at(const SampleSource& src, std::uint64_t i);
// The time of sample i [s]: one value of the time column (a columnar store reads nothing else).
double time_at(const SampleSource& src, std::uint64_t i);

// Index of the first sample with t_s ≥ t (size() when none): binary search by single reads.
std::uint64_t lower_bound_time(const SampleSource& src, double t_s);
// Index range [first, last) of the samples with t_s in [t0_s, t1_s).
struct IndexRange {
  std::uint64_t first = 0, last = 0;
  std::uint64_t size() const { return last > first ? last - first : 0; }
};
IndexRange index_range(const SampleSource& src, double t0_s, double t1_s);
// The samples with t_s in [t0_s, t1_s), in memory (for one segment or pose).
std::vector<ImuSample> read_interval(const SampleSource& src, double t0_s, double t1_s);
// One channel of samples [first, last) in memory.
std::vector<double> read_column(const SampleSource& src, Channel c, std::uint64_t first,
                                std::uint64_t last);

// ---------------------------------------------------------------------------------------------
// A recording's bench truth (what was applied: table angles, rates, temperatures, specific force),
// read a window at a time like the samples: rows of a time [s] and truth_columns values, ordered
// by time and random-access by row. The run store's reader implements it on run.h5's /truth;
// MemoryTruth wraps rows in memory. Analyses look up the rows of a time window (truth_rows_in)
// and read only those.
class RecordedTruth {
 public:
  virtual ~RecordedTruth() = default;
  virtual std::uint64_t rows() const = 0;
  virtual std::size_t columns() const = 0;  // values per row
  // Rows [first, first + count): times into t[0 .. count), values row after row into
  // values[0 .. count · columns()); whole[i] false for a row that has fewer values (its values
  // then read NaN). Requires first + count ≤ rows(). Throws InputError naming the file
  // when the rows cannot be read.
  virtual void read(std::uint64_t first, std::size_t count, double* t, double* values, bool* whole) const = 0;
  // The first row at or after t_s (rows() when none), and the first after it.
  virtual std::uint64_t lower_bound(double t_s) const;
  virtual std::uint64_t upper_bound(double t_s) const;
  // Row i's time (one read: for searches, not for loops).
  double time(std::uint64_t i) const;
};

// Truth rows held in memory (a view of vectors owned elsewhere).
class MemoryTruth final : public RecordedTruth {
 public:
  MemoryTruth(const std::vector<double>& t, const std::vector<std::vector<double>>& rows, std::size_t columns)
      : t_(&t), rows_(&rows), columns_(columns) {}
  std::uint64_t rows() const override { return t_->size(); }
  std::size_t columns() const override { return columns_; }
  void read(std::uint64_t first, std::size_t count, double* t, double* values, bool* whole) const override;
  std::uint64_t lower_bound(double t_s) const override;
  std::uint64_t upper_bound(double t_s) const override;

 private:
  const std::vector<double>* t_;
  const std::vector<std::vector<double>>* rows_;
  std::size_t columns_;
};

// Rows [lo, hi) of `truth` with t0_s ≤ t ≤ t1_s.
struct TruthRows {
  std::uint64_t lo = 0, hi = 0;
};
TruthRows truth_rows_in(const RecordedTruth& truth, double t0_s, double t1_s);
// Calls fn(t, values, whole) for each row of [first, last) in order, reading kTruthChunkRows at a time.
using TruthRowFn = std::function<void(double t, const double* values, bool whole)>;
void for_each_truth_row(const RecordedTruth& truth, std::uint64_t first, std::uint64_t last, const TruthRowFn& fn);

}  // namespace stend
