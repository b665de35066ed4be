// Whole chunks encoded by Stend and written with H5Dwrite_chunk (see hdf5_chunks.hpp).
#include "hdf5_chunks.hpp"

#include <fmt/format.h>
#include <libdeflate.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <algorithm>
#include <atomic>
#include <cstring>
#include <functional>
#include <future>
#include <new>
#include <optional>
#include <system_error>
#include <thread>
#include <tuple>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

// Adds words [0, 8·steps) of `bytes` (big-endian 16-bit) to a Fletcher-32 block's sums as the
// word-by-word loop would: sum2 += 8K·sum1 + Σ (8K − i)·w_i and sum1 += Σ w_i, K = steps. Eight
// lanes: a_l sums lane l's words, b_l the a_l before each step, so Σ (K − k)·w over a lane is
// a_l + b_l and Σ (8K − i)·w_i = 8·Σ (a_l + b_l) − Σ l·a_l. In a block of ≤ 360 words no lane
// overflows; the sums are exact in 64 bits and wrap to 32 as the word loop's would.
void fletcher32_steps(const unsigned char* bytes, std::size_t steps, std::uint32_t& sum1, std::uint32_t& sum2) {
#if defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  __m128i a_lo = zero, a_hi = zero, b_lo = zero, b_hi = zero;
  for (std::size_t k = 0; k < steps; ++k, bytes += 16) {
    const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(bytes));
    const __m128i w = _mm_or_si128(_mm_slli_epi16(v, 8), _mm_srli_epi16(v, 8));
    b_lo = _mm_add_epi32(b_lo, a_lo);
    b_hi = _mm_add_epi32(b_hi, a_hi);
    a_lo = _mm_add_epi32(a_lo, _mm_unpacklo_epi16(w, zero));
    a_hi = _mm_add_epi32(a_hi, _mm_unpackhi_epi16(w, zero));
  }
  std::uint32_t a[8], b[8];
  _mm_storeu_si128(reinterpret_cast<__m128i*>(a), a_lo);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(a + 4), a_hi);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(b), b_lo);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(b + 4), b_hi);
#else
  std::uint32_t a[8] = {}, b[8] = {};
  for (std::size_t k = 0; k < steps; ++k, bytes += 16) {
    for (int l = 0; l < 8; ++l) {
      b[l] += a[l];
      a[l] += static_cast<std::uint32_t>(bytes[2 * l]) << 8 | bytes[2 * l + 1];
    }
  }
#endif
  std::uint64_t words = 0, weighted = 0;
  for (int l = 0; l < 8; ++l) {
    words += a[l];
    weighted += 8 * (static_cast<std::uint64_t>(a[l]) + b[l]) - static_cast<std::uint64_t>(l) * a[l];
  }
  sum2 = static_cast<std::uint32_t>(sum2 + 8 * steps * static_cast<std::uint64_t>(sum1) + weighted);
  sum1 = static_cast<std::uint32_t>(sum1 + words);
}

}  // namespace

std::uint32_t hdf5_fletcher32(const unsigned char* bytes, std::size_t size) {
  std::uint32_t sum1 = 0, sum2 = 0;
  std::size_t words = size / 2;
  while (words > 0) {
    const std::size_t block = std::min<std::size_t>(words, 360);  // the most sums without overflow
    words -= block;
    const std::size_t steps = block / 8;
    fletcher32_steps(bytes, steps, sum1, sum2);
    bytes += 16 * steps;
    for (std::size_t i = 8 * steps; i < block; ++i, bytes += 2) {
      sum1 += static_cast<std::uint32_t>(bytes[0]) << 8 | bytes[1];
      sum2 += sum1;
    }
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
  }
  if (size % 2 != 0) {
    sum1 += static_cast<std::uint32_t>(bytes[0]) << 8;
    sum2 += sum1;
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
  }
  sum1 = (sum1 & 0xffff) + (sum1 >> 16);
  sum2 = (sum2 & 0xffff) + (sum2 >> 16);
  return sum2 << 16 | sum1;
}

