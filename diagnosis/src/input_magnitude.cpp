// stend gap on a session whose orientations were never recorded (hand-held IMU-TK style): only
// |g| is known. Each static segment contributes the measured mean along the estimated gravity
// direction û; to first order the two directions across û are what the unknown orientation
// absorbs, so they carry no information about the error model. See magnitude.hpp.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <stend/errors.hpp>

#include "magnitude.hpp"
#include "stend/estimation/linear_lsq.hpp"
#include "stend/processing/static_detector.hpp"
#include "stend/physics/units.hpp"
#include "stend/recording/truth_columns.hpp"

namespace stend::diagnosis {

namespace {

// Direction û (|f| = g) that the model with parameters θ maps onto the measured mean m:
// Gauss–Newton on |m − h(θ, g·û)| with ∂h/∂f ≈ I (a sensor's errors are a few percent),
// renormalized to the sphere each step.
void fit_direction(const model::ErrorModel& m, const Eigen::VectorXd& theta, double g, SegmentData& s) {
  auto& st = s.point.stimulus;
  Eigen::Vector3d f = st.specific_force;
  for (int it = 0; it < 30; ++it) {
    st.specific_force = f;
    st.input = f;
    st.gravity_up = f / f.norm();
    const Eigen::Vector3d next = g * (f + (s.point.accel.mean - m.measure<double>(theta.data(), st))).normalized();
    const double step = (next - f).norm();
    f = next;
    if (step < 1e-12 * g) break;
  }
  st.specific_force = f;
  st.input = f;
  st.gravity_up = f / f.norm();
}

}  // namespace

double magnitude_std_error(const SegmentData& s) {
  const Eigen::Vector3d u = s.point.stimulus.specific_force.normalized();
  double v = 0.0;
  for (int a = 0; a < 3; ++a) v += u[a] * u[a] * s.mean_std_error[a] * s.mean_std_error[a];
  return std::sqrt(v);
}

estimation::StaticFit fit_magnitude_rows(const GapInput& in, bool known_variance) {
  estimation::StaticFit fr;
  fr.unit = "m/s^2";
  fr.display_unit = "mg";
  const model::ErrorModel& m = in.spec.model;
  const auto n = static_cast<Eigen::Index>(in.segments.size());
  estimation::LsqProblem pr;
  pr.design.resize(n, m.size());
  pr.observations.resize(n);
  double f2 = 0.0;
  int fn = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& s = in.segments[static_cast<std::size_t>(i)];
    const Eigen::Vector3d u = s.point.stimulus.specific_force.normalized();
    pr.design.row(i) = u.transpose() * m.regressor(s.point.stimulus);
    pr.observations[i] = u.dot(s.point.accel.mean - s.point.stimulus.input);
    const double se = magnitude_std_error(s);
    if (std::isfinite(se)) {
      f2 += se * se;
      ++fn;
    }
  }
  const double floor = fn ? std::sqrt(f2 / fn) : 1.0;
  pr.weights = Eigen::VectorXd::Constant(n, 1.0 / (floor * floor));
  for (const auto& p : m.params()) {
    pr.names.push_back(p.name);
    pr.units.push_back(p.unit);
  }
  fr.params = m.params();
  for (int j = 0; j < m.size(); ++j) fr.param_index.push_back(j);
  estimation::LsqOptions o;
  o.observations_per_parameter_warning = 0.0;
  o.confidence = in.spec.confidence;
  o.known_variance = known_variance;
  fr.lsq = estimation::solve_lsq(pr, o);
  fr.status = fr.lsq.ok() ? estimation::FitStatus::kOk : estimation::FitStatus::kFailed;
  if (!fr.ok()) {
    fr.message = "magnitude-form fit: " + fr.lsq.message;
    return fr;
  }
  fr.residual_rms[0] = std::sqrt(fr.lsq.residuals.squaredNorm() / static_cast<double>(n));
  fr.residual_rms_display[0] = fr.residual_rms[0] / physics::kMilliG;
  return fr;
}

