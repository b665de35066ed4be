// The kinds of failure the `stend` program tells apart: each has its exit code (app/exit_codes.hpp,
// docs/errors.md). Code that detects bad input or a failed write throws one of these (or a type
// derived from one: ExperimentError, io::ImportError are InputErrors).
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

namespace stend {

// Input that cannot be used as it is: an experiment, model or data file, a damaged run folder.
// what() names the file (with line and column, or byte offset, where there is one) and what was
// expected.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The file system or a device failed: a write, sync or rename (folder missing, read-only, disk
// full), a device that does not answer. what() names the path or device and the system's reason.
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Longest piece of input text an error message quotes [bytes].
inline constexpr std::size_t kMaxQuotedBytes = 120;

// `text` as an error message quotes it: whole when it is at most kMaxQuotedBytes long, else its
// first kMaxQuotedBytes bytes (cut before a UTF-8 continuation byte) and "…(N bytes)", N the
// whole length — a 5 MB line is not echoed into a message.
inline std::string excerpt(std::string_view text) {
  if (text.size() <= kMaxQuotedBytes) return std::string(text);
  std::size_t cut = kMaxQuotedBytes;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return std::string(text.substr(0, cut)) + "…(" + std::to_string(text.size()) + " bytes)";
}

}  // namespace stend
