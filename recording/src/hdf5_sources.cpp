// The samples and truth of run.h5 read where they lie (see hdf5_sources.hpp).
#include "hdf5_sources.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <algorithm>
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

// The bench truth on the file: dataset /truth, rows of (t_s, values…), read a window at a time.
class Hdf5Truth final : public RecordedTruth {
 public:
  Hdf5Truth(fs::path path, Handle ds, std::uint64_t rows, std::size_t width)
      : path_(std::move(path)), ds_(std::move(ds)), rows_(rows), width_(width) {}
  std::uint64_t rows() const override { return rows_; }
  std::size_t columns() const override { return width_ > 0 ? width_ - 1 : 0; }
  void read(std::uint64_t first, std::size_t count, double* t, double* values, bool* whole) const override {
    if (count == 0) return;
    if (first > rows_ || count > rows_ - first)
      throw std::out_of_range(fmt::format("{}: truth rows {}..{} requested, {} stored", path_.string(), first,
                                          first + count, rows_));
    thread_local std::vector<double> v;
    v.resize(count * width_);
    {
      Hdf5Lock lock;
      if (read_rows(ds_.get(), H5T_NATIVE_DOUBLE, first, count, width_, v.data()) < 0)
        fail(path_, fmt::format("dataset /truth is damaged (rows {}..{})", first, first + count));
    }
    const std::size_t cols = columns();
    for (std::size_t i = 0; i < count; ++i) {
      t[i] = v[i * width_];
      whole[i] = true;
      std::copy_n(v.data() + i * width_ + 1, cols, values + i * cols);
    }
  }

 private:
  fs::path path_;
  Handle ds_;
  std::uint64_t rows_;
  std::size_t width_;
};

// The samples of run.h5, read a chunk at a time from the file.
class Hdf5Samples final : public SampleSource {
 public:
  Hdf5Samples(fs::path path, Handle file, std::uint64_t size, Hdf5SampleColumns c)
      : path_(std::move(path)), file_(std::move(file)), size_(size), t_(std::move(c.t)),
        flags_(std::move(c.flags)), counts_(std::move(c.counts)), si_(std::move(c.si)),
        codec_(c.codec), exceptions_(std::move(c.exceptions)) {}

  std::uint64_t size() const override { return size_; }

  void read(std::uint64_t first, std::size_t count, ImuSample* out) const override {
    if (count == 0) return;
    check_range(first, count);
    std::vector<double> d(count);
    std::vector<std::int32_t> c(count);
    std::vector<std::uint32_t> f(count);
    Hdf5Lock lock;
    read_into(t_.get(), H5T_NATIVE_DOUBLE, first, count, d.data(), "t_s");
    for (std::size_t i = 0; i < count; ++i) out[i].t_s = d[i];
    read_into(flags_.get(), H5T_NATIVE_UINT32, first, count, f.data(), "flags");
    for (std::size_t i = 0; i < count; ++i) out[i].flags = f[i];
    for (int ch = 0; ch < kChannels; ++ch) {
      const Codec& k = codec_[static_cast<std::size_t>(ch)];
      read_counts(ch, first, count, c.data());
      if (k.si_stored) {
        read_into(si_[static_cast<std::size_t>(ch)].get(), H5T_NATIVE_DOUBLE, first, count, d.data(), kSiNames[ch]);
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
    Hdf5Lock lock;
    if (ch == Channel::kTime) {
      read_into(t_.get(), H5T_NATIVE_DOUBLE, first, count, out, "t_s");
      return;
    }
    if (ch == Channel::kFlags) {
      thread_local std::vector<std::uint32_t> f;
      f.resize(count);
      read_into(flags_.get(), H5T_NATIVE_UINT32, first, count, f.data(), "flags");
      std::copy(f.begin(), f.end(), out);
      return;
    }
    const int k = static_cast<int>(ch) - static_cast<int>(Channel::kAx);
    const Codec& c = codec_[static_cast<std::size_t>(k)];
    if (c.si_stored) {
      read_into(si_[static_cast<std::size_t>(k)].get(), H5T_NATIVE_DOUBLE, first, count, out, kSiNames[k]);
      return;
    }
    // Counts read in their stored width (no conversion inside the library, which serialises
    // callers) and turned into SI here, in parallel across threads.
    auto from_counts = [&](auto stored, hid_t mem_type) {
      // One buffer per thread, kept between calls (a fresh one per chunk is a page-zeroing mmap).
      thread_local std::vector<decltype(stored)> raw;
      raw.resize(count);
      read_into(counts_[static_cast<std::size_t>(k)].get(), mem_type, first, count, raw.data(), kCountsNames[k]);
      counts_to_si(raw.data(), count, c.lsb, c.offset, out);
    };
    if (c.int16) {
      from_counts(std::int16_t{}, H5T_NATIVE_INT16);
    } else {
      from_counts(std::int32_t{}, H5T_NATIVE_INT32);
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
  // here. Every read in this class asks for the type as stored: a read that converts makes libhdf5
  // zero a whole type-conversion buffer (1 MiB) per call, which small reads (a pose, one sample of a
  // time search) then spend their time on.
  void read_counts(int ch, std::uint64_t first, std::size_t count, std::int32_t* out) const {
    const auto k = static_cast<std::size_t>(ch);
    if (!codec_[k].int16 || codec_[k].si_stored) {
      read_into(counts_[k].get(), H5T_NATIVE_INT32, first, count, out, kCountsNames[ch]);
      return;
    }
    thread_local std::vector<std::int16_t> narrow;
    narrow.resize(count);
    read_into(counts_[k].get(), H5T_NATIVE_INT16, first, count, narrow.data(), kCountsNames[ch]);
    std::copy(narrow.begin(), narrow.end(), out);
  }
  void read_into(hid_t ds, hid_t mem_type, std::uint64_t first, std::size_t count, void* out,
                 const char* name) const {
    if (read_rows(ds, mem_type, first, count, 0, out) < 0) {
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
  Handle t_, flags_;
  std::array<Handle, kChannels> counts_, si_;
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
