// MATLAB .mat files: import (v5 and v7.3, through matio, with the structure of v5 files checked
// first) and export. Declared in stend/io/importers.hpp.
#include <stend/io/importers.hpp>
#include <stend/recording/hdf5.hpp>
#include <stend/io/timestamps.hpp>
#include <stend/yaml/reader.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "import_common.hpp"

// MATLAB files go through matio, when stend_io is built with it: io/CMakeLists.txt links
// PkgConfig::MATIO and defines STEND_HAVE_MATIO. Without it the .mat functions say so.
#if defined(STEND_HAVE_MATIO) && __has_include(<matio.h>)
#include <matio.h>
#include <zlib.h>
#define STEND_IMPORT_MATIO 1
#else
#define STEND_IMPORT_MATIO 0
#endif

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

#if STEND_IMPORT_MATIO

bool mat_supported() { return true; }

namespace {

struct MatFileCloser {
  void operator()(mat_t* m) const {
    if (m) Mat_Close(m);
  }
};
struct MatVarFree {
  void operator()(matvar_t* v) const {
    if (v) Mat_VarFree(v);
  }
};
using MatFile = std::unique_ptr<mat_t, MatFileCloser>;
using MatVar = std::unique_ptr<matvar_t, MatVarFree>;

// The number of elements a variable's dims declare (the product of its dims); nullopt when the
// product does not fit a size_t (damage).
std::optional<std::size_t> declared_elements(const matvar_t* v) {
  std::size_t n = 1;
  for (int i = 0; i < v->rank; ++i) {
    if (v->dims[i] != 0 && n > std::numeric_limits<std::size_t>::max() / v->dims[i]) return std::nullopt;
    n *= v->dims[i];
  }
  return n;
}

// The number of elements a variable's dims declare, when its data buffer holds them all at
// element_bytes each; nullopt otherwise. matio's buffer is what the data element gave, which in a
// damaged file is shorter than the dims (fuzz finding: a char array read 2052 bytes of 4).
std::optional<std::size_t> held_elements(const matvar_t* v, std::size_t element_bytes) {
  const auto n = declared_elements(v);
  if (!n || *n > v->nbytes / element_bytes) return std::nullopt;
  return n;
}

// Numeric content of a variable as doubles (column-major), with its dims; false when it is not
// numeric or its data does not hold its dims.
bool numeric(const matvar_t* v, std::vector<double>& out, std::size_t& rows, std::size_t& cols) {
  if (!v || v->isComplex || v->rank != 2 || !v->data) return false;
  rows = v->dims[0];
  cols = v->dims[1];
  auto copy = [&](auto* p) {
    const auto n = held_elements(v, sizeof(*p));
    if (!n) return false;
    out.resize(*n);
    for (std::size_t i = 0; i < *n; ++i) out[i] = static_cast<double>(p[i]);
    return true;
  };
  switch (v->class_type) {
    case MAT_C_DOUBLE: return copy(static_cast<const double*>(v->data));
    case MAT_C_SINGLE: return copy(static_cast<const float*>(v->data));
    case MAT_C_INT8: return copy(static_cast<const std::int8_t*>(v->data));
    case MAT_C_UINT8: return copy(static_cast<const std::uint8_t*>(v->data));
    case MAT_C_INT16: return copy(static_cast<const std::int16_t*>(v->data));
    case MAT_C_UINT16: return copy(static_cast<const std::uint16_t*>(v->data));
    case MAT_C_INT32: return copy(static_cast<const std::int32_t*>(v->data));
    case MAT_C_UINT32: return copy(static_cast<const std::uint32_t*>(v->data));
    case MAT_C_INT64: return copy(static_cast<const std::int64_t*>(v->data));
    case MAT_C_UINT64: return copy(static_cast<const std::uint64_t*>(v->data));
    default: return false;
  }
}

// A char array's text ("" when there is none); nullopt when its data does not hold its dims.
std::optional<std::string> text(const matvar_t* v) {
  if (!v || v->class_type != MAT_C_CHAR || !v->data) return std::string();
  const bool wide = v->data_size == 2 || v->data_type == MAT_T_UINT16 || v->data_type == MAT_T_UTF16;
  const auto n = held_elements(v, wide ? 2 : 1);
  if (!n) return std::nullopt;
  std::string s;
  if (wide) {
    const auto* p = static_cast<const std::uint16_t*>(v->data);
    for (std::size_t i = 0; i < *n; ++i) s += p[i] < 128 ? static_cast<char>(p[i]) : '?';
  } else {
    s.assign(static_cast<const char*>(v->data), *n);
  }
  return s;
}

// The bytes of one top-level element, as stored or inflated from a compressed one (whose
// inflated bytes start with the matrix's own tag), read forwards; at most what it holds.
class MatElementBytes {
 public:
  MatElementBytes(std::ifstream& in, std::uint64_t pos, std::uint32_t bytes, bool compressed)
      : in_(in), next_(pos + 8), left_(bytes), compressed_(compressed) {
    if (compressed_ && inflateInit(&z_) != Z_OK) throw std::bad_alloc();
  }
  ~MatElementBytes() {
    if (compressed_) inflateEnd(&z_);
  }
  MatElementBytes(const MatElementBytes&) = delete;
  MatElementBytes& operator=(const MatElementBytes&) = delete;

  // n bytes into out (nullptr: skipped); false when the element (or its zlib stream) ends first.
  bool read(char* out, std::uint64_t n) {
    if (!out && !compressed_) {  // skipping stored bytes: no need to read them
      if (n > left_) return false;
      next_ += n;
      left_ -= n;
      consumed_ += n;
      return true;
    }
    char scratch[4096];
    while (n > 0) {
      const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(n, sizeof scratch));
      char* to = out ? out : scratch;
      const std::size_t got = compressed_ ? inflate_into(to, want) : read_stored(to, want);
      if (got == 0) return false;
      consumed_ += got;
      n -= got;
      if (out) out += got;
    }
    return true;
  }
  // Bytes read (or skipped) so far.
  std::uint64_t consumed() const { return consumed_; }

 private:
  std::size_t read_stored(char* to, std::size_t want) {
    const std::size_t take = static_cast<std::size_t>(std::min<std::uint64_t>(want, left_));
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(next_));
    in_.read(to, static_cast<std::streamsize>(take));
    const auto got = static_cast<std::size_t>(std::max<std::streamsize>(0, in_.gcount()));
    next_ += got;
    left_ -= got;
    return got;
  }
  std::size_t inflate_into(char* to, std::size_t want) {
    z_.next_out = reinterpret_cast<Bytef*>(to);
    z_.avail_out = static_cast<uInt>(want);
    while (z_.avail_out > 0 && !ended_) {
      if (z_.avail_in == 0) {
        const std::size_t got = read_stored(in_buf_, sizeof in_buf_);
        if (got == 0) break;
        z_.next_in = reinterpret_cast<Bytef*>(in_buf_);
        z_.avail_in = static_cast<uInt>(got);
      }
      const int rc = inflate(&z_, Z_NO_FLUSH);
      if (rc == Z_STREAM_END) ended_ = true;
      else if (rc != Z_OK) break;  // a damaged stream: matio reports it
    }
    return want - z_.avail_out;
  }

  std::ifstream& in_;
  std::uint64_t next_, left_;
  bool compressed_;
  bool ended_ = false;
  std::uint64_t consumed_ = 0;
  z_stream z_{};
  char in_buf_[4096];
};

