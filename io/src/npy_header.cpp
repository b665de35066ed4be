// The .npy header (npy_header.hpp): the preamble checked, the dict literal parsed by a small
// reader of Python literals (strings, numbers, True/False/None, tuples, lists, dicts; nesting
// bounded), its three keys read.
#include "npy_header.hpp"

#include <cstring>

namespace stend::io::detail {

namespace {

// A Python literal's value.
struct PyValue {
  enum Kind { kNone, kBool, kInt, kString, kSequence, kDict } kind = kNone;
  bool flag = false;           // kBool
  std::uint64_t number = 0;    // kInt (its magnitude)
  bool negative = false;       // kInt
  std::string text;            // kString
  std::vector<PyValue> items;  // kSequence; kDict: key, value, key, value, …
};

// The literal in `s` (a header that starts at byte `at` of the .npy read by `in`).
class PyLiteral {
 public:
  PyLiteral(std::string_view s, const ZipMemberReader& in, std::uint64_t at) : s_(s), in_(in), at_(at) {}

  // The one value the text holds (blanks around it).
  PyValue whole() {
    PyValue v = value(0);
    blanks();
    if (i_ != s_.size()) fail("text after its value");
    return v;
  }

 private:
  static constexpr int kMaxDepth = 32;

  [[noreturn]] void fail(const std::string& what) const {
    in_.fail(at_ + i_, "the .npy header is not a Python dict literal: " + what + " (damaged)");
  }
  void blanks() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r')) ++i_;
  }
  bool eat(char c) {
    blanks();
    if (i_ >= s_.size() || s_[i_] != c) return false;
    ++i_;
    return true;
  }
  bool word(std::string_view w) {
    if (s_.substr(i_, w.size()) != w) return false;
    i_ += w.size();
    return true;
  }
  static bool quote(char c) { return c == '\'' || c == '"'; }
  static bool digit(char c) { return c >= '0' && c <= '9'; }

  PyValue value(int depth) {
    if (depth > kMaxDepth) fail("nested deeper than " + std::to_string(kMaxDepth) + " levels");
    blanks();
    if (i_ >= s_.size()) fail("it ends inside a value");
    const char c = s_[i_];
    if (c == '{') return items(depth, '}', PyValue::kDict);
    if (c == '(') return items(depth, ')', PyValue::kSequence);
    if (c == '[') return items(depth, ']', PyValue::kSequence);
    if ((c == 'u' || c == 'b') && i_ + 1 < s_.size() && quote(s_[i_ + 1])) ++i_;  // u'…', b'…'
    if (quote(s_[i_])) return string();
    if (digit(c) || c == '-') return integer();
    PyValue v;
    if (word("None")) return v;
    v.kind = PyValue::kBool;
    if (word("True")) v.flag = true;
    else if (!word("False")) fail(std::string("unexpected '") + c + "'");
    return v;
  }

  // ( … ), [ … ] or { key: value, … }, a trailing comma allowed.
  PyValue items(int depth, char close, PyValue::Kind kind) {
    ++i_;
    PyValue v;
    v.kind = kind;
    while (!eat(close)) {
      v.items.push_back(value(depth + 1));
      if (kind == PyValue::kDict) {
        if (!eat(':')) fail("a key without ':'");
        v.items.push_back(value(depth + 1));
      }
      if (eat(',')) continue;
      if (!eat(close)) fail(std::string("expected ',' or '") + close + "'");
      break;
    }
    return v;
  }

  PyValue string() {
    const char q = s_[i_++];
    PyValue v;
    v.kind = PyValue::kString;
    while (i_ < s_.size() && s_[i_] != q) {
      if (s_[i_] == '\\' && i_ + 1 < s_.size()) ++i_;
      v.text += s_[i_++];
    }
    if (i_ >= s_.size()) fail("a string without its closing quote");
    ++i_;
    return v;
  }

  PyValue integer() {
    PyValue v;
    v.kind = PyValue::kInt;
    v.negative = s_[i_] == '-';
    if (v.negative) ++i_;
    if (i_ >= s_.size() || !digit(s_[i_])) fail("a '-' without a number");
    for (; i_ < s_.size() && digit(s_[i_]); ++i_) {
      const auto d = static_cast<std::uint64_t>(s_[i_] - '0');
      if (v.number > (std::uint64_t{1} << 62) / 10) fail("a number beyond 2^62");
      v.number = v.number * 10 + d;
    }
    if (i_ < s_.size() && s_[i_] == 'L') ++i_;  // Python 2's long
    return v;
  }

