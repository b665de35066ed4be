// The HDF5 run store (run.h5): writer and SampleSource reader. Layout and rules:
// docs/recording-format.md. Internal to stend_recording; RecordingWriter and Recording::open use it.
#pragma once

#include "stend/recording/recording.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace stend::detail {

inline constexpr const char* kHdf5FileName = "run.h5";

// Appends a run to run.h5 while it goes. The file is created at the first samples (their
// counts→SI conversion decides each channel's encoding) or at finish(); truth rows, segment and
// event records that come earlier wait in memory. After creation the file is in SWMR mode: every
// flush() leaves a file that a reader can open even when the writer is killed right after.
class Hdf5RunWriter {
 public:
  Hdf5RunWriter(std::filesystem::path file, const RecordingHeader& header, std::string header_json,
                std::string experiment_yaml);
  ~Hdf5RunWriter();
  Hdf5RunWriter(const Hdf5RunWriter&) = delete;
  Hdf5RunWriter& operator=(const Hdf5RunWriter&) = delete;

  void add_samples(const ImuSample* samples, std::size_t count);
  void add_truth(double t_s, const std::vector<double>& values);
  // One CSV record of segments.csv / events.csv (with its line feed).
  void add_segment_record(std::string_view csv_record);
  void add_event_record(std::string_view csv_record);
  // Everything buffered into the file, and the file flushed to the OS.
  void flush();
  // Flushes, then writes how the run ended (message, end time, status last) in place.
  void finish(RunStatus status, const std::string& end_time_utc, const std::string& message);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// What Recording::open needs from run.h5: header, experiment, truth, segment and event records
// in memory, and the samples behind a SampleSource on the file.
struct Hdf5Run {
  std::string header_json;      // the header as run.json states it; empty when header_damage says why
  // Empty, or why the header attributes (header_json, experiment_yaml) cannot be read: a damaged
  // global heap in a format 1 file. The samples, truth, segments and events are read all the same.
  std::string header_damage;
  RunStatus status = RunStatus::kRunning;
  std::string experiment_yaml;
  std::vector<double> truth_t;
  std::vector<std::vector<double>> truth;
  std::shared_ptr<const RecordedTruth> truth_store;  // TruthLoading::kStream
  std::uint64_t truth_rows = 0;
  std::size_t truth_columns = 0;  // values per row (the dataset's columns after t_s)
  std::string segments_csv, events_csv;  // the CSV text of segments.csv / events.csv
  std::shared_ptr<const SampleSource> samples;
  std::uint64_t written_samples = 0;  // samples the file claims; samples->size() are readable
  std::string damage;                 // empty, or what is damaged (readable samples stop there)
  std::int64_t gap_count = -1;        // from the summary (final, or as of the last flush)
  std::int64_t irregular_count = -1;  // likewise; −1 when the file does not say
};
// Throws InputError naming the file and what is unreadable when the file cannot be used.
// The truth rows are read (kLoad), left behind truth_store (kStream) or counted (kSkip).
Hdf5Run open_hdf5_run(const std::filesystem::path& file, TruthLoading truth = TruthLoading::kLoad);

}  // namespace stend::detail
