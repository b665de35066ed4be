// One importer through the io/ format table: the input is written to a file named
// STEND_FUZZ_FILE_NAME and opened as format STEND_FUZZ_FORMAT ("csv", "ulog", …), then every
// sample is read. Any std::exception is the importer refusing the input (a clear error is what it
// should be); a crash, a hang, a leak or a sanitizer report is a finding.
#include <stend/io/formats.hpp>
#include <stend/recording/samples.hpp>

#include <cstdint>
#include <exception>
#include <string>

#include "fuzz_support.hpp"

namespace {

// The generic csv format needs its columns mapped; the seeds use these names. With
// STEND_FUZZ_NAMED, a container's arrays are named (the seeds hold A: N×4 [t x y z], W: N×3, T).
stend::io::ImportOptions options() {
  stend::io::ImportOptions o;
#ifdef STEND_FUZZ_NAMED
  o.set("accel", "A");
  o.set("gyro", "W");
  o.set("temperature", "T");
  o.set("rate_hz", "100");
#endif
  if (std::string(STEND_FUZZ_FORMAT) == "csv") {
    o.set("time", "t");
    o.set("accel", "ax,ay,az");
    o.set("gyro", "gx,gy,gz");
    o.set("temperature", "temp");
  }
  return o;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > stend::fuzz::kMaxInputBytes) return 0;
  static const stend::io::ImportOptions kOptions = options();
  const auto file = stend::fuzz::write_input(data, size, STEND_FUZZ_FILE_NAME);
  try {
    const stend::Recording rec = stend::io::open_dataset({file}, STEND_FUZZ_FORMAT, kOptions);
    double sum = 0.0;
    stend::for_each_chunk(rec.sample_source(), [&](const stend::ImuSample* chunk, std::size_t n, std::uint64_t) {
      for (std::size_t i = 0; i < n; ++i) sum += chunk[i].t_s;
    });
    (void)sum;
  } catch (const std::exception&) {
  }
  return 0;
}
