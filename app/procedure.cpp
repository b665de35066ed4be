// --experiment on a dataset: the procedure a log was recorded with, aligned to the log
// (stend/alignment/align.hpp) — while `stend import` streams it into a run folder, or on the
// recording `stend fit` / `stend gap` open from a file.
#include "procedure.hpp"

#include "stend/core/procedure_geometry.hpp"

namespace stend::cli {

Experiment load_procedure(const std::string& file) { return load_observed_procedure(file); }

AligningSink::AligningSink(Recording& rec, io::SampleSink& inner, const Experiment& exp)
    : rec_(rec), inner_(inner), exp_(exp) {}

void AligningSink::add_samples(const ImuSample* samples, std::size_t count) {
  if (!started_) {
    if (!rec_.truth_t.empty() || !rec_.segments.empty() || !rec_.header.truth_columns.empty()) replaced_ = true;
    alignment::align_header(rec_.header, exp_);
    started_ = true;
  }
  observer_.add(samples, count);
  inner_.add_samples(samples, count);
}

void AligningSink::finish() {
  const bool had_own = replaced_ || !rec_.segments.empty() || !rec_.truth_t.empty();
  alignment::apply_alignment(rec_, exp_, alignment::align(exp_, observer_.finish(), observer_.options()));
  if (had_own)
    rec_.events.push_back({0.0, "info", "import", "the log's own segments and truth were replaced by the procedure's"});
}

void align_recording(Recording& rec, const Experiment& exp) { alignment::align_recording(rec, exp); }

}  // namespace stend::cli
