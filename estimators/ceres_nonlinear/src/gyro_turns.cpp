// Gyroscope calibration from turns by known angles (Ferraris): bias (and G) from the still means,
// scale and cross-axis from the readings integrated over the known turns, one whitened fit of both.
// See stend/ceres_nonlinear/calibration.hpp, (c).
#include "gyro.hpp"

#include <stend/physics/units.hpp>
#include <stend/recording/truth_columns.hpp>

#include <fmt/format.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace stend::ceres_nonlinear {

using namespace detail;

namespace {

// A turn's effective duration T = N·Δt [s]: each of its N samples stands for one sample period, so
// that Σ ω_i Δt = ȳ·T exactly (ȳ the mean reading).
double turn_duration_s(const processing::StaticPoint& w) {
  return static_cast<double>(w.samples_used) * sample_period_s(w);
}

// Still k as an observation: ȳ_k against measure(θ, ω_k, f̄_k) (ω_k the applied rate, f̄_k the
// measured specific force), whitened by the noise of a mean of N samples.
GyroObservation still_observation(const processing::StaticPoint& s, const Eigen::Vector3d& noise_radps) {
  GyroObservation obs;
  obs.stimulus.input = s.stimulus.input.allFinite() ? s.stimulus.input : Eigen::Vector3d::Zero();
  obs.stimulus.specific_force = s.accel.mean;
  obs.reading = s.gyro.mean;
  obs.whitening = mean_whitening(noise_radps, s.samples_used);
  return obs;
}

// A-priori covariance of the integrated turn v = Σ ω_i Δt [rad²]: the gyro noise summed over N
// samples, (σ_n·Δt)²·N per axis, plus the turn's own uncertainty σ_a along its axis and |θ|·σ_a
// across it (the axis direction known to σ_a).
Eigen::Matrix3d turn_covariance(const KnownTurn& t, const Eigen::Vector3d& noise_radps, double sigma_angle_rad) {
  const double dt = sample_period_s(t.window);
  const double n = static_cast<double>(t.window.samples_used);
  Eigen::Matrix3d c = (noise_radps * dt).cwiseAbs2().asDiagonal();
  c *= n;
  const double angle = t.rotation_rad.norm();
  const Eigen::Vector3d axis = angle > 0.0 ? Eigen::Vector3d(t.rotation_rad / angle) : Eigen::Vector3d::UnitX();
  const Eigen::Matrix3d along = axis * axis.transpose();
  const double across_rad = angle * sigma_angle_rad;
  c += sigma_angle_rad * sigma_angle_rad * along + across_rad * across_rad * (Eigen::Matrix3d::Identity() - along);
  return c;
}

// Turn k as an observation in mean form: v_k/T = ȳ against measure(θ, θ_k/T, f̄) — the same as
// v_k against A(θ)·θ_k + b·T + G·F_k — whitened by its covariance over T².
GyroObservation turn_observation(const KnownTurn& t, const Eigen::Vector3d& noise_radps, double sigma_angle_rad) {
  const double T = turn_duration_s(t.window);
  GyroObservation obs;
  obs.stimulus.input = t.rotation_rad / T;
  obs.stimulus.specific_force = t.window.accel.mean;
  obs.reading = t.window.gyro.mean;
  const Eigen::Matrix3d cov = turn_covariance(t, noise_radps, sigma_angle_rad) / (T * T);
  const Eigen::Matrix3d L = cov.llt().matrixL();
  obs.whitening = L.inverse();
  return obs;
}

// Each turn's integrated reading raw and calibrated against its stated rotation, and their RMS.
void turn_checks(const std::vector<KnownTurn>& turns, CalibrationResult& r) {
  Eigen::Vector3d before_sq = Eigen::Vector3d::Zero(), after_sq = Eigen::Vector3d::Zero();
  for (const KnownTurn& t : turns) {
    const double T = turn_duration_s(t.window);
    TurnCheck c;
    c.label = t.window.segment.label;
    c.t_start_s = t.window.t_start_s;
    c.t_end_s = t.window.t_end_s;
    c.stated_rad = t.rotation_rad;
    c.before_rad = t.window.gyro.mean * T;
    before_sq += (c.before_rad - c.stated_rad).cwiseAbs2();
    if (r.ok()) {
      model::Stimulus<double> s;
      s.specific_force = t.window.accel.mean;
      c.after_rad = r.model.correct(r.theta.data(), t.window.gyro.mean, s) * T;
      after_sq += (c.after_rad - c.stated_rad).cwiseAbs2();
    }
    r.turns.push_back(c);
  }
  const double n = static_cast<double>(std::max<std::size_t>(1, turns.size()));
  r.turn_error_axis_rad.before = (before_sq / n).cwiseSqrt();
  r.turn_error_rad.before = std::sqrt(before_sq.sum() / n);
  if (r.ok()) {
    r.turn_error_axis_rad.after = (after_sq / n).cwiseSqrt();
    r.turn_error_rad.after = std::sqrt(after_sq.sum() / n);
  } else {
    r.turn_error_rad.after = kNaN;
  }
}

// The a-priori sigmas in words (CalibrationResult::uncertainty).
std::string turn_sigmas_text(const Eigen::Vector3d& noise_radps, double sigma_angle_deg) {
  const Eigen::Vector3d dps = noise_radps / physics::kDegPerSecond;
  return fmt::format("a-priori sigmas: gyro noise {:.3g} {:.3g} {:.3g} deg/s per sample (pooled over the stills); "
                     "still mean noise/√N; turn integral noise·Δt·√N, plus {} deg along the turn's axis and "
                     "|θ|·{} deg across it",
                     dps[0], dps[1], dps[2], sigma_angle_deg, sigma_angle_deg);
}

double mean_still_gravity(const std::vector<processing::StaticPoint>& stills) {
  double g = 0.0;
  for (const auto& s : stills) g += s.accel.mean.norm();
  return stills.empty() ? 0.0 : g / static_cast<double>(stills.size());
}

// The result before the solve: every gyro parameter free, the counts.
CalibrationResult turns_setup(const std::vector<processing::StaticPoint>& stills, const std::vector<KnownTurn>& turns,
                              const GyroOptions& go) {
  CalibrationResult r;
  r.method = Method::kTurns;
  r.model = gyroscope_model(go.estimate_g_sensitivity);
  r.intervals = stills;
  r.whitened = true;
  r.gravity_mps2 = mean_still_gravity(stills);
  init_gyro_parameters(r);
  r.observations = 3 * static_cast<int>(stills.size() + turns.size());
  r.estimated = r.model.size();
  r.dof = r.observations - r.estimated;
  return r;
}

// Why the fit cannot run on these stills and turns ("" when it can).
std::string turns_refusal(const std::vector<processing::StaticPoint>& stills, const std::vector<KnownTurn>& turns,
                          const Eigen::Vector3d& noise) {
  if (stills.empty()) return "no still segments (kinds orientation or detected): the bias needs them";
  if (turns.empty())
    return "no known turns: the recording needs kRotation segments with the truth columns turn_x_deg, turn_y_deg, "
           "turn_z_deg";
  if (!finite_intervals(stills)) return "non-finite (NaN) readings in a still";
  for (const KnownTurn& t : turns)
    if (!t.window.gyro.mean.allFinite() || !t.window.accel.mean.allFinite() || !t.rotation_rad.allFinite() ||
        !(turn_duration_s(t.window) > 0.0))
      return "non-finite readings or truth, or no duration, in turn '" + t.window.segment.label + "'";
  if (!(noise.minCoeff() > 0.0))
    return "the stills show no gyro noise and the quantization step is unknown: the a-priori sigmas need one";
  return {};
}

}  // namespace

