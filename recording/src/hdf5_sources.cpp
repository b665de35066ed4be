// The samples and truth of run.h5 read where they lie (see hdf5_sources.hpp).
#include "hdf5_sources.hpp"

#include "hdf5_chunks.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

// SI values of stored counts: out[i] = in[i] · lsb + offset, over every sample of every channel
// read. Vectorised (at -O2, GCC's cheapest cost model leaves a widening conversion scalar).
template <class Count>
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((noinline, optimize("tree-vectorize", "vect-cost-model=dynamic")))
#endif
void counts_to_si(const Count* __restrict in, std::size_t n, double lsb, double offset, double* __restrict out) {
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(in[i]) * lsb + offset;
}

// Rows of one dataset as `mem_type` (the type it is stored in). Whole chunks are read as stored and
// decoded here (hdf5_chunks.hpp: outside the library's lock, so threads decode in parallel); a
// chunk this cannot decode, or a dataset whose pipeline it does not know, is read by libhdf5. A
// small read (a time search's one sample or truth row, a pose's few hundred samples) is served from
// the whole chunks it falls in, kept (the last used, up to kHeldBytes, at least two): a chunk is
// decoded once for the many small reads in it. Safe to call from several threads.
class ChunkedRows {
 public:
  ChunkedRows() = default;
  ChunkedRows(Handle ds, hid_t mem_type, hsize_t cols, std::uint64_t rows)
      : ds_(std::move(ds)), mem_type_(mem_type), cols_(cols), rows_(rows),
        row_bytes_(H5Tget_size(mem_type) * std::max<hsize_t>(cols, 1)), chunk_rows_(chunk_rows_of(ds_.get())),
        layout_(decodable_layout(ds_.get(), mem_type)) {}
  explicit operator bool() const { return static_cast<bool>(ds_); }

  // Rows [first, first + count) into out; false when they cannot be read (damage).
  bool read(std::uint64_t first, std::size_t count, void* out) const {
    if (count == 0) return true;
    auto* to = static_cast<unsigned char*>(out);
    if (count >= chunk_rows_ / 2) return read_chunks(first, count, to);
    std::lock_guard<std::mutex> guard(held_->mutex);
    for (std::uint64_t at = first, end = first + count; at < end;) {
      const std::uint64_t k = at / chunk_rows_, chunk_end = std::min<std::uint64_t>(end, (k + 1) * chunk_rows_);
      const Held* h = held(k);
      if (h == nullptr) return false;
      const auto bytes = static_cast<std::size_t>(chunk_end - at) * row_bytes_;
      std::memcpy(to, h->rows.data() + static_cast<std::size_t>(at - k * chunk_rows_) * row_bytes_, bytes);
      to += bytes;
      at = chunk_end;
    }
    return true;
  }

 private:
  struct Held {
    std::uint64_t chunk = UINT64_MAX;
    std::vector<unsigned char> rows;
  };
  struct HeldChunks {
    std::mutex mutex;
    std::vector<Held> chunks;  // the most recently used last
  };
  static constexpr std::size_t kHeldBytes = std::size_t{1} << 20;
  static hsize_t chunk_rows_of(hid_t ds) {
    const Handle dcpl(H5Dget_create_plist(ds), H5Pclose);
    hsize_t dims[2] = {0, 0};
    const bool chunked = dcpl && H5Pget_layout(dcpl.get()) == H5D_CHUNKED && H5Pget_chunk(dcpl.get(), 2, dims) >= 1;
    return chunked && dims[0] > 0 ? dims[0] : kChunkSamples;
  }
  // Rows [first, first + count) that lie in one chunk: decoded by Stend, else read by libhdf5.
  // A whole chunk below the dataset's end is decoded straight into `out`.
  bool read_in_chunk(std::uint64_t first, std::uint64_t count, unsigned char* out) const {
    const std::uint64_t k = first / chunk_rows_, begin = k * chunk_rows_;
    if (layout_ && first == begin && count == chunk_rows_ && decode_chunk(ds_.get(), *layout_, k, out)) return true;
    if (layout_) {
      thread_local std::vector<unsigned char> chunk;
      chunk.resize(static_cast<std::size_t>(chunk_rows_) * row_bytes_);
      if (decode_chunk(ds_.get(), *layout_, k, chunk.data())) {
        std::memcpy(out, chunk.data() + static_cast<std::size_t>(first - begin) * row_bytes_,
                    static_cast<std::size_t>(count) * row_bytes_);
        return true;
      }
    }
    Hdf5Lock lock;
    return read_rows(ds_.get(), mem_type_, first, count, cols_, out) >= 0;
  }
  // Rows [first, first + count), chunk by chunk.
  bool read_chunks(std::uint64_t first, std::uint64_t count, unsigned char* out) const {
    if (!layout_) {
      Hdf5Lock lock;
      return read_rows(ds_.get(), mem_type_, first, count, cols_, out) >= 0;
    }
    for (std::uint64_t at = first, end = first + count; at < end;) {
      const std::uint64_t chunk_end = std::min<std::uint64_t>(end, (at / chunk_rows_ + 1) * chunk_rows_);
      if (!read_in_chunk(at, chunk_end - at, out)) return false;
      out += static_cast<std::size_t>(chunk_end - at) * row_bytes_;
      at = chunk_end;
    }
    return true;
  }
  // Chunk k's rows (those below rows_), read whole when not held; nullptr when unreadable.
  const Held* held(std::uint64_t k) const {
    std::vector<Held>& chunks = held_->chunks;
    auto it = std::find_if(chunks.begin(), chunks.end(), [k](const Held& h) { return h.chunk == k; });
    if (it == chunks.end()) {
      const std::size_t most = std::max<std::size_t>(2, kHeldBytes / (static_cast<std::size_t>(chunk_rows_) * row_bytes_));
      if (chunks.size() < most) chunks.emplace_back();
      it = chunks.begin();  // the least recently used, or the new one
      if (chunks.back().chunk == UINT64_MAX) it = chunks.end() - 1;
    }
    std::rotate(it, it + 1, chunks.end());
    Held& h = chunks.back();
    if (h.chunk == k) return &h;
    const std::uint64_t begin = k * chunk_rows_, n = std::min<std::uint64_t>(chunk_rows_, rows_ - begin);
    h.chunk = UINT64_MAX;
    h.rows.resize(static_cast<std::size_t>(n) * row_bytes_);
    if (!read_in_chunk(begin, n, h.rows.data())) return nullptr;
    h.chunk = k;
    return &h;
  }