// Walks the matrix in a MAT v5 element the way matio's Mat_GetDir, Mat_VarReadInfo and Mat_VarRead
// do (array flags, dimensions, name; for structs and objects the field names and each field's
// matrix, for cells each element's; the data subelements' tags), and refuses any length they would
// allocate before checking: a subelement or nested matrix longer than what is left of its parent, dimensions beyond 256,
// nesting beyond 32 levels (damaged tags declared gigabytes, and matio asked for them).
// Where the walk finds the real-part data of a numeric matrix — a top-level variable ("name") or
// a field of a top-level 1×1 struct ("struct.field") — so that it can be read later without
// inflating it anew from the start for every part (what matio does for a compressed variable).
struct Mat5Data {
  std::uint64_t element = 0;  // the top-level element's tag
  std::uint32_t element_bytes = 0;
  bool compressed = false;
  std::uint32_t type = 0;     // MAT data type of the values (miDOUBLE, miINT16, …)
  std::uint64_t offset = 0;   // of the first value, in MatElementBytes' stream of the element
  std::uint64_t bytes = 0;    // of the values
};
struct Mat5Layout {
  std::map<std::string, Mat5Data> vars;
  bool read_by_stend = false;  // a little-endian MAT 5 file: every numeric variable is read from here
};

// Bytes of one value of MAT data type `type`, 0 for a type that is not a number.
std::size_t mat_value_bytes(std::uint32_t type) {
  switch (type) {
    case 1: case 2: return 1;     // miINT8, miUINT8
    case 3: case 4: return 2;     // miINT16, miUINT16
    case 5: case 6: case 7: return 4;  // miINT32, miUINT32, miSINGLE
    case 9: case 12: case 13: return 8;  // miDOUBLE, miINT64, miUINT64
    default: return 0;
  }
}

// The most bytes deflate can inflate from one: zlib's largest expansion, 1032:1 (zlib's FAQ).
constexpr std::uint64_t kMaxZlibExpansion = 1032;

template <class U32>
class MatMatrixWalk {
 public:
  MatMatrixWalk(const fs::path& file, std::uint64_t pos, MatElementBytes& bytes, const U32& u32,
                Mat5Data where = {}, Mat5Layout* layout = nullptr)
      : file_(file), pos_(pos), bytes_(bytes), u32_(u32), where_(where), layout_(layout) {}

  // The top-level matrix: its own tag first (inflated, for a compressed element).
  void top(bool compressed, std::uint32_t declared) {
    std::uint64_t left = declared;
    if (compressed) {
      char tag[8];
      if (!bytes_.read(tag, 8) || u32_(tag) != kMiMatrix) return;  // matio says what is wrong
      left = u32_(tag + 4);
      // Every length inside is bounded by this one, which matio takes as given (4 GB calloc'ed for
      // the dimensions of an 83-byte element declaring 1 GB: the fuzz target's find).
      if (left > kMaxZlibExpansion * declared + 64)
        fail(0, "declares " + std::to_string(left) + " bytes inflated from " + std::to_string(declared) +
                    " compressed bytes (deflate inflates at most " + std::to_string(kMaxZlibExpansion) + " bytes from one)");
    }
    matrix(left, 0, {});
  }

 private:
  static constexpr std::uint32_t kMiInt8 = 1, kMiInt32 = 5, kMiUint32 = 6, kMiMatrix = 14;
  static constexpr std::uint64_t kMaxDimensionBytes = 256 * 4;
  static constexpr int kMaxDepth = 32;
  enum : std::uint32_t { kCell = 1, kStruct = 2, kObject = 3, kFunction = 16, kOpaque = 17 };

  [[noreturn]] void fail(int depth, const std::string& what) const {
    const std::string which =
        depth == 0 ? "the matrix in this element" : "a matrix nested " + std::to_string(depth) + " deep in this element";
    throw ImportError(file_, ByteOffset{pos_}, which + " " + what + " (damaged .mat)");
  }

  // One subelement of MAT data type `type` inside the `left` bytes of its matrix: its tag, then its
  // data (into `keep`, or skipped); `max` bounds its length. False when the element ends first
  // (matio reports it). A tag of another type, or a small element declaring more than the 4 bytes
  // its tag holds, is damage: matio does not read such a tag as the walk would, and took the
  // bytes after it for other lengths (4 GB for a name: the fuzz target's find).
  bool subelement(std::uint64_t& left, int depth, const char* what, std::uint32_t type, std::uint64_t max,
                  std::string* keep = nullptr) {
    char tag[8];
    if (left < 8 || !bytes_.read(tag, 8)) return false;
    left -= 8;
    const std::uint32_t word = u32_(tag), small = word >> 16;  // a small element: its length in the upper half
    if ((word & 0xffff) != type)
      fail(depth, "declares " + std::string(what) + " of MAT data type " + std::to_string(small ? word & 0xffff : word) +
                      " (" + std::to_string(type) + " expected)");
    if (small > 4) fail(depth, "declares " + std::string(what) + " of " + std::to_string(small) + " bytes in a 4-byte small element");
    if (small != 0) {  // its data in the tag
      if (keep) keep->assign(tag + 4, small);
      return true;
    }
    const std::uint64_t n = u32_(tag + 4), padded = n + (8 - n % 8) % 8;
    if (n > max) fail(depth, "declares " + std::to_string(n) + " bytes of " + what);
    if (padded > left)
      fail(depth, "declares " + std::to_string(n) + " bytes of " + what + " where " + std::to_string(left) + " are left");
    left -= padded;
    if (!keep) return bytes_.read(nullptr, padded);
    // Kept a piece at a time: a compressed element's declared lengths are not bytes that exist
    // (3.6 GB reserved up front for a damaged name: the fuzz target's find).
    keep->clear();
    for (std::uint64_t got = 0; got < n;) {
      const std::size_t piece = static_cast<std::size_t>(std::min<std::uint64_t>(n - got, 65536));
      keep->resize(static_cast<std::size_t>(got) + piece);
      if (!bytes_.read(keep->data() + got, piece)) return false;
      got += piece;
    }
    return bytes_.read(nullptr, padded - n);
  }

