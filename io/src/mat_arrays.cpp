// A .mat file as named arrays (open_mat_arrays in arrays.hpp): its top-level numeric variables and
// the numeric fields of its 1×1 structs ("struct.field"), each read through MatSource (Stend's own
// MAT 5 reader, or matio for MAT 7.3 and big-endian files), samples along the longer dimension.
#include "arrays.hpp"
#include "mat_file.hpp"

#include "import_common.hpp"

#include <algorithm>
#include <map>
#include <optional>

namespace stend::io::detail {

namespace fs = std::filesystem;

namespace {

const char* class_name(matio_classes c) {
  switch (c) {
    case MAT_C_DOUBLE: return "float64";
    case MAT_C_SINGLE: return "float32";
    case MAT_C_INT8: return "int8";
    case MAT_C_UINT8: return "uint8";
    case MAT_C_INT16: return "int16";
    case MAT_C_UINT16: return "uint16";
    case MAT_C_INT32: return "int32";
    case MAT_C_UINT32: return "uint32";
    case MAT_C_INT64: return "int64";
    case MAT_C_UINT64: return "uint64";
    default: return nullptr;
  }
}

// A real numeric 2-D variable as an array: samples along its longer dimension (a 3×N matrix is N
// samples of 3 components; N×3 too); nullopt for anything else.
std::optional<ArrayInfo> array_info(const std::string& name, const matvar_t* v) {
  if (!v || v->rank != 2 || v->isComplex || !class_name(v->class_type)) return std::nullopt;
  const std::size_t r = v->dims[0], c = v->dims[1];
  if (r == 0 || c == 0) return std::nullopt;
  return ArrayInfo{name, std::max(r, c), std::min(r, c), class_name(v->class_type)};
}

class MatArrays final : public ArrayFile {
 public:
  explicit MatArrays(const fs::path& file) : file_(file), top_(file, "", MatRoot::kTopLevel) {
    for (const auto& [name, v] : top_.variables()) {
      if (auto a = array_info(name, v)) {
        arrays_.push_back(*a);
      } else if (v && v->class_type == MAT_C_STRUCT && v->rank == 2 && v->dims[0] == 1 && v->dims[1] == 1) {
        for (const auto& [field, fv] : source(name).variables())
          if (auto fa = array_info(name + "." + field, fv)) arrays_.push_back(*fa);
      }
    }
    version_ = matio().Mat_GetVersion(top_.mat()) == MAT_FT_MAT73 ? "MAT 7.3 (HDF5)"
             : matio().Mat_GetVersion(top_.mat()) == MAT_FT_MAT4  ? "MAT v4"
                                                          : "MAT v5";
  }
  const fs::path& file() const override { return file_; }
  std::vector<ArrayInfo> arrays() const override { return arrays_; }
  std::unique_ptr<ArraySeries> open(const std::string& name) const override {
    const auto it = std::find_if(arrays_.begin(), arrays_.end(), [&](const ArrayInfo& a) { return a.name == name; });
    if (it == arrays_.end()) throw ImportError(file_, 0, "no numeric array '" + name + "'");
    const auto dot = name.find('.');
    const MatSource& src = dot == std::string::npos ? top_ : source(name.substr(0, dot));
    const std::string var = dot == std::string::npos ? name : name.substr(dot + 1);
    matvar_t* v = src.get({var.c_str()});
    auto s = v ? src.series(v, var, it->cols) : nullptr;
    if (!s) throw ImportError(file_, 0, "'" + name + "' cannot be read as a numeric matrix");
    s->name = name;
    return s;
  }
  std::string layout() const override {
    return version_ + ", " + std::to_string(arrays_.size()) + " numeric array(s)";
  }

 private:
  const MatSource& source(const std::string& struct_name) const {
    auto& s = structs_[struct_name];
    if (!s) s = std::make_unique<MatSource>(top_, struct_name);
    return *s;
  }
  fs::path file_;
  MatSource top_;
  mutable std::map<std::string, std::unique_ptr<MatSource>> structs_;
  std::vector<ArrayInfo> arrays_;
  std::string version_;
};

}  // namespace

std::unique_ptr<ArrayFile> open_mat_arrays(const fs::path& file) { return std::make_unique<MatArrays>(file); }

}  // namespace stend::io::detail
