// How a recording becomes static points: where the static intervals come from, how each is
// reduced to a value, and how those settings are read — from a model file, and, for every key the
// model file does not state, from the experiment's `processing:` section recorded in the run
// folder. The keys (docs/experiment-format.md, "processing:"):
//
//   intervals: auto                # segments | detect | auto (segments when the recording has any)
//   segments: [orientation]        # segment kinds that are static points
//   extraction:                    # per interval (stend/processing/static_extraction.hpp)
//     filter: butterworth          # butterworth | none (plain mean)
//     filter_order: 6
//     cutoff_hz: 1.0
//     settle_s: 2.0                # discarded at each end of every interval
//     zero_phase: true
//   detector:                      # stend/processing/static_detector.hpp (0: chosen from the data)
//     window_s: 0                  # 0: from the sample rate
//     min_duration_s: 0            # 0: from the window
//     variance_threshold_m2ps4: 0  # 0: threshold_multiplier × the still noise variance
//     threshold_multiplier: 0      # 0: scanned 2..10 (IMU-TK), the most consistent set wins
//     init_duration_s: 0           # 0: the recording's initialization segment, if any
//     trim_s: 0
//     max_gyro_dps: 3              # after removing the gyro bias; 0: no limit
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "stend/processing/static_detector.hpp"
#include "stend/processing/static_extraction.hpp"
#include "stend/recording/recording.hpp"
#include "stend/yaml/reader.hpp"

namespace stend::processing {

enum class IntervalSource {
  kSegments,  // the recording's segments of the kinds in segment_kinds
  kDetect,    // found in the samples by the sliding-variance detector
  kAuto,      // segments when the recording has any, else detected
};
const char* interval_source_name(IntervalSource source);  // "segments" | "detect" | "auto"


struct ProcessingOptions {
  IntervalSource intervals = IntervalSource::kAuto;
  std::vector<std::string> segment_kinds = {"orientation"};  // names of SegmentKind (core/recording.hpp)
  StaticExtractionSettings extraction;
  StaticDetectorOptions detector;
  // Keys ("intervals", "segments", "extraction.cutoff_hz", "detector.window_s", …) that a model
  // file stated or the caller fixed: the experiment's processing section does not override them.
  std::set<std::string> stated;

  // The first value out of range: its key and what is wrong.
  std::optional<OptionProblem> problem() const;
  // Ceres style: false, with "KEY: what is wrong" in *message, when a value is out of range.
  bool IsValid(std::string* message = nullptr) const;
  // Whether segments of kind k are static points under segment_kinds.
  bool selects(SegmentKind k) const;
};

// The processing keys of a mapping (an experiment's `processing:` section); model files accept
// them beside their own keys.
inline const std::vector<std::string> kOptionKeys = {"intervals", "segments", "extraction",
                                                     "detector"};

// Reads the processing keys present in `m` into `options`, except those listed in `keep` (left as
// they are), and adds the keys read to options.stated. Throws ExperimentError at the offending
// key or value (unknown keys with "did you mean", wrong types, values out of range).
void read_options(const yaml::MapReader& m, ProcessingOptions& options,
                  const std::set<std::string>& keep = {});

// Writes every processing key of `options` into the open mapping of `out`.
void emit_options(YAML::Emitter& out, const ProcessingOptions& options);

// The options a recording is processed with: `options`, and for every key not in options.stated
// the value the experiment's `processing:` section (rec.experiment_yaml) gives, if any. Throws
// ExperimentError naming RUN/experiment.yaml:line:column for a bad key or value.
ProcessingOptions resolve(const ProcessingOptions& options, const Recording& rec);

}  // namespace stend::processing
