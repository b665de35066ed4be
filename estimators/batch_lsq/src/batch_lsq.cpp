// The paper's batch least-squares procedure on a recording. See stend/batch_lsq/batch_lsq.hpp.
#include "stend/batch_lsq/batch_lsq.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "stend/physics/units.hpp"

namespace stend::batch_lsq {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// The truth columns a fit reads: the true input (specific force or rate), then, for a gyroscope,
// the specific-force columns the recording has (g-sensitivity).
struct TruthColumns {
  std::vector<std::string> names;  // processing::Request::truth_columns
  int force[3] = {-1, -1, -1};     // index of f_<axis>_mps2 in `names`, −1 when absent
};

// Throws when an input column is missing, or a g-sensitivity model lacks the specific force.
TruthColumns truth_columns(const Recording& rec, const ModelSpec& spec) {
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  const char* in_cols[2][3] = {{"f_x_mps2", "f_y_mps2", "f_z_mps2"},
                               {"w_x_radps", "w_y_radps", "w_z_radps"}};
  TruthColumns out;
  std::vector<std::string> missing;
  for (const char* c : in_cols[accel ? 0 : 1]) {
    out.names.push_back(c);
    if (rec.truth_column(c) < 0) missing.push_back(c);
  }
  for (int a = 0; a < 3; ++a) {
    if (accel) {
      out.force[a] = a;
    } else if (rec.truth_column(in_cols[0][a]) >= 0) {
      out.force[a] = static_cast<int>(out.names.size());
      out.names.push_back(in_cols[0][a]);
    }
  }
  const bool needs_force = !accel && spec.model.find(model::TermKind::kGSensitivity) >= 0;
  if (needs_force)
    for (int i = 0; i < 3; ++i)
      if (out.force[i] < 0) missing.push_back(in_cols[0][i]);
  if (!missing.empty()) {
    std::string have, miss;
    for (const auto& c : rec.header.truth_columns) have += (have.empty() ? "" : ", ") + c;
    for (const auto& c : missing) miss += (miss.empty() ? "" : ", ") + c;
    throw std::runtime_error("recording '" + rec.dir.string() + "' lacks the truth column(s) " +
                             miss + " that a " + estimation::instrument_name(spec.model.instrument) +
                             " fit needs; truth columns present: " +
                             (have.empty() ? "none" : have));
  }
  return out;
}

// A processing point as this estimator's point: the fitted instrument's mean, the truth stimulus.
StaticPoint point_of(const processing::StaticPoint& q, bool accel, const TruthColumns& cols) {
  const Segment& seg = q.segment;
  StaticPoint p;
  p.segment_id = seg.id;
  p.label = seg.label.empty() ? processing::describe(seg) : seg.label;
  if (seg.orientation >= 0 && seg.label.empty()) p.label = std::string(to_string(seg.kind)) + " " + std::to_string(seg.orientation + 1);
  p.t_start_s = q.t_start_s;
  p.t_end_s = q.t_end_s;
  p.samples_used = q.samples_used;
  const processing::AxesValue& v = accel ? q.accel : q.gyro;
  p.measured = v.mean;
  p.measured_std_error = v.std_error;
  for (int a = 0; a < 3; ++a) {
    p.stimulus.input[a] = q.truth[static_cast<std::size_t>(a)];
    p.stimulus.specific_force[a] = cols.force[a] >= 0 ? q.truth[static_cast<std::size_t>(cols.force[a])] : 0.0;
  }
  p.stimulus.temperature_c = q.temperature_c;
  p.stimulus.temperature_rate_cps = q.temperature_rate_cps;
  p.stimulus.time_s = 0.5 * (p.t_start_s + p.t_end_s);
  return p;
}

// A stimulus at which every term's regressor entry is generically nonzero: used to decide which
// parameters can affect which output axes, from the vocabulary itself.
model::Stimulus<double> generic_stimulus() {
  model::Stimulus<double> s;
  s.input = {0.371, -0.713, 1.129};
  s.specific_force = {0.523, 0.917, -1.311};
  s.temperature_c = 31.77;
  s.temperature_rate_cps = 0.0137;
  s.time_s = 17.3;
  return s;
}

}  // namespace

Eigen::VectorXd FitResult::theta_full() const {
  Eigen::VectorXd t = Eigen::VectorXd::Constant(spec.model.size(), kNaN);
  if (!ok) return t;
  for (std::size_t j = 0; j < param_index.size(); ++j)
    t[param_index[j]] = lsq.estimate[static_cast<Eigen::Index>(j)];
  return t;
}

std::vector<StaticPoint> extract_points(const Recording& rec, const ModelSpec& spec,
                                        processing::Extraction* extraction) {
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  const TruthColumns cols = truth_columns(rec, spec);
  processing::Request request;
  request.accel = accel;
  request.gyro = !accel;
  request.truth_columns = cols.names;
  processing::Extraction ex = processing::extract(rec, spec.processing, request);
  std::vector<StaticPoint> points;
  for (const auto& q : ex.points) points.push_back(point_of(q, accel, cols));
  if (extraction) *extraction = std::move(ex);
  return points;
}

