// The importer of a table of means without known inputs (import_means_table in
// stend/io/importers.hpp) and its content check (looks_like_means_table in stend/io/formats.hpp):
// the layout — delimiter, column-name line or none, which columns are the means and their noise —
// found once here for both.
#include "held_rows.hpp"

#include <stend/io/formats.hpp>
#include <stend/io/importers.hpp>
#include <stend/physics/units.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Consecutive rows of a table of means are different orientations; a log's consecutive samples
// (still or turned by hand) point the same way to within a fraction of a degree. Detection takes a
// file as a table of means only when its first rows turn by more than this (median) [deg].
constexpr double kMinRowTurn_deg = 2.0;
constexpr std::size_t kDetectRows = 20;  // rows the content check reads

const std::initializer_list<const char*> kAccelPrefixes = {"", "a", "acc", "accel", "accelerometer", "mean"};
const std::initializer_list<const char*> kTimeKeys = {"t", "time", "times", "timestamp", "ts", "tus", "tms"};

// The axis (0, 1, 2) a column key names as an accelerometer mean ("ax", "accx", "x", …); −1 for none.
int accel_axis_of(const std::string& key) {
  for (int a = 0; a < 3; ++a)
    for (const char* p : kAccelPrefixes)
      if (key == std::string(p) + static_cast<char>('x' + a)) return a;
  return -1;
}

bool is_time(const std::string& key) {
  return std::any_of(kTimeKeys.begin(), kTimeKeys.end(), [&](const char* k) { return key == k; });
}

// The delimiter of a line: ',' or ';' or a tab where it has one, else runs of blanks.
char guess_delimiter(std::string_view line) {
  for (const char c : {',', ';', '\t'})
    if (line.find(c) != std::string_view::npos) return c;
  return ' ';
}

std::string delimiter_name(char d) {
  switch (d) {
    case ',': return "comma";
    case ';': return "semicolon";
    case '\t': return "tab";
    case ' ': return "blanks";
  }
  return std::string("'") + d + "'";
}

std::vector<std::string_view> fields_of(std::string_view line, char delimiter) {
  std::vector<std::string_view> f = split(line, delimiter);
  for (auto& x : f) x = trim(x);
  return f;
}

bool all_numbers(const std::vector<std::string_view>& f) {
  double v = 0.0;
  return !f.empty() && std::all_of(f.begin(), f.end(), [&](std::string_view x) { return parse_double(x, v); });
}

// Where a table of means holds what, as found from its first line.
struct Layout {
  char delimiter = ',';
  bool named = false;              // a column-name line comes first
  std::vector<std::string> names;  // the columns' names (ax, ay, az without a name line)
  std::array<int, 3> accel{-1, -1, -1};
  SpreadColumns spread;
  std::vector<int> ignored;        // named columns that are neither means nor their noise
  std::string unit;                // what the means' names state: "mps2", "g", or "" (nothing)

  // "comma-delimited, columns ax, ay, az (means), n (samples per row) …; ignored: label"
  std::string describe() const {
    auto name = [&](int i) { return names[static_cast<std::size_t>(i)]; };
    std::string s = delimiter_name(delimiter) + "-delimited, " +
                    (named ? "columns named by the first line" : "no column-name line: three columns taken as ax ay az") +
                    "; means " + name(accel[0]) + ", " + name(accel[1]) + ", " + name(accel[2]) +
                    "; noise columns " + spread.describe(names);
    if (!ignored.empty()) {
      s += "; ignored columns";
      for (int i : ignored) s += " " + name(i);
    }
    return s;
  }
};