namespace {

struct Pipeline {
  hsize_t chunk_rows = 0, chunk_cols = 0;  // chunk_cols 0: a 1-D dataset
  bool shuffle = false, deflate = false, fletcher32 = false;
};

// The dataset's chunking and filters, when Stend can encode or decode them: shuffle, deflate,
// Fletcher-32, each at most once and in that order (as create_dataset sets them).
std::optional<Pipeline> pipeline_of(hid_t ds) {
  const Handle dcpl(H5Dget_create_plist(ds), H5Pclose);
  hsize_t chunk[2] = {0, 0};
  const int rank = dcpl && H5Pget_layout(dcpl.get()) == H5D_CHUNKED ? H5Pget_chunk(dcpl.get(), 2, chunk) : -1;
  if (rank != 1 && rank != 2) return std::nullopt;
  Pipeline p;
  p.chunk_rows = chunk[0];
  p.chunk_cols = rank == 2 ? chunk[1] : 0;
  int stage = 0;
  for (int i = 0, n = H5Pget_nfilters(dcpl.get()); i < n; ++i) {
    unsigned flags = 0;
    std::size_t values = 0;
    unsigned config = 0;
    const H5Z_filter_t id = H5Pget_filter2(dcpl.get(), static_cast<unsigned>(i), &flags, &values, nullptr, 0,
                                           nullptr, &config);
    const int order = id == H5Z_FILTER_SHUFFLE ? 1 : id == H5Z_FILTER_DEFLATE ? 2 : id == H5Z_FILTER_FLETCHER32 ? 3 : 0;
    if (order <= stage) return std::nullopt;
    stage = order;
    (order == 1 ? p.shuffle : order == 2 ? p.deflate : p.fletcher32) = true;
  }
  return p;
}

// Byte j of value i to position j·n + i (HDF5's shuffle filter; values of one byte stay), from
// value `from` on.
void shuffle_bytes(const unsigned char* in, std::size_t n, std::size_t value_bytes, unsigned char* out,
                   std::size_t from = 0) {
  for (std::size_t j = 0; j < value_bytes; ++j) {
    unsigned char* to = out + j * n;
    for (std::size_t i = from; i < n; ++i) to[i] = in[i * value_bytes + j];
  }
}

#if defined(__SSE2__)
// The same for values of B = 2, 4 or 8 bytes, 16 values at a time: their B·16 bytes in B
// registers, transposed by four rounds of byte interleaving (unpack lo/hi of registers k and
// k + B/2), leave register j holding byte j of the 16 values. About twice the scalar loop's speed.
template <int B>
void shuffle_16_at_once(const unsigned char* in, std::size_t n, unsigned char* out) {
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    __m128i r[B], t[B];
    for (int k = 0; k < B; ++k) r[k] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i * B + 16 * k));
    for (int round = 0; round < 4; ++round) {
      for (int k = 0; k < B / 2; ++k) {
        t[2 * k] = _mm_unpacklo_epi8(r[k], r[k + B / 2]);
        t[2 * k + 1] = _mm_unpackhi_epi8(r[k], r[k + B / 2]);
      }
      std::copy(t, t + B, r);
    }
    for (int j = 0; j < B; ++j) _mm_storeu_si128(reinterpret_cast<__m128i*>(out + j * n + i), r[j]);
  }
  shuffle_bytes(in, n, B, out, i);
}
#endif

void shuffle(const unsigned char* in, std::size_t n, std::size_t value_bytes, unsigned char* out) {
#if defined(__SSE2__)
  if (value_bytes == 8) return shuffle_16_at_once<8>(in, n, out);
  if (value_bytes == 4) return shuffle_16_at_once<4>(in, n, out);
  if (value_bytes == 2) return shuffle_16_at_once<2>(in, n, out);
#endif
  shuffle_bytes(in, n, value_bytes, out);
}

// The inverse: byte j·n + i back to byte j of value i, from value `from` on.
void unshuffle_bytes(const unsigned char* in, std::size_t n, std::size_t value_bytes, unsigned char* out,
                     std::size_t from = 0) {
  for (std::size_t j = 0; j < value_bytes; ++j) {
    const unsigned char* plane = in + j * n;
    for (std::size_t i = from; i < n; ++i) out[i * value_bytes + j] = plane[i];
  }
}

