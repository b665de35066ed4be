// Why a static interval gave no static point: the reasons the processing stage skips one, typed,
// so that callers count them (e.g. the diagnosis: segments lost to saturation) without reading
// note text.
#pragma once

#include <stdexcept>
#include <string>

namespace stend::processing {

enum class SkipReason {
  kIncomplete,     // the run stopped inside the segment
  kUnsettled,      // fixtures or chamber were not settled for the whole segment
  kTooFewSamples,  // too few samples in the interval, or in its kept window after settle_s
  kFilter,         // the low-pass cannot be designed at the interval's sample rate
  kSaturated,      // a saturated sample of an extracted instrument inside the kept window
  kNoTruth,        // no truth snapshot inside or before the kept window
};
inline constexpr SkipReason kAllSkipReasons[] = {
    SkipReason::kIncomplete, SkipReason::kUnsettled, SkipReason::kTooFewSamples,
    SkipReason::kFilter,     SkipReason::kSaturated, SkipReason::kNoTruth};

// "incomplete" | "unsettled" | "too_few_samples" | "filter" | "saturated" | "no_truth"
const char* skip_reason_name(SkipReason reason);

// Thrown by extract_static when a stretch of samples cannot give a static value; what() says what
// to change. A std::invalid_argument, so callers that only need the message may catch that.
class SkipError : public std::invalid_argument {
 public:
  SkipError(SkipReason reason, const std::string& message)
      : std::invalid_argument(message), reason_(reason) {}
  SkipReason reason() const { return reason_; }

 private:
  SkipReason reason_;
};

}  // namespace stend::processing