// The layout from the first non-comment line, or why it is not a table of means' (*problem).
std::optional<Layout> layout_of(std::string_view first, char delimiter, std::string* problem) {
  Layout l;
  l.delimiter = delimiter ? delimiter : guess_delimiter(first);
  const auto f = fields_of(first, l.delimiter);
  if (all_numbers(f)) {
    if (f.size() != 3) {
      *problem = "a table of means without a column-name line has three columns (ax ay az); this one has " +
                 std::to_string(f.size()) + ": name the columns in a first line, e.g. ax,ay,az,n,sigma";
      return std::nullopt;
    }
    l.names = {"ax", "ay", "az"};
    l.accel = {0, 1, 2};
    return l;
  }
  l.named = true;
  for (auto x : f) l.names.push_back(unquote(x));
  std::vector<std::string> units;
  for (std::size_t i = 0; i < l.names.size(); ++i) {
    const ColumnKey k = column_key(l.names[i]);
    if (is_time(k.key)) {
      *problem = "column '" + l.names[i] + "' is a time: this is a log of samples, not a table of means (import it "
                 "with --format csv and --accel/--time)";
      return std::nullopt;
    }
    const int a = accel_axis_of(k.key);
    if (a < 0) continue;
    auto& slot = l.accel[static_cast<std::size_t>(a)];
    if (slot >= 0) {
      *problem = "two columns name the " + std::string(1, static_cast<char>('x' + a)) + " mean: '" +
                 l.names[static_cast<std::size_t>(slot)] + "' and '" + l.names[i] + "'";
      return std::nullopt;
    }
    slot = static_cast<int>(i);
    units.push_back(k.unit);
  }
  if (std::any_of(l.accel.begin(), l.accel.end(), [](int i) { return i < 0; })) {
    *problem = "no accelerometer mean for each axis among the columns (expected names such as ax, ay, az or acc_x, "
               "acc_y, acc_z)";
    return std::nullopt;
  }
  if (std::adjacent_find(units.begin(), units.end(), std::not_equal_to<>()) != units.end()) {
    *problem = "the means' names state different units";
    return std::nullopt;
  }
  l.unit = units.front();
  return l;
}

// The rest of a named layout: its noise columns (through r, which fails at the name line) and the
// columns it ignores.
void add_spread(Layout& l, const LineReader& r) {
  if (!l.named) return;
  l.spread = spread_columns(r, l.names);
  for (std::size_t i = 0; i < l.names.size(); ++i) {
    const int c = static_cast<int>(i);
    if (std::find(l.accel.begin(), l.accel.end(), c) == l.accel.end() && !l.spread.uses(c)) l.ignored.push_back(c);
  }
}

// SI per file unit of the means, from the options and what the names state.
double means_scale(const LineReader& r, const Layout& l, const MeansTableOptions& o, std::string& said) {
  const double named = l.unit == "g" ? physics::kStandardGravity : 1.0;
  if (!l.unit.empty() && o.unit_stated && (o.counts || o.accel_scale != named))
    r.fail("the columns' names state the unit " + std::string(l.unit == "g" ? "g" : "m/s^2") +
           " but the import options another (" + (o.counts ? "counts, --accel-lsb" : "--accel-unit") +
           "): drop one of them");
  if (o.counts) {
    said = "counts of " + fmt_g(o.accel_scale) + " m/s^2 (--accel-lsb)" +
           (o.accel_offset_counts != 0.0 ? " around " + fmt_g(o.accel_offset_counts) + " (--accel-offset)" : "");
    return o.accel_scale;
  }
  if (!o.unit_stated && !l.unit.empty()) {
    said = std::string(l.unit == "g" ? "g" : "m/s^2") + " (from the columns' names)";
    return named;
  }
  said = std::string(o.accel_scale == physics::kStandardGravity ? "g" : "m/s^2") +
         (o.unit_stated ? " (--accel-unit)" : " (the default: --accel-unit g for a table in g)");
  return o.accel_scale;
}

// The angle between two vectors [deg] (0 when either is zero).
double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double n = a.norm() * b.norm();
  return n > 0.0 ? std::acos(std::clamp(a.dot(b) / n, -1.0, 1.0)) * physics::kRadToDeg : 0.0;
}

}  // namespace

bool MeansTableOptions::IsValid(std::string* error) const {
  if (!finite_nonzero(accel_scale)) return invalid(error, "accel_scale must be finite and not 0");
  if (!std::isfinite(accel_offset_counts)) return invalid(error, "accel_offset_counts must be finite");
  if (!gravity_or_unknown(gravity_mps2)) return invalid(error, "gravity_mps2 must be >= 0 (0: unknown)");
  return true;
}

