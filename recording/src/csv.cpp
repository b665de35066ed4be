#include "stend/recording/csv.hpp"

#include "stend/errors.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <utility>

namespace stend::csv {

char* write_double(char* out, double v) noexcept {
  if (std::isnan(v)) return out;
  return std::to_chars(out, out + kMaxDoubleChars, v).ptr;
}

char* write_int(char* out, std::int64_t v) noexcept { return std::to_chars(out, out + 20, v).ptr; }

char* write_uint(char* out, std::uint64_t v) noexcept {
  return std::to_chars(out, out + 20, v).ptr;
}

void append_double(std::string& out, double v) {
  char buf[kMaxDoubleChars];
  out.append(buf, write_double(buf, v));
}

void append_field(std::string& out, std::string_view field) {
  if (field.find_first_of(",\"\r\n") == std::string_view::npos) {
    out.append(field);
    return;
  }
  out.push_back('"');
  for (char c : field) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  out.push_back('"');
}

void append_record(std::string& out, const std::vector<std::string>& fields) {
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i) out.push_back(',');
    append_field(out, fields[i]);
  }
  out.push_back('\n');
}

namespace {

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

}  // namespace

bool parse_double(std::string_view text, double& out) noexcept {
  if (text.empty()) {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  const char* b = text.data();
  const char* e = b + text.size();
  if (*b == '+' && e - b > 1 && b[1] != '-') ++b;
  auto [ptr, ec] = std::from_chars(b, e, out);
  if (ec == std::errc{} && ptr == e) {
    if (std::isnan(out)) out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  std::string_view t(b, static_cast<std::size_t>(e - b));
  bool neg = false;
  if (!t.empty() && t.front() == '-') {
    neg = true;
    t.remove_prefix(1);
  }
  if (iequals(t, "nan")) {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (iequals(t, "inf") || iequals(t, "infinity")) {
    out = neg ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return true;
  }
  return false;
}

bool parse_int(std::string_view text, std::int64_t& out) noexcept {
  const char* b = text.data();
  const char* e = b + text.size();
  if (b != e && *b == '+') ++b;
  auto [ptr, ec] = std::from_chars(b, e, out);
  return b != e && ec == std::errc{} && ptr == e;
}

bool parse_uint(std::string_view text, std::uint64_t& out) noexcept {
  const char* b = text.data();
  const char* e = b + text.size();
  if (b != e && *b == '+') ++b;
  auto [ptr, ec] = std::from_chars(b, e, out);
  return b != e && ec == std::errc{} && ptr == e;
}

bool parse_bool(std::string_view text, bool& out) noexcept {
  if (text == "1" || iequals(text, "true")) {
    out = true;
    return true;
  }
  if (text == "0" || iequals(text, "false")) {
    out = false;
    return true;
  }
  return false;
}

std::vector<std::string> split_record(std::string_view record) {
  std::vector<std::string> fields;
  std::string cur;
  enum { kStart, kUnquoted, kQuoted, kQuoteInQuoted } st = kStart;
  for (std::size_t i = 0; i < record.size(); ++i) {
    const char c = record[i];
    switch (st) {
      case kStart:
        if (c == '"') {
          st = kQuoted;
        } else if (c == ',') {
          fields.push_back(std::move(cur));
          cur.clear();
        } else {
          cur.push_back(c);
          st = kUnquoted;
        }
        break;
      case kUnquoted:
        if (c == ',') {
          fields.push_back(std::move(cur));
          cur.clear();
          st = kStart;
        } else if (c == '"') {
          throw InputError("a double quote inside an unquoted field");
        } else {
          cur.push_back(c);
        }
        break;
      case kQuoted:
        if (c == '"') {
          st = kQuoteInQuoted;
        } else {
          cur.push_back(c);
        }
        break;
      case kQuoteInQuoted:
        if (c == '"') {
          cur.push_back('"');
          st = kQuoted;
        } else if (c == ',') {
          fields.push_back(std::move(cur));
          cur.clear();
          st = kStart;
        } else if (c == '\r' && i + 1 == record.size()) {
          // CRLF line ending after a closing quote
        } else {
          throw InputError("text after a closing double quote");
        }
        break;
    }
  }
  if (st == kQuoted) throw InputError("unterminated double quote");
  if (st == kUnquoted && !cur.empty() && cur.back() == '\r') cur.pop_back();
  fields.push_back(std::move(cur));
  return fields;
}

// ---------------------------------------------------------------------------------------------

Reader::Reader(const std::filesystem::path& file, std::size_t chunk_bytes)
    : path_(file), buf_(chunk_bytes < 4096 ? 4096 : chunk_bytes) {
  fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) {
    throw InputError(file.string() + ": cannot open: " + std::strerror(errno));
  }
  struct stat st {};
  if (::fstat(fd_, &st) == 0) file_size_ = static_cast<std::uint64_t>(st.st_size);
#ifdef POSIX_FADV_SEQUENTIAL
  ::posix_fadvise(fd_, 0, 0, POSIX_FADV_SEQUENTIAL);
#endif
}

Reader::Reader(std::filesystem::path name, std::string_view text)
    : path_(std::move(name)), buf_(text.begin(), text.end()), end_(text.size()), eof_(true),
      file_size_(text.size()) {}

Reader::~Reader() {
  if (fd_ >= 0) ::close(fd_);
}

bool Reader::fill() {
  if (eof_) return false;
  if (pos_ > 0) {
    std::memmove(buf_.data(), buf_.data() + pos_, end_ - pos_);
    end_ -= pos_;
    pos_ = 0;
  }
  if (end_ == buf_.size()) buf_.resize(buf_.size() * 2);
  for (;;) {
    const ssize_t n = ::read(fd_, buf_.data() + end_, buf_.size() - end_);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(path_.string() + ": read failed: " + std::strerror(errno));
    }
    if (n == 0) {
      eof_ = true;
      return false;
    }
    end_ += static_cast<std::size_t>(n);
    return true;
  }
}

bool Reader::next_line(std::string_view& line) {
  std::size_t scanned = pos_;
  for (;;) {
    const char* base = buf_.data();
    const void* nl = std::memchr(base + scanned, '\n', end_ - scanned);
    if (nl) {
      const char* b = base + pos_;
      const char* e = static_cast<const char*>(nl);
      const std::size_t len = static_cast<std::size_t>(e - b);
      consumed_ += len + 1;
      pos_ += len + 1;
      if (e != b && e[-1] == '\r') --e;
      line = std::string_view(b, static_cast<std::size_t>(e - b));
      line_ = next_line_++;
      return true;
    }
    const std::size_t pending = end_ - pos_;
    if (!fill()) {
      if (end_ > pos_) {
        ++partial_;
        pos_ = end_;
      }
      return false;
    }
    scanned = pending;  // after fill() the pending bytes start at 0
  }
}

bool Reader::next_record(std::vector<std::string>& fields) {
  for (;;) {
    // Find the line feed that ends the record, outside double quotes.
    enum { kStart, kUnquoted, kQuoted, kQuoteInQuoted } st = kStart;
    std::size_t inner_newlines = 0;
    std::size_t quote_line = 0;  // line of the quote that opened the current quoted field
    std::size_t i = pos_;
    bool found = false;
    for (; i < end_ && !found; ++i) {
      const char c = buf_[i];
      switch (st) {
        case kStart:
          if (c == '"') {
            st = kQuoted;
            quote_line = next_line_ + inner_newlines;
          } else if (c == '\n') {
            found = true;
          } else if (c != ',') {
            st = kUnquoted;
          }
          break;
        case kUnquoted:
          if (c == ',') st = kStart;
          else if (c == '\n') found = true;
          break;
        case kQuoted:
          if (c == '"') st = kQuoteInQuoted;
          else if (c == '\n') ++inner_newlines;
          break;
        case kQuoteInQuoted:
          if (c == '"') st = kQuoted;
          else if (c == ',') st = kStart;
          else if (c == '\n') found = true;
          else st = kUnquoted;  // malformed; split_record reports it
          break;
      }
    }
    if (found) {
      const std::size_t nl = i - 1;
      std::string_view rec(buf_.data() + pos_, nl - pos_);
      line_ = next_line_;
      next_line_ += 1 + inner_newlines;
      consumed_ += nl + 1 - pos_;
      pos_ = nl + 1;
      if (!rec.empty() && rec.back() == '\r') rec.remove_suffix(1);
      try {
        fields = split_record(rec);
      } catch (const std::exception& e) {
        throw InputError(path_.string() + ":" + std::to_string(line_) + ": " + e.what());
      }
      return true;
    }
    if (!fill()) {
      // A quote still open at the end: an interrupted write when the file stops mid-line, else
      // a quote that was never closed.
      if (st == kQuoted && end_ > 0 && buf_[end_ - 1] == '\n') {
        throw InputError(path_.string() + ":" + std::to_string(quote_line) +
                         ": unterminated double quote (the quoted field runs to the end of "
                         "the file)");
      }
      if (end_ > pos_) {
        ++partial_;
        pos_ = end_;
      }
      return false;
    }
  }
}

}  // namespace stend::csv
