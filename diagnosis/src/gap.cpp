// stend gap: the fit of the model as given, the twin's replay of every segment, then where, the
// folds, which and how far (steps.hpp). See stend/diagnosis/gap.hpp.
#include "stend/diagnosis/gap.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "magnitude.hpp"
#include "steps.hpp"
#include "stend/estimation/report_section.hpp"
#include "stend/estimation/static_fit.hpp"
#include "stend/physics/units.hpp"

namespace stend::diagnosis {

namespace {

// Report fields known before any fit: units, display scale, source, segments, floor source, notes.
GapReport report_header(const GapInput& in) {
  GapReport rep;
  const bool accel = in.spec.model.instrument == model::Instrument::kAccelerometer;
  rep.unit = accel ? "m/s^2" : "rad/s";
  const estimation::DisplayUnit display = estimation::display_unit(rep.unit);  // the one table of display units
  rep.display_unit = display.unit;
  rep.display_per_unit = display.scale;
  rep.magnitude = in.magnitude;
  rep.model_name = in.spec.source.empty() ? "<model>" : in.spec.source;
  rep.source = in.source;
  rep.segments = in.segments;
  rep.floor_source = in.floor_source;
  rep.notes = in.notes;
  if (!in.truth_source.empty()) rep.notes.insert(rep.notes.begin(), "truth: " + in.truth_source);
  return rep;
}

// The model as given, fitted by the shared static fit (in the magnitude form: on the |f| rows).
estimation::StaticFit fit_model(const GapInput& in) {
  if (in.magnitude) return fit_magnitude_rows(in);
  std::vector<processing::StaticPoint> points;
  for (const auto& s : in.segments) points.push_back(s.point);
  return estimation::fit_static_points(points, in.spec);
}

// θ̂ in the model's full parameter order (parameters the fit did not estimate are 0).
VectorXd full_theta(const model::ErrorModel& M, const estimation::StaticFit& fit) {
  VectorXd theta = VectorXd::Zero(M.size());
  for (std::size_t j = 0; j < fit.param_index.size(); ++j)
    theta[fit.param_index[j]] = fit.lsq.min_norm_solution[static_cast<Eigen::Index>(j)];
  return theta;
}

// Axes that give rows: the fitted ones; in the magnitude form slot 0 (the |f| row).
std::vector<bool> fitted_axes(const GapInput& in) {
  if (in.magnitude) return {true, false, false};
  std::vector<bool> fitted(3, false);
  for (int a : in.spec.axes) fitted[static_cast<std::size_t>(a)] = true;
  return fitted;
}

// Noise floor per row slot: RMS over segments of the segment-mean standard error [unit]; NaN
// where no segment has one.
Eigen::Vector3d noise_floor(const GapInput& in, const std::vector<bool>& fitted) {
  std::vector<double> floor2(3, 0.0);
  std::vector<int> floor_n(3, 0);
  auto add = [&](int a, double se) {
    if (!std::isfinite(se)) return;
    floor2[static_cast<std::size_t>(a)] += se * se;
    ++floor_n[static_cast<std::size_t>(a)];
  };
  for (const auto& s : in.segments)
    if (in.magnitude) {
      add(0, magnitude_std_error(s));
    } else {
      for (int a = 0; a < 3; ++a)
        if (fitted[static_cast<std::size_t>(a)]) add(a, s.mean_std_error[a]);
    }
  Eigen::Vector3d floor = Eigen::Vector3d::Constant(kNaN);
  for (std::size_t a = 0; a < 3; ++a)
    if (floor_n[a]) floor[static_cast<Eigen::Index>(a)] = std::sqrt(floor2[a] / floor_n[a]);
  return floor;
}

// Row weight 1/floor² [1/unit²]; 1 where the floor is unknown or zero.
double floor_weight(double floor) {
  const double known = std::isfinite(floor) && floor > 0 ? floor : 1.0;
  return 1.0 / (known * known);
}

// The rows of the problem (Δ = measured − true input, weight 1/floor²) and, per segment, the
// twin's residual measured − measure(θ̂, truth) on the row slots (NaN elsewhere) into rep.residual.
Rows build_rows(const GapInput& in, const VectorXd& theta, const std::vector<bool>& fitted, GapReport& rep) {
  Rows rows;
  std::vector<double> yv, wv;
  auto add_row = [&](std::size_t s, int slot, double y) {
    rows.seg.push_back(static_cast<int>(s));
    rows.axis.push_back(slot);
    yv.push_back(y);
    wv.push_back(floor_weight(rep.floor[slot]));
  };
  for (std::size_t s = 0; s < in.segments.size(); ++s) {
    const model::Stimulus<double>& truth = in.segments[s].point.stimulus;
    const Eigen::Vector3d& mean = measured(in, in.segments[s]);
    const Eigen::Vector3d twin = in.spec.model.measure<double>(theta.data(), truth);
    Eigen::Vector3d res = Eigen::Vector3d::Constant(kNaN);
    if (in.magnitude) {
      const Eigen::Vector3d u = truth.specific_force.normalized();
      res[0] = u.dot(mean - twin);
      rows.dir.push_back(u);
      add_row(s, 0, u.dot(mean - truth.input));
    } else {
      for (int a = 0; a < 3; ++a) {
        if (!fitted[static_cast<std::size_t>(a)]) continue;
        res[a] = mean[a] - twin[a];
        add_row(s, a, mean[a] - truth.input[a]);
      }
    }
    rep.residual.push_back(res);
  }
  rows.y = Eigen::Map<VectorXd>(yv.data(), static_cast<Eigen::Index>(yv.size()));
  rows.w = Eigen::Map<VectorXd>(wv.data(), static_cast<Eigen::Index>(wv.size()));
  return rows;
}

// Noise ratio of one slot: RMS segment sample std over the twin's white-noise std (or, when the
// source gives none, over the median segment std). The magnitude form pools the three axes.
double noise_ratio(const GapInput& in, int a) {
  std::vector<double> stds;
  for (const auto& seg : in.segments)
    for (int b = in.magnitude ? 0 : a; b <= (in.magnitude ? 2 : a); ++b)
      if (std::isfinite(seg.raw_std[b])) stds.push_back(seg.raw_std[b]);
  if (stds.empty()) return kNaN;
  double ref = in.twin_sample_std[a];
  if (!std::isfinite(ref)) {
    std::nth_element(stds.begin(), stds.begin() + static_cast<std::ptrdiff_t>(stds.size() / 2), stds.end());
    ref = stds[stds.size() / 2];
  }
  double q = 0;
  for (double v : stds) q += v * v;
  return std::sqrt(q / static_cast<double>(stds.size())) / ref;
}

// In-sample gap RMS [unit] and noise ratio per fitted slot, and the note saying what the ratio is
// against.
void gap_and_noise(const GapInput& in, const std::vector<bool>& fitted, GapReport& rep) {
  for (int a = 0; a < 3; ++a) {
    if (!fitted[static_cast<std::size_t>(a)]) continue;
    double s2 = 0;
    for (const auto& res : rep.residual) s2 += res[a] * res[a];
    rep.gap_rms[a] = std::sqrt(s2 / static_cast<double>(rep.residual.size()));
    rep.noise_ratio[a] = noise_ratio(in, a);
  }
  if (!std::isfinite(in.twin_sample_std[0]))
    rep.notes.push_back("noise ratio: segment std against the recording's median segment std (no twin noise "
                        "settings known for this source)");
  else
    rep.notes.push_back("noise ratio: segment std against the twin's white noise (sim_imu noise density and "
                        "low-pass of the run's experiment)");
}

}  // namespace

bool GapOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (!(alpha > 0.0 && alpha < 1.0)) return fail("alpha: must be in (0, 1)");
  if (max_steps < 0) return fail("max_steps: must be >= 0 (0: no forward selection)");
  if (!(explain_fraction >= 0.0 && explain_fraction <= 1.0)) return fail("explain_fraction: must be in [0, 1]");
  if (max_folds < 0) return fail("max_folds: must be >= 0 (0: one fold per group)");
  return true;
}

GapReport diagnose(const GapInput& in, const GapOptions& opt) {
  if (std::string why; !opt.IsValid(&why)) throw std::invalid_argument("gap options: " + why);
  GapReport rep = report_header(in);
  // 1. Fit the model as given and replay every segment through the twin.
  rep.fit = fit_model(in);
  if (!rep.fit.ok()) {
    rep.message = "the model could not be fitted: " + rep.fit.message;
    // As many parameters as rows: nothing is left to test, held out or in-sample.
    if (rep.fit.lsq.rank > 0 && rep.fit.lsq.dof <= 0)
      rep.message += ". No fold scheme can test this design either: every held-out row needs parameters that only "
                     "its own segment determines. " + untestable_design_advice();
    return rep;
  }
  const std::vector<bool> fitted = fitted_axes(in);
  rep.floor = noise_floor(in, fitted);
  Rows rows = build_rows(in, full_theta(in.spec.model, rep.fit), fitted, rep);
  gap_and_noise(in, fitted, rep);
  // 2. Where.
  locate_gap(in, rows, rep);
  // 3.–5. The folds that fit the design, which, and how far.
  explain_gap(in, rows, opt, rep);
  return rep;
}

}  // namespace stend::diagnosis
