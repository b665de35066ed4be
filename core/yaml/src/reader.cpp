// Strict YAML reading with file:line:column messages and "did you mean" hints.
#include <stend/yaml/reader.hpp>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

namespace stend::yaml {

namespace {

char lower(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

std::string to_lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = lower(c);
  return out;
}

// Unit suffixes used in keys and how the unit reads in a hint.
struct UnitSuffix {
  const char* suffix;
  const char* sentence;
};
constexpr std::array<UnitSuffix, 8> kUnitSuffixes{{
    {"_s", "durations are in seconds"},
    {"_deg", "angles are in degrees"},
    {"_c", "temperatures are in degrees Celsius"},
    {"_hz", "frequencies are in hertz"},
    {"_g", "amplitudes are in g (standard gravity)"},
    {"_dps", "rates are in degrees per second"},
    {"_m", "heights are in metres"},
    {"_mps2", "accelerations are in m/s^2"},
}};

const UnitSuffix* unit_suffix_of(std::string_view key) {
  for (const auto& u : kUnitSuffixes) {
    const std::string_view s = u.suffix;
    if (key.size() > s.size() && key.substr(key.size() - s.size()) == s) return &u;
  }
  return nullptr;
}

// The part before a short trailing "_unit" ("dwell_ms" -> "dwell"); the whole word otherwise.
std::string stem(std::string_view word) {
  const auto pos = word.rfind('_');
  if (pos == std::string_view::npos || pos == 0) return std::string(word);
  const std::string_view tail = word.substr(pos + 1);
  if (tail.empty() || tail.size() > 4) return std::string(word);
  for (char c : tail)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'))) return std::string(word);
  return std::string(word.substr(0, pos));
}

bool is_quoted_or_string_tagged(const YAML::Node& node) {
  const std::string& tag = node.Tag();
  return tag == "!" || tag == "tag:yaml.org,2002:str";
}

std::string last_segment(const std::string& path) {
  const auto pos = path.rfind('.');
  return pos == std::string::npos ? path : path.substr(pos + 1);
}

std::string for_key(const std::string& path) {
  const std::string k = last_segment(path);
  return k.empty() ? std::string{} : " for '" + k + "'";
}

std::string with_unit(const std::string& what, const std::string& unit_words) {
  return unit_words.empty() ? what : what + " " + unit_words;
}

[[noreturn]] void fail_at(const YAML::Node& node, const std::string& file, const std::string& path,
                          const std::string& message, const std::string& hint = {}) {
  throw ExperimentError(location_of(node, file), path, message, hint);
}

}  // namespace

std::string read_file(const std::string& file, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) throw InputError(what + " not found: " + file);
  if (std::filesystem::is_directory(file, ec)) throw InputError(what + " " + file + " is a folder, not a file");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError("cannot read " + what + " " + file + ": " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

YAML::Node load_file(const std::string& file, const std::string& what) {
  const std::string text = read_file(file, what);
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ExperimentError({file, e.mark.line + 1, e.mark.column + 1}, "", "YAML syntax error: " + e.msg);
  }
}

YAML::Node parse_kept(const std::string& text) {
  thread_local std::string last_text;
  thread_local YAML::Node last_root;
  if (text == last_text && last_root) return last_root;
  last_root = YAML::Load(text);
  last_text = text;
  return last_root;
}

SourceLocation location_of(const YAML::Node& node, const std::string& file) {
  SourceLocation loc;
  loc.file = file;
  if (!node.IsDefined()) return loc;
  const YAML::Mark m = node.Mark();
  if (m.line >= 0 && m.column >= 0) {
    loc.line = m.line + 1;
    loc.column = m.column + 1;
  }
  return loc;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  const std::string x = to_lower(a), y = to_lower(b);
  const std::size_t n = x.size(), m = y.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1, 0));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = x[i - 1] == y[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && x[i - 1] == y[j - 2] && x[i - 2] == y[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

std::string closest_match(const std::string& word, const std::vector<std::string>& candidates) {
  // Score: 0 same stem (unit differs), 1..2 edit distance, 3 prefix.
  const std::string w = to_lower(word);
  const std::string w_stem = stem(w);
  std::string best;
  int best_score = 100;
  for (const auto& c : candidates) {
    const std::string lc = to_lower(c);
    if (lc == w) continue;  // the same word is not a suggestion
    int score = 100;
    const std::string c_stem = stem(lc);
    if (unit_suffix_of(lc) && (c_stem == w || (c_stem == w_stem && w_stem != w))) {
      score = 0;
    } else {
      const std::size_t d = edit_distance(w, lc);
      if (d <= 2 && d < w.size()) {
        score = static_cast<int>(d);
      } else {
        const std::size_t shorter = std::min(w.size(), lc.size());
        if (shorter >= 3 && (lc.compare(0, shorter, w, 0, shorter) == 0)) score = 3;
      }
    }
    if (score < best_score) {
      best_score = score;
      best = c;
    }
  }
  return best;
}

std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string best = closest_match(word, candidates);
  if (best.empty()) return {};
  std::string out = "did you mean '" + best + "'?";
  if (const UnitSuffix* u = unit_suffix_of(best)) {
    const std::string b_stem = stem(best);
    if (b_stem == word || b_stem == stem(word)) out += std::string(" ") + u->sentence;
  }
  return out;
}

std::string join_sentences(const std::string& first, const std::string& second) {
  if (first.empty()) return second;
  if (second.empty()) return first;
  const char last = first.back();
  return first + (last == '?' || last == '.' || last == '!' ? " " : ". ") + second;
}

std::string join(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i) out += separator;
    out += items[i];
  }
  return out;
}

