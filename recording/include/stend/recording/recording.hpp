// The recording: the only contract between acquisition and analysis.
//
// A run folder, readable without Stend (layout in docs/recording-format.md), in one of two
// formats. HDF5 (the default): run.json and experiment.yaml as below, and run.h5 holding the
// samples (counts in their native width, SI derived from the stored conversion), truth, segments,
// events and the header as attributes; written in SWMR mode and flushed each second of wall time,
// so a SIGKILL loses at most about the last second and the file stays readable. run.h5 is the
// source of truth: its header attributes win over run.json, a human-readable copy written at the
// start and at finish(). CSV (RecordingFormat::kCsv, and every run folder of older versions):
//   run.json        header: format version, experiment name, stend version, plugins, sensor
//                   identity and info, gravity, mounting, seed, clock, truth columns, start time;
//                   rewritten at finish() with status "complete" | "interrupted" | "failed"
//                   (a run killed mid-way keeps "running", which readers report as incomplete)
//   experiment.yaml the resolved experiment
//   imu.csv         one row per sample: t_s, ax_counts, ay_counts, az_counts, gx_counts, gy_counts,
//                   gz_counts, temp_counts, ax_mps2, ay_mps2, az_mps2, gx_radps, gy_radps, gz_radps,
//                   temp_c, flags
//   truth.csv       bench truth snapshots: t_s, then header.truth_columns
//   segments.csv    one row per closed segment (see Segment)
//   events.csv      t_s, level, source, message — faults, retries, gaps, operator notes
// Written incrementally through write(2): a SIGKILL loses at most the last ~1 s (run time or wall
// time, whichever comes first), and a reader accepts a truncated last line.
#pragma once

