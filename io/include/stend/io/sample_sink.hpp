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
          std::string experiment_name = {}, RecordingWriterOptions options = {});
  ~RunSink() override;
  RunSink(const RunSink&) = delete;
  RunSink& operator=(const RunSink&) = delete;

  // Before the first samples: the samples are written (compressed, checksummed) on a thread of
  // their own, batches of kBackgroundBatch samples handed over with at most two waiting, so that
  // reading the source overlaps writing the store. Only for sources not read through libhdf5
  // (Format::reads_hdf5): libhdf5 built without thread safety takes one thread at a time.
  void write_in_background();
  void add_samples(const ImuSample* samples, std::size_t count) override;
  // Truth, segments, events, status (the recording's; kComplete when it says kRunning). Creates
  // the folder when no sample came. Rethrows a failure of the background writer.
  void finish();
  // Stops the background writer without writing what waits (after a failed import, before its
  // folder is removed); finish() may not follow.
  void abandon();
  std::uint64_t sample_count() const { return samples_; }

  static constexpr std::size_t kBackgroundBatch = std::size_t{1} << 14;  // 1.8 MB of samples

 private:
  struct Background;
  void open();
  void write(const ImuSample* samples, std::size_t count);
  const Recording* rec_;
  std::filesystem::path dir_;
  std::string yaml_, name_;
  RecordingWriterOptions options_;
  std::unique_ptr<RecordingWriter> writer_;
  std::unique_ptr<Background> background_;
  std::uint64_t samples_ = 0;
  double first_t_s_ = 0.0;  // the first sample's time [s]
};

}  // namespace stend::io
