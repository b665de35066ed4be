// RecordingWriter: a run folder written while the run goes, into the HDF5 store (run.h5) or the
// CSV store (csv_run_store.hpp); run.json and experiment.yaml beside either. The durability rule
// (flush at least every second) is kept here, the same for both stores. Format:
// docs/recording-format.md.
#include "stend/recording/recording.hpp"

#include "csv_run_store.hpp"
#include "hdf5_store.hpp"
#include "run_json.hpp"
#include "store_files.hpp"

#include "stend/errors.hpp"
#include "stend/recording/files.hpp"
#include "stend/recording/instruments.hpp"

#include <sys/stat.h>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <system_error>
#include <utility>

namespace stend {

namespace fs = std::filesystem;

namespace {

constexpr double kFlushInterval_s = 1.0;

// Throws std::invalid_argument unless the header and the experiment can be written as a run the
// reader accepts: 9 mounting values or none, truth columns named, unique and not "t_s", the
// experiment valid YAML.
void check_header(const RecordingHeader& header, const std::string& resolved_experiment_yaml) {
  if (!header.mounting_R.empty() && header.mounting_R.size() != 9) {
    throw std::invalid_argument(fmt::format(
        "recording header: mounting_R has {} values, expected 9 (row-major 3x3) or none",
        header.mounting_R.size()));
  }
  for (std::size_t i = 0; i < header.truth_columns.size(); ++i) {
    const std::string& c = header.truth_columns[i];
    if (c.empty() || c == "t_s") {
      throw std::invalid_argument(fmt::format("recording header: truth column {} is named '{}'",
                                              i, c));
    }
    for (std::size_t k = 0; k < i; ++k) {
      if (header.truth_columns[k] == c) {
        throw std::invalid_argument(
            fmt::format("recording header: truth column '{}' appears twice", c));
      }
    }
  }
  try {
    // The reader checks experiment.yaml too; refuse now rather than write an unreadable run.
    (void)YAML::Load(resolved_experiment_yaml);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(fmt::format(
        "recording: the resolved experiment is not valid YAML (line {}, column {}): {}",
        e.mark.line + 1, e.mark.column + 1, e.msg));
  }
}

// Creates the run folder (its parents too); "runs/x/" names the folder "runs/x". Returns it.
fs::path make_run_dir(const fs::path& run_dir) {
  const fs::path target = run_dir.has_filename() ? run_dir : run_dir.parent_path();
  if (target.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(target.parent_path(), ec);
    if (ec) {
      throw IoError(fmt::format("{}: cannot create the parent directory: {}",
                                target.parent_path().string(), ec.message()));
    }
  }
  if (::mkdir(target.c_str(), 0755) != 0) {
    if (errno == EEXIST) {
      throw InputError(fmt::format(
          "{}: run directory already exists; a recording is never overwritten — choose another "
          "run directory or remove this one",
          run_dir.string()));
    }
    throw IoError(
        fmt::format("{}: cannot create the run directory: {}", run_dir.string(), std::strerror(errno)));
  }
  return target;
}

}  // namespace

bool RecordingWriterOptions::IsValid(std::string* error) const {
  return format == RecordingFormat::kHdf5 || format == RecordingFormat::kCsv ? true : invalid(error, "unknown format");
}

struct RecordingWriter::Impl {
  RecordingHeader header;
  std::unique_ptr<detail::CsvRunWriter> csv;  // one of the two stores
  std::unique_ptr<detail::Hdf5RunWriter> h5;
  std::uint64_t samples = 0, truth_rows = 0, segment_rows = 0, event_rows = 0;
  double last_flush_run_s = -std::numeric_limits<double>::infinity();
  std::chrono::steady_clock::time_point last_flush_wall = std::chrono::steady_clock::now();
  std::uint64_t flush_every_samples = 0, last_flush_samples = 0;  // RecordingWriterOptions
  bool finished = false;
  std::string scratch;
  std::vector<ImuSample> blanked;  // a chunk with the absent instruments' values blanked

