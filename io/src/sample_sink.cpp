#include <stend/io/sample_sink.hpp>

namespace stend::io {

void RunSink::open() {
  if (writer_) return;
  RecordingHeader header = rec_->header;
  if (!name_.empty()) header.experiment_name = name_;
  writer_ = std::make_unique<RecordingWriter>(dir_, std::move(header), yaml_, options_);
}

void RunSink::add_samples(const ImuSample* samples, std::size_t count) {
  open();
  writer_->add_samples(samples, count);
}

void RunSink::finish() {
  open();
  for (std::size_t i = 0; i < rec_->truth_t.size(); ++i) writer_->add_truth(rec_->truth_t[i], rec_->truth[i]);
  for (const auto& s : rec_->segments) writer_->add_segment(s);
  for (const auto& e : rec_->events) writer_->add_event(e);
  writer_->finish(rec_->header.status == RunStatus::kRunning ? RunStatus::kComplete : rec_->header.status);
}

}  // namespace stend::io
