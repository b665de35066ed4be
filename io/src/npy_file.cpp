// NumPy files as named arrays (open_npy in arrays.hpp): a .npy (np.save: one array, named by the
// file's stem) or an .npz (np.savez, np.savez_compressed: a zip of .npy members, each named without
// ".npy"). Every header is read and every shape checked against the bytes that hold it when the
// file is opened; the values are read forwards a block at a time, converted to double here.
#include "arrays.hpp"
#include "npy_header.hpp"
#include "zip_archive.hpp"

#include <stend/io/formats.hpp>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <unordered_set>

namespace stend::io {

namespace fs = std::filesystem;

bool looks_like_npy(const fs::path& p) {
  const std::string head = detail::file_prefix(p, detail::kZipLocalHeaderBytes);
  if (head.starts_with(detail::kNpyMagic)) return true;
  const auto* h = reinterpret_cast<const std::uint8_t*>(head.data());
  if (head.size() < detail::kZipLocalHeaderBytes || detail::load_le<std::uint32_t>(h) != detail::kZipLocalHeader) return false;
  const std::size_t n = detail::load_le<std::uint16_t>(h + 26);  // the first member's name
  const std::string name = detail::file_prefix(p, detail::kZipLocalHeaderBytes + n).substr(head.size());
  return name.size() == n && name.ends_with(".npy");
}

namespace detail {

namespace {

// Values converted per step of a read: bounds the buffer of raw bytes (8 bytes each at most).
constexpr std::size_t kBlockValues = 8192;
// The most components (columns, once samples run along the rows) of an array read: an IMU log's
// widest arrays hold tens; a reader of its rows holds a few thousand rows of it at once.
constexpr std::uint64_t kMaxColumns = 1024;

// One array: what arrays() lists, and where and how its values lie.
struct NpyArray {
  ArrayInfo info;
  ZipMember bytes;          // its .npy: an .npz's member, or the whole .npy file
  NpyHeader header;
  bool sequential = true;   // whole rows one after the other; else one component after the other
};

// The samples × components of a shape: (N,) → N×1, () → 1×1, (d0, d1) → d0×d1, read transposed
// (d1×d0) when the samples run along the second dimension: 1×N, 3×N and 4×N with N larger.
struct Orientation {
  std::uint64_t rows = 1, cols = 1;
  bool transposed = false;
};
Orientation orient(const std::vector<std::uint64_t>& shape) {
  const std::uint64_t d0 = shape.empty() ? 1 : shape[0], d1 = shape.size() < 2 ? 1 : shape[1];
  const bool t = (d0 == 1 && d1 > 1) || ((d0 == 3 || d0 == 4) && d1 > d0);
  return {t ? d1 : d0, t ? d0 : d1, t};
}

// The rows of one array through one cursor (rows one after the other) or one per component
// (cursor c starting at value c·rows).
class NpySeries final : public ArraySeries {
 public:
  NpySeries(const fs::path& file, const NpyArray& a)
      : ArraySeries(a.info.name, a.info.rows, a.info.cols), type_(a.header.type), sequential_(a.sequential) {
    const std::size_t cursors = sequential_ ? 1 : cols;
    for (std::size_t c = 0; c < cursors; ++c) {
      cursors_.push_back(std::make_unique<ZipMemberReader>(file, a.bytes));
      if (!cursors_.back()->skip(a.header.data + c * rows * type_.bytes)) cut(c);
    }
  }

  void read(std::size_t n, double* out) override {
    if (n > rows - next_)
      throw std::logic_error("'" + name + "': " + std::to_string(n) + " rows asked for after " + std::to_string(next_) +
                             " of " + std::to_string(rows));
    const std::size_t size = type_.bytes;
    if (sequential_) {  // the values in the order `out` takes them
      for (std::size_t done = 0, all = n * cols; done < all;) {
        const std::size_t k = std::min(kBlockValues, all - done);
        raw_.resize(k * size);
        if (!cursors_[0]->read(raw_.data(), raw_.size())) cut(0);
        to_doubles(type_, raw_.data(), k, size, out + done, 1);
        done += k;
      }
    } else {  // each component's next n values, into every cols-th place
      for (std::size_t done = 0; done < n;) {
        const std::size_t k = std::min(kBlockValues, n - done);
        raw_.resize(k * size);
        for (std::size_t c = 0; c < cols; ++c) {
          if (!cursors_[c]->read(raw_.data(), raw_.size())) cut(c);
          to_doubles(type_, raw_.data(), k, size, out + done * cols + c, cols);
        }
        done += k;
      }
    }
    next_ += n;
  }

 private:
  // The member's bytes end before the values its shape declares (a deflate stream ending early).
  [[noreturn]] void cut(std::size_t c) const {
    const ZipMemberReader& r = *cursors_[c];
    r.fail(r.position(), "the values of '" + name + "' end before the " + std::to_string(rows) + "x" +
                             std::to_string(cols) + " its shape declares (damaged, or cut short)");
  }

