#include <stend/io/sample_sink.hpp>

#include "import_event.hpp"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace stend::io {

// The background writer: full batches queue for the thread, which writes them in order.
struct RunSink::Background {
  static constexpr std::size_t kWaiting = 2;  // batches handed over and not yet written
  std::mutex m;
  std::condition_variable changed;
  std::deque<std::vector<ImuSample>> queue;
  std::vector<ImuSample> filling;
  bool closing = false;
  std::exception_ptr error;
  std::thread thread;

  // Waits for room (or a failure), then queues `batch`; rethrows the writer's failure.
  void hand_over(std::vector<ImuSample> batch) {
    std::unique_lock lock(m);
    changed.wait(lock, [&] { return queue.size() < kWaiting || error; });
    if (error) std::rethrow_exception(error);
    queue.push_back(std::move(batch));
    changed.notify_all();
  }

  // The thread: writes each batch through `write` until closed and drained, or until one fails.
  template <class Write>
  void run(Write write) {
    for (;;) {
      std::vector<ImuSample> batch;
      {
        std::unique_lock lock(m);
        changed.wait(lock, [&] { return !queue.empty() || closing; });
        if (queue.empty()) return;
        batch = std::move(queue.front());
        queue.pop_front();
        changed.notify_all();
      }
      try {
        write(batch.data(), batch.size());
      } catch (...) {
        std::lock_guard lock(m);
        error = std::current_exception();
        queue.clear();
        changed.notify_all();
        return;
      }
    }
  }

  // Closes the queue (dropping what waits when `drop`) and joins the thread.
  void close(bool drop) {
    {
      std::lock_guard lock(m);
      closing = true;
      if (drop) queue.clear();
      changed.notify_all();
    }
    if (thread.joinable()) thread.join();
  }
};

RunSink::RunSink(const Recording& recording, std::filesystem::path dir, std::string experiment_yaml,
                 std::string experiment_name, RecordingWriterOptions options)
    : rec_(&recording), dir_(std::move(dir)), yaml_(std::move(experiment_yaml)), name_(std::move(experiment_name)),
      options_(options) {}

RunSink::~RunSink() { abandon(); }

void RunSink::write_in_background() {
  if (!background_) background_ = std::make_unique<Background>();
}

void RunSink::abandon() {
  if (background_) background_->close(true);
}

void RunSink::open() {
  if (writer_) return;
  RecordingHeader header = rec_->header;
  if (!name_.empty()) header.experiment_name = name_;
  RecordingWriterOptions options = options_;
  if (options.flush_every_samples == 0) options.flush_every_samples = kImportFlushSamples;
  writer_ = std::make_unique<RecordingWriter>(dir_, std::move(header), yaml_, options);
  if (background_)
    background_->thread = std::thread([this] { background_->run([this](const ImuSample* s, std::size_t n) { write(s, n); }); });
}

void RunSink::write(const ImuSample* samples, std::size_t count) { writer_->add_samples(samples, count); }

void RunSink::add_samples(const ImuSample* samples, std::size_t count) {
  open();
  if (count > 0 && samples_ == 0) first_t_s_ = samples[0].t_s;
  samples_ += count;
  if (!background_) return write(samples, count);
  std::vector<ImuSample>& filling = background_->filling;
  while (count > 0) {
    if (filling.capacity() < kBackgroundBatch) filling.reserve(kBackgroundBatch);
    const std::size_t take = std::min(count, kBackgroundBatch - filling.size());
    filling.insert(filling.end(), samples, samples + take);
    samples += take;
    count -= take;
    if (filling.size() == kBackgroundBatch) background_->hand_over(std::exchange(filling, {}));
  }
}

void RunSink::finish() {
  open();
  if (background_) {
    if (!background_->filling.empty()) background_->hand_over(std::exchange(background_->filling, {}));
    background_->close(false);
    if (background_->error) std::rethrow_exception(background_->error);
  }
  writer_->add_truth(*rec_->recorded_truth());
  for (const auto& s : rec_->segments) writer_->add_segment(s);
  std::vector<Event> events = rec_->events;
  place_import_events(events, first_t_s_);
  for (const auto& e : events) writer_->add_event(e);
  writer_->finish(rec_->header.status == RunStatus::kRunning ? RunStatus::kComplete : rec_->header.status);
}

}  // namespace stend::io