GapInput magnitude_form(GapInput in, double g) {
  if (in.spec.model.instrument != model::Instrument::kAccelerometer)
    throw InputError("the magnitude form of the gap needs an accelerometer model (|g| is the only truth)");
  if (in.segments.size() < 2) throw InputError("the magnitude form needs at least two static segments");
  const model::ErrorModel& m = in.spec.model;
  for (auto& s : in.segments) {
    s.point.stimulus.specific_force = s.point.accel.mean;  // first guess: the raw direction
    fit_direction(m, Eigen::VectorXd::Zero(m.size()), g, s);
  }
  in.magnitude = true;
  // Fit on |f| rows ↔ directions, to a fixed point (the directions move by O(errors²) after the
  // first pass).
  double moved = 0.0;
  for (int outer = 0; outer < 8; ++outer) {
    // Only the solution is used here: the floors as known variances let a design with as many
    // parameters as segments be put in this form (diagnose then says why it cannot be tested).
    const estimation::StaticFit fr = fit_magnitude_rows(in, /*known_variance=*/true);
    if (!fr.ok()) throw InputError(fr.message);
    moved = 0.0;
    for (auto& s : in.segments) {
      const Eigen::Vector3d before = s.point.stimulus.specific_force;
      fit_direction(m, fr.lsq.min_norm_solution, g, s);
      moved = std::max(moved, (s.point.stimulus.specific_force - before).norm());
    }
    if (moved < 1e-10 * g) break;
  }
  for (auto& s : in.segments) {
    s.point.stimulus.angular_rate.setZero();
    for (auto& v : s.point.stimulus.table_df_dangle) v.setZero();
    for (auto& v : s.point.stimulus.table_df_dtilt) v.setZero();
  }
  std::ostringstream os;
  os << "magnitude only: |g| = " << g << " m/s^2 known, each segment's direction estimated from its mean "
     << "through the fitted model (fixed point, last move " << moved << " m/s^2)";
  in.truth_source = os.str();
  in.notes.push_back("magnitude form: one row per segment (the mean along the estimated gravity direction); "
                     "rotations of the sensor frame (antisymmetric cross-axis, table angles) cannot be seen");
  return in;
}

GapInput build_magnitude_input(const Recording& rec, const estimation::ModelSpec& spec) {
  if (spec.model.instrument != model::Instrument::kAccelerometer)
    throw InputError("'" + rec.dir.string() +
                             "' has no rate truth: a gyroscope gap needs a rate table's truth columns "
                             "(w_x_radps …); sessions with unknown orientations give only |g|");
  const double g = rec.header.gravity_or_standard_mps2();
  processing::StaticDetectorOptions det;  // the still start (an "initialization" segment) sets the threshold
  // Long enough for the extraction to keep something after settle_s at both ends.
  det.min_duration_s = 2.0 * spec.processing.extraction.settle_s + 1.0;
  const processing::Detection detection = processing::detect_static(rec, det);
  const auto& ivs = detection.intervals;
  if (ivs.size() < 2)
    throw InputError("'" + rec.dir.string() + "': " + std::to_string(ivs.size()) +
                             " static interval(s) long enough for the extraction (settle_s at both ends) "
                             "found (" + detection.summary.rejections() +
                             "); the magnitude form of the gap needs several orientations");
  Recording aug = rec;
  aug.segments.clear();
  aug.truth_t.clear();
  aug.truth.clear();
  aug.truth_store.reset();  // the provisional rows below replace the recording's truth
  aug.header.truth_columns = truth_column_names({kSpecificForceColumns, kRateColumns});
  int id = 0;
  for (const auto& iv : ivs) {
    Segment s;
    s.id = id;
    s.kind = SegmentKind::kOrientation;
    s.orientation = id;
    s.orientation_count = static_cast<int>(ivs.size());
    s.t_start_s = iv.t_start_s;
    s.t_end_s = iv.t_end_s;
    std::ostringstream label;
    label << "static " << id + 1 << " (" << iv.t_start_s << "-" << iv.t_end_s << " s)";
    s.label = label.str();
    aug.segments.push_back(s);
    // Provisional truth: the raw direction at |g| (magnitude_form replaces it).
    const Eigen::Vector3d f = g * iv.accel_mean_mps2.normalized();
    const std::vector<double> row = {f[0], f[1], f[2], 0.0, 0.0, 0.0};
    for (double t : {iv.t_start_s, 0.5 * (iv.t_start_s + iv.t_end_s), iv.t_end_s})
      if (aug.truth_t.empty() || t > aug.truth_t.back()) {
        aug.truth_t.push_back(t);
        aug.truth.push_back(row);
      }
    ++id;
  }
  GapInput in = build_input(aug, spec);
  in.source = rec.dir.string();
  std::ostringstream note;
  note << ivs.size() << " static intervals found by the sliding-variance detector (window " << det.window_s
       << " s, at least " << det.min_duration_s << " s)";
  in.notes.push_back(note.str());
  return magnitude_form(std::move(in), g);
}

}  // namespace stend::diagnosis
