// Whether a record is still enough for a noise analysis (the Allan deviation and its noise-model
// fit): the one stationarity rule, with its thresholds, used by every command that analyses noise.
//
// The samples are summarised in blocks of kStationarityBlockS (at least kMinStationarityBlockSamples
// samples): per channel the block mean and the spread of the samples inside the block. A record
// moves where the mean jumps — a turn (the gyroscope far above its noise), a step or a ramp of the
// accelerometer — and that is told from the slow wanderings the noise model itself contains
// (random walk, bias instability, rate ramp) by looking at increments: at the scales of 1, 2, 4, …
// blocks, the difference of adjacent means of that many blocks. Those of a noise process (white,
// flicker, random walk, a steady ramp) are alike all along the record, so their robust spread
// (1.4826 × the median absolute increment; never less than the white spread of a block's samples)
// states what the noise does at that scale; an increment more than kMaxIncrementSigmas times that
// spread is an event the noise model does not contain. A stretch is named at the finest scale that
// sees it. Scales are tried while they give at least kMinStationarityIncrements increments.
//
// Temperature, where the record has one (NaN = not measured: no check), must stay within
// kMaxTemperatureDriftC over the record (block means): a sweep changes the sensor's bias, and the
// Allan deviation would read that drift as noise.
//
// Only the instruments the recording has are judged (stend/recording/instruments.hpp): a gyro-only
// record is still where its gyroscope is, an accelerometer-only one where its accelerometer is
// (Stationarity::basis says so).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "stend/recording/samples.hpp"

namespace stend::processing {

inline constexpr double kStationarityBlockS = 1.0;             // [s]
inline constexpr std::size_t kMinStationarityBlockSamples = 16;
inline constexpr std::size_t kMinStationarityIncrements = 16;  // per scale, for a robust spread
inline constexpr double kMaxIncrementSigmas = 10.0;            // an increment beyond: the record moves
inline constexpr double kMaxTemperatureDriftC = 2.0;           // [°C] range of the block means

// What moves: the accelerometer (steps, tilts), the gyroscope (turns) or the temperature (drift).
enum class Mover { kAccelerometer, kGyroscope, kTemperature };

// One stretch of the record that moves, [t_start_s, t_end_s] in run time [s]; `change` is how far
// the mean goes from where it stood before the stretch (for the instruments the norm over the
// three axes: m/s², rad/s), or for the temperature the range of its block means [°C].
struct MovingStretch {
  Mover mover = Mover::kAccelerometer;
  double t_start_s = 0.0, t_end_s = 0.0;
  double change = 0.0;
};

struct Stationarity {
  std::vector<MovingStretch> stretches;  // in time order per mover: accelerometer, gyroscope, temperature
  // The longest stretch where neither instrument moves [s] (NaN when none was judged).
  double still_start_s = kNaN, still_end_s = kNaN;
  std::size_t blocks = 0;  // blocks summarised
  bool judged = false;     // false: too short to judge (fewer than kMinStationarityIncrements + 1 blocks)
  // "" when both instruments were judged, else "still stretches from the gyroscope alone (the
  // recording has no accelerometer)" or the accelerometer's counterpart.
  std::string basis;

  bool still() const { return stretches.empty(); }
  // "the accelerometer moves at 36.0–42.0 s (a changes by 2040 mg) and in 8 more stretches up to
  // 96.0 s; the gyroscope turns at … (by up to 117.3 deg/s); the temperature drifts at 0.0–300.0 s
  // (by 19.9 °C)" — empty when still.
  std::string describe() const;
};

// The block summaries the rule judges, gathered column by column as a caller reads them anyway
// (the Allan analysis reads each channel once: it feeds the same chunks here, so the check costs no
// second pass over the store). Each channel's chunks come in order from the range's first sample;
// different channels may be fed from different threads at once.
class BlockSummary {
 public:
  // For `samples` samples at rate_hz [Hz]: blocks of kStationarityBlockS (at least
  // kMinStationarityBlockSamples samples); a shorter tail is left out.
  BlockSummary(std::uint64_t samples, double rate_hz);
  // Samples [offset, offset + n) of the range of channel c (kTime, kAx … kGz, kTemperature).
  void add(Channel c, std::uint64_t offset, const double* x, std::size_t n);
  // Reads channel c of samples [range.first, range.last) of src and adds it, a chunk at a time.
  void add_column(const SampleSource& src, IndexRange range, Channel c);
  // The rule over what was added: kTime and the channels of the instruments `info` says the
  // recording has (kAx … kAz, kGx … kGz) are required; kTemperature is checked when it was added
  // (and finite).
  Stationarity judge(const SensorInfo& info) const;

 private:
  struct Column {
    std::vector<double> mean, sd, first, last;  // per block; first/last: values of its end samples
    double origin = 0.0, sum = 0.0, sum2 = 0.0;  // the block being summed, about its first sample
    bool added = false;
  };
  // Samples [in_block, in_block + n) of block `block` into col; the block's summary once it is whole.
  void add_run(Column& col, std::size_t block, std::size_t in_block, const double* x, std::size_t n);
  std::size_t per_block_ = 0, blocks_ = 0;
  std::array<Column, 9> columns_;  // indexed by Channel
};

// The rule above over samples [range.first, range.last) of src at rate_hz [Hz], reading the
// columns of what `info` says the recording has (present_channels).
Stationarity check_stationarity(const SampleSource& src, IndexRange range, double rate_hz, const SensorInfo& info);

}  // namespace stend::processing