#if defined(__SSE2__)
// The same for values of B = 2, 4 or 8 bytes, 16 values at a time: register j holds byte j of the
// 16 values; log2(B) rounds interleave registers 2m and 2m + 1 by 1, 2 then 4 bytes (low halves to
// m, high halves to m + B/2), which leaves the values' bytes in order, two, four or eight values per
// register, the registers in bit-reversed order.
template <int B>
void unshuffle_16_at_once(const unsigned char* in, std::size_t n, unsigned char* out) {
  constexpr int kRounds = B == 2 ? 1 : B == 4 ? 2 : 3;
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    __m128i r[B], t[B];
    for (int j = 0; j < B; ++j) r[j] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + j * n + i));
    for (int round = 0; round < kRounds; ++round) {
      for (int m = 0; m < B / 2; ++m) {
        const __m128i a = r[2 * m], b = r[2 * m + 1];
        t[m] = round == 0 ? _mm_unpacklo_epi8(a, b) : round == 1 ? _mm_unpacklo_epi16(a, b) : _mm_unpacklo_epi32(a, b);
        t[m + B / 2] = round == 0 ? _mm_unpackhi_epi8(a, b) : round == 1 ? _mm_unpackhi_epi16(a, b) : _mm_unpackhi_epi32(a, b);
      }
      std::copy(t, t + B, r);
    }
    for (int m = 0; m < B; ++m) {
      int reversed = 0;
      for (int bit = 0; bit < kRounds; ++bit) reversed |= ((m >> bit) & 1) << (kRounds - 1 - bit);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i * B + 16 * m), r[reversed]);
    }
  }
  unshuffle_bytes(in, n, B, out, i);
}
#endif

void unshuffle(const unsigned char* in, std::size_t n, std::size_t value_bytes, unsigned char* out) {
#if defined(__SSE2__)
  if (value_bytes == 8) return unshuffle_16_at_once<8>(in, n, out);
  if (value_bytes == 4) return unshuffle_16_at_once<4>(in, n, out);
  if (value_bytes == 2) return unshuffle_16_at_once<2>(in, n, out);
#endif
  unshuffle_bytes(in, n, value_bytes, out);
}

}  // namespace

std::optional<ChunkLayout> decodable_layout(hid_t ds, hid_t mem_type) {
  const std::optional<Pipeline> p = pipeline_of(ds);
  const Handle stored(H5Dget_type(ds), H5Tclose);
  if (!p || !stored || H5Tequal(stored.get(), mem_type) <= 0) return std::nullopt;
  const Handle space(H5Dget_space(ds), H5Sclose);
  hsize_t dims[2] = {0, 0};
  const int rank = space ? H5Sget_simple_extent_dims(space.get(), dims, nullptr) : -1;
  if (rank != (p->chunk_cols == 0 ? 1 : 2) || (rank == 2 && p->chunk_cols != dims[1]) || p->chunk_rows == 0)
    return std::nullopt;  // a 2-D dataset whose chunks cut its rows
  ChunkLayout l;
  l.rows = p->chunk_rows;
  l.value_bytes = H5Tget_size(stored.get());
  l.row_bytes = l.value_bytes * static_cast<std::size_t>(std::max<hsize_t>(p->chunk_cols, 1));
  l.shuffle = p->shuffle;
  l.deflate = p->deflate;
  l.fletcher32 = p->fletcher32;
  return l;
}

