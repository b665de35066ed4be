#include <stend/io/importers.hpp>
#include <stend/io/series.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>

namespace stend::io {

namespace {

bool separator(char c) { return c == ' ' || c == '\t' || c == ',' || c == ';' || c == '\r'; }

std::vector<std::string_view> fields_of(std::string_view line) {
  std::vector<std::string_view> out;
  for (std::size_t at = 0; at < line.size();) {
    while (at < line.size() && separator(line[at])) ++at;
    if (at == line.size()) break;
    std::size_t end = at;
    while (end < line.size() && !separator(line[end])) ++end;
    out.push_back(line.substr(at, end - at));
    at = end;
  }
  return out;
}

std::optional<double> number(std::string_view text) {
  const std::string_view digits = text.size() > 1 && text[0] == '+' ? text.substr(1) : text;  // from_chars takes no '+'
  double v = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (ec != std::errc() || end != digits.data() + digits.size() || (digits[0] == '-' && text[0] == '+') ||
      !std::isfinite(v))
    return std::nullopt;
  return v;
}

std::string shown(std::string_view text) {
  return std::string(text.substr(0, 40)) + (text.size() > 40 ? "…" : "");
}

}  // namespace

SeriesValues read_series(const std::filesystem::path& file, const SeriesColumn& which) {
  const bool by_number = !which.column.empty() && std::all_of(which.column.begin(), which.column.end(),
                                                              [](char c) { return c >= '0' && c <= '9'; });
  std::size_t index = 0;  // 0-based field
  if (by_number) {
    const auto n = number(which.column);
    if (!n || *n < 1) throw ImportError(file, 0, "column numbers start at 1 (got '" + which.column + "')");
    index = static_cast<std::size_t>(*n) - 1;
  } else if (which.column.empty()) {
    throw ImportError(file, 0, "no column given");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in || std::filesystem::is_directory(file)) throw ImportError(file, 0, "cannot open it (missing, or not a file)");
  SeriesValues out;
  std::string line;
  bool first = true;  // the first line after skip_lines: column names, or data
  for (std::size_t number_of_line = 1; std::getline(in, line); ++number_of_line) {
    if (number_of_line <= which.skip_lines) continue;
    const std::size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#' || line[start] == '%') continue;
    const auto fields = fields_of(line);
    if (first) {
      first = false;
      if (!by_number) {
        const auto it = std::find(fields.begin(), fields.end(), which.column);
        if (it == fields.end())
          throw ImportError(file, number_of_line, "no column named '" + which.column + "' on the column-name line '" +
                                                      shown(line) + "'");
        index = static_cast<std::size_t>(it - fields.begin());
        out.header = line;
        continue;
      }
      if (index < fields.size() && !number(fields[index])) {
        out.header = line;  // its field is text: the column names
        continue;
      }
    }
    if (index >= fields.size()) {
      throw ImportError(file, number_of_line, "has " + std::to_string(fields.size()) + " field(s); column " +
                                                  which.column + " was asked for");
    }
    const auto v = number(fields[index]);
    if (!v) {
      throw ImportError(file, number_of_line, "column " + which.column + ": '" + shown(fields[index]) +
                                                  "' is not a finite number");
    }
    if (out.values.empty()) out.first_line = number_of_line;
    out.values.push_back(*v);
  }
  if (in.bad()) throw ImportError(file, 0, "reading it failed");
  return out;
}

}  // namespace stend::io