  // The matrix whose `left` bytes follow (its tag read); returns with the stream wherever the
  // walk stopped inside it. `field`: its name as a field of a top-level struct ("" otherwise).
  void matrix(std::uint64_t& left, int depth, const std::string& field) {
    if (depth > kMaxDepth) fail(depth, "is nested deeper than " + std::to_string(kMaxDepth) + " levels");
    constexpr std::uint64_t kAny = ~std::uint64_t{0};
    std::string flags, dims, name;
    // matio reads the flags as 8 bytes whatever their tag says and the dimensions' tag right after:
    // any other length would have the walk and matio read different bytes as the dimensions and the
    // name (checked from the tag too: a longer one may not be there to be read).
    constexpr const char* kFlags = "array flags (8 expected)";
    if (!subelement(left, depth, kFlags, kMiUint32, 8, &flags)) return;
    if (flags.size() != 8) fail(depth, "declares " + std::to_string(flags.size()) + " bytes of " + kFlags);
    if ((u32_(flags.data()) & 0xff) == kOpaque) {  // a MATLAB object (datetime, string, table, …): no dimensions
      if (subelement(left, depth, "name", kMiInt8, kAny) && subelement(left, depth, "type system name", kMiInt8, kAny))
        subelement(left, depth, "class name", kMiInt8, kAny);
      return;  // its data (a matrix only MATLAB reads) is not Stend's, nor read by matio to list it
    }
    if (!subelement(left, depth, "dimensions (at most 256 dimensions of 4 bytes)", kMiInt32, kMaxDimensionBytes, &dims))
      return;
    if (dims.size() < 8 || dims.size() % 4 != 0)
      fail(depth, "declares " + std::to_string(dims.size()) + " bytes of dimensions (2 or more of 4 bytes expected)");
    if (!subelement(left, depth, "name", kMiInt8, kAny, &name)) return;
    const std::uint32_t cls = u32_(flags.data()) & 0xff;
    if (cls == kObject && !subelement(left, depth, "class name", kMiInt8, kAny)) return;
    std::vector<std::string> fields;
    if (cls == kStruct || cls == kObject) {
      std::string length, names;
      constexpr const char* kLength = "field name length (4 expected)";  // matio reads 4 bytes whatever the tag says
      if (!subelement(left, depth, kLength, kMiInt32, 4, &length)) return;
      if (length.size() != 4) fail(depth, "declares " + std::to_string(length.size()) + " bytes of " + kLength);
      if (!subelement(left, depth, "field names", kMiInt8, kAny, &names)) return;
      // A 1×1 top-level struct's field names, NUL-padded to the stated length, in order.
      const std::uint32_t each = u32_(length.data());
      check_members(dims, each > 0 ? names.size() / each : 0, left, depth);
      if (depth == 0 && each > 0 && one_element(dims))
        for (std::size_t at = 0; at + each <= names.size(); at += each)
          fields.push_back(names.substr(at, names.find('\0', at) == std::string::npos
                                                ? each
                                                : std::min<std::size_t>(each, names.find('\0', at) - at)));
    } else if (cls == kCell || cls == kFunction) {  // (matio reads a function handle's parts as cell elements)
      check_members(dims, 1, left, depth);
    } else {
      const bool noted = layout_ && cls >= kFirstNumeric && cls <= kLastNumeric && (depth == 0 || !field.empty());
      const bool complex = (u32_(flags.data()) & kComplexFlag) != 0;
      const bool numeric = cls >= kFirstNumeric && cls <= kLastNumeric;
      data(left, depth, cls == kSparse || complex, numeric ? elements(dims) : -1.0L,
           noted ? (depth == 0 ? name : field) : std::string());
      return;
    }
    std::size_t index = 0;
    while (left >= 8) {  // the fields or cell elements, each a matrix
      char tag[8];
      if (!bytes_.read(tag, 8)) return;
      left -= 8;
      std::uint64_t n = u32_(tag + 4);
      if (u32_(tag) != kMiMatrix)
        fail(depth, "holds an element of data type " + std::to_string(u32_(tag)) + " where a matrix (14) is expected");
      if (n > left) fail(depth, "holds a matrix of " + std::to_string(n) + " bytes where " + std::to_string(left) + " are left");
      left -= n;
      matrix(n, depth + 1, index < fields.size() ? name + "." + fields[index] : std::string());
      ++index;
      if (!bytes_.read(nullptr, n)) return;  // the rest of the nested matrix (its data)
    }
  }

  // matio allocates a pointer per cell element (per element and field of a struct) before it reads
  // them (2 GB for a cell declaring 2^28 elements: the fuzz target's find); each is a matrix of at
  // least its 8-byte tag, so that many must fit in the `left` bytes.
  void check_members(const std::string& dims, std::uint64_t per_element, std::uint64_t left, int depth) const {
    const long double count = per_element * elements(dims);
    if (count * 8 > static_cast<long double>(left))
      fail(depth, "declares " + count_text(count) + " cell elements or struct fields where " +
                      std::to_string(left) + " bytes hold at most " + std::to_string(left / 8));
  }

  // The number of elements dimensions (int32 each) declare; and such a count as text.
  long double elements(const std::string& dims) const {
    long double count = 1;
    for (std::size_t at = 0; at + 4 <= dims.size(); at += 4) count *= u32_(dims.data() + at);
    return count;
  }
  static std::string count_text(long double count) {
    return count < 1e18L ? std::to_string(static_cast<std::uint64_t>(count)) : std::string("over 10^18");
  }

  // Dimensions (int32 each) of exactly one element.
  bool one_element(const std::string& dims) const {
    for (std::size_t at = 0; at + 4 <= dims.size(); at += 4)
      if (u32_(dims.data() + at) != 1) return false;
    return !dims.empty();
  }

  // The data subelements of a numeric, char, sparse or logical matrix, whose first tag comes next:
  // the real part (a sparse matrix's row and column indices before it, an imaginary part after).
  // matio sizes some of them from their tags (a char array's UTF-8 data, the sparse parts), so each
  // must lie inside its matrix. `all`: walk past the first one to the others (sparse, complex);
  // a real matrix's one subelement is only checked, never read (it may be 10^7 compressed values).
  // `values` (numeric classes; else negative): how many its dimensions declare, which matio allocates
  // before reading them, so the real part must be of a numeric type and hold them all.
  // `key` (non-empty): note where the real part's values lie in the layout.
  void data(std::uint64_t& left, int depth, bool all, long double values, const std::string& key) {
    for (bool first = true; left >= 8; first = false) {
      char tag[8];
      if (!bytes_.read(tag, 8)) return;
      left -= 8;
      const std::uint32_t type = u32_(tag);
      const bool small = (type >> 16) != 0;  // its length in the upper half, its data in the tag
      const std::uint64_t n = small ? type >> 16 : u32_(tag + 4), padded = small ? 0 : n + (8 - n % 8) % 8;
      if (n > 4 && small) fail(depth, "declares " + std::to_string(n) + " bytes of data in a 4-byte small element");
      if (!small && n > left)  // (the padding after the last one may be missing)
        fail(depth, "declares " + std::to_string(n) + " bytes of data where " + std::to_string(left) + " are left");
      if (first && values > 0) {
        const std::uint32_t value_type = small ? type & 0xffff : type;
        const std::size_t each = mat_value_bytes(value_type);
        if (each == 0) fail(depth, "declares its values of MAT data type " + std::to_string(value_type) + ", not a number");
        if (values * each > static_cast<long double>(n))
          fail(depth, "declares " + count_text(values) + " values where its data holds " + std::to_string(n / each));
      }
      if (first && !key.empty())
        layout_->vars[key] = Mat5Data{where_.element, where_.element_bytes, where_.compressed, small ? type & 0xffff : type,
                                   bytes_.consumed() - (small ? 4 : 0), n};
      if (!all) return;
      const std::uint64_t skip = std::min(padded, left);
      left -= skip;
      if (!bytes_.read(nullptr, skip)) return;
    }
  }

  static constexpr std::uint32_t kFirstNumeric = 6, kLastNumeric = 15;  // mxDOUBLE … mxUINT64
  static constexpr std::uint32_t kSparse = 5, kComplexFlag = 0x0800;     // array flags: class, complex bit
  const fs::path& file_;
  std::uint64_t pos_;
  MatElementBytes& bytes_;
  const U32& u32_;
  Mat5Data where_;
  Mat5Layout* layout_;
};

// Whether the 128-byte header is a MAT 5 (version 0x0100) or 7.3 (0x0200, HDF5) file's: the
// endian indicator "IM" (or "MI" from a big-endian writer) and the version beside it.
bool is_mat5_or_73_header(const std::string& header) {
  const bool le = header[126] == 'I' && header[127] == 'M', be = header[126] == 'M' && header[127] == 'I';
  const auto lo = static_cast<std::uint8_t>(header[le ? 124 : 125]), hi = static_cast<std::uint8_t>(header[le ? 125 : 124]);
  return (le || be) && lo == 0 && (hi == 1 || hi == 2);
}