  Handle ds_;
  hid_t mem_type_ = H5I_INVALID_HID;
  hsize_t cols_ = 0;
  std::uint64_t rows_ = 0;
  std::size_t row_bytes_ = 0;
  hsize_t chunk_rows_ = kChunkSamples;
  std::optional<ChunkLayout> layout_;
  std::unique_ptr<HeldChunks> held_ = std::make_unique<HeldChunks>();
};

// The bench truth on the file: dataset /truth, rows of (t_s, values…), read a window at a time.
class Hdf5Truth final : public RecordedTruth {
 public:
  Hdf5Truth(fs::path path, Handle ds, std::uint64_t rows, std::size_t width)
      : path_(std::move(path)), rows_(rows), width_(width), ds_(std::move(ds), H5T_NATIVE_DOUBLE, width, rows) {}
  std::uint64_t rows() const override { return rows_; }
  std::size_t columns() const override { return width_ > 0 ? width_ - 1 : 0; }
  void read(std::uint64_t first, std::size_t count, double* t, double* values, bool* whole) const override {
    if (count == 0) return;
    if (first > rows_ || count > rows_ - first)
      throw std::out_of_range(fmt::format("{}: truth rows {}..{} requested, {} stored", path_.string(), first,
                                          first + count, rows_));
    thread_local std::vector<double> v;
    v.resize(count * width_);
    if (!ds_.read(first, count, v.data()))
      fail(path_, fmt::format("dataset /truth is damaged (rows {}..{})", first, first + count));
    const std::size_t cols = columns();
    for (std::size_t i = 0; i < count; ++i) {
      t[i] = v[i * width_];
      whole[i] = true;
      std::copy_n(v.data() + i * width_ + 1, cols, values + i * cols);
    }
  }

 private:
  fs::path path_;
  std::uint64_t rows_;
  std::size_t width_;
  ChunkedRows ds_;
};

// The samples of run.h5, read a chunk at a time from the file.
class Hdf5Samples final : public SampleSource {
 public:
  Hdf5Samples(fs::path path, Handle file, std::uint64_t size, Hdf5SampleColumns c)
      : path_(std::move(path)), file_(std::move(file)), size_(size),
        t_(std::move(c.t), H5T_NATIVE_DOUBLE, 0, size), flags_(std::move(c.flags), H5T_NATIVE_UINT32, 0, size),
        codec_(c.codec), exceptions_(std::move(c.exceptions)) {
    for (std::size_t k = 0; k < kChannels; ++k) {
      // Counts are read in their stored width: a read that converts makes libhdf5 zero a whole
      // type-conversion buffer (1 MiB) per call.
      const bool narrow = codec_[k].int16 && !codec_[k].si_stored;
      counts_[k] = ChunkedRows(std::move(c.counts[k]), narrow ? H5T_NATIVE_INT16 : H5T_NATIVE_INT32, 0, size);
      if (c.si[k]) si_[k] = ChunkedRows(std::move(c.si[k]), H5T_NATIVE_DOUBLE, 0, size);
    }
  }

  std::uint64_t size() const override { return size_; }

