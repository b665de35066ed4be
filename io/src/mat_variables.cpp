// The variables of a .mat file (MatSource in mat_file.hpp): found by name at the top level or in a
// struct, their headers checked, their values read a block at a time — by Stend from a
// little-endian MAT 5 element (Mat5Series), otherwise by matio (MatioSeries: MAT 7.3, big-endian).
#include "mat_file.hpp"

#include "import_common.hpp"


#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <utility>

namespace stend::io::detail {

namespace fs = std::filesystem;

std::optional<std::size_t> declared_elements(const matvar_t* v) {
  std::size_t n = 1;
  for (int i = 0; i < v->rank; ++i) {
    if (v->dims[i] != 0 && n > std::numeric_limits<std::size_t>::max() / v->dims[i]) return std::nullopt;
    n *= v->dims[i];
  }
  return n;
}

namespace {

// The number of elements a variable's dims declare, when its data buffer holds them all at
// element_bytes each; nullopt otherwise. matio's buffer is what the data element gave, which in a
// damaged file is shorter than the dims (fuzz finding: a char array read 2052 bytes of 4).
std::optional<std::size_t> held_elements(const matvar_t* v, std::size_t element_bytes) {
  const auto n = declared_elements(v);
  if (!n || *n > v->nbytes / element_bytes) return std::nullopt;
  return n;
}

}  // namespace

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

namespace {

// Through matio's Mat_VarReadData (a hyperslab of a v7.3 file's dataset, or a seek in a v5 file).
class MatioSeries final : public MatSeries {
 public:
  MatioSeries(const fs::path& file, mat_t* mat, matvar_t* info, std::size_t n_rows, std::size_t n_cols, bool along_first)
      : MatSeries(info->name ? info->name : "", n_rows, n_cols), file_(file), mat_(mat), info_(info),
        along_first_(along_first) {}
  void read(std::size_t n, double* out) override {
    if (n == 0) return;
    std::vector<char> raw(n * cols * matio().Mat_SizeOfClass(info_->class_type));
    int start[2] = {0, 0}, stride[2] = {1, 1}, edge[2] = {0, 0};
    const int k = along_first_ ? 0 : 1;
    start[k] = static_cast<int>(next_);
    edge[k] = static_cast<int>(n);
    edge[1 - k] = static_cast<int>(cols);
    if (matio().Mat_VarReadData(mat_, info_, raw.data(), start, stride, edge) != 0)
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

}  // namespace

std::size_t struct_elements(const fs::path& file, matvar_t* s) {
  const auto count = declared_elements(s);
  const unsigned nfields = matio().Mat_VarGetNumberOfFields(s);
  char* const* names = matio().Mat_VarGetStructFieldnames(s);
  const bool whole = count && (nfields == 0 || (names && s->data && s->nbytes / sizeof(matvar_t*) / nfields >= *count &&
                                                std::all_of(names, names + nfields, [](const char* n) { return n != nullptr; })));
  if (!whole)
    throw ImportError(file, 0, std::string(s->name ? s->name : "a struct") + ": a struct array of " +
                                   (count ? std::to_string(*count) : "more elements than a size_t counts") +
                                   " whose field names or fields matio could not read (damaged)");
  return *count;
}

matvar_t* struct_field(const fs::path& file, matvar_t* s, const char* name, std::size_t index) {
  return index < struct_elements(file, s) ? matio().Mat_VarGetStructFieldByName(s, name, index) : nullptr;
}

MatSource::MatSource(const fs::path& file, const std::string& struct_name, MatRoot root) : file_(file) {
  layout_ = std::make_shared<const Mat5Layout>(check_mat5_elements(file));
  matio().silence_hdf5_error_printing();  // a MAT 7.3 file is HDF5: its errors are this importer's to report
  owned_mat_.reset(matio().Mat_Open(file.c_str(), MAT_ACC_RDONLY));
  mat_ = owned_mat_.get();
  if (!mat_) throw ImportError(file, 0, "matio cannot open it as a MATLAB file (missing, or not a .mat)");
  std::size_t n = 0;
  char** dir = matio().Mat_GetDir(mat_, &n);
  if (!dir) throw ImportError(file, 0, "matio cannot list its variables");
  std::vector<std::string> names(dir, dir + n);
  std::map<std::string, MatVar> headers = read_headers();
  for (const auto& nm : names) {
    auto it = headers.find(nm);
    if (it == headers.end())  // not reached by the walk (a damaged header before it): by name
      it = headers.emplace(nm, MatVar(matio().Mat_VarReadInfo(mat_, nm.c_str()))).first;
    if (it->second) check_declared_size(nm, it->second.get());
  }
  if (!struct_name.empty()) {
    const auto it = headers.find(struct_name);
    if (it != headers.end()) owned_root_ = std::move(it->second);
    root_ = owned_root_.get();
    if (!root_ || root_->class_type != MAT_C_STRUCT) {
      throw ImportError(file, 0, "no struct variable named '" + struct_name + "'");
    }
    return;
  }
  for (const auto& nm : names) {
    auto it = headers.find(nm);
    if (it == headers.end() || !it->second) continue;
    top_[nm] = std::move(it->second);
  }
  if (root == MatRoot::kTopLevel) return;
  bool has_acc = top_.count("acc") || top_.count("accel") || top_.count("accelerometer") ||
                 top_.count("acc_counts");
  if (!has_acc) {
    for (auto& [nm, v] : top_) {
      if (v->class_type == MAT_C_STRUCT) {
        owned_root_ = std::move(v);
        root_ = owned_root_.get();
        top_.clear();
        break;
      }
    }
  }
}

MatSource::MatSource(const MatSource& top, const std::string& struct_name)
    : file_(top.file_), layout_(top.layout_), mat_(top.mat_) {
  const auto it = top.top_.find(struct_name);
  root_ = it == top.top_.end() ? nullptr : it->second.get();
  if (!root_ || root_->class_type != MAT_C_STRUCT) throw ImportError(file_, 0, "no struct variable named '" + struct_name + "'");
}

// Every variable's header, read once in file order, by name (the first of a name). Mat_VarReadInfo
// finds a name by reading the headers from the file's start: a pass per variable, quadratic in a
// crafted file of many (19 s for 2000).
std::map<std::string, MatVar> MatSource::read_headers() const {
  std::map<std::string, MatVar> out;
  if (matio().Mat_Rewind(mat_) != 0) return out;
  while (matvar_t* v = matio().Mat_VarReadNextInfo(mat_)) {
    MatVar header(v);
    if (header->name) out.emplace(header->name, std::move(header));
  }
  return out;
}

// Refuses a variable whose header declares more data than the file can hold (compressed
// variables: zlib's largest expansion) before matio allocates it.
void MatSource::check_declared_size(const std::string& name, matvar_t* info) const {
  const double file_bytes = static_cast<double>(fs::file_size(file_));
  const double declared = static_cast<double>(matio().Mat_VarGetSize(info));
  if (declared > static_cast<double>(kMaxZlibExpansion) * file_bytes + 4096.0) {
    throw ImportError(file_, 0, "variable '" + name + "' declares " + std::to_string(matio().Mat_VarGetSize(info)) +
                                    " bytes of data, more than a file of " + std::to_string(fs::file_size(file_)) +
                                    " bytes can hold (damaged header?)");
  }
}

std::vector<std::pair<std::string, matvar_t*>> MatSource::variables() const {
  std::vector<std::pair<std::string, matvar_t*>> out;
  if (!root_) {
    for (const auto& [name, v] : top_) out.emplace_back(name, v.get());
    return out;
  }
  const unsigned n = matio().Mat_VarGetNumberOfFields(root_);
  char* const* names = matio().Mat_VarGetStructFieldnames(root_);
  if (!names || n == 0) return out;
  const bool held = struct_elements(file_, root_) > 0;  // checked once, not per field
  for (unsigned i = 0; i < n; ++i)  // by index: by name, matio searches the names (quadratic in a crafted struct)
    if (names[i]) out.emplace_back(names[i], held ? matio().Mat_VarGetStructFieldByIndex(root_, i, 0) : nullptr);
  return out;
}

matvar_t* MatSource::get(std::initializer_list<const char*> names) const {
  for (const char* n : names) {
    if (root_) {
      matvar_t* f = struct_field(file_, root_, n, 0);
      if (f) return f;
    } else {
      auto it = top_.find(n);
      if (it != top_.end()) return it->second.get();
    }
  }
  return nullptr;
}

std::unique_ptr<MatSeries> MatSource::series(matvar_t* v, const std::string& which, std::size_t cols) const {
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
  if (layout_->read_by_stend && walked) {
    const auto it = layout_->vars.find(key);
    if (it == layout_->vars.end())
      throw ImportError(file_, 0, "'" + which + "': its data element was not found where its matrix declares it (damaged)");
    const std::uint64_t needed = mat_value_bytes(it->second.type) * rows * cols;
    if (needed != it->second.bytes)
      throw ImportError(file_, 0, "'" + which + "' is " + std::to_string(r) + "x" + std::to_string(c) + ", " +
                                      std::to_string(needed) + " bytes of data, but its data element holds " +
                                      std::to_string(it->second.bytes) + " (damaged)");
    if (along_first && it->second.compressed && cols > kMaxComponentCursors)
      throw ImportError(file_, 0, "'" + which + "' is " + std::to_string(r) + "x" + std::to_string(c) +
                                      ", compressed: its " + std::to_string(cols) + " components lie one after the other, "
                                      "and at most " + std::to_string(kMaxComponentCursors) +
                                      " are read so (save it uncompressed, or as components x samples)");
    return std::make_unique<Mat5Series>(file_, which, it->second, rows, cols, along_first);
  }
  return std::make_unique<MatioSeries>(file_, mat_, v, rows, cols, along_first);
}

const matvar_t* MatSource::segments() {
  if (!root_) {
    if (!top_.count("segments")) return nullptr;
    whole_.reset(matio().Mat_VarRead(mat_, "segments"));
    return whole_.get();
  }
  if (!struct_field(file_, root_, "segments", 0) || !root_->name) return nullptr;
  whole_.reset(matio().Mat_VarRead(mat_, root_->name));
  segments_in_root_ = true;
  return whole_ ? struct_field(file_, whole_.get(), "segments", 0) : nullptr;
}

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

std::unique_ptr<MatSeries> vector_of(const MatSource& src, std::initializer_list<const char*> names) {
  matvar_t* v = src.get(names);
  if (!v) return nullptr;
  const std::string which = v->name ? v->name : *names.begin();
  auto s = src.series(v, which, 1);
  if (!s) throw ImportError(src.file(), 0, "'" + which + "' is not a real numeric vector");
  return s;
}

}  // namespace stend::io::detail
