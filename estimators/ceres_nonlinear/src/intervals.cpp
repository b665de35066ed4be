// The static intervals of the ceres_nonlinear fits: the processing stage's points (see
// stend/ceres_nonlinear/calibration.hpp).
#include "solver.hpp"

#include <stdexcept>

namespace stend::ceres_nonlinear {

processing::StaticPoint make_interval(const Recording& rec, std::size_t first, std::size_t last, std::string label) {
  if (last < first || last >= rec.sample_count()) throw std::out_of_range("make_interval: bad sample range");
  std::vector<ImuSample> S(last - first + 1);  // one static interval
  rec.sample_source().read(first, S.size(), S.data());
  processing::StaticPoint iv;
  iv.first = first;
  iv.last = last;
  iv.t_start_s = S.front().t_s;
  iv.t_end_s = S.back().t_s;
  iv.samples_used = last - first + 1;
  iv.segment.label = std::move(label);
  Eigen::Vector3d accel = Eigen::Vector3d::Zero(), gyro = Eigen::Vector3d::Zero();
  for (const ImuSample& x : S) {
    accel += x.accel_mps2;
    gyro += x.gyro_radps;
  }
  const double n = static_cast<double>(iv.samples_used);
  iv.accel.mean = accel / n;
  iv.gyro.mean = gyro / n;
  Eigen::Vector3d a2 = Eigen::Vector3d::Zero(), g2 = Eigen::Vector3d::Zero();
  for (const ImuSample& x : S) {
    a2 += (x.accel_mps2 - iv.accel.mean).cwiseAbs2();
    g2 += (x.gyro_radps - iv.gyro.mean).cwiseAbs2();
  }
  iv.accel.sample_std = iv.gyro.sample_std = Eigen::Vector3d::Zero();
  if (iv.samples_used > 1) {
    iv.accel.sample_std = (a2 / (n - 1.0)).cwiseSqrt();
    iv.gyro.sample_std = (g2 / (n - 1.0)).cwiseSqrt();
  }
  iv.accel.std_error = iv.accel.sample_std / std::sqrt(n);
  iv.gyro.std_error = iv.gyro.sample_std / std::sqrt(n);
  return iv;
}

processing::ProcessingOptions default_interval_options() {
  processing::ProcessingOptions o;
  o.intervals = processing::IntervalSource::kDetect;
  o.extraction.filter = processing::Filter::kNone;
  o.extraction.settle_s = 0.0;
  return o;
}

processing::ProcessingOptions rate_table_interval_options() {
  processing::ProcessingOptions o;
  o.intervals = processing::IntervalSource::kSegments;
  o.segment_kinds = {"orientation", "rate"};
  o.extraction.filter = processing::Filter::kNone;
  o.extraction.settle_s = 0.5;
  o.stated = {"intervals", "segments"};
  return o;
}

namespace detail {

Extracted extract_intervals(const Recording& rec, const processing::ProcessingOptions& o,
                            std::vector<std::string> truth_columns) {
  processing::Request request;
  request.truth_columns = std::move(truth_columns);
  Extracted out;
  processing::Extraction ex = processing::extract(rec, o, request);
  for (auto& p : ex.points) {
    out.truth.push_back(p.truth);
    out.intervals.push_back(std::move(p));
  }
  out.detection = ex.detection;
  return out;
}

}  // namespace detail

std::vector<processing::StaticPoint> static_intervals(const Recording& rec, const processing::ProcessingOptions& options) {
  return detail::extract_intervals(rec, options).intervals;
}

}  // namespace stend::ceres_nonlinear