  void read(std::uint64_t first, std::size_t count, ImuSample* out) const override {
    if (count == 0) return;
    check_range(first, count);
    std::vector<double> d(count);
    std::vector<std::int32_t> c(count);
    std::vector<std::uint32_t> f(count);
    read_into(t_, first, count, d.data(), "t_s");
    for (std::size_t i = 0; i < count; ++i) out[i].t_s = d[i];
    read_into(flags_, first, count, f.data(), "flags");
    for (std::size_t i = 0; i < count; ++i) out[i].flags = f[i];
    for (int ch = 0; ch < kChannels; ++ch) {
      const Codec& k = codec_[static_cast<std::size_t>(ch)];
      read_counts(ch, first, count, c.data());
      if (k.si_stored) {
        read_into(si_[static_cast<std::size_t>(ch)], first, count, d.data(), kSiNames[ch]);
        for (std::size_t i = 0; i < count; ++i) set_channel(out[i], ch, c[i], d[i]);
      } else {
        for (std::size_t i = 0; i < count; ++i) set_channel(out[i], ch, c[i], k.si(c[i]));
      }
    }
    for (const auto* e = exceptions_in(first); e != exceptions_.data() + exceptions_.size() &&
                                               (*e)[0] < static_cast<double>(first + count); ++e) {
      set_channel(out[static_cast<std::size_t>((*e)[0]) - first], static_cast<int>((*e)[1]),
                  static_cast<std::int32_t>((*e)[2]), (*e)[3]);
    }
  }

  void read_column(Channel ch, std::uint64_t first, std::size_t count, double* out) const override {
    if (count == 0) return;
    check_range(first, count);
    if (ch == Channel::kTime) {
      read_into(t_, first, count, out, "t_s");
      return;
    }
    if (ch == Channel::kFlags) {
      thread_local std::vector<std::uint32_t> f;
      f.resize(count);
      read_into(flags_, first, count, f.data(), "flags");
      std::copy(f.begin(), f.end(), out);
      return;
    }
    const int k = static_cast<int>(ch) - static_cast<int>(Channel::kAx);
    const Codec& c = codec_[static_cast<std::size_t>(k)];
    if (c.si_stored) {
      read_into(si_[static_cast<std::size_t>(k)], first, count, out, kSiNames[k]);
      return;
    }
    // Counts read in their stored width (no conversion inside the library, which serialises
    // callers) and turned into SI here, in parallel across threads.
    auto from_counts = [&](auto stored) {
      // One buffer per thread, kept between calls (a fresh one per chunk is a page-zeroing mmap).
      thread_local std::vector<decltype(stored)> raw;
      raw.resize(count);
      read_into(counts_[static_cast<std::size_t>(k)], first, count, raw.data(), kCountsNames[k]);
      counts_to_si(raw.data(), count, c.lsb, c.offset, out);
    };
    if (c.int16) {
      from_counts(std::int16_t{});
    } else {
      from_counts(std::int32_t{});
    }
    for (const auto* e = exceptions_in(first); e != exceptions_.data() + exceptions_.size() &&
                                               (*e)[0] < static_cast<double>(first + count); ++e) {
      if (static_cast<int>((*e)[1]) == k) out[static_cast<std::size_t>((*e)[0]) - first] = (*e)[3];
    }
  }

 private:
  void check_range(std::uint64_t first, std::size_t count) const {
    if (first + count > size_) {
      throw std::out_of_range(fmt::format("{}: samples [{}, {}) requested, {} readable",
                                          path_.string(), first, first + count, size_));
    }
  }
  // Channel ch's counts of samples [first, first + count), read in their stored width and widened
  // here.
  void read_counts(int ch, std::uint64_t first, std::size_t count, std::int32_t* out) const {
    const auto k = static_cast<std::size_t>(ch);
    if (!codec_[k].int16 || codec_[k].si_stored) {
      read_into(counts_[k], first, count, out, kCountsNames[ch]);
      return;
    }
    thread_local std::vector<std::int16_t> narrow;
    narrow.resize(count);
    read_into(counts_[k], first, count, narrow.data(), kCountsNames[ch]);
    std::copy(narrow.begin(), narrow.end(), out);
  }
  void read_into(const ChunkedRows& column, std::uint64_t first, std::size_t count, void* out,
                 const char* name) const {
    if (!column.read(first, count, out)) {
      throw InputError(fmt::format(
          "{}: dataset /samples/{} is damaged: samples {}..{} cannot be read ({})", path_.string(),
          name, first, first + count - 1, hdf5_error()));
    }
  }
  const std::array<double, 4>* exceptions_in(std::uint64_t first) const {
    const auto it = std::lower_bound(exceptions_.begin(), exceptions_.end(), static_cast<double>(first),
                                     [](const std::array<double, 4>& e, double i) { return e[0] < i; });
    return exceptions_.data() + (it - exceptions_.begin());
  }

  fs::path path_;
  Handle file_;
  std::uint64_t size_;
  ChunkedRows t_, flags_;
  std::array<ChunkedRows, kChannels> counts_, si_;
  std::array<Codec, kChannels> codec_;
  std::vector<std::array<double, 4>> exceptions_;  // sorted by index
};

}  // namespace

std::shared_ptr<const RecordedTruth> hdf5_truth(fs::path path, Handle ds, std::uint64_t rows, std::size_t width) {
  return std::make_shared<Hdf5Truth>(std::move(path), std::move(ds), rows, width);
}

std::shared_ptr<const SampleSource> hdf5_samples(fs::path path, Handle file, std::uint64_t size,
                                                 Hdf5SampleColumns columns) {
  return std::make_shared<Hdf5Samples>(std::move(path), std::move(file), size, std::move(columns));
}

}  // namespace stend::detail