namespace {

// The parameters that can affect the fitted axes (the others are listed as excluded).
void select_parameters(const ModelSpec& spec, FitResult& fr) {
  const std::vector<model::ParamInfo> all = spec.model.params();
  const Eigen::MatrixXd generic = spec.model.regressor(generic_stimulus());
  for (int j = 0; j < spec.model.size(); ++j) {
    bool affects = false;
    for (int a : spec.axes) affects = affects || generic(a, j) != 0.0;
    if (affects) {
      fr.params.push_back(all[static_cast<std::size_t>(j)]);
      fr.param_index.push_back(j);
    } else {
      fr.excluded.push_back(all[static_cast<std::size_t>(j)].name);
    }
  }
}

// The linear problem: one row per point and fitted axis, observation = measured − true input,
// weight 1/SE² with segment-noise weighting. Fills the residual rows' observed values; returns
// false (message set) when a weight cannot be formed.
bool build_problem(const std::vector<StaticPoint>& points, const ModelSpec& spec, FitResult& fr,
                   estimation::LsqProblem& prob) {
  const int p = static_cast<int>(fr.params.size());
  const int k = static_cast<int>(points.size() * spec.axes.size());
  const bool weighted = spec.weighting == estimation::Weighting::kSegmentNoise;
  prob.design.resize(k, p);
  prob.observations.resize(k);
  if (weighted) prob.weights.resize(k);
  for (const auto& pi : fr.params) {
    prob.names.push_back(pi.name);
    prob.units.push_back(pi.unit);
  }
  int row = 0;
  for (std::size_t n = 0; n < points.size(); ++n) {
    const StaticPoint& pt = points[n];
    const Eigen::MatrixXd phi = spec.model.regressor(pt.stimulus);
    for (int a : spec.axes) {
      for (int j = 0; j < p; ++j) prob.design(row, j) = phi(a, fr.param_index[static_cast<std::size_t>(j)]);
      prob.observations[row] = pt.measured[a] - pt.stimulus.input[a];
      if (weighted) {
        const double se = pt.measured_std_error[a];
        if (!(se > 0.0) || !std::isfinite(se)) {
          fr.message = "weighting: segment_noise needs a positive standard error for every point; "
                       "point '" + pt.label + "' axis " + estimation::axis_name(a) + " has " + num(se) +
                       ". Use weighting: none.";
          return false;
        }
        prob.weights[row] = 1.0 / (se * se);
      }
      fr.residuals.push_back({static_cast<int>(n), a, prob.observations[row], 0.0, 0.0});
      ++row;
    }
  }
  return true;
}

// Residual and fitted value of every row, and the residual RMS per fitted axis (in the residual
// unit and × display_factor in the display unit).
void fill_residuals(const ModelSpec& spec, double display_factor, FitResult& fr) {
  Eigen::Vector3d ss = Eigen::Vector3d::Zero();
  Eigen::Vector3i cnt = Eigen::Vector3i::Zero();
  for (std::size_t r = 0; r < fr.residuals.size(); ++r) {
    Residual& res = fr.residuals[r];
    res.residual = fr.lsq.residuals[static_cast<Eigen::Index>(r)];
    res.fitted = res.observed - res.residual;
    ss[res.axis] += res.residual * res.residual;
    ++cnt[res.axis];
  }
  for (int a : spec.axes) {
    fr.residual_rms[a] = std::sqrt(ss[a] / cnt[a]);
    fr.residual_rms_display[a] = fr.residual_rms[a] * display_factor;
  }
}

}  // namespace

FitResult fit_points(const std::vector<StaticPoint>& points, const ModelSpec& spec) {
  FitResult fr;
  fr.spec = spec;
  fr.points = points;
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  fr.unit = accel ? "m/s^2" : "rad/s";
  fr.display_unit = accel ? "mg" : "deg/h";
  const double display_factor =
      accel ? 1.0 / physics::kMilliG : 1.0 / physics::kDegPerHour;

  if (spec.axes.empty() || spec.model.terms.empty()) {
    fr.message = "the model specification has no axes or no terms";
    return fr;
  }
  select_parameters(spec, fr);
  estimation::LsqProblem prob;
  if (!build_problem(points, spec, fr, prob)) return fr;
  estimation::LsqOptions opt;
  opt.confidence = spec.confidence;
  opt.tolerances = spec.tolerances;
  fr.lsq = estimation::solve_lsq(prob, opt);
  if (!fr.lsq.ok()) {
    fr.message = fr.lsq.message;
    fr.residuals.clear();
    return fr;
  }
  fr.ok = true;
  fill_residuals(spec, display_factor, fr);
  return fr;
}

FitResult fit_recording(const Recording& rec, const ModelSpec& spec) {
  processing::Extraction ex;
  FitResult fr;
  std::vector<StaticPoint> points;
  try {
    points = extract_points(rec, spec, &ex);
  } catch (const std::exception& e) {
    fr.spec = spec;
    fr.message = e.what();
  }
  if (fr.message.empty()) {
    ModelSpec used = spec;
    used.processing = ex.options;
    fr = fit_points(points, used);
    if (!fr.ok && points.empty())
      fr.message = "no usable static segment in the recording (" + ex.tally() + "); " + fr.message;
    fr.notes.insert(fr.notes.begin(), ex.notes.begin(), ex.notes.end());
  }
  fr.extracted = true;
  fr.recording_dir = rec.dir.string();
  fr.experiment_name = rec.header.experiment_name;
  fr.recording_status = to_string(rec.header.status);
  if (!rec.complete())
    fr.notes.push_back("the recording's status is '" + fr.recording_status +
                       "', not 'complete': it may be truncated");
  const processing::StaticExtractionSettings& x = fr.spec.processing.extraction;
  if (x.filter == processing::Filter::kButterworth && x.settle_s < 1.0 / x.cutoff_hz)
    fr.notes.push_back("settle_s = " + num(x.settle_s) +
                       " s is shorter than 1/cutoff_hz = " + num(1.0 / x.cutoff_hz) +
                       " s: the filter's edge transients may reach the averaged window");
  return fr;
}

}  // namespace stend::batch_lsq