// A file without a MAT 5 header is what matio then tries as a MAT v4 file: variables one after
// another, each a header of five int32 (type MOPT, rows, columns, imaginary flag, name length with
// its NUL), the name, the data. matio allocates the name length and the data as declared, so each
// variable must be a valid v4 header whose name and data lie inside the file, else the file is
// refused here (it was 1.8 GB for a 54-byte file whose "name length" was text).
void check_mat4_variables(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  const std::uint64_t size = fs::file_size(file);
  const auto refuse = [&](std::uint64_t pos, const std::string& why) {
    throw ImportError(file, ByteOffset{pos}, why + " (not a MATLAB file: no MAT 5 header, and not a valid MAT v4 variable)");
  };
  for (std::uint64_t pos = 0; pos < size;) {
    std::array<std::uint8_t, 20> h{};
    if (size - pos < h.size()) refuse(pos, "a variable header needs 20 bytes, " + std::to_string(size - pos) + " are left");
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(reinterpret_cast<char*>(h.data()), h.size());
    const auto word = [&](std::size_t i, bool swap) {
      std::uint32_t v = 0;
      for (int b = 0; b < 4; ++b) v |= std::uint32_t{h[i * 4 + static_cast<std::size_t>(swap ? 3 - b : b)]} << (8 * b);
      return v;
    };
    // MOPT: M the byte order (0 little-, 1 big-endian; the other digits of old machines), O = 0,
    // P the data type (double, single, int32, int16, uint16, uint8), T full, text or sparse.
    const auto valid = [](std::uint32_t t) { return t < 5000 && t / 100 % 10 == 0 && t / 10 % 10 <= 5 && t % 10 <= 2; };
    const bool swap = !valid(word(0, false));
    const std::uint32_t type = word(0, swap), rows = word(1, swap), cols = word(2, swap), imag = word(3, swap),
                        name = word(4, swap);
    if (!valid(type)) refuse(pos, "the type word " + std::to_string(word(0, false)) + " is no MAT v4 type");
    if (rows > INT32_MAX || cols > INT32_MAX || imag > 1)
      refuse(pos, "the variable header declares " + std::to_string(rows) + " x " + std::to_string(cols) +
                      (imag > 1 ? " with an imaginary flag of " + std::to_string(imag) : std::string()));
    constexpr std::uint64_t kSize[] = {8, 4, 4, 2, 2, 1};
    const std::uint64_t left = size - pos - h.size();
    if (name == 0 || name > left)
      refuse(pos, "the variable name declares " + std::to_string(name) + " bytes where " + std::to_string(left) + " are left");
    const long double data = static_cast<long double>(rows) * cols * kSize[type / 10 % 10] * (imag ? 2 : 1);
    if (data > static_cast<long double>(left - name))
      refuse(pos, "the variable's data (" + std::to_string(rows) + " x " + std::to_string(cols) + (imag ? " complex" : "") +
                      " values of " + std::to_string(kSize[type / 10 % 10]) + " bytes) does not fit in the " +
                      std::to_string(left - name) + " bytes left");
    pos += h.size() + name + static_cast<std::uint64_t>(data);
  }
}

// Refuses a MAT v5 file whose top-level elements (8-byte tag: uint32 data type, uint32 byte
// count) are not matrices or compressed matrices lying inside the file, or whose matrices declare
// lengths matio would allocate unchecked (MatMatrixWalk), before matio reads it; returns where
// the numeric variables' data lie (Mat5Data). v7.3 files (HDF5, version 0x0200) are left to
// matio (an empty layout).
Mat5Layout check_mat5_elements(const fs::path& file) {
  Mat5Layout layout;
  std::ifstream in(file, std::ios::binary);
  std::string header(128, '\0');
  if (!in.read(header.data(), 128) || !is_mat5_or_73_header(header)) {
    check_mat4_variables(file);  // what matio tries for a file without a MAT 5 header
    return layout;
  }
  const bool swap = header[126] == 'M' && header[127] == 'I';
  const auto u32 = [swap](const char* p) {
    std::uint8_t b[4];
    std::memcpy(b, p, 4);
    if (swap) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
    return static_cast<std::uint32_t>(b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24);
  };
  const std::uint32_t version = swap ? static_cast<std::uint8_t>(header[124]) << 8 | static_cast<std::uint8_t>(header[125])
                                     : static_cast<std::uint8_t>(header[125]) << 8 | static_cast<std::uint8_t>(header[124]);
  if (version == 0x0200) {  // MAT 7.3: an HDF5 file after the 512-byte header block
    static const std::string kHdf5("\x89HDF\r\n\x1a\n", 8);
    std::string signature(8, '\0');
    if (!in.seekg(512) || !in.read(signature.data(), 8) || signature != kHdf5)
      throw ImportError(file, ByteOffset{512}, "its header says MAT 7.3 (HDF5), but no HDF5 file signature follows "
                                               "the header block (damaged or truncated .mat)");
    return layout;
  }
  constexpr std::uint32_t kMiMatrix = 14, kMiCompressed = 15;
  const std::uint64_t size = fs::file_size(file);
  struct Element {
    std::uint64_t pos;
    bool compressed;
    std::uint32_t bytes;
  };
  std::vector<Element> elements;  // all inside the file, then each one's dimensions
  for (std::uint64_t pos = 128; pos + 8 <= size;) {
    char tag[8];
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(tag, 8);
    const std::uint32_t type = u32(tag), bytes = u32(tag + 4);
    if ((type != kMiMatrix && type != kMiCompressed) || bytes > size - pos - 8) {
      throw ImportError(file, ByteOffset{pos},
                        "a top-level element of data type " + std::to_string(type) + " declares " +
                            std::to_string(bytes) + " bytes; expected a matrix (14) or compressed matrix (15) "
                            "inside the file, which ends at byte " + std::to_string(size) + " (damaged or truncated .mat)");
    }
    elements.push_back({pos, type == kMiCompressed, bytes});
    pos += 8 + bytes + (type == kMiMatrix ? (8 - bytes % 8) % 8 : 0);
  }
  for (const auto& e : elements) {
    MatElementBytes bytes(in, e.pos, e.bytes, e.compressed);
    MatMatrixWalk(file, e.pos, bytes, u32, Mat5Data{e.pos, e.bytes, e.compressed}, &layout).top(e.compressed, e.bytes);
  }
  if (swap) layout.vars.clear();  // big-endian values: matio converts them
  layout.read_by_stend = !swap;
  return layout;
}

// The rows of a numeric variable — N×1, 1×N, N×3 or 3×N, taken as samples × components — read
// forward a block at a time, so that no variable is held whole.
class MatSeries {
 public:
  MatSeries(std::string which, std::size_t n_rows, std::size_t n_cols) : name(std::move(which)), rows(n_rows), cols(n_cols) {}
  virtual ~MatSeries() = default;
  // The next n rows into out (n × cols values, row after row).
  virtual void read(std::size_t n, double* out) = 0;
  // Every value (a scalar, or a short vector).
  std::vector<double> all() {
    std::vector<double> v(rows * cols);
    read(rows, v.data());
    return v;
  }
  std::string name;
  std::size_t rows, cols;
};

