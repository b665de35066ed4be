// The CSV run store: imu.csv, truth.csv, segments.csv and events.csv of a run folder (layout in
// docs/recording-format.md), written through write(2) while the run goes and read back whole.
// The segment and event records are the same CSV text in run.h5 (segments_csv, events_csv).
// Internal to stend_recording.
#pragma once

#include "run_damage.hpp"

#include "stend/recording/csv.hpp"
#include "stend/recording/recording.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace stend::detail {

inline constexpr std::string_view kImuHeader =
    "t_s,ax_counts,ay_counts,az_counts,gx_counts,gy_counts,gz_counts,temp_counts,"
    "ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps,temp_c,flags";
inline constexpr const char* kImuColumnNames[] = {
    "t_s",     "ax_counts", "ay_counts", "az_counts", "gx_counts", "gy_counts",
    "gz_counts", "temp_counts", "ax_mps2", "ay_mps2",  "az_mps2",   "gx_radps",
    "gy_radps", "gz_radps", "temp_c",    "flags"};
inline constexpr std::size_t kImuColumns = sizeof(kImuColumnNames) / sizeof(kImuColumnNames[0]);
// Upper bound of one imu.csv row [bytes]: 8 doubles, 7 int32, one uint32, 15 commas and a line feed.
inline constexpr std::size_t kImuRowMax = 8 * csv::kMaxDoubleChars + 7 * csv::kMaxInt32Chars + 10 + 16;

// --- segment and event records (run_records.cpp) --------------------------------------------

// The column-name lines' fields of segments.csv and events.csv.
const std::vector<std::string>& segment_columns();
const std::vector<std::string>& event_columns();
// One record of segments.csv / events.csv, with its line feed, appended to `line`.
void append_segment_record(std::string& line, const Segment& s);
void append_event_record(std::string& line, const Event& e);
// The records of segments.csv / events.csv (or run.h5's text of them) into r.segments / r.events.
// Throws InputError naming the file, line and column of a malformed record.
FileRead read_segments(csv::Reader& rd, Recording& r);
FileRead read_events(csv::Reader& rd, Recording& r);

// --- writer (csv_run_writer.cpp) -------------------------------------------------------------

// The four files of a CSV run folder, appended to through buffers drained by write(2). Durability
// (when to flush) is the RecordingWriter's; an event record is written through at once.
class CsvRunWriter {
 public:
  // Creates imu.csv, truth.csv, segments.csv and events.csv in `run_dir` (none may exist) and puts
  // the column-name lines of imu.csv and truth.csv (t_s, then `truth_columns`) in their buffers.
  CsvRunWriter(const std::filesystem::path& run_dir, const std::vector<std::string>& truth_columns);
  ~CsvRunWriter();
  CsvRunWriter(const CsvRunWriter&) = delete;
  CsvRunWriter& operator=(const CsvRunWriter&) = delete;

  void add_samples(const ImuSample* samples, std::size_t count);
  void add_truth(double t_s, const std::vector<double>& values);
  void add_segment_record(std::string_view record);
  void add_event_record(std::string_view record);  // and the events file flushed
  void flush();  // every buffer to the OS
  void sync();   // every file to the device (fdatasync)
  // Each file's length written so far [bytes], as run.json's "file_bytes" records it.
  nlohmann::ordered_json file_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// --- reader (csv_run_reader.cpp) -------------------------------------------------------------

// The CSV files of run folder `run_dir` into `r` (samples in memory, or behind r.source with
// kStream; truth read unless kSkip), checked against the counts in run.json (r.damage).
void open_csv(const std::filesystem::path& run_dir, const nlohmann::json& run_json, Recording& r,
              SampleLoading loading, TruthLoading truth);

}  // namespace stend::detail
