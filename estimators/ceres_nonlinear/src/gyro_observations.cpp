// The whitened gyro observations the turns and earth_rate methods fit (see gyro.hpp): the cost
// through the vocabulary's ErrorModel::measure, the pooled still noise, the segment settings.
#include "gyro.hpp"

#include <stend/processing/truth.hpp>

#include <cmath>

namespace stend::ceres_nonlinear::detail {

namespace {

// W·(measure(θ, s) − ȳ) with θ the model's full vector built from the free parameters.
struct WhitenedGyroCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  GyroObservation obs;
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    std::vector<T> theta(static_cast<std::size_t>(m->size()), T(0));
    for (std::size_t k = 0; k < free_index.size(); ++k) theta[static_cast<std::size_t>(free_index[k])] = p[0][k];
    model::Stimulus<T> s;
    s.input = obs.stimulus.input.cast<T>();
    s.specific_force = obs.stimulus.specific_force.cast<T>();
    const model::Vec3<T> d = m->measure<T>(theta.data(), s) - obs.reading.cast<T>();
    for (Eigen::Index row = 0; row < obs.whitening.rows(); ++row) {
      residual[row] = T(0);
      for (int j = 0; j < 3; ++j) residual[row] += obs.whitening(row, j) * d[j];
    }
    return true;
  }
};

}  // namespace

void solve_gyro_observations(const std::vector<GyroObservation>& observations, const std::vector<int>& free_index,
                             const GyroOptions& options, CalibrationResult& r) {
  std::vector<double> x(free_index.size(), 0.0);
  ceres::Problem problem;
  const CalibrationOptions o = as_calibration_options(options, options.loss_scale_radps);
  int residuals = 0;
  for (const GyroObservation& obs : observations) {
    auto* cost = new ceres::DynamicAutoDiffCostFunction<WhitenedGyroCost, 8>(new WhitenedGyroCost{&r.model, free_index, obs});
    cost->AddParameterBlock(static_cast<int>(free_index.size()));
    cost->SetNumResiduals(static_cast<int>(obs.whitening.rows()));
    problem.AddResidualBlock(cost, make_loss(o), x.data());
    residuals += static_cast<int>(obs.whitening.rows());
  }
  solve(problem, x, free_index, residuals, o, r, Weighting::kAPriori);
}

Eigen::Vector3d pooled_gyro_noise(const std::vector<processing::StaticPoint>& stills, double quantization_radps) {
  Eigen::Vector3d sum_sq = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& s : stills)
    if (s.gyro.sample_std.allFinite()) {
      sum_sq += s.gyro.sample_std.cwiseAbs2();
      ++n;
    }
  const Eigen::Vector3d pooled = n > 0 ? Eigen::Vector3d((sum_sq / n).cwiseSqrt()) : Eigen::Vector3d::Zero();
  return pooled.cwiseMax(quantization_radps / std::sqrt(12.0));
}

Eigen::Matrix3d mean_whitening(const Eigen::Vector3d& noise_radps, std::size_t samples) {
  const double root_n = std::sqrt(static_cast<double>(samples));
  return Eigen::Vector3d(root_n / noise_radps[0], root_n / noise_radps[1], root_n / noise_radps[2]).asDiagonal();
}

processing::ProcessingOptions still_segment_options(const GyroOptions& options) {
  processing::ProcessingOptions o = options.processing;
  o.intervals = processing::IntervalSource::kSegments;
  o.segment_kinds = {to_string(SegmentKind::kOrientation), to_string(SegmentKind::kDetected)};
  o.stated.insert({"intervals", "segments"});
  return o;
}

processing::ProcessingOptions turn_segment_options() {
  processing::ProcessingOptions o;
  o.intervals = processing::IntervalSource::kSegments;
  o.segment_kinds = {to_string(SegmentKind::kRotation)};
  o.extraction.filter = processing::Filter::kNone;
  o.extraction.settle_s = 0.0;
  o.stated = {"intervals", "segments", "extraction.filter", "extraction.settle_s"};
  return o;
}

double sample_period_s(const processing::StaticPoint& window) {
  return window.samples_used > 1 ? (window.t_end_s - window.t_start_s) / static_cast<double>(window.samples_used - 1)
                                 : 0.0;
}

Eigen::Vector3d finite_truth_mean(const Recording& rec, const std::array<int, 3>& columns, double t0_s, double t1_s) {
  const std::shared_ptr<const RecordedTruth> truth = rec.recorded_truth();
  const TruthRows rows = truth_rows_in(*truth, t0_s, t1_s);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), count = Eigen::Vector3d::Zero();
  for_each_truth_row(*truth, rows.lo, rows.hi, [&](double, const double* values, bool whole) {
    if (!whole) return;
    for (int a = 0; a < 3; ++a) {
      const double v = values[columns[static_cast<std::size_t>(a)]];
      if (!std::isfinite(v)) continue;
      sum[a] += v;
      count[a] += 1.0;
    }
  });
  Eigen::Vector3d mean;
  for (int a = 0; a < 3; ++a) mean[a] = count[a] > 0.0 ? sum[a] / count[a] : kNaN;
  return mean;
}

std::optional<std::array<int, 3>> truth_columns(const Recording& rec, const std::array<const char*, 3>& names) {
  std::array<int, 3> c{};
  for (std::size_t a = 0; a < 3; ++a) {
    c[a] = rec.truth_column(names[a]);
    if (c[a] < 0) return std::nullopt;
  }
  return c;
}

}  // namespace stend::ceres_nonlinear::detail
