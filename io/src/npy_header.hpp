// The header of a NumPy .npy (numpy/lib/format.py): the magic "\x93NUMPY", the version (1.0, 2.0
// or 3.0), the header's length (2 bytes in 1.0, 4 in 2.0 and 3.0), then the header — a Python dict
// literal {'descr': '<f8', 'fortran_order': False, 'shape': (1000, 3), } — padded to the values.
// Internal to stend_io.
#pragma once

#include "binary_values.hpp"
#include "zip_archive.hpp"

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace stend::io::detail {

inline constexpr std::string_view kNpyMagic{"\x93NUMPY", 6};
// The longest header read [bytes]: NumPy's own reader refuses one over 10000 by default.
inline constexpr std::uint64_t kMaxNpyHeaderBytes = std::uint64_t{1} << 16;

struct NpyHeader {
  int major = 1, minor = 0;        // format version
  std::string descr;               // "<f8"; the dtype's text for a structured one
  ValueType type;                  // descr's, when `unsupported` is empty
  bool fortran_order = false;      // the values column-major
  std::vector<std::uint64_t> shape;
  std::uint64_t data = 0;          // bytes of the .npy before its first value
  std::string unsupported;         // why Stend does not read the array ("" when it does)
};

// The header of the .npy whose bytes `in` reads from their start; `in` is left at the first value
// (for a header over kMaxNpyHeaderBytes: after its length). A well-formed header of an array Stend does not read (a structured, complex, text or object
// dtype, more than 2 dimensions, a header over kMaxNpyHeaderBytes) says so in `unsupported`; a
// damaged one (no magic, an unknown version, a header cut short or not a dict of the three keys)
// throws ImportError through in.fail().
NpyHeader read_npy_header(ZipMemberReader& in);

// "(1000, 3)", "(5,)", "()": a shape as NumPy prints it.
std::string shape_text(const std::vector<std::uint64_t>& shape);

}  // namespace stend::io::detail