// Through matio's Mat_VarReadData (a hyperslab of a v7.3 file's dataset, or a seek in a v5 file).
class MatioSeries final : public MatSeries {
 public:
  MatioSeries(const fs::path& file, mat_t* mat, matvar_t* info, std::size_t n_rows, std::size_t n_cols, bool along_first)
      : MatSeries(info->name ? info->name : "", n_rows, n_cols), file_(file), mat_(mat), info_(info),
        along_first_(along_first) {}
  void read(std::size_t n, double* out) override {
    if (n == 0) return;
    std::vector<char> raw(n * cols * Mat_SizeOfClass(info_->class_type));
    int start[2] = {0, 0}, stride[2] = {1, 1}, edge[2] = {0, 0};
    const int k = along_first_ ? 0 : 1;
    start[k] = static_cast<int>(next_);
    edge[k] = static_cast<int>(n);
    edge[1 - k] = static_cast<int>(cols);
    if (Mat_VarReadData(mat_, info_, raw.data(), start, stride, edge) != 0)
      throw ImportError(file_, 0, "matio cannot read rows " + std::to_string(next_ + 1) + "… of '" + name + "'");
    // Column-major: rows first (n × cols) when the samples run along the first dimension.
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t c = 0; c < cols; ++c)
        out[i * cols + c] = value(raw.data(), along_first_ ? i + c * n : c + i * cols);
    next_ += n;
  }

 private:
  double value(const char* raw, std::size_t i) const {
    auto at = [&](auto v) {
      std::memcpy(&v, raw + i * sizeof v, sizeof v);
      return static_cast<double>(v);
    };
    switch (info_->class_type) {
      case MAT_C_DOUBLE: return at(double{});
      case MAT_C_SINGLE: return at(float{});
      case MAT_C_INT8: return at(std::int8_t{});
      case MAT_C_UINT8: return at(std::uint8_t{});
      case MAT_C_INT16: return at(std::int16_t{});
      case MAT_C_UINT16: return at(std::uint16_t{});
      case MAT_C_INT32: return at(std::int32_t{});
      case MAT_C_UINT32: return at(std::uint32_t{});
      case MAT_C_INT64: return at(std::int64_t{});
      case MAT_C_UINT64: return at(std::uint64_t{});
      default: return std::nan("");
    }
  }
  fs::path file_;
  mat_t* mat_;
  matvar_t* info_;
  bool along_first_;
  std::size_t next_ = 0;
};

// A v5 variable's values read straight from its element (Mat5Data): a compressed one inflated
// once, forwards, by one cursor per column (matio inflates it from its start for every read).
class Mat5Series final : public MatSeries {
 public:
  Mat5Series(const fs::path& file, const std::string& which, const Mat5Data& d, std::size_t n_rows, std::size_t n_cols,
             bool along_first)
      : MatSeries(which, n_rows, n_cols), file_(file), in_(file, std::ios::binary), type_(d.type),
        along_first_(along_first) {
    const std::size_t streams = along_first ? cols : 1;
    for (std::size_t c = 0; c < streams; ++c) {
      cursors_.push_back(std::make_unique<MatElementBytes>(in_, d.element, d.element_bytes, d.compressed));
      if (!cursors_.back()->read(nullptr, d.offset + c * rows * mat_value_bytes(type_))) fail();
    }
  }
  void read(std::size_t n, double* out) override {
    const std::size_t size = mat_value_bytes(type_);
    if (along_first_) {
      raw_.resize(n * size);
      for (std::size_t c = 0; c < cols; ++c) {
        if (!cursors_[c]->read(raw_.data(), raw_.size())) fail();
        for (std::size_t i = 0; i < n; ++i) out[i * cols + c] = value(raw_.data() + i * size);
      }
    } else {
      raw_.resize(n * cols * size);
      if (!cursors_[0]->read(raw_.data(), raw_.size())) fail();
      for (std::size_t i = 0; i < n * cols; ++i) out[i] = value(raw_.data() + i * size);
    }
  }

 private:
  [[noreturn]] void fail() const {
    throw ImportError(file_, 0, "the values of '" + name + "' end before its dimensions say (damaged .mat)");
  }
  double value(const char* p) const {
    auto at = [p](auto v) {
      std::memcpy(&v, p, sizeof v);
      return static_cast<double>(v);
    };
    switch (type_) {
      case 1: return at(std::int8_t{});
      case 2: return at(std::uint8_t{});
      case 3: return at(std::int16_t{});
      case 4: return at(std::uint16_t{});
      case 5: return at(std::int32_t{});
      case 6: return at(std::uint32_t{});
      case 7: return at(float{});
      case 12: return at(std::int64_t{});
      case 13: return at(std::uint64_t{});
      default: return at(double{});
    }
  }
  fs::path file_;
  std::ifstream in_;
  std::uint32_t type_;
  bool along_first_;
  std::vector<std::unique_ptr<MatElementBytes>> cursors_;
  std::vector<char> raw_;
};

// The number of elements of struct array `s`, checked. matio's Mat_VarGetStructFieldByName
// indexes the field names and a field pointer per element and field unchecked, and matio can
// return a damaged struct without them (SEGV, twice a fuzz target's find: the segments struct,
// then a struct holding the variables): every field name and field pointer must be there, else the
// struct is damage.
std::size_t struct_elements(const fs::path& file, matvar_t* s) {
  const auto count = declared_elements(s);
  const unsigned nfields = Mat_VarGetNumberOfFields(s);
  char* const* names = Mat_VarGetStructFieldnames(s);
  const bool whole = count && (nfields == 0 || (names && s->data && s->nbytes / sizeof(matvar_t*) / nfields >= *count &&
                                                std::all_of(names, names + nfields, [](const char* n) { return n != nullptr; })));
  if (!whole)
    throw ImportError(file, 0, std::string(s->name ? s->name : "a struct") + ": a struct array of " +
                                   (count ? std::to_string(*count) : "more elements than a size_t counts") +
                                   " whose field names or fields matio could not read (damaged)");
  return *count;
}

// Field `name` of element `index` of struct array `s` (nullptr when it has none; damage throws).
matvar_t* struct_field(const fs::path& file, matvar_t* s, const char* name, std::size_t index) {
  return index < struct_elements(file, s) ? Mat_VarGetStructFieldByName(s, name, index) : nullptr;
}

// The variables of the file (top level or one struct's fields), by name: their headers, and
// their values through a MatSeries as they are needed.
class MatSource {
 public:
  MatSource(const fs::path& file, const std::string& struct_name) : file_(file) {
    layout_ = check_mat5_elements(file);
    silence_hdf5_error_printing();  // a MAT 7.3 file is HDF5: its errors are this importer's to report
    mat_.reset(Mat_Open(file.c_str(), MAT_ACC_RDONLY));
    if (!mat_) throw ImportError(file, 0, "matio cannot open it as a MATLAB file (missing, or not a .mat)");
    std::size_t n = 0;
    char** dir = Mat_GetDir(mat_.get(), &n);
    if (!dir) throw ImportError(file, 0, "matio cannot list its variables");
    std::vector<std::string> names(dir, dir + n);
    for (const auto& nm : names) check_declared_size(nm);
    if (!struct_name.empty()) {
      root_.reset(Mat_VarReadInfo(mat_.get(), struct_name.c_str()));
      if (!root_ || root_->class_type != MAT_C_STRUCT) {
        throw ImportError(file, 0, "no struct variable named '" + struct_name + "'");
      }
      return;
    }
    for (const auto& nm : names) {
      MatVar v(Mat_VarReadInfo(mat_.get(), nm.c_str()));
      if (!v) continue;
      top_[nm] = std::move(v);
    }
    bool has_acc = top_.count("acc") || top_.count("accel") || top_.count("accelerometer") ||
                   top_.count("acc_counts");
    if (!has_acc) {
      for (auto& [nm, v] : top_) {
        if (v->class_type == MAT_C_STRUCT) {
          root_ = std::move(v);
          top_.clear();
          break;
        }
      }
    }
  }
  // Refuses a variable whose header declares more data than the file can hold (compressed
  // variables: zlib's largest expansion) before matio allocates it.
  void check_declared_size(const std::string& name) const {
    MatVar info(Mat_VarReadInfo(mat_.get(), name.c_str()));
    if (!info) return;  // unreadable: Mat_VarRead says so, or skips it
    const double file_bytes = static_cast<double>(fs::file_size(file_));
    const double declared = static_cast<double>(Mat_VarGetSize(info.get()));
    if (declared > static_cast<double>(kMaxZlibExpansion) * file_bytes + 4096.0) {
      throw ImportError(file_, 0, "variable '" + name + "' declares " + std::to_string(Mat_VarGetSize(info.get())) +
                                      " bytes of data, more than a file of " + std::to_string(fs::file_size(file_)) +
                                      " bytes can hold (damaged header?)");
    }
  }

