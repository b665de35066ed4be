// The kinds of failure the `stend` program tells apart: each has its exit code (app/exit_codes.hpp,
// docs/errors.md). Code that detects bad input or a failed write throws one of these (or a type
// derived from one: ExperimentError, io::ImportError are InputErrors; a device transport's error
// is an IoError). Part of the SDK, so that plugins, devices and importers throw the same types.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace stend {

// The types are thrown across plugin boundaries, so their type information is visible to every
// plugin (as FixtureLinkFault's in sdk.hpp).

// Input that cannot be used as it is: an experiment, model or data file, a damaged run folder.
// what() names the file (with line and column, or byte offset, where there is one) and what was
// expected.
class __attribute__((visibility("default"))) InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The file system or a device failed: a write, sync or rename (folder missing, read-only, disk
// full), a device that does not answer. what() names the path or device and the system's reason.
class __attribute__((visibility("default"))) IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A place in a hand-written file (experiment, model, mapping YAML).
struct SourceLocation {
  std::string file;
  int line = 0;    // 1-based; 0 = unknown
  int column = 0;  // 1-based
  // "file:line:column" ("file:line" without a column, "file" without a line).
  std::string str() const {
    if (line <= 0) return file;
    if (column <= 0) return file + ":" + std::to_string(line);
    return file + ":" + std::to_string(line) + ":" + std::to_string(column);
  }
};

// A problem at a place in a hand-written YAML file (experiment, model, mapping). what() reads
//   "FILE:LINE:COL: error: MESSAGE"   (plus "\n  hint: …" when there is a hint)
class __attribute__((visibility("default"))) ExperimentError : public InputError {
 public:
  ExperimentError(SourceLocation where, std::string key, std::string message, std::string hint = {})
      : InputError(compose(where, message, hint)),
        where_(std::move(where)),
        key_(std::move(key)),
        message_(std::move(message)),
        hint_(std::move(hint)) {}
  const SourceLocation& where() const { return where_; }
  const std::string& key() const { return key_; }  // dotted path, e.g. "procedure[2].dwell_s"
  const std::string& message() const { return message_; }
  const std::string& hint() const { return hint_; }

 private:
  static std::string compose(const SourceLocation& where, const std::string& message, const std::string& hint) {
    std::string out = where.file.empty() && where.line == 0 ? std::string("<experiment>") : where.str();
    out += ": error: " + message;
    if (!hint.empty()) out += "\n  hint: " + hint;
    return out;
  }

  SourceLocation where_;
  std::string key_, message_, hint_;
};

// In an IsValid: `why` into *error (when asked for) and false.
inline bool invalid(std::string* error, std::string why) {
  if (error) *error = std::move(why);
  return false;
}

// The one check of an Options or Config struct where it is read or used. Such a struct states its
// defaults in its member initializers and says what it accepts in
//   bool IsValid(std::string* error = nullptr) const;   // false with the first problem in *error
// (Ceres style). Returns `options`, or throws std::invalid_argument "WHO: WHY".
template <class Options>
const Options& require_valid(const Options& options, std::string_view who) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(std::string(who) + ": " + why);
  return options;
}

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
