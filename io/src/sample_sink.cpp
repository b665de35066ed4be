#include <stend/io/sample_sink.hpp>

#include "import_event.hpp"

namespace stend::io {

void RunSink::open() {
  if (writer_) return;
  RecordingHeader header = rec_->header;
  if (!name_.empty()) header.experiment_name = name_;
  RecordingWriterOptions options = options_;
  if (options.flush_every_samples == 0) options.flush_every_samples = kImportFlushSamples;
  writer_ = std::make_unique<RecordingWriter>(dir_, std::move(header), yaml_, options);
}

void RunSink::add_samples(const ImuSample* samples, std::size_t count) {
  open();
  if (count > 0 && writer_->sample_count() == 0) first_t_s_ = samples[0].t_s;
  writer_->add_samples(samples, count);
}

void RunSink::finish() {
  open();
  writer_->add_truth(*rec_->recorded_truth());
  for (const auto& s : rec_->segments) writer_->add_segment(s);
  std::vector<Event> events = rec_->events;
  place_import_events(events, first_t_s_);
  for (const auto& e : events) writer_->add_event(e);
  writer_->finish(rec_->header.status == RunStatus::kRunning ? RunStatus::kComplete : rec_->header.status);
}

}  // namespace stend::io