bool decode_chunk(hid_t ds, const ChunkLayout& l, std::uint64_t k, unsigned char* out) {
  struct Decompressor {
    libdeflate_decompressor* d = libdeflate_alloc_decompressor();
    ~Decompressor() { libdeflate_free_decompressor(d); }
  };
  thread_local Decompressor inflate;
  thread_local std::vector<unsigned char> stored, shuffled;
  const hsize_t offset[2] = {k * l.rows, 0};
  hsize_t size = 0;
  std::uint32_t skipped = 0;
  {
    Hdf5Lock lock;
    if (H5Dget_chunk_storage_size(ds, offset, &size) < 0 || size == 0) return false;
    stored.resize(static_cast<std::size_t>(size));
    if (H5Dread_chunk(ds, H5P_DEFAULT, offset, &skipped, stored.data()) < 0 || skipped != 0) return false;
  }
  std::size_t n = stored.size();
  if (l.fletcher32) {
    if (n < 4) return false;
    n -= 4;
    std::uint32_t sum = 0;
    for (int b = 0; b < 4; ++b) sum |= static_cast<std::uint32_t>(stored[n + static_cast<std::size_t>(b)]) << (8 * b);
    if (hdf5_fletcher32(stored.data(), n) != sum) return false;
  }
  const std::size_t bytes = static_cast<std::size_t>(l.rows) * l.row_bytes;
  const bool unshuffled = l.shuffle && l.value_bytes > 1;
  if (unshuffled) shuffled.resize(bytes);
  unsigned char* plain = unshuffled ? shuffled.data() : out;
  if (l.deflate) {
    std::size_t got = 0;
    if (inflate.d == nullptr ||
        libdeflate_zlib_decompress(inflate.d, stored.data(), n, plain, bytes, &got) != LIBDEFLATE_SUCCESS || got != bytes)
      return false;
  } else {
    if (n != bytes) return false;
    std::memcpy(plain, stored.data(), n);
  }
  if (unshuffled) unshuffle(plain, bytes / l.value_bytes, l.value_bytes, out);
  return true;
}

namespace {

// How rows of one column are encoded into a chunk, found from its dataset (libhdf5 calls: made on
// the writing thread, before any encoding).
struct ChunkEncoding {
  Pipeline pipeline;
  std::size_t value_bytes = 0;  // of the stored type
  bool narrowed = false;        // int32 counts stored as int16
};

// The encoding of rows [at, at + rows) of `ds` given as `mem_type`: a whole chunk, or the first rows
// of one the dataset does not reach yet (padded with zeros, the fill value, as libhdf5 pads an edge
// chunk; a later write into it goes through libhdf5). Nothing when this writer cannot make them.
std::optional<ChunkEncoding> encoding_of(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows) {
  const std::optional<Pipeline> p = pipeline_of(ds);
  if (!p || p->chunk_cols != 0 || at % p->chunk_rows != 0 || rows > p->chunk_rows ||
      (rows < p->chunk_rows && extent_rows(ds) != at))
    return std::nullopt;
  const Handle stored(H5Dget_type(ds), H5Tclose);
  if (!stored) return std::nullopt;
  const bool as_given = H5Tequal(stored.get(), mem_type) > 0;
  const bool narrowed = !as_given && H5Tequal(stored.get(), H5T_STD_I16LE) > 0 &&
                        H5Tequal(mem_type, H5T_NATIVE_INT32) > 0 && H5Tequal(H5T_NATIVE_INT16, H5T_STD_I16LE) > 0;
  if (!as_given && !narrowed) return std::nullopt;
  return ChunkEncoding{*p, H5Tget_size(stored.get()), narrowed};
}

// Whether a second thread can encode beside the writing one.
bool second_core() {
  static const bool two = std::thread::hardware_concurrency() > 1;
  return two;
}

}  // namespace

// A compressor and its buffers; encodes without calling libhdf5, so on any thread.
class ChunkWriter::Encoder {
 public:
  Encoder() : deflate_(libdeflate_alloc_compressor(1)) {
    if (deflate_ == nullptr) throw std::bad_alloc();
  }
  ~Encoder() { libdeflate_free_compressor(deflate_); }
  Encoder(const Encoder&) = delete;
  Encoder& operator=(const Encoder&) = delete;

