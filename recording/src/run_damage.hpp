// The damage checks of a CSV run folder: what reading each file found, against the rows and bytes
// the writer recorded in run.json when the run finished. (run.h5 checks itself while it is read:
// hdf5_reader.cpp, hdf5_damage.cpp.) Internal to stend_recording.
#pragma once

#include "stend/recording/csv.hpp"
#include "stend/recording/recording.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

namespace stend::detail {

// What reading one CSV file found: its whole rows (header and blank lines not counted; nullopt when
// the rows were not read), the line of the last whole one, whether the file ends inside a line (no
// line feed), and its length [bytes].
struct FileRead {
  std::filesystem::path path;
  bool exists = true;
  std::optional<std::uint64_t> rows;
  std::size_t last_line = 0;
  bool cut = false;
  std::uint64_t bytes = 0;
};

// The FileRead of a file that is not there, or whose rows were not read (its length only).
FileRead file_not_read(const std::filesystem::path& file);
// The FileRead of `rows` rows read through `rd`; a cut last line is counted in r.
FileRead file_read(const csv::Reader& rd, std::uint64_t rows, Recording& r);

// A finished run's files against what its writer recorded in run.json at finish: what differs
// goes to r.damage (the rows read stay usable), and r.written_samples becomes the samples written.
void check_recorded_counts(const nlohmann::json& run_json, const std::vector<FileRead>& files, Recording& r);

}  // namespace stend::detail
