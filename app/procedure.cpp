// --experiment on a dataset: the procedure a log was recorded with, aligned to the log
// (stend/alignment/align.hpp) — while `stend import` streams it into a run folder, or on the
// recording `stend fit` / `stend gap` open from a file.
#include "procedure.hpp"

#include "stend/core/plugin_host.hpp"
#include "stend/core/procedure_geometry.hpp"

#include <fmt/format.h>

namespace stend::cli {

Experiment load_procedure(const std::string& file) {
  PluginHost host;  // the fixtures a procedure may declare; its own plugin_paths are not loaded
  host.scan(PluginHost::default_search_path());
  return as_observed_procedure(load_experiment(file, host), host);
}

namespace {

// The aligned segments, truth and notes in place of whatever the importer made.
void apply_alignment(Recording& rec, const Experiment& exp, alignment::Alignment a) {
  const std::string summary = a.summary();
  rec.header.truth_columns = a.truth_columns;
  rec.truth_store.reset();
  rec.truth_t = std::move(a.truth_t);
  rec.truth = std::move(a.truth);
  rec.truth_rows = rec.truth_t.size();
  rec.segments = std::move(a.segments);
  rec.events.push_back({0.0, "info", "import",
                        fmt::format("procedure from {} (experiment '{}'): {}", exp.file, exp.name, summary)});
  for (const auto& n : a.notes) rec.events.push_back({0.0, "info", "import", "alignment: " + n});
}

// What an aligned recording states before its first sample: the truth columns and the site's g.
void align_header(RecordingHeader& h, const Experiment& exp) {
  h.truth_columns = alignment::aligned_truth_columns();
  h.gravity_mps2 = exp.gravity.resolved_mps2;
}

}  // namespace

AligningSink::AligningSink(Recording& rec, io::SampleSink& inner, const Experiment& exp)
    : rec_(rec), inner_(inner), exp_(exp) {}

void AligningSink::add_samples(const ImuSample* samples, std::size_t count) {
  if (!started_) {
    if (!rec_.truth_t.empty() || !rec_.segments.empty() || !rec_.header.truth_columns.empty()) replaced_ = true;
    align_header(rec_.header, exp_);
    started_ = true;
  }
  observer_.add(samples, count);
  inner_.add_samples(samples, count);
}

void AligningSink::finish() {
  const bool had_own = replaced_ || !rec_.segments.empty() || !rec_.truth_t.empty();
  apply_alignment(rec_, exp_, alignment::align(exp_, observer_.finish(), observer_.options()));
  if (had_own)
    rec_.events.push_back({0.0, "info", "import", "the log's own segments and truth were replaced by the procedure's"});
}

void align_recording(Recording& rec, const Experiment& exp) {
  alignment::Observer observer;
  for_each_chunk(rec.sample_source(), 0, rec.sample_count(),
                 [&](const ImuSample* chunk, std::size_t n, std::uint64_t) { observer.add(chunk, n); });
  const bool had_own = !rec.segments.empty() || rec.truth_rows > 0;
  align_header(rec.header, exp);
  apply_alignment(rec, exp, alignment::align(exp, observer.finish(), observer.options()));
  rec.experiment_yaml = exp.resolved_yaml;
  if (had_own) rec.events.push_back({0.0, "info", "import", "the log's own segments and truth were replaced by the procedure's"});
}

}  // namespace stend::cli
