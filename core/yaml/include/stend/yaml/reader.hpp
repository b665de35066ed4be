// Helpers for validating hand-written YAML with good messages: locations (1-based
// file:line:column from yaml-cpp marks), "did you mean" suggestions, and a strict reader for one
// mapping (unknown keys, duplicate keys, missing required keys, typed values with units).
// Used by the experiment model, processing, estimator and import configs alike; every error is an
// ExperimentError (stend/errors.hpp) at the offending key or value.
#pragma once

#include <stend/errors.hpp>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>
#include <yaml-cpp/yaml.h>

namespace stend::yaml {

// The whole text of a hand-written file (`what` names it in messages: "model file"). Throws
// InputError "<what> not found: FILE" when there is no such file, "<what> FILE is a folder" for a
// folder, "cannot read <what> FILE: <reason>" otherwise.
std::string read_file(const std::string& file, const std::string& what);

// read_file, parsed as YAML; a syntax error is an ExperimentError at FILE:LINE:COLUMN.
YAML::Node load_file(const std::string& file, const std::string& what);

// `text` parsed as YAML (YAML::Exception on a syntax error), for a text that several steps read —
// a recording's experiment is checked when the run is opened and read again for its processing
// options: the last text parsed on this thread is kept with its tree, so it is parsed once. The
// tree is shared with the next caller of the same text: read it, do not change it.
YAML::Node parse_kept(const std::string& text);

// 1-based location of a node (line 0 when the node has no mark, e.g. undefined or empty doc).
SourceLocation location_of(const YAML::Node& node, const std::string& file);

// Optimal-string-alignment (Damerau-Levenshtein) distance, ASCII case-insensitive.
std::size_t edit_distance(std::string_view a, std::string_view b);

// The candidate closest to `word`: edit distance <= 2 (but less than the word's length), or one
// is a prefix of the other (at least 3 characters shared). "" when none is close.
std::string closest_match(const std::string& word, const std::vector<std::string>& candidates);

// "did you mean 'X'? " plus, when X differs from `word` only by a unit suffix ("_s", "_deg",
// "_c", "_hz", "_g", "_dps", "_m", "_mps2"), a sentence stating the unit ("durations are in
// seconds"). Empty when nothing is close.
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

// Two hint sentences joined: "did you mean 'x'?" + "Allowed keys: …" (a period added when the
// first does not end a sentence). Either may be empty.
std::string join_sentences(const std::string& first, const std::string& second);

// "a, b, c"
std::string join(const std::vector<std::string>& items, const std::string& separator = ", ");

// Describes a scalar for a message: 'five', "quoted", a mapping, a list, nothing.
std::string describe(const YAML::Node& node);

// One YAML mapping read strictly. Construction checks the node is a mapping (null counts as an
// empty mapping), that keys are plain scalars, unique and among `allowed` (+ `hidden`, accepted
// but never suggested). Every error is an ExperimentError at the offending key or value.
// `where_if_empty` is the location reported for a mapping that is absent or null (typically the
// location of its key), since yaml-cpp marks a null value at the following line.
class MapReader {
 public:
  MapReader(const YAML::Node& node, std::string file, std::string path, std::string what,
            std::vector<std::string> allowed, std::vector<std::string> hidden = {},
            SourceLocation where_if_empty = {});

  bool has(const std::string& key) const;
  YAML::Node get(const std::string& key) const;  // undefined node when absent
  SourceLocation key_location(const std::string& key) const;
  // Of the value; of the key when the value is null; of the mapping when the key is absent.
  SourceLocation value_location(const std::string& key) const;
  SourceLocation location() const { return where_; }  // of the mapping
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  std::string child_path(const std::string& key) const;
  // Keys in document order.
  const std::vector<std::string>& keys() const { return order_; }

  // Throws "missing required key 'K' (what_it_is)" at the mapping.
  void require(const std::string& key, const std::string& what_it_is) const;
  // Throws unless exactly one / at most one of `keys` is present.
  void exactly_one_of(const std::vector<std::string>& keys) const;
  void at_most_one_of(const std::vector<std::string>& keys, const std::string& hint = {}) const;

  // Typed reads. `unit_words` is how the unit reads in a message ("in seconds", "in degrees");
  // may be empty. A missing key returns the fallback (use require() first for required keys).
  double number(const std::string& key, double fallback, const std::string& unit_words) const;
  std::int64_t integer(const std::string& key, std::int64_t fallback) const;
  bool boolean(const std::string& key, bool fallback) const;
  std::string string(const std::string& key, const std::string& fallback) const;
  std::vector<double> numbers(const std::string& key, const std::string& unit_words) const;

  [[noreturn]] void fail_key(const std::string& key, const std::string& message,
                             const std::string& hint = {}) const;
  [[noreturn]] void fail_value(const std::string& key, const std::string& message,
                               const std::string& hint = {}) const;

 private:
  struct Entry {
    std::string key;
    YAML::Node key_node, value;
  };
  const Entry* find(const std::string& key) const;
  std::string file_, path_, what_;
  SourceLocation where_;
  std::vector<Entry> entries_;
  std::vector<std::string> order_;
};

// Typed conversions of one node (throw ExperimentError at the node, key path `path`).
// Numbers must be plain (unquoted) finite scalars.
double as_number(const YAML::Node& node, const std::string& file, const std::string& path,
                 const std::string& unit_words);
std::int64_t as_integer(const YAML::Node& node, const std::string& file, const std::string& path);
bool as_bool(const YAML::Node& node, const std::string& file, const std::string& path);
std::string as_string(const YAML::Node& node, const std::string& file, const std::string& path);
std::vector<double> as_numbers(const YAML::Node& node, const std::string& file,
                               const std::string& path, const std::string& unit_words);

// Shortest text that reads back as exactly the same double ("0.1", "44", "-1e-09").
std::string format_number(double value);

// Emits a string so that it reads back as the same string (quoted when it would otherwise read
// as null or be empty).
void emit_string(YAML::Emitter& out, const std::string& text);

}  // namespace stend::yaml