std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsMap()) return "a mapping";
  if (node.IsSequence()) return "a list";
  // A scalar is quoted cut (stend::excerpt): a data file read as YAML is one scalar of megabytes.
  if (is_quoted_or_string_tagged(node)) return "the quoted text \"" + excerpt(node.Scalar()) + "\"";
  return "'" + excerpt(node.Scalar()) + "'";
}

std::string format_number(double value) {
  std::array<char, 64> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), value);
  return std::string(buf.data(), res.ptr);
}

// ----------------------------------------------------------------------------------------------
// Typed conversions.

double as_number(const YAML::Node& node, const std::string& file, const std::string& path,
                 const std::string& unit_words) {
  const std::string expected = "expected " + with_unit("a number", unit_words) + for_key(path);
  if (!node.IsDefined() || !node.IsScalar()) fail_at(node, file, path, expected + ", got " + describe(node));
  if (is_quoted_or_string_tagged(node))
    fail_at(node, file, path, expected + ", got " + describe(node), "remove the quotes");
  double v = 0.0;
  try {
    v = node.as<double>();
  } catch (const YAML::Exception&) {
    fail_at(node, file, path, expected + ", got " + describe(node));
  }
  if (!std::isfinite(v)) fail_at(node, file, path, expected + ", got " + describe(node) + " (numbers must be finite)");
  return v;
}

std::int64_t as_integer(const YAML::Node& node, const std::string& file, const std::string& path) {
  const std::string expected = "expected an integer" + for_key(path);
  if (!node.IsDefined() || !node.IsScalar()) fail_at(node, file, path, expected + ", got " + describe(node));
  if (is_quoted_or_string_tagged(node))
    fail_at(node, file, path, expected + ", got " + describe(node), "remove the quotes");
  try {
    return node.as<std::int64_t>();
  } catch (const YAML::Exception&) {
    fail_at(node, file, path, expected + ", got " + describe(node));
  }
}

bool as_bool(const YAML::Node& node, const std::string& file, const std::string& path) {
  const std::string expected = "expected true or false" + for_key(path);
  if (!node.IsDefined() || !node.IsScalar() || is_quoted_or_string_tagged(node))
    fail_at(node, file, path, expected + ", got " + describe(node));
  try {
    return node.as<bool>();
  } catch (const YAML::Exception&) {
    fail_at(node, file, path, expected + ", got " + describe(node));
  }
}

std::string as_string(const YAML::Node& node, const std::string& file, const std::string& path) {
  if (!node.IsDefined() || !node.IsScalar())
    fail_at(node, file, path, "expected text" + for_key(path) + ", got " + describe(node));
  return node.Scalar();
}

std::vector<double> as_numbers(const YAML::Node& node, const std::string& file,
                               const std::string& path, const std::string& unit_words) {
  if (!node.IsDefined() || !node.IsSequence())
    fail_at(node, file, path,
            "expected a list of numbers" + (unit_words.empty() ? "" : " " + unit_words) +
                for_key(path) + ", got " + describe(node),
            "write a list like [1, 2, 3]");
  std::vector<double> out;
  out.reserve(node.size());
  for (std::size_t i = 0; i < node.size(); ++i)
    out.push_back(as_number(node[i], file, path + "[" + std::to_string(i) + "]", unit_words));
  return out;
}

// ----------------------------------------------------------------------------------------------
// MapReader

MapReader::MapReader(const YAML::Node& node, std::string file, std::string path, std::string what,
                     std::vector<std::string> allowed, std::vector<std::string> hidden,
                     SourceLocation where_if_empty)
    : file_(std::move(file)), path_(std::move(path)), what_(std::move(what)) {
  where_ = location_of(node, file_);
  if (!node.IsDefined() || node.IsNull()) {
    if (where_if_empty.line > 0) where_ = where_if_empty;
    return;
  }
  if (!node.IsMap())
    throw ExperimentError(where_, path_,
                          "expected a mapping (key: value) for " + what_ + ", got " + describe(node));
  for (auto it = node.begin(); it != node.end(); ++it) {
    const YAML::Node k = it->first;
    if (!k.IsScalar())
      throw ExperimentError(location_of(k, file_), path_,
                            "keys of " + what_ + " must be plain names, got " + describe(k));
    const std::string key = k.Scalar();
    const std::string kpath = child_path(key);
    for (const auto& e : entries_) {
      if (e.key == key) {
        const SourceLocation first = location_of(e.key_node, file_);
        throw ExperimentError(location_of(k, file_), kpath,
                              "duplicate key '" + key + "' in " + what_ + " (first given at line " +
                                  std::to_string(first.line) + ")",
                              "give each key once");
      }
    }
    const bool known = std::find(allowed.begin(), allowed.end(), key) != allowed.end() ||
                       std::find(hidden.begin(), hidden.end(), key) != hidden.end();
    if (!known) {
      const std::string first = key == "<<"
                                    ? "YAML merge keys ('<<') are not supported; write the keys out."
                                    : did_you_mean(key, allowed);
      const std::string hint = join_sentences(
          first, allowed.empty() ? "No keys are allowed here." : "Allowed keys: " + join(allowed));
      throw ExperimentError(location_of(k, file_), kpath,
                            "unknown key '" + key + "' in " + what_, hint);
    }
    entries_.push_back({key, k, it->second});
    order_.push_back(key);
  }
}

