// The linear fit of a ModelSpec on static points. See stend/estimation/static_fit.hpp.
#include "stend/estimation/static_fit.hpp"
#include "stend/estimation/report_section.hpp"

#include "stend/estimation/summary.hpp"

#include <cmath>
#include <stend/errors.hpp>

#include "stend/physics/units.hpp"
#include "stend/recording/truth_columns.hpp"

namespace stend::estimation {

namespace {

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
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

// The parameters that can affect the fitted axes (the others are listed as excluded).
void select_parameters(const ModelSpec& spec, StaticFit& fit) {
  const std::vector<model::ParamInfo> all = spec.model.params();
  const Eigen::MatrixXd generic = spec.model.regressor(generic_stimulus());
  for (int j = 0; j < spec.model.size(); ++j) {
    bool affects = false;
    for (int a : spec.axes) affects = affects || generic(a, j) != 0.0;
    if (affects) {
      fit.params.push_back(all[static_cast<std::size_t>(j)]);
      fit.param_index.push_back(j);
    } else {
      fit.excluded.push_back(all[static_cast<std::size_t>(j)].name);
    }
  }
}

// The linear problem: one row per point and fitted axis, observation = measured − true input,
// weight 1/SE² with segment-noise weighting. Fills the residual rows' observed values; returns
// false (message set) when a weight cannot be formed.
bool build_problem(const std::vector<processing::StaticPoint>& points, const ModelSpec& spec, StaticFit& fit,
                   LsqProblem& prob) {
  const int p = static_cast<int>(fit.params.size());
  const int k = static_cast<int>(points.size() * spec.axes.size());
  const bool weighted = spec.weighting == Weighting::kSegmentNoise;
  prob.design.resize(k, p);
  prob.observations.resize(k);
  if (weighted) prob.weights.resize(k);
  for (const auto& pi : fit.params) {
    prob.names.push_back(pi.name);
    prob.units.push_back(pi.unit);
  }
  int row = 0;
  for (std::size_t n = 0; n < points.size(); ++n) {
    const processing::StaticPoint& pt = points[n];
    const processing::AxesValue& reading = pt.axes(spec.model.instrument);
    const Eigen::MatrixXd phi = spec.model.regressor(pt.stimulus);
    for (int a : spec.axes) {
      for (int j = 0; j < p; ++j) prob.design(row, j) = phi(a, fit.param_index[static_cast<std::size_t>(j)]);
      prob.observations[row] = reading.mean[a] - pt.stimulus.input[a];
      if (weighted) {
        const double se = reading.std_error[a];
        if (!(se > 0.0) || !std::isfinite(se)) {
          fit.message = "weighting: segment_noise needs a positive standard error for every point; "
                        "point '" + processing::label(pt.segment) + "' axis " + axis_name(a) + " has " + number_text(se) +
                        ". Use weighting: none.";
          return false;
        }
        prob.weights[row] = 1.0 / (se * se);
      }
      fit.residuals.push_back({static_cast<int>(n), a, prob.observations[row], 0.0, 0.0});
      ++row;
    }
  }
  return true;
}

// Residual and fitted value of every row, and the residual RMS per fitted axis (in the residual
// unit and × display_factor in the display unit).
void fill_residuals(const ModelSpec& spec, double display_factor, StaticFit& fit) {
  Eigen::Vector3d ss = Eigen::Vector3d::Zero();
  Eigen::Vector3i cnt = Eigen::Vector3i::Zero();
  for (std::size_t r = 0; r < fit.residuals.size(); ++r) {
    Residual& res = fit.residuals[r];
    res.residual = fit.lsq.residuals[static_cast<Eigen::Index>(r)];
    res.fitted = res.observed - res.residual;
    ss[res.axis] += res.residual * res.residual;
    ++cnt[res.axis];
  }
  for (int a : spec.axes) {
    fit.residual_rms[a] = std::sqrt(ss[a] / cnt[a]);
    fit.residual_rms_display[a] = fit.residual_rms[a] * display_factor;
  }
}

}  // namespace

processing::Request static_request(const Recording& rec, const ModelSpec& spec) {
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  processing::Request request;
  request.accel = accel;
  request.gyro = !accel;
  std::vector<std::string> missing;
  for (int a = 0; a < 3; ++a) {
    const char* input = accel ? kSpecificForceColumns[a] : kRateColumns[a];
    request.stimulus.input[static_cast<std::size_t>(a)] = input;
    if (rec.truth_column(input) < 0) missing.push_back(input);
    if (accel || rec.truth_column(kSpecificForceColumns[a]) >= 0)
      request.stimulus.specific_force[static_cast<std::size_t>(a)] = kSpecificForceColumns[a];
  }
  if (!accel && spec.model.find(model::TermKind::kGSensitivity) >= 0)
    for (int a = 0; a < 3; ++a)
      if (request.stimulus.specific_force[static_cast<std::size_t>(a)].empty()) missing.push_back(kSpecificForceColumns[a]);
  if (!missing.empty()) {
    const std::string have = join(rec.header.truth_columns);
    throw InputError("recording '" + rec.dir.string() + "' lacks the truth column(s) " + join(missing) +
                     " that a " + instrument_name(spec.model.instrument) +
                     " fit needs; truth columns present: " + (have.empty() ? "none" : have));
  }
  return request;
}

processing::Extraction extract_static_points(const Recording& rec, const ModelSpec& spec) {
  return processing::extract(rec, spec.processing, static_request(rec, spec));
}

StaticFit fit_static_points(const std::vector<processing::StaticPoint>& points, const ModelSpec& spec) {
  StaticFit fit;
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  fit.unit = accel ? "m/s^2" : "rad/s";
  const DisplayUnit display = display_unit(fit.unit);
  fit.display_unit = display.unit;
  const double display_factor = display.scale;

  if (spec.axes.empty() || spec.model.terms.empty()) {
    fit.message = "the model specification has no axes or no terms";
    return fit;
  }
  select_parameters(spec, fit);
  LsqProblem prob;
  if (!build_problem(points, spec, fit, prob)) return fit;
  LsqOptions opt;
  opt.confidence = spec.confidence;
  opt.tolerances = spec.tolerances;
  fit.lsq = solve_lsq(prob, opt);
  if (!fit.lsq.ok()) {
    fit.message = fit.lsq.message;
    fit.residuals.clear();
    return fit;
  }
  fit.status = FitStatus::kOk;
  fill_residuals(spec, display_factor, fit);
  return fit;
}

}  // namespace stend::estimation
