// Where an importer puts its samples, a chunk at a time, so that an import's memory does not grow
// with the length of the log: into a vector (the in-memory importers) or straight into a new run
// folder through the RecordingWriter (`stend import`).
#pragma once

#include <stend/recording/recording.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace stend::io {

class SampleSink {
 public:
  virtual ~SampleSink() = default;
  // Samples in time order. The importer has filled the recording's header (rate, LSBs, identity)
  // before the first call.
  virtual void add_samples(const ImuSample* samples, std::size_t count) = 0;
};

// Appends to a vector owned by the caller.
class VectorSink final : public SampleSink {
 public:
  explicit VectorSink(std::vector<ImuSample>& out) : out_(&out) {}
  void add_samples(const ImuSample* samples, std::size_t count) override {
    out_->insert(out_->end(), samples, samples + count);
  }

 private:
  std::vector<ImuSample>* out_;
};

// An import flushes its run store every kImportFlushSamples samples and at finish, never by the
// clock: the same work on any machine at any load (RecordingWriterOptions::flush_every_samples).
inline constexpr std::uint64_t kImportFlushSamples = std::uint64_t{1} << 20;

// Writes a new run folder: the writer is created at the first samples with the header of
// `recording` as it is then (so a log without samples creates no folder), `experiment_yaml` and,
// when not empty, `experiment_name`; finish() adds the recording's truth, segments and events and
// its final status, the import events (source "import") at the first sample's time.
class RunSink final : public SampleSink {
 public:
  // `recording` must outlive the sink; `dir` must not exist.
  RunSink(const Recording& recording, std::filesystem::path dir, std::string experiment_yaml,
          std::string experiment_name = {}, RecordingWriterOptions options = {})
      : rec_(&recording), dir_(std::move(dir)), yaml_(std::move(experiment_yaml)),
        name_(std::move(experiment_name)), options_(options) {}
  void add_samples(const ImuSample* samples, std::size_t count) override;
  // Truth, segments, events, status (the recording's; kComplete when it says kRunning). Creates
  // the folder when no sample came.
  void finish();
  std::uint64_t sample_count() const { return writer_ ? writer_->sample_count() : 0; }

 private:
  void open();
  const Recording* rec_;
  std::filesystem::path dir_;
  std::string yaml_, name_;
  RecordingWriterOptions options_;
  std::unique_ptr<RecordingWriter> writer_;
  double first_t_s_ = 0.0;  // the first sample's time [s]
};

}  // namespace stend::io