Recording import_means_table(const fs::path& file, const MeansTableOptions& o) {
  require_valid(o, "means table options");
  LineReader r(file);
  std::string line;
  std::optional<Layout> layout;
  std::size_t first_data_line = 0;
  Recording rec = new_recording(file, "means_table");
  rec.header.gravity_mps2 = o.gravity_mps2;
  rec.header.truth_columns = held_truth_columns({});
  std::string unit_said;
  double scale = 1.0;
  while (r.next(line)) {
    const std::string_view t = trim(line);
    if (t.empty() || t.front() == '#' || t.front() == '%') continue;
    if (!layout) {
      std::string problem;
      layout = layout_of(t, o.delimiter, &problem);
      if (!layout) r.fail(problem);
      add_spread(*layout, r);
      scale = means_scale(r, *layout, o, unit_said);
      if (layout->named) continue;
    }
    const auto f = fields_of(t, layout->delimiter);
    if (f.size() != layout->names.size())
      r.fail("expected " + std::to_string(layout->names.size()) + " fields, found " + std::to_string(f.size()));
    if (first_data_line == 0) first_data_line = r.line();
    Eigen::Vector3d mean;
    for (int a = 0; a < 3; ++a) {
      const auto i = static_cast<std::size_t>(layout->accel[static_cast<std::size_t>(a)]);
      const double v = number(r, f[i], layout->names[i]);
      if (!std::isfinite(v)) r.fail("column '" + layout->names[i] + "': not a finite number");
      mean[a] = (v - (o.counts ? o.accel_offset_counts : 0.0)) * scale;
    }
    hold_row(rec, "row " + std::to_string(rec.segments.size() + 1) + " (line " + std::to_string(r.line()) + ")", mean,
             {}, row_spread(r, f, layout->spread, layout->names, scale));
  }
  if (!layout) throw ImportError(file, 0, "no data: only blank and comment lines");
  if (rec.segments.empty()) throw ImportError(file, 0, "no data rows after the column names");
  finish_held_rows(rec);
  if (o.counts) rec.header.info.accel_lsb_mps2 = o.accel_scale;
  add_import_event(rec, "imported a table of means without known inputs: " + std::to_string(rec.segments.size()) +
                            " rows from " + file.string() + " (first data line " + std::to_string(first_data_line) +
                            "); layout: " + layout->describe() + "; means in " + unit_said + "; " +
                            held_rows_text(layout->spread) +
                            "; no known input: for the unknown-orientation fit (|g| only)");
  return rec;
}

bool looks_like_means_table(const fs::path& p) {
  if (!fs::is_regular_file(p)) return false;
  std::ifstream in(p, std::ios::binary);
  std::vector<char> buf(kMaxLineBytes + 1);
  std::string line;
  bool cut = false;
  std::optional<Layout> layout;
  std::vector<Eigen::Vector3d> rows;
  while (rows.size() < kDetectRows && read_bounded_line(in, buf, line, cut)) {
    const std::string_view t = trim(line);
    if (cut || t.find('\0') != std::string_view::npos) return false;
    if (t.empty() || t.front() == '#' || t.front() == '%') continue;
    if (!layout) {
      std::string problem;
      layout = layout_of(t, 0, &problem);
      if (!layout) return false;
      if (layout->named) {
        try {
          add_spread(*layout, LineReader(p));
        } catch (const ImportError&) {
          return false;
        }
        if (!layout->ignored.empty()) return false;  // a column we cannot name: --format means_table
        continue;
      }
    }
    const auto f = fields_of(t, layout->delimiter);
    if (f.size() != layout->names.size() || !all_numbers(f)) return false;
    Eigen::Vector3d v;
    for (int a = 0; a < 3; ++a) parse_double(f[static_cast<std::size_t>(layout->accel[static_cast<std::size_t>(a)])], v[a]);
    rows.push_back(v);
  }
  if (rows.size() < 2) return false;
  std::vector<double> turns;
  for (std::size_t k = 1; k < rows.size(); ++k) turns.push_back(angle_deg(rows[k - 1], rows[k]));
  std::nth_element(turns.begin(), turns.begin() + static_cast<std::ptrdiff_t>(turns.size() / 2), turns.end());
  return turns[turns.size() / 2] > kMinRowTurn_deg;
}

}  // namespace stend::io
