// The records of segments.csv and events.csv (the same text in run.h5's segments_csv and
// events_csv): written from a Segment / Event, and read back with every field checked.
#include "csv_run_store.hpp"
#include "store_files.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <iterator>
#include <limits>
#include <utility>

namespace stend::detail {

namespace fs = std::filesystem;

const std::vector<std::string>& segment_columns() {
  static const std::vector<std::string> columns = {
      "id",      "step",    "kind",     "label",   "repeat",     "orientation", "orientation_count",
      "t_start_s", "t_end_s", "settled", "complete", "targets",  "setpoint_c",  "rate_per_s"};
  return columns;
}

const std::vector<std::string>& event_columns() {
  static const std::vector<std::string> columns = {"t_s", "level", "source", "message"};
  return columns;
}

void append_segment_record(std::string& line, const Segment& s) {
  fmt::format_to(std::back_inserter(line), "{},{},", s.id, s.step);
  csv::append_field(line, to_string(s.kind));
  line.push_back(',');
  csv::append_field(line, s.label);
  fmt::format_to(std::back_inserter(line), ",{},{},{},", s.repeat, s.orientation,
                 s.orientation_count);
  csv::append_double(line, s.t_start_s);
  line.push_back(',');
  csv::append_double(line, s.t_end_s);
  line.append(s.settled ? ",1," : ",0,");
  line.append(s.complete ? "1," : "0,");
  csv::append_field(line, s.targets);
  line.push_back(',');
  csv::append_double(line, s.setpoint_c);
  line.push_back(',');
  csv::append_double(line, s.rate);
  line.push_back('\n');
}

void append_event_record(std::string& line, const Event& e) {
  csv::append_double(line, e.t_s);
  line.push_back(',');
  csv::append_field(line, e.level);
  line.push_back(',');
  csv::append_field(line, e.source);
  line.push_back(',');
  csv::append_field(line, e.message);
  line.push_back('\n');
}

namespace {

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

bool blank(const std::vector<std::string>& f) { return f.size() == 1 && f[0].empty(); }

void check_header(const csv::Reader& rd, const std::vector<std::string>& got,
                  const std::vector<std::string>& want) {
  if (got != want) {
    std::string a, b;
    csv::append_record(a, got);
    csv::append_record(b, want);
    a.pop_back();
    b.pop_back();
    fail_at(rd.path(), rd.line(), fmt::format("unexpected header '{}'; expected '{}'", excerpt(a), b));
  }
}

}  // namespace

FileRead read_segments(csv::Reader& rd, Recording& r) {
  static const std::string kKindWords = "a segment kind (" + join(segment_kind_names()) + ")";
  const fs::path& file = rd.path();
  std::vector<std::string> f;
  if (!rd.next_record(f)) return file_read(rd, 0, r);
  check_header(rd, f, segment_columns());
  std::uint64_t rows = 0;
  while (rd.next_record(f)) {
    if (blank(f)) continue;
    if (f.size() != segment_columns().size()) {
      fail_at(file, rd.line(), fmt::format("expected {} fields, found {}",
                                           segment_columns().size(), f.size()));
    }
    auto bad = [&](std::size_t col, const char* what) {
      fail_at(file, rd.line(), fmt::format("column {} ({}): '{}' is not {}", col + 1,
                                           segment_columns()[col], excerpt(f[col]), what));
    };
    auto integer = [&](std::size_t col, int& out) {
      std::int64_t v = 0;
      if (!csv::parse_int(f[col], v) || v < std::numeric_limits<int>::min() ||
          v > std::numeric_limits<int>::max()) {
        bad(col, "an integer");
      }
      out = static_cast<int>(v);
    };
    auto number = [&](std::size_t col, double& out) {
      if (!csv::parse_double(f[col], out)) bad(col, "a number");
    };
    auto flag = [&](std::size_t col, bool& out) {
      if (!csv::parse_bool(f[col], out)) bad(col, "0 or 1");
    };
    Segment s;
    integer(0, s.id);
    integer(1, s.step);
    const auto kind = segment_kind_from_string(f[2]);
    if (!kind) bad(2, kKindWords.c_str());
    s.kind = *kind;
    s.label = std::move(f[3]);
    integer(4, s.repeat);
    integer(5, s.orientation);
    integer(6, s.orientation_count);
    number(7, s.t_start_s);
    number(8, s.t_end_s);
    flag(9, s.settled);
    flag(10, s.complete);
    s.targets = std::move(f[11]);
    number(12, s.setpoint_c);
    number(13, s.rate);
    r.segments.push_back(std::move(s));
    ++rows;
  }
  return file_read(rd, rows, r);
}

FileRead read_events(csv::Reader& rd, Recording& r) {
  const fs::path& file = rd.path();
  std::vector<std::string> f;
  if (!rd.next_record(f)) return file_read(rd, 0, r);
  check_header(rd, f, event_columns());
  std::uint64_t rows = 0;
  while (rd.next_record(f)) {
    if (blank(f)) continue;
    if (f.size() != event_columns().size()) {
      fail_at(file, rd.line(),
              fmt::format("expected {} fields, found {}", event_columns().size(), f.size()));
    }
    Event e;
    if (!csv::parse_double(f[0], e.t_s)) {
      fail_at(file, rd.line(), fmt::format("column 1 (t_s): '{}' is not a number", excerpt(f[0])));
    }
    e.level = std::move(f[1]);
    e.source = std::move(f[2]);
    e.message = std::move(f[3]);
    r.events.push_back(std::move(e));
    ++rows;
  }
  return file_read(rd, rows, r);
}


}  // namespace stend::detail
