// The run-folder readers: a template run folder (STEND_FUZZ_RUN_TEMPLATE, written by `stend import`)
// with one file replaced by the input, then Recording::open and every sample read.
//   CSV run folder: the first byte chooses the file (imu.csv, truth.csv, segments.csv, events.csv,
//                   run.json), the rest is its content.
//   run.h5:         the input is run.h5.
// Recording::open either returns or throws a std::runtime_error naming the file and place.
#include <stend/recording/recording.hpp>
#include <stend/recording/samples.hpp>

#include <array>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <system_error>
#include <string>

#include "fuzz_support.hpp"

namespace fs = std::filesystem;

namespace {

#ifdef STEND_FUZZ_RUN_H5
// The file the input replaces: run.h5, all of the input.
const char* take_file(const std::uint8_t*&, std::size_t&) { return "run.h5"; }
#else
// The file the input replaces, chosen by its first byte (then dropped from the input).
const char* take_file(const std::uint8_t*& data, std::size_t& size) {
  static constexpr std::array<const char*, 5> kFiles = {"imu.csv", "truth.csv", "segments.csv", "events.csv",
                                                        "run.json"};
  if (size == 0) return nullptr;
  const char* file = kFiles[data[0] % kFiles.size()];
  ++data;
  --size;
  return file;
}
#endif

// A fresh copy of the template in the scratch folder. libstdc++'s copy (sendfile) gives up on
// EINTR, which libFuzzer's timer signal caused once in 164 291 runs on a loaded machine (the
// harness stopped, not a finding): tried again then.
fs::path fresh_run_folder() {
  const fs::path dir = stend::fuzz::scratch_dir() / "run";
  for (int attempt = 0;; ++attempt) {
    fs::remove_all(dir);
    std::error_code ec;
    fs::copy(STEND_FUZZ_RUN_TEMPLATE, dir, fs::copy_options::recursive, ec);
    if (!ec) return dir;
    if (ec != std::errc::interrupted || attempt == 10) throw fs::filesystem_error("run template copy", dir, ec);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > stend::fuzz::kMaxInputBytes) return 0;
  const char* file = take_file(data, size);
  if (file == nullptr) return 0;
  const fs::path dir = fresh_run_folder();
  stend::fuzz::write_input(data, size, "input");
  fs::rename(stend::fuzz::scratch_dir() / "input", dir / file);
  try {
    const stend::Recording rec = stend::Recording::open(dir, stend::SampleLoading::kStream);
    double sum = 0.0;
    stend::for_each_chunk(rec.sample_source(), [&](const stend::ImuSample* chunk, std::size_t n, std::uint64_t) {
      for (std::size_t i = 0; i < n; ++i) sum += chunk[i].accel_mps2.x();
    });
    (void)sum;
  } catch (const std::exception&) {
  }
  return 0;
}
