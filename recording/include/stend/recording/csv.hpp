// Fast CSV helpers shared by the recording store and exporters/importers.
//
// Writing: numbers go through std::to_chars (doubles in shortest round-trip form, so reading them
// back with std::from_chars is bit-exact); NaN is an empty field; text fields are quoted
// RFC 4180-style only when they must be. Reading: a chunked file reader that hands out complete
// lines (fast path, no quoting) or complete records (quoted fields, embedded line breaks), and
// never returns a trailing record that lacks its line feed (an interrupted write) — it counts it
// in partial() instead. Quoting is strict: malformed quoting is an error naming file and line.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace stend::csv {

// Room write_double needs: "-2.2250738585072014e-308" is 24 characters.
inline constexpr std::size_t kMaxDoubleChars = 24;
// Room write_int needs for any 32-bit value ("-2147483648").
inline constexpr std::size_t kMaxInt32Chars = 11;

// Shortest round-trip text of v at `out`; NaN writes nothing (an empty field); ±infinity writes
// "inf" / "-inf". Returns the end of what was written (needs kMaxDoubleChars of room).
char* write_double(char* out, double v) noexcept;
char* write_int(char* out, std::int64_t v) noexcept;
char* write_uint(char* out, std::uint64_t v) noexcept;

void append_double(std::string& out, double v);
// Appends `field`, quoted ("a ""b"", c") when it holds a comma, a double quote, CR or LF.
void append_field(std::string& out, std::string_view field);
// Appends the fields joined by commas and a terminating '\n'.
void append_record(std::string& out, const std::vector<std::string>& fields);

// Whole-field parsers; false when the text is not exactly one value of the type.
// parse_double: empty, "nan", "NaN", "-nan" → NaN; "inf", "-inf", "Inf" → ±infinity.
bool parse_double(std::string_view text, double& out) noexcept;
bool parse_int(std::string_view text, std::int64_t& out) noexcept;
bool parse_uint(std::string_view text, std::uint64_t& out) noexcept;
// "1"/"0"/"true"/"false" (any case).
bool parse_bool(std::string_view text, bool& out) noexcept;

// Splits one record (without its terminating line feed) into fields, undoing RFC 4180 quoting.
// Throws InputError on malformed quoting.
std::vector<std::string> split_record(std::string_view record);

// Reads a CSV file in large chunks through read(2).
class Reader {
 public:
  // Throws InputError naming the file when it cannot be opened.
  explicit Reader(const std::filesystem::path& file, std::size_t chunk_bytes = 4u << 20);
  // Reads `text` held in memory (copied); `name` stands for the file in errors.
  Reader(std::filesystem::path name, std::string_view text);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // Next complete line, without "\n" or "\r\n", no quote handling. The view is valid until the
  // next call. Returns false at the end; a trailing line without '\n' is not returned and is
  // counted in partial().
  bool next_line(std::string_view& line);
  // Next complete record with RFC 4180 quoting (quoted fields may hold line breaks).
  // Throws InputError naming file and line on malformed quoting: a double quote inside an
  // unquoted field, text after a closing quote, or a quote left open at the end of the file (named
  // at the line where it opened).
  bool next_record(std::vector<std::string>& fields);

  // First physical line (1-based) of what the last call returned.
  std::size_t line() const { return line_; }
  std::size_t partial() const { return partial_; }
  std::uint64_t file_size() const { return file_size_; }
  std::uint64_t bytes_consumed() const { return consumed_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  bool fill();  // false at end of file

  std::filesystem::path path_;
  int fd_ = -1;
  std::vector<char> buf_;
  std::size_t pos_ = 0, end_ = 0;
  bool eof_ = false;
  std::size_t line_ = 0;       // first line of the last returned line/record
  std::size_t next_line_ = 1;  // line number of the byte at pos_
  std::size_t partial_ = 0;
  std::uint64_t file_size_ = 0;
  std::uint64_t consumed_ = 0;
};

}  // namespace stend::csv