  std::string_view s_;
  const ZipMemberReader& in_;
  std::uint64_t at_;
  std::size_t i_ = 0;
};

// The value of `key` in the header's dict; fails when it is absent.
const PyValue& entry(const PyValue& dict, const std::string& key, const ZipMemberReader& in, std::uint64_t at) {
  for (std::size_t i = 0; i + 1 < dict.items.size(); i += 2)
    if (dict.items[i].kind == PyValue::kString && dict.items[i].text == key) return dict.items[i + 1];
  in.fail(at, "the .npy header has no '" + key + "' (damaged)");
}

// '<f8', '>i2', '|u1', '=f4' → the type; false for a dtype Stend does not read.
bool simple_dtype(const std::string& d, ValueType& t) {
  std::size_t i = 0;
  const char order = !d.empty() && std::strchr("<>|=", d[0]) ? d[i++] : '|';
  if (i >= d.size()) return false;
  t.kind = d[i++];
  const std::string size = d.substr(i);
  if (size.empty() || size.size() > 2 || size.find_first_not_of("0123456789") != std::string::npos) return false;
  t.bytes = static_cast<std::size_t>(std::stoul(size));
  t.big_endian = order == '>';
  return readable(t.kind, t.bytes);
}

}  // namespace

std::string shape_text(const std::vector<std::uint64_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

NpyHeader read_npy_header(ZipMemberReader& in) {
  NpyHeader h;
  std::uint8_t pre[12];
  if (!in.read(pre, 10)) in.fail(0, "shorter than a .npy preamble (10 bytes): not a .npy, or cut short");
  if (std::memcmp(pre, kNpyMagic.data(), kNpyMagic.size()) != 0) in.fail(0, "no .npy magic (\\x93NUMPY): not a NumPy .npy");
  h.major = pre[6];
  h.minor = pre[7];
  if (h.major < 1 || h.major > 3 || h.minor != 0)
    in.fail(6, ".npy version " + std::to_string(h.major) + "." + std::to_string(h.minor) + ": only 1.0, 2.0 and 3.0 are read");
  std::uint64_t length = load_le<std::uint16_t>(pre + 8);
  std::uint64_t preamble = 10;
  if (h.major > 1) {
    if (!in.read(pre + 10, 2)) in.fail(8, "the .npy ends inside its header's length");
    length = load_le<std::uint32_t>(pre + 8);
    preamble = 12;
  }
  h.data = preamble + length;
  if (length > in.member().size - in.position())
    in.fail(8, "the .npy header declares " + std::to_string(length) + " bytes where " +
                   std::to_string(in.member().size - in.position()) + " remain (cut short?)");
  if (length > kMaxNpyHeaderBytes) {
    h.unsupported = "a header of " + std::to_string(length) + " bytes (at most " + std::to_string(kMaxNpyHeaderBytes) + " are read)";
    return h;
  }
  std::string text(static_cast<std::size_t>(length), '\0');
  if (!in.read(reinterpret_cast<std::uint8_t*>(text.data()), text.size())) in.fail(preamble, "the .npy ends inside its header");
  const PyValue dict = PyLiteral(text, in, preamble).whole();
  if (dict.kind != PyValue::kDict) in.fail(preamble, "the .npy header is not a dict (damaged)");
  const PyValue& descr = entry(dict, "descr", in, preamble);
  const PyValue& order = entry(dict, "fortran_order", in, preamble);
  const PyValue& shape = entry(dict, "shape", in, preamble);
  if (order.kind != PyValue::kBool) in.fail(preamble, "the .npy header's 'fortran_order' is not True or False (damaged)");
  if (shape.kind != PyValue::kSequence) in.fail(preamble, "the .npy header's 'shape' is not a tuple (damaged)");
  h.fortran_order = order.flag;
  for (const PyValue& d : shape.items) {
    if (d.kind != PyValue::kInt || d.negative) in.fail(preamble, "the .npy header's 'shape' holds other than counts (damaged)");
    h.shape.push_back(d.number);
  }
  h.descr = descr.kind == PyValue::kString ? descr.text : "a structured dtype";
  if (descr.kind != PyValue::kString || !simple_dtype(descr.text, h.type))
    h.unsupported = "dtype " + (descr.kind == PyValue::kString ? "'" + descr.text + "'" : h.descr) +
                    " (integers of 1, 2, 4 or 8 bytes and floats of 4 or 8 are read)";
  else if (h.shape.size() > 2)
    h.unsupported = std::to_string(h.shape.size()) + " dimensions " + shape_text(h.shape) + " (1 or 2 are read)";
  return h;
}

}  // namespace stend::io::detail
