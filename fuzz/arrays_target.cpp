// A container of named arrays read at the array level (io/src/arrays.hpp), every array to its end:
//   STEND_FUZZ_CONTAINER "npy"      the input is a .npy or an .npz (open_npy);
//                        "records"  the input's first line is the record_layout, its second the
//                                   byte_order, its third header_bytes, the rest the records
//                                   (open_records; the layout's parsing is fuzzed too).
// Each array is opened twice: one reader reads it in blocks of 1000 rows, the other one row at a
// time for its first rows. Any std::exception is the reader refusing the input (a clear error is
// what it should be); a crash, a hang, a leak or a sanitizer report is a finding.
#include <stend/io/import_options.hpp>

#include "arrays.hpp"

#include <algorithm>
#include <cstdint>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_support.hpp"

namespace {

// The next line of `text` from `at` (without its '\n'); `at` moves past it.
std::string line(std::string_view text, std::size_t& at) {
  const std::size_t end = std::min(text.find('\n', at), text.size());
  const std::string l(text.substr(at, end - at));
  at = std::min(end + 1, text.size());
  return l;
}

std::unique_ptr<stend::io::detail::ArrayFile> open(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  if (std::string_view(STEND_FUZZ_CONTAINER) == "npy")
    return stend::io::detail::open_npy(stend::fuzz::write_input(data, size, "arrays.npz"));
  std::size_t at = 0;
  stend::io::ImportOptions o;
  o.set("record_layout", line(input, at));
  o.set("byte_order", line(input, at));
  o.set("header_bytes", line(input, at));
  const auto file = stend::fuzz::write_input(data + at, size - at, "records.bin");
  return stend::io::detail::open_records(file, o);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > stend::fuzz::kMaxInputBytes) return 0;
  try {
    const auto f = open(data, size);
    double sum = static_cast<double>(f->layout().size() + f->damage().size());
    for (const auto& a : f->arrays()) {
      auto blocks = f->open(a.name), rows = f->open(a.name);
      std::vector<double> v;
      for (std::size_t at = 0; at < a.rows;) {
        const std::size_t n = std::min<std::size_t>(1000, a.rows - at);
        v.resize(n * a.cols);
        blocks->read(n, v.data());
        for (const double x : v) sum += x;
        at += n;
      }
      v.resize(a.cols);
      for (std::size_t i = 0; i < std::min<std::size_t>(a.rows, 3); ++i) rows->read(1, v.data());
    }
    (void)sum;
  } catch (const std::exception&) {
  }
  return 0;
}
