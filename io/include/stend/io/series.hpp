// A plain time series in a text file — one value per line, or one column of several — as Stable32,
// allantools, clock counters and many gyro loggers write it: phase (time error) or frequency / rate
// data for `stend deviations`. Lines that are empty or start with '#' or '%' are skipped; fields
// are separated by spaces, tabs, commas or semicolons.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace stend::io {

struct SeriesColumn {
  std::string column = "1";   // 1-based number, or a name from the column-name line
  std::size_t skip_lines = 0;  // lines before the column names (or the data), read as they are
};

struct SeriesValues {
  std::vector<double> values;  // in file order
  std::size_t first_line = 0;  // 1-based line of the first value
  std::string header;          // the column-name line, when there is one
};

// The values of one column of every data line. The first line after skip_lines names the columns
// when the column is asked for by name, or when its field there is not a number. Throws
// ImportError naming file:line for a missing file, an unknown column name, a line without the
// column, a field that is not a finite number (with its text, cut to 40 characters).
SeriesValues read_series(const std::filesystem::path& file, const SeriesColumn& which = {});

}  // namespace stend::io