  // The header of the first of `names` present (a struct field's, with a struct root).
  matvar_t* get(std::initializer_list<const char*> names) const {
    for (const char* n : names) {
      if (root_) {
        matvar_t* f = struct_field(file_, root_.get(), n, 0);
        if (f) return f;
      } else {
        auto it = top_.find(n);
        if (it != top_.end()) return it->second.get();
      }
    }
    return nullptr;
  }

  // The values of `v` (a header from get(), a real numeric matrix with one of its dimensions 1
  // or `cols`, the other the samples) as `which` names it; nullptr when its shape is not that.
  std::unique_ptr<MatSeries> series(matvar_t* v, const std::string& which, std::size_t cols) const {
    if (v->rank != 2 || v->isComplex || v->class_type < MAT_C_DOUBLE || v->class_type > MAT_C_UINT64) return nullptr;
    const std::size_t r = v->dims[0], c = v->dims[1];
    const bool along_first = c == cols;  // N × cols (a 1 × 1 scalar too)
    if (!along_first && r != cols) return nullptr;
    const std::size_t rows = along_first ? r : c;
    const std::string key = root_ && root_->name ? std::string(root_->name) + "." + which : which;
    // A little-endian MAT 5 variable (top level, or a field of a 1×1 struct) is read by Stend itself, never by matio (which leaked its
    // inflate state reading a damaged compressed one: the fuzz target's find): it must have been
    // found by the element walk, and its data must hold what its dimensions declare.
    const bool walked = !root_ || (root_->rank == 2 && root_->dims[0] == 1 && root_->dims[1] == 1);
    if (layout_.read_by_stend && walked) {
      const auto it = layout_.vars.find(key);
      if (it == layout_.vars.end())
        throw ImportError(file_, 0, "'" + which + "': its data element was not found where its matrix declares it (damaged)");
      const std::uint64_t needed = mat_value_bytes(it->second.type) * rows * cols;
      if (needed != it->second.bytes)
        throw ImportError(file_, 0, "'" + which + "' is " + std::to_string(r) + "x" + std::to_string(c) + ", " +
                                        std::to_string(needed) + " bytes of data, but its data element holds " +
                                        std::to_string(it->second.bytes) + " (damaged)");
      return std::make_unique<Mat5Series>(file_, which, it->second, rows, cols, along_first);
    }
    return std::make_unique<MatioSeries>(file_, mat_.get(), v, rows, cols, along_first);
  }

  // The segments struct array, read whole (it is small); with a struct root holding it, the root
  // is read whole as well (matio reads a struct's fields together).
  const matvar_t* segments() {
    if (!root_) {
      if (!top_.count("segments")) return nullptr;
      whole_.reset(Mat_VarRead(mat_.get(), "segments"));
      return whole_.get();
    }
    if (!struct_field(file_, root_.get(), "segments", 0) || !root_->name) return nullptr;
    whole_.reset(Mat_VarRead(mat_.get(), root_->name));
    segments_in_root_ = true;
    return whole_ ? struct_field(file_, whole_.get(), "segments", 0) : nullptr;
  }
  bool segments_in_root() const { return segments_in_root_; }
  const fs::path& file() const { return file_; }

 private:
  fs::path file_;
  Mat5Layout layout_;
  MatFile mat_;
  MatVar root_;
  std::map<std::string, MatVar> top_;
  MatVar whole_;
  bool segments_in_root_ = false;
};

// The N×3 or 3×N matrix under the first of `names` present (nullptr when none is).
std::unique_ptr<MatSeries> triad(const MatSource& src, std::initializer_list<const char*> names) {
  matvar_t* v = src.get(names);
  if (!v) return nullptr;
  const std::string which = v->name ? v->name : *names.begin();
  auto s = src.series(v, which, 3);
  if (s) return s;
  if (v->rank == 2 && !v->isComplex && v->class_type >= MAT_C_DOUBLE && v->class_type <= MAT_C_UINT64) {
    throw ImportError(src.file(), 0, "'" + which + "' is " + std::to_string(v->dims[0]) + "x" +
                                         std::to_string(v->dims[1]) + ", expected N x 3");
  }
  throw ImportError(src.file(), 0, "'" + which + "' is not a real numeric matrix");
}

// The vector (or scalar) under the first of `names` present (nullptr when none is).
std::unique_ptr<MatSeries> vector_of(const MatSource& src, std::initializer_list<const char*> names) {
  matvar_t* v = src.get(names);
  if (!v) return nullptr;
  const std::string which = v->name ? v->name : *names.begin();
  auto s = src.series(v, which, 1);
  if (!s) throw ImportError(src.file(), 0, "'" + which + "' is not a real numeric vector");
  return s;
}

MatVar make_double(const char* name, std::size_t rows, std::size_t cols, const double* data) {
  std::size_t dims[2] = {rows, cols};
  return MatVar(Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, const_cast<double*>(data), 0));
}
MatVar make_int32(const char* name, std::size_t rows, std::size_t cols, const std::int32_t* data) {
  std::size_t dims[2] = {rows, cols};
  return MatVar(Mat_VarCreate(name, MAT_C_INT32, MAT_T_INT32, 2, dims, const_cast<std::int32_t*>(data), 0));
}
MatVar make_text(const char* name, const std::string& s) {
  std::size_t dims[2] = {1, s.size()};
  return MatVar(Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UINT8, 2, dims, const_cast<char*>(s.data()), 0));
}

// The variables an import looks for, as found (nullptr when absent): the series read as the
// samples are made, the scalars read whole.
struct MatData {
  std::unique_ptr<MatSeries> acc, gyr, acc_counts, gyr_counts, t, temp;
  std::string fs_name;
  std::vector<double> rate_v, acc_lsb_v, gyr_lsb_v;
  bool have_fs = false, have_acc_lsb = false, have_gyr_lsb = false;

  std::size_t rows() const { return acc ? acc->rows : acc_counts->rows; }
  bool fixed_rate() const { return have_fs && rate_v.size() == 1 && rate_v[0] > 0.0; }
  double acc_lsb() const { return have_acc_lsb && !acc_lsb_v.empty() ? acc_lsb_v[0] : 0.0; }
  double gyr_lsb() const { return have_gyr_lsb && !gyr_lsb_v.empty() ? gyr_lsb_v[0] : 0.0; }
  bool has_gyro() const { return gyr || (gyr_counts && gyr_lsb() > 0.0); }
};

// A scalar-like variable's values (at most kMaxScalar of them are kept: a longer one is no scalar).
bool small_values(const MatSource& src, std::initializer_list<const char*> names, std::vector<double>& out,
                  std::string* which = nullptr) {
  constexpr std::size_t kMaxScalar = 16;
  auto s = vector_of(src, names);
  if (!s) return false;
  if (which) *which = s->name;
  if (s->rows * s->cols <= kMaxScalar) out = s->all();
  else out.assign(2, 0.0);  // not one value
  return true;
}

// Finds the variables (or struct fields) under their accepted names.
MatData read_mat_data(const MatSource& src) {
  MatData m;
  m.acc = triad(src, {"acc", "accel", "accelerometer"});
  m.acc_counts = triad(src, {"acc_counts"});
  m.gyr = triad(src, {"gyro", "gyr", "gyroscope"});
  m.gyr_counts = triad(src, {"gyro_counts", "gyr_counts"});
  m.t = vector_of(src, {"t", "time", "timestamp"});
  m.have_fs = small_values(src, {"fs", "rate_hz", "rate"}, m.rate_v, &m.fs_name);
  m.temp = vector_of(src, {"temp", "temperature"});
  m.have_acc_lsb = small_values(src, {"acc_lsb"}, m.acc_lsb_v);
  m.have_gyr_lsb = small_values(src, {"gyro_lsb", "gyr_lsb"}, m.gyr_lsb_v);
  return m;
}

