// The noise of one segment mean in the segment-level validation generators (validate.cpp,
// validate_rate.cpp): a Gauss–Markov bias instability stepped exactly between segment mid-times,
// the white noise of the mean, and the floor an 8-batch-means estimate would report
// (se·sqrt(χ²₇/7)), as build_input does on samples.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "stend/diagnosis/gap.hpp"
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

  // Adds the noise of a mean at mid-time `mid_s` [s] to y; fills the segment's floor fields.
  void apply(model::Rng& rng, double mid_s, Eigen::Vector3d& y, SegmentData& s) {
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
    s.point.measured_std_error = Eigen::Vector3d::Constant(se_);
  }

 private:
  double se_, sigma_, bi_, tau_s_;
  Eigen::Vector3d gm_ = Eigen::Vector3d::Zero();
  double t_prev_s_ = 0.0;
};

}  // namespace stend::diagnosis
