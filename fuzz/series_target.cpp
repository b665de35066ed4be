// `stend deviations`' input: a plain text series (io::read_series) and its deviations. Byte 0 of
// the input chooses how it is read — the column by number (1–3) or by the name "y", 0–3 lines
// skipped, phase or frequency — the rest is the file. What is read goes through every deviation
// kind at octave τ (noise identification, EDF, intervals) as the command computes them. The reader
// either returns or throws io::ImportError with the reason; the deviations take any finite values.
#include <stend/allan/deviation_report.hpp>
#include <stend/io/importers.hpp>
#include <stend/io/series.hpp>

#include <cstdint>
#include <string>

#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1 || size > stend::fuzz::kMaxInputBytes) return 0;
  const std::uint8_t how = data[0];
  const auto file = stend::fuzz::write_input(data + 1, size - 1, "series.txt");
  stend::io::SeriesColumn which;
  which.column = (how & 3) == 3 ? std::string("y") : std::to_string((how & 3) + 1);
  which.skip_lines = (how >> 2) & 3;
  const bool phase = (how & 16) != 0;
  try {
    const auto s = stend::io::read_series(file, which);
    stend::allan::DeviationRequest request;
    request.kinds.assign(stend::allan::kAllDeviationKinds.begin(), stend::allan::kAllDeviationKinds.end());
    const stend::allan::ChannelInfo channel{"y", stend::allan::Instrument::kOther, "1"};
    const double* v = s.values.data();
    const auto d = phase ? stend::allan::phase_deviations(v, s.values.size(), 100.0, channel, request)
                         : stend::allan::channel_deviations(v, s.values.size(), 100.0, channel, request);
    (void)d;
  } catch (const stend::io::ImportError&) {
  }
  return 0;
}
