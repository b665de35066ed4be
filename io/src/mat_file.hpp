// MATLAB .mat files (import_mat, export_mat in stend/io/importers.hpp) through matio, with what
// Stend reads itself: the MAT 5 elements walked and checked before matio reads them
// (mat_elements.cpp), the variables found by name and read a block at a time (mat_variables.cpp),
// the variables made a recording (mat_import.cpp) and a recording written back (mat_export.cpp).
// MAT 7.3 files are HDF5 files that matio reads. Internal to stend_io.
#pragma once

#include <stend/io/importers.hpp>

#include "arrays.hpp"

#include <stend/matio_library.hpp>
#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace stend::io::detail {

struct MatFileCloser {
  void operator()(mat_t* m) const {
    if (m) matio().Mat_Close(m);
  }
};
struct MatVarFree {
  void operator()(matvar_t* v) const {
    if (v) matio().Mat_VarFree(v);
  }
};
using MatFile = std::unique_ptr<mat_t, MatFileCloser>;
using MatVar = std::unique_ptr<matvar_t, MatVarFree>;

// --- the variables' headers as matio gives them (mat_variables.cpp) ---------------------------

// The number of elements a variable's dims declare (the product of its dims); nullopt when the
// product does not fit a size_t (damage).
std::optional<std::size_t> declared_elements(const matvar_t* v);
// Numeric content of a variable as doubles (column-major), with its dims; false when it is not
// numeric or its data does not hold its dims.
bool numeric(const matvar_t* v, std::vector<double>& out, std::size_t& rows, std::size_t& cols);
// A char array's text ("" when there is none); nullopt when its data does not hold its dims.
std::optional<std::string> text(const matvar_t* v);

// --- MAT 5 elements (mat_elements.cpp) ---------------------------------------------------------

// The bytes of one top-level element, as stored or inflated from a compressed one (whose
// inflated bytes start with the matrix's own tag), read forwards; at most what it holds.
class MatElementBytes {
 public:
  MatElementBytes(std::ifstream& in, std::uint64_t pos, std::uint32_t bytes, bool compressed);
  ~MatElementBytes();
  MatElementBytes(const MatElementBytes&) = delete;
  MatElementBytes& operator=(const MatElementBytes&) = delete;

  // n bytes into out (nullptr: skipped); false when the element (or its zlib stream) ends first.
  bool read(char* out, std::uint64_t n);
  // Bytes read (or skipped) so far.
  std::uint64_t consumed() const { return consumed_; }

 private:
  std::size_t read_stored(char* to, std::size_t want);
  std::size_t inflate_into(char* to, std::size_t want);

  std::ifstream& in_;
  std::uint64_t next_, left_;
  bool compressed_;
  bool ended_ = false;
  std::uint64_t consumed_ = 0;
  z_stream z_{};
  char in_buf_[4096];
};

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
std::size_t mat_value_bytes(std::uint32_t type);

// The most bytes deflate can inflate from one: zlib's largest expansion, 1032:1 (zlib's FAQ).
inline constexpr std::uint64_t kMaxZlibExpansion = 1032;

// Refuses a file matio would read unchecked: a MAT v5 file whose top-level elements (8-byte tag:
// uint32 data type, uint32 byte count) are not matrices or compressed matrices lying inside the
// file, or whose matrices declare lengths matio would allocate unchecked; a file without a MAT 5
// header that is not a valid MAT v4 file; a MAT 7.3 header without an HDF5 file after it. Returns
// where a little-endian MAT 5 file's numeric variables lie (Mat5Data); otherwise an empty layout.
Mat5Layout check_mat5_elements(const std::filesystem::path& file);

// --- variables (mat_variables.cpp) ------------------------------------------------------------

// The rows of a numeric variable — N×1, 1×N, N×K or K×N, taken as samples × components — read
// forward a block at a time, so that no variable is held whole.
using MatSeries = ArraySeries;

// Which variables a MatSource reads without a struct name: the top level, or (kAuto) the fields of
// the only struct when the top level holds no accelerometer under its usual names.
enum class MatRoot { kAuto, kTopLevel };

// The variables of the file (top level or one struct's fields), by name: their headers, and
// their values through a MatSeries as they are needed.
class MatSource {
 public:
  // Opens `file` after check_mat5_elements; with `struct_name`, the variables are that struct's
  // fields; without, the top-level variables, or the fields of the only struct when there is no
  // accelerometer at the top level.
  MatSource(const std::filesystem::path& file, const std::string& struct_name, MatRoot root = MatRoot::kAuto);
  // The fields of struct variable `struct_name` of `top` (a top-level source), sharing its file,
  // its checked layout and the struct's header (each struct opened and walked anew made a file of
  // many structs quadratic or worse); `top` must outlive it.
  MatSource(const MatSource& top, const std::string& struct_name);
  // The variables read (the top level's, or the struct's fields), by name, in name order.
  std::vector<std::pair<std::string, matvar_t*>> variables() const;
  // The header of the first of `names` present (a struct field's, with a struct root).
  matvar_t* get(std::initializer_list<const char*> names) const;
  // The values of `v` (a header from get(), a real numeric matrix with one of its dimensions 1
  // or `cols`, the other the samples) as `which` names it; nullptr when its shape is not that.
  std::unique_ptr<MatSeries> series(matvar_t* v, const std::string& which, std::size_t cols) const;
  // The segments struct array, read whole (it is small); with a struct root holding it, the root
  // is read whole as well (matio reads a struct's fields together).
  const matvar_t* segments();
  bool segments_in_root() const { return segments_in_root_; }
  mat_t* mat() const { return mat_; }
  const std::filesystem::path& file() const { return file_; }

 private:
  std::map<std::string, MatVar> read_headers() const;
  void check_declared_size(const std::string& name, matvar_t* info) const;

  std::filesystem::path file_;
  std::shared_ptr<const Mat5Layout> layout_;
  MatFile owned_mat_;
  mat_t* mat_ = nullptr;  // owned_mat_, or the top-level source's
  MatVar owned_root_;
  matvar_t* root_ = nullptr;  // owned_root_, or a header the top-level source holds; nullptr: top level
  std::map<std::string, MatVar> top_;
  MatVar whole_;
  bool segments_in_root_ = false;
};

// The N×3 or 3×N matrix under the first of `names` present (nullptr when none is).
std::unique_ptr<MatSeries> triad(const MatSource& src, std::initializer_list<const char*> names);
// The vector (or scalar) under the first of `names` present (nullptr when none is).
std::unique_ptr<MatSeries> vector_of(const MatSource& src, std::initializer_list<const char*> names);

// The number of elements of struct array `s`, checked. matio's Mat_VarGetStructFieldByName
// indexes the field names and a field pointer per element and field unchecked, and matio can
// return a damaged struct without them (SEGV, twice a fuzz target's find: the segments struct,
// then a struct holding the variables): every field name and field pointer must be there, else the
// struct is damage.
std::size_t struct_elements(const std::filesystem::path& file, matvar_t* s);
// Field `name` of element `index` of struct array `s` (nullptr when it has none; damage throws).
matvar_t* struct_field(const std::filesystem::path& file, matvar_t* s, const char* name, std::size_t index);

}  // namespace stend::io::detail