// An accelerometer (SI or counts with LSB), every series as long as it, and a time or a rate.
void check_mat_data(const fs::path& file, const MatData& m) {
  if (!m.acc && !(m.acc_counts && m.have_acc_lsb)) {
    throw ImportError(file, 0, "no accelerometer: expected a variable/field 'acc' (N x 3, m/s^2), or "
                               "'acc_counts' with 'acc_lsb'");
  }
  const std::size_t n = m.rows();
  for (const MatSeries* s : {m.acc_counts.get(), m.gyr.get(), m.gyr_counts.get(), m.temp.get(), m.t.get()}) {
    if (s && s->rows != n) {
      throw ImportError(file, 0, "'" + s->name + "' has " + std::to_string(s->rows) + " rows, the accelerometer " +
                                     std::to_string(n));
    }
  }
  if (!m.t && !m.fixed_rate()) {
    throw ImportError(file, 0, "no time: expected 't' (N-vector, s) or a positive scalar 'fs' (Hz)");
  }
}

// The samples in blocks: each series' next rows, then row i of the block as a sample — time [s]
// (t × time_scale_s, or i / fs), acceleration [m/s²] and rate [rad/s] (SI × scale, or counts ×
// LSB), counts, temperature [°C] — handed to `out`. Returns how many.
std::size_t stream_mat_samples(const fs::path& file, MatData& m, const MatOptions& opt, SampleSink& out) {
  constexpr std::size_t kBlock = 1 << 14;
  const std::size_t n = m.rows();
  const bool has_gyro = m.has_gyro();
  std::vector<double> acc, acc_c, gyr, gyr_c, t, temp;
  std::vector<ImuSample> block;
  double t_prev = -std::numeric_limits<double>::infinity();
  for (std::size_t first = 0; first < n; first += kBlock) {
    const std::size_t k = std::min(kBlock, n - first);
    auto take = [k](MatSeries* s, std::vector<double>& buf) {
      if (!s) return;
      buf.resize(k * s->cols);
      s->read(k, buf.data());
    };
    take(m.acc.get(), acc);
    take(m.acc_counts.get(), acc_c);
    take(m.gyr.get(), gyr);
    take(m.gyr_counts.get(), gyr_c);
    take(m.t.get(), t);
    take(m.temp.get(), temp);
    block.assign(k, ImuSample{});
    for (std::size_t j = 0; j < k; ++j) {
      ImuSample& s = block[j];
      const std::size_t i = first + j;
      s.t_s = m.t ? t[j] * opt.time_scale_s : static_cast<double>(i) / m.rate_v[0];
      if (m.t && s.t_s < t_prev) {  // repeats are repaired later
        throw ImportError(file, 0, "'" + m.t->name + "' goes back at element " + std::to_string(i + 1));
      }
      t_prev = s.t_s;
      for (std::size_t c = 0; c < 3; ++c) {
        const int ic = static_cast<int>(c);
        if (m.acc_counts) s.accel_counts[c] = static_cast<std::int32_t>(std::lround(acc_c[3 * j + c]));
        s.accel_mps2[ic] = m.acc ? acc[3 * j + c] * opt.accel_scale : acc_c[3 * j + c] * m.acc_lsb();
        if (m.gyr_counts) s.gyro_counts[c] = static_cast<std::int32_t>(std::lround(gyr_c[3 * j + c]));
        if (m.gyr) {
          s.gyro_radps[ic] = gyr[3 * j + c] * opt.gyro_scale;
        } else if (has_gyro) {
          s.gyro_radps[ic] = gyr_c[3 * j + c] * m.gyr_lsb();
        }
      }
      if (m.temp) s.temperature_c = temp[j];
    }
    out.add_samples(block.data(), block.size());
  }
  return n;
}

// Segments from a struct array 'segments' with fields kind, label, t_start_s, t_end_s [s].
void add_mat_segments(MatSource& src, const fs::path& file, Recording& rec) {
  const matvar_t* segs = src.segments();
  if (!segs) return;
  if (segs->class_type != MAT_C_STRUCT) {
    static constexpr const char* kClasses[] = {"empty",  "cell",   "struct", "object", "char",     "sparse",
                                               "double", "single", "int8",   "uint8",  "int16",    "uint16",
                                               "int32",  "uint32", "int64",  "uint64", "function", "object (opaque)"};
    const auto cls = static_cast<std::size_t>(segs->class_type);
    throw ImportError(file, 0, std::string("'segments' is a ") + (cls < std::size(kClasses) ? kClasses[cls] : "matrix") +
                                   " array; expected a struct array with fields kind, label, t_start_s, t_end_s [s]");
  }
  auto* sv = const_cast<matvar_t*>(segs);
  const std::size_t count = struct_elements(file, sv);
  for (std::size_t i = 0; i < count; ++i) {
    std::vector<double> a, b;
    std::size_t r = 0, c = 0;
    matvar_t* t0 = struct_field(file, sv, "t_start_s", i);
    matvar_t* t1 = struct_field(file, sv, "t_end_s", i);
    if (!numeric(t0, a, r, c) || a.size() != 1 || !numeric(t1, b, r, c) || b.size() != 1) {
      throw ImportError(file, 0, "segments(" + std::to_string(i + 1) +
                                     ") needs scalar fields t_start_s and t_end_s");
    }
    auto field_text = [&](const char* name) {
      const matvar_t* f = struct_field(file, sv, name, i);
      if (f && f->class_type != MAT_C_CHAR && declared_elements(f) != std::size_t{0})  // (MATLAB's [] for a field never set is fine)
        throw ImportError(file, 0, "segments(" + std::to_string(i + 1) + ")." + name + " is not text (a char array)");
      const auto t = text(f);
      if (!t) {
        throw ImportError(file, 0, "segments(" + std::to_string(i + 1) + ")." + name +
                                       " declares more characters than its data holds (damaged)");
      }
      return *t;
    };
    // kind: a segment kind's name; absent or empty means a static position ("orientation").
    const std::string kind_text = field_text("kind");
    const auto kind = kind_text.empty() ? SegmentKind::kOrientation : segment_kind_from_string(kind_text);
    if (!kind) {
      throw ImportError(file, 0, "segments(" + std::to_string(i + 1) + ").kind '" + kind_text +
                                     "' is not a segment kind (" + yaml::join(segment_kind_names()) + ")");
    }
    Segment seg = make_segment(static_cast<int>(i), *kind, field_text("label"), a[0], b[0]);
    rec.segments.push_back(seg);
  }
}

// Sensor description: rate [Hz] (fs, or from the median sample step), gyro, temperature, LSB sizes.
void set_mat_sensor_info(const MatData& m, const MatOptions& opt, Recording& rec) {
  SensorInfo& info = rec.header.info;
  info.output_rate_hz = m.fixed_rate() ? m.rate_v[0] : 0.0;  // 0: set by the timestamp repair
  info.has_gyro = m.has_gyro();
  info.has_temperature = m.temp != nullptr;
  info.accel_lsb_mps2 = m.acc_lsb();
  info.gyro_lsb_radps = m.gyr_lsb();
  rec.header.identity = opt.identity;
  rec.header.gravity_mps2 = opt.gravity_mps2;
}

}  // namespace

