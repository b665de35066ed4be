// The MAT 5 element walk and its damage checks (check_mat5_elements in mat_file.hpp): every
// length a top-level element, a nested matrix or a subelement declares checked against what holds
// it before matio reads the file, and where each numeric variable's values lie, for Stend to read
// them itself. A file without a MAT 5 header is checked as matio would read it, as MAT v4.
#include "mat_file.hpp"

#include "import_common.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <new>
#include <utility>

namespace stend::io::detail {

namespace fs = std::filesystem;

MatElementBytes::MatElementBytes(std::ifstream& in, std::uint64_t pos, std::uint32_t bytes, bool compressed)
    : in_(in), next_(pos + 8), left_(bytes), compressed_(compressed) {
  if (compressed_ && inflateInit(&z_) != Z_OK) throw std::bad_alloc();
}

MatElementBytes::~MatElementBytes() {
  if (compressed_) inflateEnd(&z_);
}

bool MatElementBytes::read(char* out, std::uint64_t n) {
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

std::size_t MatElementBytes::read_stored(char* to, std::size_t want) {
  const std::size_t take = static_cast<std::size_t>(std::min<std::uint64_t>(want, left_));
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(next_));
  in_.read(to, static_cast<std::streamsize>(take));
  const auto got = static_cast<std::size_t>(std::max<std::streamsize>(0, in_.gcount()));
  next_ += got;
  left_ -= got;
  return got;
}

std::size_t MatElementBytes::inflate_into(char* to, std::size_t want) {
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

std::size_t mat_value_bytes(std::uint32_t type) {
  switch (type) {
    case 1: case 2: return 1;     // miINT8, miUINT8
    case 3: case 4: return 2;     // miINT16, miUINT16
    case 5: case 6: case 7: return 4;  // miINT32, miUINT32, miSINGLE
    case 9: case 12: case 13: return 8;  // miDOUBLE, miINT64, miUINT64
    default: return 0;
  }
}

namespace {

// Walks the matrix in a MAT v5 element the way matio's Mat_GetDir, Mat_VarReadInfo and Mat_VarRead
// do (array flags, dimensions, name; for structs and objects the field names and each field's
// matrix, for cells each element's; the data subelements' tags), and refuses any length they would
// allocate before checking: a subelement or nested matrix longer than what is left of its parent, dimensions beyond 256,
// nesting beyond 32 levels (damaged tags declared gigabytes, and matio asked for them).
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

}  // namespace

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

}  // namespace stend::io::detail
