// Damage checks of a run folder (see run_damage.hpp) and require_whole.
#include "run_damage.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <string>
#include <system_error>
#include <utility>

namespace stend {
namespace detail {

namespace fs = std::filesystem;

FileRead file_not_read(const fs::path& file) {
  FileRead f;
  f.path = file;
  std::error_code ec;
  f.exists = fs::exists(file, ec);
  if (f.exists) f.bytes = fs::file_size(file, ec);
  return f;
}

FileRead file_read(const csv::Reader& rd, std::uint64_t rows, Recording& r) {
  r.dropped_partial_lines += rd.partial();
  return {rd.path(), true, rows, rd.line(), rd.partial() > 0, rd.file_size()};
}

namespace {

// run.json's count `key` under `obj`, nullopt when absent (run folders from before that count).
std::optional<std::uint64_t> recorded_count(const nlohmann::json& obj, const char* key) {
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_number_unsigned()) return std::nullopt;
  return it->get<std::uint64_t>();
}

// What is damaged in one file of a finished run, against the rows and bytes run.json records
// (absent counts are not compared); empty when the file is whole.
std::string file_damage(const FileRead& f, std::optional<std::uint64_t> rows,
                        std::optional<std::uint64_t> bytes) {
  if (!f.exists) {
    // A file of no rows lost nothing but its column-name line (events.csv of a run without events).
    if (rows ? *rows == 0 : bytes.value_or(0) == 0) return {};
    return fmt::format("{}: missing; run.json records {} rows", f.path.string(), rows.value_or(0));
  }
  std::vector<std::string> what;
  if (f.cut) what.push_back("the last line is cut mid-line (no line feed at the end of the file)");
  if (rows && f.rows && *rows != *f.rows) {
    what.push_back(fmt::format("run.json records {} rows, {} whole rows found (the last good line is {})",
                               *rows, *f.rows, f.last_line));
  }
  if (bytes && *bytes != f.bytes)
    what.push_back(fmt::format("run.json records {} bytes, the file holds {}", *bytes, f.bytes));
  if (what.empty()) return {};
  std::string out = fmt::format("{}:{}: ", f.path.string(), f.cut ? f.last_line + 1 : f.last_line);
  for (std::size_t i = 0; i < what.size(); ++i) out += (i ? "; " : "") + what[i];
  return out;
}

}  // namespace

void check_recorded_counts(const nlohmann::json& run_json, const std::vector<FileRead>& files, Recording& r) {
  if (r.header.status == RunStatus::kRunning) return;  // killed: no counts, a cut last line is expected
  constexpr std::pair<const char*, const char*> kRowKeys[] = {
      {"imu.csv", "sample_count"}, {"truth.csv", "truth_count"},
      {"segments.csv", "segment_count"}, {"events.csv", "event_count"}};
  const auto bytes_it = run_json.find("file_bytes");
  for (const FileRead& f : files) {
    const std::string name = f.path.filename().string();
    std::optional<std::uint64_t> rows, bytes;
    for (const auto& [file, key] : kRowKeys)
      if (name == file) rows = recorded_count(run_json, key);
    if (bytes_it != run_json.end() && bytes_it->is_object()) bytes = recorded_count(*bytes_it, name.c_str());
    const std::string d = file_damage(f, rows, bytes);
    if (d.empty()) continue;
    r.damage += (r.damage.empty() ? "" : "; ") + d;
    if (name == "imu.csv" && rows) r.written_samples = *rows;
  }
}

}  // namespace detail

void require_whole(const Recording& rec) {
  if (rec.damage.empty()) return;
  throw InputError(fmt::format("{}: the run is damaged ({} of {} samples are readable): {}", rec.dir.string(),
                               rec.sample_count(), rec.written_samples, rec.damage));
}

}  // namespace stend
