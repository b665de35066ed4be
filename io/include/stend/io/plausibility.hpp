// Plausibility on the way in: the checks every imported sample passes, written once and applied
// by the format registry (formats.cpp) to every format — `stend import`, and `stend fit|gap` on a
// file — before anything is fitted:
//   * a bad sample (a time or value that is not a finite number) is refused naming where it is,
//     or, with drop_bad_samples, dropped and counted (the count in the import event);
//   * the stillest stretch of the log must read |a| near 1 g, and a rate no MEMS gyroscope
//     reads, else the units are wrong (counts without an LSB, g read as m/s², m/s² read as g) and
//     the import is refused saying what the data look like, unless accept_implausible.
// What the recording lacks is stated here for every importer: the samples of a recording without an
// accelerometer, a gyroscope or a temperature carry NaN in its values (blank_absent,
// stend/recording/instruments.hpp), never 0 read as data, and only the instruments present are
// judged (a gyro-only log: its still stretches and its rate from the gyroscope alone).
#pragma once

#include <stend/io/import_options.hpp>
#include <stend/io/sample_sink.hpp>
#include <stend/recording/recording.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace stend::io {

// The stillest-stretch rule: the log is cut into blocks of kStillBlock_s; a block is still when
// its accelerometer vector scatters by less than kStillScatter of its mean |a| (and it holds at
// least kStillMinSamples samples); the verdict is taken on the kStillBlocksKept stillest blocks
// (their median |a| and |ω|). A log with no still block (moving throughout, or |a| ≈ 0) is not
// judged: the rule needs one still stretch of kStillBlock_s. A log without an accelerometer is
// judged on its rate alone, in the blocks where the gyroscope scatters least.
inline constexpr double kStillBlock_s = 0.5;
inline constexpr std::size_t kStillMinSamples = 8;
inline constexpr double kStillScatter = 0.05;
inline constexpr std::size_t kStillBlocksKept = 5;
// A still |a| in [kMinStillG, kMaxStillG] g is plausible; a still |ω| above kMaxStillRate_dps
// (more than any MEMS gyroscope's full scale) means counts.
inline constexpr double kMinStillG = 0.5;
inline constexpr double kMaxStillG = 2.0;
inline constexpr double kMaxStillRate_dps = 2000.0;
// A still |a| above this many g is counts (no MEMS accelerometer has fewer counts per g).
inline constexpr double kMinCountsPerG = 100.0;

// What is wrong with sample `s` of a recording whose sensor `info` describes (empty: nothing): a
// time that is not finite, a value of an instrument it has that is not finite, a temperature that
// is infinite (NaN is an absent reading). An absent instrument's values are not looked at.
std::string sample_problem(const ImuSample& s, const SensorInfo& info);

// The stillest stretches of a log, in O(1) memory: samples in time order.
class Stillness {
 public:
  // The samples carry the instruments `info` says.
  explicit Stillness(const SensorInfo& info = {});
  void add(const ImuSample& s);
  // The median |a| [m/s²] and |ω| [rad/s] of the stillest blocks (NaN for an absent instrument);
  // nullopt without a still block.
  struct Still {
    double accel_mps2 = 0.0;
    double rate_radps = 0.0;
    std::size_t blocks = 0;
  };
  std::optional<Still> stillest() const;

 private:
  struct Block {
    // RMS distance of the accelerometer vectors from their mean, over |a| [1]; without an
    // accelerometer, of the gyroscope vectors [rad/s]
    double scatter = 0.0;
    double accel_mps2 = 0.0;
    double rate_radps = 0.0;
  };
  void close_block();
  bool accel_ = true, gyro_ = true;  // the instruments the samples carry
  std::vector<Block> kept_;  // at most kStillBlocksKept, the stillest
  double t0_s_ = 0.0;
  std::size_t n_ = 0;
  Eigen::Vector3d sum_a_ = Eigen::Vector3d::Zero(), sum_w_ = Eigen::Vector3d::Zero();
  double sum_aa_ = 0.0, sum_ww_ = 0.0;
};

// Why a still stretch reading `still` is implausible for data imported with `options` (empty:
// plausible): "… these look like raw counts — give --accel-lsb (e.g. 1/16384g)".
// `where` says where `still` was read.
std::string implausible_because(const Stillness::Still& still, const ImportOptions& options,
                                const std::string& where = "in the stillest stretch");

// The same rule on a table of means (its rows, held, are no log to find a still stretch in; every
// row is still): the median |a| of its rows must be about 1 g, else it is refused (ImportError)
// saying what the values look like, unless accept_implausible.
void check_held_means(const Recording& rec, const std::filesystem::path& file, const ImportOptions& options);

// What becomes of bad samples: refused (the error thrown as it is) or, with drop, counted.
class BadSamples {
 public:
  explicit BadSamples(bool drop) : drop_(drop) {}
  // Throws `refusal` unless dropping; then counts it (the first is kept to be quoted).
  void report(const ImportError& refusal);
  std::uint64_t dropped() const { return dropped_; }
  // "2 bad sample(s) dropped (--drop-bad-samples), the first: log.csv:5: …" ("" when none).
  std::string describe() const;

 private:
  bool drop_;
  std::uint64_t dropped_ = 0;
  std::string first_;
};

// The gate every imported sample passes on its way to `out`: what the recording lacks set to NaN
// (blank_absent), bad samples refused (ImportError at FILE: sample N) or dropped and counted, the
// stillness gathered.
// finish() adds the import event of the dropped samples and refuses an implausible log.
class SampleCheck final : public SampleSink {
 public:
  SampleCheck(const Recording& rec, SampleSink& out, std::filesystem::path file, const ImportOptions& options)
      : rec_(&rec),
        out_(&out),
        file_(std::move(file)),
        options_(&options),
        bad_(options.drop_bad_samples) {}
  void add_samples(const ImuSample* samples, std::size_t count) override;
  void finish(Recording& rec);

 private:
  void pass_kept();  // the checked samples kept so far, on to `out`

  const Recording* rec_;
  SampleSink* out_;
  std::filesystem::path file_;
  const ImportOptions* options_;
  std::vector<ImuSample> kept_;
  std::uint64_t seen_ = 0;
  BadSamples bad_;
  // Made at the first samples, when the importer has said which instruments the log holds.
  std::optional<Stillness> stillness_;
};

// The same gate on a recording read whole (its samples filtered in place).
void check_samples(Recording& rec, const std::filesystem::path& file, const ImportOptions& options);

}  // namespace stend::io
