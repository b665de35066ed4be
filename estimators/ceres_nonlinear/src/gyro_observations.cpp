// The jointly whitened gyro observations the turns and the rate table with stated sigmas fit (see
// gyro.hpp): the cost through the vocabulary's ErrorModel::measure, the a-priori covariances (the
// Earth rate, the g-sensitivity), the pooled still noise, the segment settings.
#include "gyro.hpp"

#include <stend/physics/gravity.hpp>
#include <stend/processing/truth.hpp>

#include <Eigen/Cholesky>

#include <cmath>

namespace stend::ceres_nonlinear::detail {

namespace {

// All observations stacked: W·(measure(θ, s_k) − ȳ_k), W the joint whitening (3n × 3n).
struct JointGyroCost {
  const model::ErrorModel* m;
  std::vector<int> free_index;
  std::vector<GyroObservation> obs;
  Eigen::MatrixXd W;
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    std::vector<T> theta(static_cast<std::size_t>(m->size()), T(0));
    for (std::size_t k = 0; k < free_index.size(); ++k) theta[static_cast<std::size_t>(free_index[k])] = p[0][k];
    std::vector<T> d(3 * obs.size());
    for (std::size_t k = 0; k < obs.size(); ++k) {
      model::Stimulus<T> s;
      s.input = obs[k].stimulus.input.cast<T>();
      s.specific_force = obs[k].stimulus.specific_force.cast<T>();
      const model::Vec3<T> e = m->measure<T>(theta.data(), s) - obs[k].reading.cast<T>();
      for (std::size_t a = 0; a < 3; ++a) d[3 * k + a] = e[static_cast<Eigen::Index>(a)];
    }
    for (Eigen::Index row = 0; row < W.rows(); ++row) {
      residual[row] = T(0);
      for (Eigen::Index c = 0; c < W.cols(); ++c) residual[row] += W(row, c) * d[static_cast<std::size_t>(c)];
    }
    return true;
  }
};

}  // namespace

int add_joint_gyro_observations(const std::vector<GyroObservation>& observations, const Eigen::MatrixXd& covariance,
                                const model::ErrorModel& m, const std::vector<int>& free_index,
                                const CalibrationOptions& o, ceres::Problem& problem, std::vector<double>& x) {
  const Eigen::MatrixXd L = covariance.llt().matrixL();
  auto* cost = new ceres::DynamicAutoDiffCostFunction<JointGyroCost, 8>(
      new JointGyroCost{&m, free_index, observations, L.inverse()});
  cost->AddParameterBlock(static_cast<int>(free_index.size()));
  const int residuals = static_cast<int>(3 * observations.size());
  cost->SetNumResiduals(residuals);
  (void)o;  // one block for all: a robust loss would act on their sum, so none is applied
  problem.AddResidualBlock(cost, nullptr, x.data());
  return residuals;
}

std::string joint_loss_note(const CalibrationOptions& o) {
  if (o.loss == Loss::kNone) return {};
  return std::string("loss '") + loss_name(o.loss) +
         "' not applied: the observations are whitened jointly (they share the Earth rate, the g-sensitivity), "
         "so they form one residual block";
}

Eigen::MatrixXd g_sensitivity_covariance(const std::vector<Eigen::Vector3d>& f, double sigma) {
  const auto n = static_cast<Eigen::Index>(f.size());
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  const auto finite = [](const Eigen::Vector3d& v) { return v.allFinite() ? v : Eigen::Vector3d::Zero(); };
  for (Eigen::Index k = 0; k < n; ++k)
    for (Eigen::Index l = 0; l < n; ++l)
      c.block(3 * k, 3 * l, 3, 3) = Eigen::Matrix3d::Identity() * sigma * sigma *
                                    finite(f[static_cast<std::size_t>(k)]).dot(finite(f[static_cast<std::size_t>(l)]));
  return c;
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
  return pooled.cwiseMax(quantization_radps / std::sqrt(12.0)) * noise_correlation_factor(stills, true);
}

Eigen::Matrix3d earth_rate_factor(const Eigen::Vector3d& applied, const Eigen::Vector3d& f) {
  const double earth_sq = physics::kEarthRateRadps * physics::kEarthRateRadps;
  const double stated_sq = applied.allFinite() ? applied.squaredNorm() : 0.0;
  if (!(stated_sq > 0.0) || !(f.norm() > 0.0)) return Eigen::Matrix3d::Identity() * physics::kEarthRateRadps;
  const Eigen::Vector3d up = f.normalized();
  return std::sqrt(std::max(0.0, earth_sq - stated_sq)) * (Eigen::Matrix3d::Identity() - up * up.transpose());
}

Eigen::Matrix3d earth_rate_covariance(const Eigen::Vector3d& applied, const Eigen::Vector3d& f) {
  const Eigen::Matrix3d b = earth_rate_factor(applied, f);
  return b * b.transpose();
}

Eigen::MatrixXd stills_earth_rate_covariance(const std::vector<processing::StaticPoint>& stills) {
  const auto n = static_cast<Eigen::Index>(stills.size());
  const double same = std::cos(30.0 * physics::kDegToRad);
  std::vector<Eigen::Matrix3d> b;
  std::vector<Eigen::Vector3d> up;
  for (const auto& s : stills) {
    b.push_back(earth_rate_factor(s.stimulus.input, s.accel.mean));
    up.push_back(s.accel.mean.norm() > 0.0 ? Eigen::Vector3d(s.accel.mean.normalized()) : Eigen::Vector3d::Zero());
  }
  // Each still joins the orientation of the first earlier one within 30° of it.
  std::vector<std::size_t> cluster(stills.size());
  for (std::size_t k = 0; k < stills.size(); ++k) {
    cluster[k] = k;
    for (std::size_t j = 0; j < k; ++j)
      if (cluster[j] == j && up[k].dot(up[j]) > same) {
        cluster[k] = j;
        break;
      }
  }
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (Eigen::Index k = 0; k < n; ++k)
    for (Eigen::Index l = 0; l < n; ++l)
      if (cluster[static_cast<std::size_t>(k)] == cluster[static_cast<std::size_t>(l)])
        c.block(3 * k, 3 * l, 3, 3) = b[static_cast<std::size_t>(k)] * b[static_cast<std::size_t>(l)].transpose();
  return c;
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
