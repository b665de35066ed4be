// stend gap: the noise- and output-stage candidates (quantization, saturation, coloured noise).
// Internal to stend_diagnosis. They cannot move the static means' fit, so they are judged on the raw
// samples (evidence gathered by build_input through the functions below) — each a test with a
// stated false-positive level, an effect size and an interval:
//
//   coloured_noise  within-segment white-noise test: 64 sub-block means per (segment, axis) in 8
//                   groups; pooled over segments, between-group over within-group mean square is
//                   F(7K, 56K) under white (or low-passed white) noise. Level alpha/3, Bonferroni
//                   over the fitted axes. Size: variance ratio of an 8-batch mean against white,
//                   with its F interval. When a kept window ≥ 100 s exists, the overlapping Allan
//                   deviation (stend/noise/noise_model.hpp) names the kind from the slope of the Allan
//                   variance above white over the last four octaves: > 0.5 random walk (K, the
//                   Allan fit's value ± 1.96 σ), else bias instability (B = largest Allan
//                   deviation above white / 0.664, with that point's 95 % EDF interval).
//   quantization    the noise does not dither the quantizer: the first Fourier harmonic of the
//                   rounding error averaged over Gaussian noise of the sample std σ̂ bounds the
//                   bias of a mean by (LSB/π)·exp(−2π²σ̂²/LSB²); significant when that bound
//                   exceeds the mean's noise floor on any (segment, axis). Size: the LSB (header,
//                   else the smallest spacing of the sample values), interval: spacings seen.
//   saturation      clipped samples in the static segments, skipped ones included (the sensor's
//                   flag when the recording uses it, else |value| ≥ range − LSB/2, or with the
//                   range unknown a run of ≥ 3 identical extreme values); significant on any
//                   clipped sample (unclipped Gaussian noise ≥ 5 std from the range clips with
//                   probability < 3e-7 a sample). Size: fraction clipped on the worst axis, Wilson
//                   95 % interval; evidence: largest |mean| and its headroom in sample std.
#pragma once

#include <set>
#include <string>
#include <vector>

#include "samples.hpp"
#include "stend/diagnosis/gap.hpp"

namespace stend::diagnosis::noise_stage {

// Sub-block ANOVA, distinct values and value spacing of one segment's kept window of n samples,
// per axis, fed a sample at a time in window order: fills SegmentData::ss_between, ss_within,
// distinct_values, value_step, raw_samples. Memory: the 64 sub-block sums and up to kMaxDistinct
// distinct values per axis; an axis with more (no 16-bit output has) is not quantized at a visible
// step, and its distinct_values and value_step stay NaN.
class SegmentEvidence {
 public:
  static constexpr std::size_t kMaxDistinct = std::size_t{1} << 16;
  SegmentEvidence(std::size_t n, bool accel);
  void add(const ImuSample& x);
  void fill(SegmentData& d) const;

 private:
  std::size_t n_;
  bool accel_;
  std::vector<BlockSums> sub_;               // per axis: the 64 sub-block sums
  std::vector<std::set<double>> distinct_;  // per axis: the distinct values
};

// Clipped samples over the static segments of `spec`'s kinds, and the Allan analysis of the
// longest kept window when ≥ 100 s: fills GapInput::clipped_samples, static_samples, allan_*.
void recording_evidence(GapInput& in, const Recording& recording);

// The three candidates, in the order quantization, saturation, coloured_noise.
// `alpha`: the family-wise level of the diagnosis (each noise candidate is tested at alpha/3).
std::vector<CandidateResult> candidates(const GapInput& in, const std::vector<int>& axes, const std::string& unit,
                                        double alpha);

}  // namespace stend::diagnosis::noise_stage