  // The samples as stored: what the header says is absent blanked (NaN, counts 0).
  const ImuSample* stored(const ImuSample* given, std::size_t count) {
    const SensorInfo& info = header.info;
    if (info.has_accel && info.has_gyro && info.has_temperature) return given;
    blanked.assign(given, given + count);
    for (ImuSample& s : blanked) blank_absent(info, s);
    return blanked.data();
  }

  void check_open(const char* what) const {
    if (finished) {
      throw std::logic_error(fmt::format("RecordingWriter::{}: the recording was already finished",
                                         what));
    }
  }
  // Writes run.json and experiment.yaml and opens the store with its column-name records.
  void create_files(const fs::path& run_dir, RecordingHeader h,
                    const std::string& resolved_experiment_yaml, RecordingFormat format);
  // Flush rule: every flush_every_samples samples when set; otherwise ≥ 1 s of wall time since the
  // last flush, or (CSV) ≥ 1 s of run time.
  bool flush_due(double run_time_s) const {
    if (flush_every_samples > 0) return samples - last_flush_samples >= flush_every_samples;
    return (!h5 && run_time_s - last_flush_run_s >= kFlushInterval_s) ||
           std::chrono::steady_clock::now() - last_flush_wall >= std::chrono::seconds(1);
  }
  void flush_all() {
    if (h5) {
      h5->flush();
    } else {
      csv->flush();
    }
    last_flush_wall = std::chrono::steady_clock::now();
    last_flush_samples = samples;
  }
  void add_segment_record(std::string_view record) {
    if (h5) {
      h5->add_segment_record(record);
    } else {
      csv->add_segment_record(record);
    }
  }
};

void RecordingWriter::Impl::create_files(const fs::path& run_dir, RecordingHeader h,
                                         const std::string& resolved_experiment_yaml,
                                         RecordingFormat format) {
  header = std::move(h);
  const std::string run_json = detail::dump_json(detail::header_json(header));
  write_file_atomic(run_dir / "run.json", run_json);
  detail::write_new_file(run_dir / "experiment.yaml", resolved_experiment_yaml);
  if (format == RecordingFormat::kHdf5) {
    h5 = std::make_unique<detail::Hdf5RunWriter>(run_dir / detail::kHdf5FileName, header, run_json,
                                                 resolved_experiment_yaml);
  } else {
    csv = std::make_unique<detail::CsvRunWriter>(run_dir, header.truth_columns);
  }
  std::string line;
  csv::append_record(line, detail::segment_columns());
  add_segment_record(line);
  line.clear();
  csv::append_record(line, detail::event_columns());
  if (h5) {
    h5->add_event_record(line);
    return;
  }
  csv->add_event_record(line);
  flush_all();
}

RecordingWriter::RecordingWriter(const fs::path& run_dir, RecordingHeader header,
                                 const std::string& resolved_experiment_yaml,
                                 const RecordingWriterOptions& options)
    : impl_(std::make_unique<Impl>()), dir_(run_dir) {
  require_valid(options, "recording writer options");
  impl_->flush_every_samples = options.flush_every_samples;
  check_header(header, resolved_experiment_yaml);
  if (header.start_time_utc.empty()) header.start_time_utc = detail::utc_now_iso();
  header.status = RunStatus::kRunning;
  const fs::path target = make_run_dir(run_dir);
  try {
    impl_->create_files(run_dir, std::move(header), resolved_experiment_yaml, options.format);
  } catch (...) {
    // The folder is ours (mkdir succeeded): do not leave a half-made run behind.
    impl_.reset();
    std::error_code ec;
    fs::remove_all(target, ec);
    throw;
  }
}

RecordingWriter::~RecordingWriter() {
  if (!impl_) return;
  try {
    impl_->flush_all();
  } catch (...) {
    // A destructor must not throw; the error was (or will be) visible through flush()/finish().
  }
}

void RecordingWriter::add_samples(const ImuSample* samples, std::size_t count) {
  Impl& I = *impl_;
  I.check_open("add_samples");
  if (count == 0) return;
  const double t_last = samples[count - 1].t_s;
  samples = I.stored(samples, count);
  if (I.h5) {
    I.h5->add_samples(samples, count);
  } else {
    I.csv->add_samples(samples, count);
  }
  I.samples += count;
  // Also bounded by sample time (CSV), so durability holds even between sparse tick() calls.
  if (I.flush_due(t_last)) {
    I.flush_all();
    I.last_flush_run_s = t_last;
  }
}

void RecordingWriter::add_truth(double t_s, const std::vector<double>& values) {
  Impl& I = *impl_;
  I.check_open("add_truth");
  if (values.size() != I.header.truth_columns.size()) {
    throw std::invalid_argument(fmt::format(
        "RecordingWriter::add_truth: {} values for {} truth columns", values.size(),
        I.header.truth_columns.size()));
  }
  ++I.truth_rows;
  if (I.h5) {
    I.h5->add_truth(t_s, values);
  } else {
    I.csv->add_truth(t_s, values);
  }
}

void RecordingWriter::add_truth(const RecordedTruth& truth) {
  std::vector<double> row;
  for_each_truth_row(truth, 0, truth.rows(), [&](double t, const double* values, bool) {
    row.assign(values, values + truth.columns());
    add_truth(t, row);
  });
}

void RecordingWriter::add_segment(const Segment& s) {
  Impl& I = *impl_;
  I.check_open("add_segment");
  I.scratch.clear();
  detail::append_segment_record(I.scratch, s);
  I.add_segment_record(I.scratch);
  ++I.segment_rows;
}

void RecordingWriter::add_event(const Event& e) {
  Impl& I = *impl_;
  I.check_open("add_event");
  I.scratch.clear();
  detail::append_event_record(I.scratch, e);
  if (I.h5) {
    I.h5->add_event_record(I.scratch);
    I.flush_all();
  } else {
    I.csv->add_event_record(I.scratch);
  }
  ++I.event_rows;
}

void RecordingWriter::tick(double run_time_s) {
  Impl& I = *impl_;
  if (I.flush_due(run_time_s)) {
    I.flush_all();
    I.last_flush_run_s = run_time_s;
  }
}

void RecordingWriter::flush() { impl_->flush_all(); }

void RecordingWriter::finish(RunStatus status, const std::string& message) {
  if (status == RunStatus::kRunning)
    throw std::invalid_argument("RecordingWriter::finish: the final status cannot be 'running'");
  Impl& I = *impl_;
  I.flush_all();
  // Data reaches the disk before run.json claims a final status.
  if (I.csv) I.csv->sync();
  I.header.status = status;
  nlohmann::ordered_json j = detail::header_json(I.header);
  const std::string end_time = detail::utc_now_iso();
  j["end_time_utc"] = end_time;
  j["status_message"] = message;
  j["sample_count"] = I.samples;
  j["truth_count"] = I.truth_rows;
  j["segment_count"] = I.segment_rows;
  j["event_count"] = I.event_rows;
  // Lengths beside the row counts: a reader tells a truncated or extended file from a whole one.
  if (I.csv) j["file_bytes"] = I.csv->file_bytes();
  // run.h5 first: it is the source of truth, run.json its readable copy.
  if (I.h5) I.h5->finish(status, end_time, message);
  write_file_atomic(dir_ / "run.json", detail::dump_json(j));
  detail::fsync_dir(dir_);
  I.finished = true;
}

std::uint64_t RecordingWriter::sample_count() const { return impl_->samples; }

void write_recording(const Recording& rec, const fs::path& dir, const RecordingWriterOptions& options) {
  RecordingWriter w(dir, rec.header, rec.experiment_yaml, options);
  for_each_chunk(rec.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t) { w.add_samples(c, n); });
  w.add_truth(*rec.recorded_truth());
  for (const auto& s : rec.segments) w.add_segment(s);
  for (const auto& e : rec.events) w.add_event(e);
  if (rec.header.status == RunStatus::kRunning) {
    w.flush();
  } else {
    w.finish(rec.header.status);
  }
}

}  // namespace stend