  ValueType type_;
  bool sequential_;
  std::vector<std::unique_ptr<ZipMemberReader>> cursors_;
  std::vector<std::uint8_t> raw_;
  std::size_t next_ = 0;
};

class NpyFile final : public ArrayFile {
 public:
  explicit NpyFile(const fs::path& file) : file_(file) {
    if (file_prefix(file, 4) != "PK\x03\x04") {
      add(whole_file(file), file.stem().string());
      layout_ = "NumPy .npy (version " + std::to_string(version_) + ".0)";
      return;
    }
    const BinaryReader zip(file);
    bool any = false, stored = false, deflated = false;
    for (const ZipMember& m : zip_members(zip)) {
      if (m.name.ends_with("/")) continue;  // a folder
      if (!m.name.ends_with(".npy")) {
        skipped_.push_back("'" + m.name + "' (not a .npy)");
        continue;
      }
      any = true;
      stored = stored || m.method == 0;
      deflated = deflated || m.deflated();
      add(m, m.name.substr(0, m.name.size() - 4));
    }
    if (!any) throw ImportError(file, 0, "a zip archive without a .npy member: not a NumPy .npz");
    const char* how = stored && deflated ? " (stored and deflated)" : stored ? " (stored)" : deflated ? " (deflated)" : "";
    layout_ = "NumPy .npz" + std::string(how) + ", " + std::to_string(arrays_.size()) + (arrays_.size() == 1 ? " array" : " arrays");
  }

  const fs::path& file() const override { return file_; }

  std::vector<ArrayInfo> arrays() const override {
    std::vector<ArrayInfo> out;
    for (const NpyArray& a : arrays_) out.push_back(a.info);
    return out;
  }

  std::unique_ptr<ArraySeries> open(const std::string& name) const override {
    for (const NpyArray& a : arrays_) {
      if (a.info.name != name) continue;
      if (!a.sequential && a.info.cols > kMaxComponentCursors)
        throw ImportError(file_, 0, "'" + name + "' is " + shape_text(a.header.shape) + (a.header.fortran_order ? " in Fortran order" : "") +
                                        ": its " + std::to_string(a.info.cols) + " components lie one after the other, and at most " +
                                        std::to_string(kMaxComponentCursors) + " are read so (np.ascontiguousarray(x) before saving)");
      return std::make_unique<NpySeries>(file_, a);
    }
    std::string list;
    for (const NpyArray& a : arrays_) list += (list.empty() ? "" : ", ") + a.info.name;
    throw ImportError(file_, 0, "no array named '" + name + "' (arrays: " + (list.empty() ? "none" : list) + ")");
  }

  std::string layout() const override {
    std::string s = layout_;
    for (std::size_t i = 0; i < skipped_.size(); ++i) s += (i ? ", " : "; not read: ") + skipped_[i];
    return s;
  }

 private:
  // The array of the .npy in `m`: its header read, its shape checked against the bytes after it.
  void add(const ZipMember& m, const std::string& name) {
    if (m.method != 0 && !m.deflated()) {
      skipped_.push_back("'" + m.name + "' (zip method " + std::to_string(m.method) + ")");
      return;
    }
    if (names_.count(name))  // a set beside arrays_: a crafted archive may hold very many
      throw ImportError(file_, ByteOffset{m.header}, "a second member named '" + m.name + "' (damaged)");
    ZipMemberReader in(file_, m);
    NpyArray a;
    a.info.name = name;
    a.bytes = m;
    a.header = read_npy_header(in);
    const NpyHeader& h = a.header;
    version_ = h.major;
    if (!h.unsupported.empty()) {
      skipped_.push_back("'" + name + "' (" + h.unsupported + ")");
      return;
    }
    const Orientation o = orient(h.shape);
    const std::uint64_t room = (m.size - h.data) / h.type.bytes;  // values the bytes after the header hold
    if ((o.cols != 0 && o.rows > std::numeric_limits<std::uint64_t>::max() / o.cols) || o.rows * o.cols > room)
      in.fail(h.data, "'" + name + "' declares shape " + shape_text(h.shape) + " of " + h.descr + " where " +
                          std::to_string(m.size - h.data) + " bytes of values follow its header (damaged, or cut short)");
    if (o.cols > kMaxColumns) {
      skipped_.push_back("'" + name + "' (" + shape_text(h.shape) + ": more than " + std::to_string(kMaxColumns) +
                         " components per sample)");
      return;
    }
    a.info.rows = static_cast<std::size_t>(o.rows);
    a.info.cols = static_cast<std::size_t>(o.cols);
    a.info.type = type_name(h.type);
    a.sequential = o.cols == 1 || h.fortran_order == o.transposed;
    names_.insert(name);
    arrays_.push_back(std::move(a));
  }

  fs::path file_;
  std::vector<NpyArray> arrays_;
  std::unordered_set<std::string> names_;  // of arrays_
  std::vector<std::string> skipped_;  // "'names' (dtype '<U5' …)"
  std::string layout_;
  int version_ = 1;
};

}  // namespace

std::unique_ptr<ArrayFile> open_npy(const fs::path& file) { return std::make_unique<NpyFile>(file); }

}  // namespace detail

}  // namespace stend::io
