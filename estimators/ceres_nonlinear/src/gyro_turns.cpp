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

// The period each sample of the turn stands for [s] (KnownTurn::sample_period_s).
double turn_sample_period_s(const KnownTurn& t) {
  return t.sample_period_s > 0.0 ? t.sample_period_s : sample_period_s(t.window);
}

// A turn's effective duration T = N·Δt [s]: each of its N samples stands for one sample period, so
// that Σ ω_i Δt = ȳ·T exactly (ȳ the mean reading).
double turn_duration_s(const KnownTurn& t) {
  return static_cast<double>(t.window.samples_used) * turn_sample_period_s(t);
}

// Still k as an observation: ȳ_k against measure(θ, ω_k, f̄_k) (ω_k the applied rate, f̄_k the
// measured specific force); `c` gets the noise of its mean of N samples (the Earth rate the truth
// does not state is added jointly: stills_earth_rate_covariance).
GyroObservation still_observation(const processing::StaticPoint& s, const Eigen::Vector3d& noise_radps, Eigen::Matrix3d& c) {
  GyroObservation obs;
  obs.stimulus.input = s.stimulus.input.allFinite() ? s.stimulus.input : Eigen::Vector3d::Zero();
  obs.stimulus.specific_force = s.accel.mean;
  obs.reading = s.gyro.mean;
  const Eigen::Vector3d var = noise_radps.cwiseAbs2() / static_cast<double>(std::max<std::size_t>(1, s.samples_used));
  c = var.asDiagonal();
  return obs;
}

// A-priori covariance of the integrated turn v = Σ ω_i Δt [rad²]: the gyro noise summed over N
// samples, (σ_n·Δt)²·N per axis, plus the turn's own uncertainty σ_a along its axis and |θ|·σ_a
// across it (the axis direction known to σ_a).
Eigen::Matrix3d turn_covariance(const KnownTurn& t, const Eigen::Vector3d& noise_radps, double sigma_angle_rad) {
  const double dt = turn_sample_period_s(t);
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
// v_k against A(θ)·θ_k + b·T + G·F_k — with its covariance over T² in `c`.
GyroObservation turn_observation(const KnownTurn& t, const Eigen::Vector3d& noise_radps, double sigma_angle_rad,
                                 Eigen::Matrix3d& c) {
  const double T = turn_duration_s(t);
  GyroObservation obs;
  obs.stimulus.input = t.rotation_rad / T;
  obs.stimulus.specific_force = t.window.accel.mean;
  obs.reading = t.window.gyro.mean;
  c = turn_covariance(t, noise_radps, sigma_angle_rad) / (T * T);
  return obs;
}

// Each turn's integrated reading raw and calibrated against its stated rotation, and their RMS.
void turn_checks(const std::vector<KnownTurn>& turns, CalibrationResult& r) {
  Eigen::Vector3d before_sq = Eigen::Vector3d::Zero(), after_sq = Eigen::Vector3d::Zero();
  for (const KnownTurn& t : turns) {
    const double T = turn_duration_s(t);
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
                     "still mean noise/√N, plus the Earth rate the truth does not state (its horizontal part: the "
                     "heading is unknown; one value for the stills at one orientation); turn integral noise·Δt·√N, "
                     "plus {} deg along the turn's axis and |θ|·{} deg across it",
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
        !(turn_duration_s(t) > 0.0))
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
  const auto n = static_cast<Eigen::Index>(stills.size() + turns.size());
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  c.topLeftCorner(3 * static_cast<Eigen::Index>(stills.size()), 3 * static_cast<Eigen::Index>(stills.size())) =
      stills_earth_rate_covariance(stills);
  Eigen::Matrix3d ck;
  for (const auto& s : stills) {
    obs.push_back(still_observation(s, noise, ck));
    c.block(3 * static_cast<Eigen::Index>(obs.size() - 1), 3 * static_cast<Eigen::Index>(obs.size() - 1), 3, 3) += ck;
  }
  for (const KnownTurn& t : turns) {
    obs.push_back(turn_observation(t, noise, sigma_angle_rad, ck));
    c.block(3 * static_cast<Eigen::Index>(obs.size() - 1), 3 * static_cast<Eigen::Index>(obs.size() - 1), 3, 3) += ck;
  }
  r.uncertainty = turn_sigmas_text(noise, go.turn_angle_sigma_deg);
  std::vector<int> free_index(static_cast<std::size_t>(r.estimated));
  std::iota(free_index.begin(), free_index.end(), 0);
  std::vector<double> x(free_index.size(), 0.0);
  ceres::Problem problem;
  const CalibrationOptions o = as_calibration_options(go, go.loss_scale_radps);
  if (const std::string note = joint_loss_note(o); !note.empty()) r.notes.push_back(note);
  const int residuals = add_joint_gyro_observations(obs, c, r.model, free_index, o, problem, x);
  solve(problem, x, free_index, residuals, o, r, Weighting::kAPrioriAtLeast);
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
    const double rate_hz = rec.header.info.output_rate_hz;
    turns.push_back({w, turn_deg * physics::kDegToRad, rate_hz > 0.0 ? 1.0 / rate_hz : 0.0});
    turns.back().window.segment.label = name;
  }
  return turns;
}

}  // namespace

CalibrationResult calibrate_gyro_turns(const Recording& rec, const GyroOptions& go, const CalibrationResult* accel) {
  const std::optional<std::array<int, 3>> columns = truth_columns(rec, kTurnColumns);
  std::vector<std::string> notes;
  std::vector<KnownTurn> turns;
  if (columns) turns = known_turns(rec, *columns, notes);
  processing::Extraction stills = turn_stills(rec, go);
  for (const std::string& n : skipped_still_notes(stills)) notes.push_back(n);
  if (accel != nullptr && accel->ok()) {  // the g-sensitivity sees the calibrated specific force
    for (auto& s : stills.points) s.accel.mean = accel->correct(s.accel.mean);
    for (auto& t : turns) t.window.accel.mean = accel->correct(t.window.accel.mean);
    notes.push_back("the specific force of the stills and turns calibrated with the accelerometer fit");
  }
  CalibrationResult r = calibrate_gyro_turns(stills.points, turns, go, rec.header.info.gyro_lsb_radps);
  r.notes.insert(r.notes.begin(), notes.begin(), notes.end());
  if (!columns)
    fail_all(r, "the turns gyro calibration needs the truth columns turn_x_deg, turn_y_deg, turn_z_deg (the "
                "rotation vector of each known turn); this recording has none");
  return r;
}

}  // namespace stend::ceres_nonlinear