#include <stend/physics/units.hpp>
#include <stend/recording/samples.hpp>
#include <stend/sdk.hpp>

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace stend {

inline constexpr int kRecordingFormatVersion = 1;

// A run's state, run.json's "status": kRunning from the start until finish(), and forever when
// the writer never finished (a killed run); then kComplete, kInterrupted (stopped by the operator)
// or kFailed (a fault).
enum class RunStatus { kRunning, kComplete, kInterrupted, kFailed };
// "running" | "complete" | "interrupted" | "failed".
const char* to_string(RunStatus s);
// The status of that name, or nullopt.
std::optional<RunStatus> run_status_from_string(std::string_view name);
std::ostream& operator<<(std::ostream& os, RunStatus s);

struct PluginUse {
  std::string role;  // "sensor" or the fixture id
  std::string name, version, file;
  std::string origin;  // the search-path entry it was found through (SearchDir::origin)
  std::string hash;    // "crc32:<8 hex digits>" (zlib CRC-32) of the file's content; "" when unreadable
};

struct RecordingHeader {
  std::string experiment_name;
  std::string experiment_file;
  std::string stend_version;
  std::vector<PluginUse> plugins;
  SensorIdentity identity;
  SensorInfo info;
  double gravity_mps2 = 0.0;  // local gravity of the run; 0 = unknown (an import that does not say)
  double latitude_deg = 0.0;
  double height_m = 0.0;
  std::vector<double> mounting_R;  // 9 values, row-major R_sensor_from_mount
  std::uint64_t seed = 0;
  std::string clock;  // "simulated" | "wall"
  std::vector<std::string> truth_columns;  // e.g. "table.angle.cmd_deg", "air_c", "f_x_mps2"
  std::string start_time_utc;  // ISO 8601; filled by the writer when empty
  RunStatus status = RunStatus::kRunning;

  // The run's local gravity [m/s²], or standard gravity when the recording does not state one.
  double gravity_or_standard_mps2() const {
    return gravity_mps2 > 0.0 ? gravity_mps2 : physics::kStandardGravity;
  }
};

// What a segment of the recording is. The runner writes one per pose (kOrientation) or rate
// (kRate) of a table step, one per record step and one per recorded set_temperature settling;
// importers add kRotation (a turn between poses); the static detector marks its intervals
// kDetected; kWait is accepted as a kind that processing options may name.
enum class SegmentKind { kOrientation, kRate, kRotation, kSetTemperature, kRecord, kWait, kDetected };
// "orientation" | "rate" | "rotation" | "set_temperature" | "record" | "wait" | "detected".
const char* to_string(SegmentKind k);
// The kind of that name, or nullopt.
std::optional<SegmentKind> segment_kind_from_string(std::string_view name);
// Every kind's name, in the enum's order (for messages and option checks).
const std::vector<std::string>& segment_kind_names();
std::ostream& operator<<(std::ostream& os, SegmentKind k);

struct Segment {
  int id = 0;
  int step = 0;            // index into the procedure
  SegmentKind kind = SegmentKind::kRecord;
  std::string label;
  int repeat = 0;
  int orientation = -1;    // index within the step (orientation k), −1 when not applicable
  int orientation_count = 0;
  double t_start_s = 0.0;  // recorded data interval
  double t_end_s = 0.0;
  bool settled = true;     // fixture/chamber were settled for the whole interval
  bool complete = true;    // false when the run stopped inside the segment
  std::string targets;     // "table.angle=10 deg; chamber.temperature=25 degC"
  double setpoint_c = std::numeric_limits<double>::quiet_NaN();  // chamber setpoint during the segment, NaN when none
  double rate = std::numeric_limits<double>::quiet_NaN();        // commanded rate (axis unit/s), NaN when none

  // "#3 orientation 'tilt 10' 12.00–22.00 s [unsettled]": id, kind, label, interval, flags.
  void print(std::ostream& os) const;
  // Every field equal; times, setpoint and rate within `tol` (relative above 1; NaN matches NaN).
  bool equals(const Segment& other, double tol = 1e-9) const;
};

struct Event {
  double t_s = 0.0;
  std::string level;   // "info" | "warning" | "error"
  std::string source;  // "sensor", a fixture id, "runner"
  std::string message;
};

// How a run folder stores its data: run.h5 (HDF5) or the CSV files.
enum class RecordingFormat { kHdf5, kCsv };
// "hdf5" | "csv".
const char* to_string(RecordingFormat f);
// The format of that name, or nullopt.
std::optional<RecordingFormat> recording_format_from_string(std::string_view name);
// Upper bounds of the bytes one sensor sample and one bench-truth value take in a run folder of
// that format (uncompressed), for the size a run will reach before it starts.
std::size_t max_bytes_per_sample(RecordingFormat f);
std::size_t max_bytes_per_truth_value(RecordingFormat f);

struct RecordingWriterOptions {
  RecordingFormat format = RecordingFormat::kHdf5;
  // When the store is flushed. 0: at least every second of wall time (and, for the CSV store, of
  // run time), the durability a live bench needs. N > 0: every N samples and at finish, whatever
  // the clock — an import, whose source stays on disk, does the same work on any machine at any
  // load.
  std::uint64_t flush_every_samples = 0;

  bool IsValid(std::string* error = nullptr) const;  // a known format
};

class RecordingWriter {
 public:
  // Creates `run_dir` (must not exist), writes run.json and experiment.yaml, opens the streams.
  RecordingWriter(const std::filesystem::path& run_dir, RecordingHeader header,
                  const std::string& resolved_experiment_yaml,
                  const RecordingWriterOptions& options = {});
  ~RecordingWriter();  // flushes; does not change the status
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  void add_samples(const ImuSample* samples, std::size_t count);
  void add_truth(double t_s, const std::vector<double>& values);  // size = truth_columns
  void add_truth(const RecordedTruth& truth);  // every row of another recording's truth
  void add_segment(const Segment& s);
  void add_event(const Event& e);  // written (and flushed) at once
  // Call often with the run time; flushes to the OS when ≥ 1 s of wall time has passed since the
  // last flush (CSV: also ≥ 1 s of run time).
  void tick(double run_time_s);
  void flush();
  // Final status and counts into run.json.
  void finish(RunStatus status, const std::string& message = {});  // not kRunning
  const std::filesystem::path& dir() const { return dir_; }
  std::uint64_t sample_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::filesystem::path dir_;
};

// How Recording::open treats the samples: read them all into `samples` (kInMemory), or leave
// them in the store and read them through `source` a chunk at a time (kStream; a CSV run folder,
// having no index, is still read whole, into the source).
enum class SampleLoading { kInMemory, kStream };
// How Recording::open treats the bench truth: read it all into `truth_t` / `truth` (kLoad), leave
// it in the store and read it through `truth_store` a window at a time (kStream; a CSV run folder's
// truth.csv is read whole), or only count its rows (kSkip: for analyses of the sensor's output
// alone, such as `stend info` and the noise analysis). The truth of a long run grows with its
// length (10 Hz rows).
enum class TruthLoading { kLoad, kStream, kSkip };

// A recording for analysis: header, truth, segments and events in memory; the samples either in
// memory (`samples`) or in the store (`source`). Analyses iterate sample_source().
struct Recording {
  std::filesystem::path dir;
  RecordingHeader header;
  bool complete() const { return header.status == RunStatus::kComplete; }
  std::string experiment_yaml;
  std::vector<ImuSample> samples;                // in memory; empty when `source` is set
  std::shared_ptr<const SampleSource> source;    // the store's samples (SampleLoading::kStream)
  std::vector<double> truth_t;
  std::vector<std::vector<double>> truth;  // rows, each truth_columns.size()
  std::shared_ptr<const RecordedTruth> truth_store;  // the store's truth (TruthLoading::kStream)
  std::uint64_t truth_rows = 0;  // rows in the store (loaded or, with TruthLoading::kSkip, not)
  std::vector<Segment> segments;
  std::vector<Event> events;
  std::size_t dropped_partial_lines = 0;  // truncated trailing lines ignored by the reader
  RecordingFormat format = RecordingFormat::kCsv;
  // Samples the writer wrote (run.h5's extent or summary; run.json's sample_count when imu.csv is
  // damaged), and what is damaged: file:line or dataset, what was recorded and what was found
  // (empty when the run is whole; sample_count() is what can be read). A killed run (status
  // running) is not damaged by the last line its writer left unfinished.
  std::uint64_t written_samples = 0;
  std::string damage;
  // Samples flagged kGapBefore, as the store's summary states (run.h5 as of its last flush; CSV
  // counted on reading); −1 when unknown.
  std::int64_t gap_count = -1;
  // Sample intervals that are interval_irregular() against header.info.output_rate_hz, as run.h5's
  // summary states; −1 when unknown (CSV, no stated rate, a file from before this count).
  std::int64_t irregular_count = -1;

  // Throws InputError (stend/errors.hpp) naming the file and line when the folder is not a
  // readable recording (missing or damaged files, a format_version it does not read), IoError when
  // reading itself fails.
  static Recording open(const std::filesystem::path& run_dir,
                        SampleLoading loading = SampleLoading::kInMemory,
                        TruthLoading truth = TruthLoading::kLoad);
  // The samples to iterate: `source` when set, else a view of `samples`.
  const SampleSource& sample_source() const;
  // Number of samples, wherever they are.
  std::uint64_t sample_count() const { return source ? source->size() : samples.size(); }
  // The truth to read: `truth_store` when set, else a view of `truth_t` / `truth` (valid while
  // they live unchanged).
  std::shared_ptr<const RecordedTruth> recorded_truth() const;
  // Column index of a truth column, −1 when absent.
  int truth_column(const std::string& name) const;

 private:
  mutable std::shared_ptr<const MemorySamples> memory_view_;  // sample_source() over `samples`
};

// Throws InputError when `rec` is damaged: the run folder, what is damaged and how many
// samples are still readable. Analyses call it unless the user accepted the readable part.
void require_whole(const Recording& rec);

// Writes `rec` as a new run folder `dir` (must not exist) in `options.format`: the same header,
// experiment, samples (streamed a chunk at a time), truth, segments and events; a finished run
// keeps its status (its end time becomes the copy's), an unfinished one stays "running".
void write_recording(const Recording& rec, const std::filesystem::path& dir,
                     const RecordingWriterOptions& options);

}  // namespace stend
