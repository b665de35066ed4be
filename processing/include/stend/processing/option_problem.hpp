// The first value of an options struct out of range: its key ("cutoff_hz", "detector.window_s",
// …) and what is wrong — what the processing options' problem() return and their IsValid say.
#pragma once

#include <string>

namespace stend::processing {

struct OptionProblem {
  std::string key, message;
};

}  // namespace stend::processing