CalibrationResult calibrate_gyro_turns(const std::vector<processing::StaticPoint>& stills,
                                       const std::vector<KnownTurn>& turns, const GyroOptions& go,
                                       double quantization_radps) {
  CalibrationResult r = turns_setup(stills, turns, go);
  const Eigen::Vector3d noise = pooled_gyro_noise(stills, quantization_radps);
  if (const std::string why = turns_refusal(stills, turns, noise); !why.empty()) {
    fail_all(r, why);
    turn_checks(turns, r);
    return r;
  }
  const double sigma_angle_rad = go.turn_angle_sigma_deg * physics::kDegToRad;
  std::vector<GyroObservation> obs;
  for (const auto& s : stills) obs.push_back(still_observation(s, noise));
  for (const KnownTurn& t : turns) obs.push_back(turn_observation(t, noise, sigma_angle_rad));
  r.uncertainty = turn_sigmas_text(noise, go.turn_angle_sigma_deg);
  std::vector<int> free_index(static_cast<std::size_t>(r.estimated));
  std::iota(free_index.begin(), free_index.end(), 0);
  solve_gyro_observations(obs, free_index, go, r);
  turn_checks(turns, r);
  return r;
}

namespace {

// The still segments with their applied rate (the truth's w columns where the recording has them;
// NaN left for still_observation to take as 0).
processing::Extraction turn_stills(const Recording& rec, const GyroOptions& go) {
  processing::Request request;
  if (truth_columns(rec, kRateColumns))
    for (std::size_t a = 0; a < 3; ++a) request.stimulus.input[a] = kRateColumns[a];
  processing::Extraction ex = processing::extract(rec, still_segment_options(go), request);
  std::stable_sort(ex.points.begin(), ex.points.end(),
                   [](const processing::StaticPoint& a, const processing::StaticPoint& b) { return a.t_start_s < b.t_start_s; });
  return ex;
}

// The still segments the processing stage skipped, one note per reason: how many, and the first
// one's note (an aligned log holds many short unnamed stills that the trim leaves empty).
std::vector<std::string> skipped_still_notes(const processing::Extraction& stills) {
  std::vector<std::string> notes;
  for (processing::SkipReason reason : processing::kAllSkipReasons) {
    const std::size_t n = stills.count(reason);
    if (n == 0) continue;
    const auto first = std::find_if(stills.skipped.begin(), stills.skipped.end(),
                                    [&](const processing::Skip& s) { return s.reason == reason; });
    notes.push_back(fmt::format("{} still segment(s) left out ({}), e.g. {}", n, processing::skip_reason_name(reason),
                                first->note));
  }
  return notes;
}

// The recording's known turns: kRotation segments with a finite turn truth and no lost sample;
// `notes` gets the ones left out.
std::vector<KnownTurn> known_turns(const Recording& rec, const std::array<int, 3>& columns,
                                   std::vector<std::string>& notes) {
  processing::Request request;
  const processing::Extraction ex = processing::extract(rec, turn_segment_options(), request);
  for (const auto& s : ex.skipped) notes.push_back("turn " + s.note);
  std::vector<KnownTurn> turns;
  for (const processing::StaticPoint& w : ex.points) {
    const std::string name = processing::label(w.segment);
    if (w.gaps > 0) {
      notes.push_back(fmt::format("turn '{}' left out: {} lost sample(s) inside it spoil the integral", name, w.gaps));
      continue;
    }
    const Eigen::Vector3d turn_deg = finite_truth_mean(rec, columns, w.t_start_s, w.t_end_s);
    if (!turn_deg.allFinite()) {
      notes.push_back(fmt::format("turn '{}' left out: no finite turn_*_deg truth over it", name));
      continue;
    }
    turns.push_back({w, turn_deg * physics::kDegToRad});
    turns.back().window.segment.label = name;
  }
  return turns;
}

}  // namespace

CalibrationResult calibrate_gyro_turns(const Recording& rec, const GyroOptions& go) {
  const std::optional<std::array<int, 3>> columns = truth_columns(rec, kTurnColumns);
  std::vector<std::string> notes;
  std::vector<KnownTurn> turns;
  if (columns) turns = known_turns(rec, *columns, notes);
  const processing::Extraction stills = turn_stills(rec, go);
  for (const std::string& n : skipped_still_notes(stills)) notes.push_back(n);
  CalibrationResult r = calibrate_gyro_turns(stills.points, turns, go, rec.header.info.gyro_lsb_radps);
  r.notes.insert(r.notes.begin(), notes.begin(), notes.end());
  if (!columns)
    fail_all(r, "the turns gyro calibration needs the truth columns turn_x_deg, turn_y_deg, turn_z_deg (the "
                "rotation vector of each known turn); this recording has none");
  return r;
}

}  // namespace stend::ceres_nonlinear