  // out ← `rows` rows of `data` as the pipeline stores them in a chunk; false when deflate fails.
  bool encode(const ChunkEncoding& e, hsize_t rows, const void* data, std::vector<unsigned char>& out) {
    const Pipeline& p = e.pipeline;
    const auto n = static_cast<std::size_t>(p.chunk_rows), given = static_cast<std::size_t>(rows);
    const auto* bytes = static_cast<const unsigned char*>(data);
    if (e.narrowed || given < n) {
      stored_.assign(n * e.value_bytes, 0);
      if (!e.narrowed) std::memcpy(stored_.data(), data, given * e.value_bytes);
      const auto* wide = static_cast<const std::int32_t*>(data);
      for (std::size_t i = 0; e.narrowed && i < given; ++i) {  // int32 counts stored as int16, clipped as libhdf5 does
        const auto v = static_cast<std::int16_t>(std::clamp<std::int32_t>(wide[i], INT16_MIN, INT16_MAX));
        std::memcpy(stored_.data() + i * sizeof v, &v, sizeof v);
      }
      bytes = stored_.data();
    }
    std::size_t size = n * e.value_bytes;
    const bool zeros = bytes[0] == 0 && std::memcmp(bytes, bytes + 1, size - 1) == 0;
    if (zeros && zeros_.size == size && zeros_.pipeline == std::tuple(p.shuffle, p.deflate, p.fletcher32)) {
      out = zeros_.encoded;
      return true;
    }
    if (p.shuffle && e.value_bytes > 1) {
      shuffled_.resize(size);
      shuffle(bytes, n, e.value_bytes, shuffled_.data());
      bytes = shuffled_.data();
    }
    if (p.deflate) {  // into this encoder's buffer: `out` (one per column) keeps only what deflate made
      deflated_.resize(libdeflate_zlib_compress_bound(deflate_, size));
      size = libdeflate_zlib_compress(deflate_, bytes, size, deflated_.data(), deflated_.size());
      if (size == 0) return false;
      bytes = deflated_.data();
    }
    out.resize(size + (p.fletcher32 ? 4 : 0));
    std::memcpy(out.data(), bytes, size);
    if (p.fletcher32) {
      const std::uint32_t sum = hdf5_fletcher32(out.data(), size);
      for (int k = 0; k < 4; ++k) out[size + static_cast<std::size_t>(k)] = static_cast<unsigned char>(sum >> (8 * k));  // little-endian
    }
    if (zeros) zeros_ = {n * e.value_bytes, std::tuple(p.shuffle, p.deflate, p.fletcher32), out};
    return true;
  }

 private:
  libdeflate_compressor* deflate_;
  std::vector<unsigned char> stored_, shuffled_, deflated_;
  // The last chunk of zeros encoded (the counts an import keeps beside SI values are zeros, chunk
  // after chunk): reused for the next of the same size and pipeline instead of deflated again.
  struct {
    std::size_t size = 0;
    std::tuple<bool, bool, bool> pipeline;  // shuffle, deflate, Fletcher-32
    std::vector<unsigned char> encoded;
  } zeros_;
};

ChunkWriter::ChunkWriter() : here_(std::make_unique<Encoder>()) {}

ChunkWriter::~ChunkWriter() = default;

void ChunkWriter::write(std::span<const ChunkColumn> columns, hsize_t at, hsize_t rows, const fs::path& file) {
  if (rows == 0) return;
  const std::size_t n = columns.size();
  std::vector<std::optional<ChunkEncoding>> how(n);
  for (std::size_t k = 0; k < n; ++k) how[k] = encoding_of(columns[k].ds, columns[k].mem_type, at, rows);
  encoded_.resize(std::max(encoded_.size(), n));
  std::vector<char> ok(n, 0);  // column k's chunk is in encoded_[k]
  std::atomic<std::size_t> next{0};
  const auto encode = [&](Encoder& e) {
    for (std::size_t k; (k = next.fetch_add(1)) < n;) ok[k] = how[k] && e.encode(*how[k], rows, columns[k].data, encoded_[k]);
  };
  std::future<void> beside;
  if (second_core() && std::count_if(how.begin(), how.end(), [](const auto& h) { return h.has_value(); }) > 1) {
    if (!beside_) beside_ = std::make_unique<Encoder>();
    try {
      beside = std::async(std::launch::async, encode, std::ref(*beside_));
    } catch (const std::system_error&) {
      // No thread to be had: this one encodes them all.
    }
  }
  encode(*here_);
  if (beside.valid()) beside.get();
  const hsize_t dims[1] = {at + rows}, offset[1] = {at};
  for (std::size_t k = 0; k < n; ++k) {
    const ChunkColumn& c = columns[k];
    if (!ok[k]) {
      write_rows(c.ds, c.mem_type, at, rows, 0, c.data, file, c.name);
      continue;
    }
    check_write(H5Dset_extent(c.ds, dims), file, fmt::format("cannot extend dataset '{}'", c.name));
    check_write(H5Dwrite_chunk(c.ds, H5P_DEFAULT, 0, offset, encoded_[k].size(), encoded_[k].data()), file,
                fmt::format("cannot write dataset '{}'", c.name));
  }
}

}  // namespace stend::detail
