// --experiment on a dataset (docs/procedures.md): the experiment file as the procedure of a log
// made elsewhere, aligned to it so that the log carries segments and truth as a bench run does.
#pragma once

#include "stend/alignment/align.hpp"
#include "stend/io/sample_sink.hpp"

#include <string>

namespace stend::cli {

// The experiment file read as a procedure (no sensor needed): its table steps turned into what the
// sensor saw (as_observed_procedure), so that every step can be aligned.
Experiment load_procedure(const std::string& file);

// Passes an import's samples on to `inner` and summarises them for the alignment: the aligned
// truth columns and the site's gravity go into the header before the first sample reaches
// `inner` (which writes the header then); finish() — after the last sample, before the run is
// finished — aligns and puts the segments, truth and notes into `rec`. Throws AlignmentError.
class AligningSink final : public io::SampleSink {
 public:
  AligningSink(Recording& rec, io::SampleSink& inner, const Experiment& exp);
  void add_samples(const ImuSample* samples, std::size_t count) override;
  void finish();

 private:
  Recording& rec_;
  io::SampleSink& inner_;
  const Experiment& exp_;
  alignment::Observer observer_;
  bool started_ = false, replaced_ = false;
};

// A recording opened from a dataset file aligned to the procedure: segments, truth, the site's g
// and the experiment (its processing: section, the procedure fingerprint) replaced.
void align_recording(Recording& rec, const Experiment& exp);

}  // namespace stend::cli