void import_mat(const fs::path& file, const MatOptions& opt, Recording& rec, SampleSink& out) {
  MatSource src(file, opt.struct_name);
  MatData m = read_mat_data(src);
  check_mat_data(file, m);
  rec = new_recording(file, "mat");
  add_mat_segments(src, file, rec);
  set_mat_sensor_info(m, opt, rec);
  std::size_t n = 0, gaps = 0;
  if (m.t) {
    TimestampRepairStream repair(rec, out, m.fixed_rate() ? m.rate_v[0] : 0.0);
    n = stream_mat_samples(file, m, opt, repair);
    gaps = repair.finish().gaps;
  } else {
    n = stream_mat_samples(file, m, opt, out);
  }
  const bool has_gyro = m.has_gyro();
  add_import_event(rec, "imported " + std::to_string(n) + " samples from " + file.string() +
                            " (MATLAB file" + (opt.struct_name.empty() ? "" : ", struct " + opt.struct_name) +
                            "; accel from '" + (m.acc ? m.acc->name : m.acc_counts->name) + "'" +
                            (has_gyro ? ", gyro from '" + (m.gyr ? m.gyr->name : m.gyr_counts->name) + "'" : ", no gyro") +
                            (m.t ? ", time '" + m.t->name + "'" : ", rate '" + m.fs_name + "'") +
                            (gaps ? "; " + std::to_string(gaps) + " gap(s) flagged" : "") +
                            (src.segments_in_root() ? "; the struct read whole for its segments" : "") + ")");
}

Recording import_mat(const fs::path& file, const MatOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_mat(file, opt, rec, out); });
}

namespace {

// The samples as column-major N x 1 / N x 3 arrays: time [s], acceleration [m/s²], rate [rad/s],
// their counts, temperature [°C].
struct MatColumns {
  std::vector<double> t, acc, gyr, temp;
  std::vector<std::int32_t> acc_c, gyr_c;
};

MatColumns mat_columns(const Recording& rec) {
  const std::size_t n = rec.samples.size();
  MatColumns m{std::vector<double>(n), std::vector<double>(3 * n), std::vector<double>(3 * n), std::vector<double>(n),
               std::vector<std::int32_t>(3 * n), std::vector<std::int32_t>(3 * n)};
  for (std::size_t i = 0; i < n; ++i) {
    const ImuSample& s = rec.samples[i];
    m.t[i] = s.t_s;
    m.temp[i] = s.temperature_c;
    for (std::size_t k = 0; k < 3; ++k) {
      const int ik = static_cast<int>(k);
      m.acc[i + k * n] = s.accel_mps2[ik];
      m.gyr[i + k * n] = s.gyro_radps[ik];
      m.acc_c[i + k * n] = s.accel_counts[k];
      m.gyr_c[i + k * n] = s.gyro_counts[k];
    }
  }
  return m;
}

// The segments as a struct array with fields kind, label, t_start_s, t_end_s [s].
MatVar segments_struct(const Recording& rec, const fs::path& file) {
  const char* segment_fields[] = {"kind", "label", "t_start_s", "t_end_s", nullptr};
  std::size_t dims[2] = {rec.segments.size(), 1};
  MatVar s(Mat_VarCreateStruct2("segments", 2, dims, segment_fields));
  if (!s) throw ImportError(file, 0, "matio failed to create 'segments'");
  for (std::size_t i = 0; i < rec.segments.size(); ++i) {
    const Segment& seg = rec.segments[i];
    Mat_VarSetStructFieldByName(s.get(), "kind", i, make_text("kind", to_string(seg.kind)).release());
    Mat_VarSetStructFieldByName(s.get(), "label", i, make_text("label", seg.label).release());
    Mat_VarSetStructFieldByName(s.get(), "t_start_s", i, make_double("t_start_s", 1, 1, &seg.t_start_s).release());
    Mat_VarSetStructFieldByName(s.get(), "t_end_s", i, make_double("t_end_s", 1, 1, &seg.t_end_s).release());
  }
  return s;
}

// Writes variables to a MAT file: at the top level each at once, or (struct_name given)
// collected and written as the fields of one struct by finish().
class MatWriter {
 public:
  MatWriter(mat_t* mat, const fs::path& file, const std::string& struct_name)
      : mat_(mat), file_(file), struct_name_(struct_name) {}

  void write(MatVar v, const char* what) {
    if (!v) throw ImportError(file_, 0, std::string("matio failed to create '") + what + "'");
    if (!struct_name_.empty()) {
      fields_.emplace_back(what, std::move(v));
      return;
    }
    if (Mat_VarWrite(mat_, v.get(), MAT_COMPRESSION_NONE) != 0) {
      throw ImportError(file_, 0, std::string("matio failed to write '") + what + "'");
    }
  }

  void finish() {
    if (struct_name_.empty()) return;
    std::vector<const char*> names;
    for (const auto& f : fields_) names.push_back(f.first.c_str());
    names.push_back(nullptr);
    std::size_t dims[2] = {1, 1};
    MatVar root(Mat_VarCreateStruct2(struct_name_.c_str(), 2, dims, names.data()));
    if (!root) throw ImportError(file_, 0, "matio failed to create struct '" + struct_name_ + "'");
    for (auto& f : fields_) Mat_VarSetStructFieldByName(root.get(), f.first.c_str(), 0, f.second.release());
    if (Mat_VarWrite(mat_, root.get(), MAT_COMPRESSION_NONE) != 0) {
      throw ImportError(file_, 0, "matio failed to write struct '" + struct_name_ + "'");
    }
  }

 private:
  mat_t* mat_;
  fs::path file_;
  std::string struct_name_;
  std::vector<std::pair<std::string, MatVar>> fields_;
};

}  // namespace

void export_mat(const Recording& rec, const fs::path& file, const std::string& struct_name) {
  MatFile mat(Mat_CreateVer(file.c_str(), nullptr, MAT_FT_MAT5));
  if (!mat) throw ImportError(file, 0, "matio cannot create it");
  const std::size_t n = rec.samples.size();
  const MatColumns c = mat_columns(rec);
  const double fs_hz = rec.header.info.output_rate_hz;
  const double acc_lsb = rec.header.info.accel_lsb_mps2, gyr_lsb = rec.header.info.gyro_lsb_radps;
  MatWriter w(mat.get(), file, struct_name);
  w.write(make_double("t", n, 1, c.t.data()), "t");
  w.write(make_double("fs", 1, 1, &fs_hz), "fs");
  w.write(make_double("acc", n, 3, c.acc.data()), "acc");
  w.write(make_int32("acc_counts", n, 3, c.acc_c.data()), "acc_counts");
  w.write(make_double("acc_lsb", 1, 1, &acc_lsb), "acc_lsb");
  if (rec.header.info.has_gyro) {
    w.write(make_double("gyro", n, 3, c.gyr.data()), "gyro");
    w.write(make_int32("gyro_counts", n, 3, c.gyr_c.data()), "gyro_counts");
    w.write(make_double("gyro_lsb", 1, 1, &gyr_lsb), "gyro_lsb");
  }
  if (rec.header.info.has_temperature) w.write(make_double("temp", n, 1, c.temp.data()), "temp");
  if (!rec.segments.empty()) w.write(segments_struct(rec, file), "segments");
  w.finish();
}

#else  // built without matio

namespace {
constexpr const char* kNoMatio =
    "MATLAB files need matio, and this stend_core was built without it (install libmatio-dev; "
    "io/CMakeLists.txt links PkgConfig::MATIO and defines STEND_HAVE_MATIO)";
}

bool mat_supported() { return false; }

Recording import_mat(const fs::path& file, const MatOptions&) { throw ImportError(file, 0, kNoMatio); }
void import_mat(const fs::path& file, const MatOptions&, Recording&, SampleSink&) { throw ImportError(file, 0, kNoMatio); }
void export_mat(const Recording&, const fs::path& file, const std::string&) {
  throw ImportError(file, 0, kNoMatio);
}

#endif

}  // namespace stend::io
