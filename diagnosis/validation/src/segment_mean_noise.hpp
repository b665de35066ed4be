// The noise of one segment mean in the segment-level validation generators (validate.cpp,
// validate_rate.cpp; internal to stend_gap_validation): a Gauss–Markov bias instability stepped exactly between segment mid-times,
// the white noise of the mean, and the floor an 8-batch-means estimate would report
// (se·sqrt(χ²₇/7)), as build_input does on samples.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>

#include "stend/diagnosis/gap.hpp"
#include "stend/diagnosis/validate.hpp"
#include "stend/model/noise.hpp"

namespace stend::diagnosis {

class SegmentMeanNoise {
 public:
  // se: white standard error of a mean [unit]; sigma: white sample std [unit];
  // bias_instability: GM σ [unit]; correlation_s: GM time constant [s].
  SegmentMeanNoise(model::Rng& rng, double se, double sigma, double bias_instability, double correlation_s)
      : se_(se), sigma_(sigma), bi_(bias_instability), tau_s_(correlation_s) {
    for (int a = 0; a < 3; ++a) gm_[a] = bi_ * rng.normal();
  }

  // Adds the noise of a mean at mid-time `mid_s` [s] to y; fills the segment's floor fields and
  // the white standard error of the instrument's mean.
  void apply(model::Rng& rng, double mid_s, Eigen::Vector3d& y, model::Instrument instrument, SegmentData& s) {
    const double phi = std::exp(-(mid_s - t_prev_s_) / tau_s_);
    t_prev_s_ = mid_s;
    for (int a = 0; a < 3; ++a) {
      gm_[a] = phi * gm_[a] + bi_ * std::sqrt(1 - phi * phi) * rng.normal();
      y[a] += gm_[a] + se_ * rng.normal();
      double chi = 0;
      for (int k = 0; k < 7; ++k) {
        const double z = rng.normal();
        chi += z * z;
      }
      s.mean_std_error[a] = se_ * std::sqrt(chi / 7.0);
      s.raw_std[a] = sigma_;
    }
    s.point.axes(instrument).std_error = Eigen::Vector3d::Constant(se_);
  }

 private:
  double se_, sigma_, bi_, tau_s_;
  Eigen::Vector3d gm_ = Eigen::Vector3d::Zero();
  double t_prev_s_ = 0.0;
};

// A generator's input before any segment: the fitted model, the source, truth and floor notes.
inline GapInput generated_input(const estimation::ModelSpec& fit_model, const std::string& source) {
  GapInput in;
  in.spec = fit_model;
  in.source = source;
  in.truth_source = "generator truth";
  in.floor_source = "batch means of 8 blocks (generator: white floor × sqrt(chi2_7/7))";
  return in;
}

// A generated segment's id and window [t_start_s, t_start_s + record_s] [s] with its samples at
// rate_hz [Hz]; returns the mid-time [s].
inline double time_segment(SegmentData& s, int id, double t_start_s, double record_s, double rate_hz) {
  auto& p = s.point;
  p.segment.id = id;
  p.t_start_s = t_start_s;
  p.t_end_s = t_start_s + record_s;
  p.samples_used = static_cast<std::size_t>(record_s * rate_hz);
  return t_start_s + 0.5 * record_s;
}

// The measured mean of a generated segment: the true model at its stimulus, plus the
// out-of-vocabulary effect of its id (when planted), plus the noise of the mean at mid_s [s].
inline void measure_segment(const Planted& truth, SegmentMeanNoise& noise, model::Rng& rng, double mid_s,
                            SegmentData& s) {
  auto& p = s.point;
  Eigen::Vector3d y = truth.model.measure<double>(truth.theta.data(), p.stimulus);
  if (!truth.extra.empty()) y += truth.extra[static_cast<std::size_t>(p.segment.id) % truth.extra.size()];
  noise.apply(rng, mid_s, y, truth.model.instrument, s);
  p.axes(truth.model.instrument).mean = y;
}

}  // namespace stend::diagnosis