const MapReader::Entry* MapReader::find(const std::string& key) const {
  for (const auto& e : entries_)
    if (e.key == key) return &e;
  return nullptr;
}

bool MapReader::has(const std::string& key) const { return find(key) != nullptr; }

YAML::Node MapReader::get(const std::string& key) const {
  const Entry* e = find(key);
  return e ? e->value : YAML::Node(YAML::NodeType::Undefined);
}

SourceLocation MapReader::key_location(const std::string& key) const {
  const Entry* e = find(key);
  return e ? location_of(e->key_node, file_) : where_;
}

SourceLocation MapReader::value_location(const std::string& key) const {
  const Entry* e = find(key);
  if (!e) return where_;
  if (!e->value.IsDefined() || e->value.IsNull()) return location_of(e->key_node, file_);
  return location_of(e->value, file_);
}

std::string MapReader::child_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void MapReader::require(const std::string& key, const std::string& what_it_is) const {
  if (has(key)) return;
  std::string msg = "missing required key '" + key + "' in " + what_;
  if (!what_it_is.empty()) msg += " (" + what_it_is + ")";
  throw ExperimentError(where_, child_path(key), msg);
}

void MapReader::exactly_one_of(const std::vector<std::string>& keys) const {
  std::vector<std::string> quoted;
  for (const auto& k : keys) quoted.push_back("'" + k + "'");
  const Entry* first = nullptr;
  for (const auto& e : entries_) {
    if (std::find(keys.begin(), keys.end(), e.key) == keys.end()) continue;
    if (first)
      fail_key(e.key, "give only one of " + join(quoted) + " in " + what_ + " (found '" +
                          first->key + "' and '" + e.key + "')");
    first = &e;
  }
  if (!first)
    throw ExperimentError(where_, path_, what_ + " needs one of " + join(quoted));
}

void MapReader::at_most_one_of(const std::vector<std::string>& keys, const std::string& hint) const {
  const Entry* first = nullptr;
  for (const auto& e : entries_) {
    if (std::find(keys.begin(), keys.end(), e.key) == keys.end()) continue;
    if (first)
      fail_key(e.key, "'" + first->key + "' and '" + e.key + "' cannot both be given in " + what_,
               hint);
    first = &e;
  }
}

void MapReader::fail_key(const std::string& key, const std::string& message,
                         const std::string& hint) const {
  throw ExperimentError(key_location(key), child_path(key), message, hint);
}

void MapReader::fail_value(const std::string& key, const std::string& message,
                           const std::string& hint) const {
  throw ExperimentError(value_location(key), child_path(key), message, hint);
}

double MapReader::number(const std::string& key, double fallback,
                         const std::string& unit_words) const {
  const Entry* e = find(key);
  if (!e) return fallback;
  if (e->value.IsNull())
    fail_key(key, "expected " + with_unit("a number", unit_words) + " for '" + key + "', got nothing");
  return as_number(e->value, file_, child_path(key), unit_words);
}

std::int64_t MapReader::integer(const std::string& key, std::int64_t fallback) const {
  const Entry* e = find(key);
  if (!e) return fallback;
  if (e->value.IsNull()) fail_key(key, "expected an integer for '" + key + "', got nothing");
  return as_integer(e->value, file_, child_path(key));
}

bool MapReader::boolean(const std::string& key, bool fallback) const {
  const Entry* e = find(key);
  if (!e) return fallback;
  if (e->value.IsNull()) fail_key(key, "expected true or false for '" + key + "', got nothing");
  return as_bool(e->value, file_, child_path(key));
}

std::string MapReader::string(const std::string& key, const std::string& fallback) const {
  const Entry* e = find(key);
  if (!e) return fallback;
  if (e->value.IsNull()) fail_key(key, "expected text for '" + key + "', got nothing");
  return as_string(e->value, file_, child_path(key));
}

std::vector<double> MapReader::numbers(const std::string& key,
                                       const std::string& unit_words) const {
  const Entry* e = find(key);
  if (!e) return {};
  if (e->value.IsNull())
    fail_key(key, "expected a list of numbers for '" + key + "', got nothing");
  return as_numbers(e->value, file_, child_path(key), unit_words);
}

}  // namespace stend::yaml
