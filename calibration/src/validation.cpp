// How well a calibration holds on a held-out recording. See stend/calibration/validation.hpp.
#include "stend/calibration/validation.hpp"

#include <stend/estimation/linear_lsq.hpp>
#include <stend/physics/units.hpp>
#include <stend/sdk.hpp>
#include <stend/processing/static_points.hpp>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <ostream>
#include <stdexcept>

namespace stend::calibration {

namespace {

// A still interval must not turn faster than this (calibrated, so the gyro bias is gone): a
// constant-rate turn about the vertical leaves the accelerometer still.
constexpr double kStillMaxRateDps = 3.0;

// Mean of a sample field over [first, last], read a chunk at a time.
template <class Get>
Eigen::Vector3d mean_of(const Recording& rec, std::size_t first, std::size_t last, Get get) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for_each_chunk(rec.sample_source(), first, last + 1, [&](const ImuSample* c, std::size_t n, std::uint64_t) {
    for (std::size_t k = 0; k < n; ++k) m += get(c[k]);
  });
  return m / static_cast<double>(last - first + 1);
}
Eigen::Vector3d accel_mean(const Recording& rec, std::size_t first, std::size_t last) {
  return mean_of(rec, first, last, [](const ImuSample& s) { return s.accel_mps2; });
}

// The local gravity the check uses: the options', the recording's, the calibration's, standard.
double gravity_for(const Recording& rec, const Calibration& cal, const ValidationOptions& o) {
  if (o.gravity_mps2 > 0.0) return o.gravity_mps2;
  if (rec.header.gravity_mps2 > 0.0) return rec.header.gravity_mps2;
  if (cal.gravity_mps2 > 0.0) return cal.gravity_mps2;
  return physics::kStandardGravity;
}

struct Summary3 {
  double mean = kNaN, rms = kNaN, max = kNaN;
};
Summary3 summarize(const std::vector<double>& v) {
  Summary3 s;
  if (v.empty()) return s;
  double sum = 0.0, sq = 0.0, mx = 0.0;
  for (double x : v) {
    sum += x;
    sq += x * x;
    mx = std::max(mx, std::abs(x));
  }
  const double n = static_cast<double>(v.size());
  return {sum / n, std::sqrt(sq / n), mx};
}

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * physics::kRadToDeg;
}

// The calibration's own variance of |a| at a still pose [(m/s^2)^2]: its parameters' standard
// errors through the regressor at the calibrated reading `a`, projected on the reading's
// direction (the results keep no correlations, so none are used).
double calibration_variance(const InstrumentCalibration& ic, const Eigen::Vector3d& a, double temperature_c) {
  model::Stimulus<double> s;
  s.input = s.specific_force = a;
  s.temperature_c = temperature_c;
  const Eigen::RowVectorXd along = a.normalized().transpose() * ic.model.regressor(s);
  double v = 0.0;
  for (std::size_t j = 0; j < ic.parameters.size(); ++j)
    v += std::pow(along[static_cast<Eigen::Index>(j)] * ic.std_error(ic.parameters[j].name), 2);
  return v;
}

// |a| − g before and after over the static points, the noise floor, the gravity direction's
// stability inside each; the calibrated RMS against kStaticLimitNoiseFloors × the floor.
StaticCheck static_check(const Recording& raw, const Recording& cal, const InstrumentCalibration& accel,
                         const std::vector<processing::StaticPoint>& pts, double g) {
  StaticCheck c;
  if (pts.empty()) {
    c.not_checked = "no static interval detected";
    return c;
  }
  c.intervals = static_cast<int>(pts.size());
  c.gravity_mps2 = g;
  std::vector<double> before, after, floor2, dir;
  for (const auto& p : pts) {
    const Eigen::Vector3d a = accel_mean(cal, p.first, p.last);
    before.push_back(accel_mean(raw, p.first, p.last).norm() - g);
    after.push_back(a.norm() - g);
    // Standard error of |mean a|: the per-axis standard errors projected on the mean's direction,
    // and the calibration's own.
    floor2.push_back(p.accel.std_error.cwiseAbs2().dot(a.normalized().cwiseAbs2()) +
                     calibration_variance(accel, a, p.stimulus.temperature_c));
    const std::size_t mid = p.first + (p.last - p.first) / 2;
    if (mid > p.first && mid + 1 <= p.last)
      dir.push_back(angle_deg(accel_mean(cal, p.first, mid), accel_mean(cal, mid + 1, p.last)));
  }
  const Summary3 b = summarize(before), a = summarize(after), d = summarize(dir);
  std::tie(c.mean_before, c.rms_before, c.max_before) = std::tie(b.mean, b.rms, b.max);
  std::tie(c.mean_after, c.rms_after, c.max_after) = std::tie(a.mean, a.rms, a.max);
  double f = 0.0;
  for (double x : floor2) f += x;
  c.noise_floor = floor2.empty() ? kNaN : std::sqrt(f / static_cast<double>(floor2.size()));
  c.direction_rms_deg = d.rms;
  c.direction_max_deg = d.max;
  c.limit_mps2 = kStaticLimitNoiseFloors * c.noise_floor;
  c.verdict = c.rms_after <= c.limit_mps2 ? CheckVerdict::kPass : CheckVerdict::kFail;
  return c;
}

// Why the static check cannot be made with this calibration ("" when it can): |a| needs the
// accelerometer's three axes calibrated.
std::string static_check_unavailable(const Calibration& cal) {
  if (!cal.accel.present()) return "no accelerometer calibration";
  if (cal.accel.axes.size() < 3) {
    std::string axes;
    for (int a : cal.accel.axes) axes += std::string(axes.empty() ? "" : " ") + "xyz"[a];
    return "the accelerometer calibration covers axes " + (axes.empty() ? std::string("none") : axes) +
           " only: |a| - g needs the three";
  }
  return {};
}

// The gyro's white noise per sample on each axis [rad/s]: the pooled sample spread of the static points.
Eigen::Vector3d gyro_noise(const std::vector<processing::StaticPoint>& pts) {
  Eigen::Vector3d s2 = Eigen::Vector3d::Zero();
  for (const auto& p : pts) s2 += p.gyro.sample_std.cwiseAbs2();
  return (s2 / static_cast<double>(std::max<std::size_t>(1, pts.size()))).cwiseSqrt();
}

// Mean calibrated rate over the first `seconds` and its standard error; throws when that span is
// not still (no static point covers it).
void rebias(const Recording& cal, const std::vector<processing::StaticPoint>& pts, double seconds, ValidationReport& r) {
  const SampleSource& src = cal.sample_source();
  if (src.size() == 0) throw std::invalid_argument("--rebias-from-start: the recording has no samples");
  const double t0 = time_at(src, 0);
  // The last sample within `seconds` of the first (a binary search, not a scan).
  const std::uint64_t past = lower_bound_time(src, std::nextafter(t0 + seconds, INFINITY));
  const std::size_t last = past > 0 ? static_cast<std::size_t>(past - 1) : 0;
  const bool still = std::any_of(pts.begin(), pts.end(), [&](const processing::StaticPoint& p) {
    return time_at(src, p.first) - t0 <= 0.5 * seconds && p.last >= last;
  });
  if (!still || last < 8)
    throw std::invalid_argument(fmt::format(
        "--rebias-from-start {} s: the recording's first {} s are not one still interval (the static detector finds "
        "none covering them); give a shorter span or leave the calibration's bias",
        seconds, seconds));
  const Eigen::Vector3d m = mean_of(cal, 0, last, [](const ImuSample& s) { return s.gyro_radps; });
  Eigen::Vector3d s2 = Eigen::Vector3d::Zero();
  for_each_chunk(src, 0, last + 1, [&](const ImuSample* c, std::size_t n, std::uint64_t) {
    for (std::size_t k = 0; k < n; ++k) s2 += (c[k].gyro_radps - m).cwiseAbs2();
  });
  const double n = static_cast<double>(last + 1);
  r.rebiased = true;
  r.rebias_radps = m;
  r.rebias_se_radps = (s2 / (n - 1.0) / n).cwiseSqrt();
}

// The rotation carried by the rates over samples [a, b] (trapezoid rates, rotation vectors
// composed), as a rotation vector [rad] in the frame at sample a.
Eigen::Vector3d integrated_rotation(const Recording& cal, std::size_t a, std::size_t b, const Eigen::Vector3d& bias) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  std::vector<ImuSample> S(b - a + 1);  // one turn
  cal.sample_source().read(a, S.size(), S.data());
  for (std::size_t i = 0; i + 1 < S.size(); ++i) {
    const Eigen::Vector3d w = 0.5 * (S[i].gyro_radps + S[i + 1].gyro_radps) - bias;
    const Eigen::Vector3d d = w * (S[i + 1].t_s - S[i].t_s);
    const double ang = d.norm();
    if (ang > 0.0) q = q * Eigen::Quaterniond(Eigen::AngleAxisd(ang, d / ang));
  }
  const Eigen::AngleAxisd aa(q.normalized());
  return aa.axis() * aa.angle();
}

// The window of the turn between static points `before` and `after` [first, last sample]: the
// motion between them and kTurnMarginS of each still.
std::pair<std::size_t, std::size_t> turn_window(const SampleSource& src, const processing::StaticPoint& before,
                                                const processing::StaticPoint& after) {
  const double t_end = time_at(src, before.last), t_start = time_at(src, after.first);
  const auto a = static_cast<std::size_t>(lower_bound_time(src, t_end - kTurnMarginS));
  const auto b = static_cast<std::size_t>(lower_bound_time(src, t_start + kTurnMarginS));
  return {std::max(a, before.first), std::min(b, after.last)};
}

// Every motion between consecutive static points that turns by more than half the stated angle,
// checked against it over its window (turn_window).
std::vector<TurnCheck> turn_checks(const Recording& cal, const Calibration& c,
                                   const std::vector<processing::StaticPoint>& pts, const ExpectedRotation& e,
                                   const ValidationReport& r, double z) {
  const char* ax = "xyz";
  const Eigen::Vector3d bias = r.rebiased ? r.rebias_radps : Eigen::Vector3d::Zero();
  const Eigen::Vector3d noise = gyro_noise(pts);
  const double bias_se = r.rebiased ? r.rebias_se_radps[e.axis] : c.gyro.std_error(std::string("bias_") + ax[e.axis]);
  const double scale_se = c.gyro.std_error(std::string("scale_") + ax[e.axis]);
  std::vector<TurnCheck> out;
  for (std::size_t k = 0; k + 1 < pts.size(); ++k) {
    const auto [a, b] = turn_window(cal.sample_source(), pts[k], pts[k + 1]);
    if (b <= a) continue;
    const Eigen::Vector3d rv = integrated_rotation(cal, a, b, bias);
    if (std::abs(rv[e.axis]) * physics::kRadToDeg < 0.5 * std::abs(e.angle_deg)) continue;
    TurnCheck t;
    t.expected = e;
    t.t_start_s = time_at(cal.sample_source(), a);
    t.t_end_s = time_at(cal.sample_source(), b);
    t.measured_deg = rv[e.axis] * physics::kRadToDeg;
    t.error_deg = std::abs(t.measured_deg) - std::abs(e.angle_deg);
    const double T = t.t_end_s - t.t_start_s, n = static_cast<double>(b - a);
    t.sigma_noise_deg = noise[e.axis] * std::sqrt(n) * (T / n) * physics::kRadToDeg;
    t.sigma_bias_deg = bias_se * T * physics::kRadToDeg;
    t.sigma_scale_deg = scale_se * std::abs(e.angle_deg);
    t.sigma_deg = std::sqrt(t.sigma_noise_deg * t.sigma_noise_deg + t.sigma_bias_deg * t.sigma_bias_deg +
                            t.sigma_scale_deg * t.sigma_scale_deg);
    t.bound_deg = z * t.sigma_deg;
    t.verdict = std::abs(t.error_deg) <= t.bound_deg ? CheckVerdict::kPass : CheckVerdict::kFail;
    out.push_back(t);
  }
  return out;
}

std::string num(double v, int digits = 4) { return estimation::number_text(v, digits); }

std::string turn_name(const TurnCheck& t) {
  return fmt::format("turn {}:{}", "xyz"[t.expected.axis], num(t.expected.angle_deg));
}

// Why the validation does not pass ("" when it does): the checks that FAIL; else a stated turn no
// motion matches; else that nothing could be checked.
std::string verdict_message(const ValidationReport& r) {
  std::vector<std::string> failed, unmatched;
  if (r.statics.verdict == CheckVerdict::kFail) failed.push_back("static |a| - g");
  bool checked = r.statics.verdict != CheckVerdict::kNotChecked;
  for (const auto& t : r.turns) {
    if (t.verdict == CheckVerdict::kFail)
      failed.push_back(fmt::format("{} at {}-{} s", turn_name(t), num(t.t_start_s, 6), num(t.t_end_s, 6)));
    if (t.verdict == CheckVerdict::kNotChecked) unmatched.push_back(turn_name(t));
    checked = checked || t.verdict != CheckVerdict::kNotChecked;
  }
  if (!failed.empty()) return fmt::format("outside the limit: {}", fmt::join(failed, "; "));
  if (!unmatched.empty())
    return fmt::format("no motion between static intervals turns by more than half the stated angle: {}",
                       fmt::join(unmatched, "; "));
  if (!checked) return "nothing could be checked: " + r.statics.not_checked;
  return {};
}

}  // namespace

ExpectedRotation parse_expected_rotation(const std::string& text) {
  const auto colon = text.find(':');
  const std::string axis = text.substr(0, colon);
  ExpectedRotation e;
  e.axis = axis == "x" ? 0 : axis == "y" ? 1 : axis == "z" ? 2 : -1;
  bool ok = colon != std::string::npos && e.axis >= 0;
  if (ok) {
    try {
      std::size_t used = 0;
      e.angle_deg = std::stod(text.substr(colon + 1), &used);
      ok = used == text.size() - colon - 1 && std::isfinite(e.angle_deg) && e.angle_deg != 0.0;
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok)
    throw std::invalid_argument("expected rotation '" + text +
                                "': expected AXIS:DEGREES with AXIS x, y or z (sensor frame) and a nonzero angle, "
                                "e.g. x:90");
  return e;
}

processing::ProcessingOptions validation_interval_options() {
  processing::ProcessingOptions o;
  o.intervals = processing::IntervalSource::kDetect;
  o.extraction.filter = processing::Filter::kNone;
  o.extraction.settle_s = 0.0;
  o.detector.max_gyro_radps = kStillMaxRateDps * physics::kDegPerSecond;
  o.stated = {"intervals", "extraction.filter", "extraction.settle_s", "detector.max_gyro_dps"};
  return o;
}

bool ValidationOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (!(confidence > 0.0 && confidence < 1.0)) return fail("confidence must lie in (0, 1)");
  if (!(gravity_mps2 >= 0.0)) return fail("gravity must be >= 0 m/s^2 (0: the recording's)");
  if (!(rebias_from_start_s >= 0.0)) return fail("--rebias-from-start must be >= 0 s");
  return intervals.IsValid(error);
}

void check_applicable(const Calibration& cal, const ValidationOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw std::invalid_argument(why);
  if ((!o.rotations.empty() || o.rebias_from_start_s > 0.0) && !cal.gyro.present())
    throw std::invalid_argument(cal.source + " holds no gyroscope calibration (" +
                                (cal.accel.present() ? "accelerometer only" : "nothing") +
                                "): a rotation check or a gyro re-bias needs one; give the results of a gyroscope fit");
}

ValidationReport validate(const Recording& raw, const Recording& calibrated, const Calibration& cal,
                          const ValidationOptions& o) {
  check_applicable(cal, o);
  ValidationReport r;
  r.calibration = cal.source;
  r.confidence = o.confidence;
  processing::Request request;
  const processing::Extraction ex = processing::extract(calibrated, o.intervals, request);
  const auto& pts = ex.points;
  r.notes.insert(r.notes.end(), ex.notes.begin(), ex.notes.end());
  r.statics.not_checked = static_check_unavailable(cal);
  if (r.statics.not_checked.empty()) r.statics = static_check(raw, calibrated, cal.accel, pts, gravity_for(raw, cal, o));
  if (o.rebias_from_start_s > 0.0) rebias(calibrated, pts, o.rebias_from_start_s, r);
  const double z = estimation::normal_quantile(0.5 * (1.0 + o.confidence));
  for (const auto& e : o.rotations) {
    auto turns = turn_checks(calibrated, cal, pts, e, r, z);
    if (turns.empty()) turns.push_back({.expected = e});  // not checked
    r.turns.insert(r.turns.end(), turns.begin(), turns.end());
  }
  r.message = verdict_message(r);
  r.ok = r.message.empty();
  return r;
}

const char* to_string(CheckVerdict v) {
  switch (v) {
    case CheckVerdict::kPass: return "PASS";
    case CheckVerdict::kFail: return "FAIL";
    case CheckVerdict::kNotChecked: break;
  }
  return "NOT CHECKED";
}

CheckVerdict ValidationReport::verdict() const {
  if (ok) return CheckVerdict::kPass;
  const bool failed = statics.verdict == CheckVerdict::kFail ||
                      std::any_of(turns.begin(), turns.end(), [](const TurnCheck& t) { return t.verdict == CheckVerdict::kFail; });
  return failed ? CheckVerdict::kFail : CheckVerdict::kNotChecked;
}

void ValidationReport::print(std::ostream& os) const {
  os << "validation of " << calibration << ": " << to_string(verdict()) << (ok ? "" : " — " + message) << "\n";
  const auto& s = statics;
  const double mg = physics::kMilliG;
  if (s.verdict != CheckVerdict::kNotChecked) {
    os << fmt::format("static |a| - g over {} detected still intervals (g = {} m/s^2), mg:\n", s.intervals,
                      num(s.gravity_mps2, 8));
    os << fmt::format("  raw         mean {:>9}  RMS {:>9}  max {:>9}\n", num(s.mean_before / mg),
                      num(s.rms_before / mg), num(s.max_before / mg));
    os << fmt::format("  calibrated  mean {:>9}  RMS {:>9}  max {:>9}   (noise floor {} mg)\n", num(s.mean_after / mg),
                      num(s.rms_after / mg), num(s.max_after / mg), num(s.noise_floor / mg));
    os << fmt::format("gravity direction stability inside the intervals (half to half): RMS {} deg, max {} deg\n",
                      num(s.direction_rms_deg), num(s.direction_max_deg));
  }
  if (rebiased)
    os << fmt::format("gyro bias re-estimated from the still start: {} {} {} deg/s (std error {} {} {})\n",
                      num(rebias_radps[0] / physics::kDegPerSecond), num(rebias_radps[1] / physics::kDegPerSecond),
                      num(rebias_radps[2] / physics::kDegPerSecond), num(rebias_se_radps[0] / physics::kDegPerSecond),
                      num(rebias_se_radps[1] / physics::kDegPerSecond), num(rebias_se_radps[2] / physics::kDegPerSecond));
  os << "checks:\n";
  if (s.verdict == CheckVerdict::kNotChecked)
    os << fmt::format("  {:<11}  static |a| - g: {}\n", to_string(s.verdict), s.not_checked);
  else
    os << fmt::format("  {:<11}  static |a| - g: calibrated RMS {} mg, limit {} mg ({} x the noise floor {} mg)\n",
                      to_string(s.verdict), num(s.rms_after / mg), num(s.limit_mps2 / mg), num(kStaticLimitNoiseFloors),
                      num(s.noise_floor / mg));
  for (const auto& t : turns) {
    if (t.verdict == CheckVerdict::kNotChecked) {
      os << fmt::format("  {:<11}  {} deg: no motion between static intervals turns by more than half of it\n",
                        to_string(t.verdict), turn_name(t));
      continue;
    }
    os << fmt::format("  {:<11}  {} deg at {}-{} s: integrated {} deg, error {} deg, limit +/-{} deg ({:.3g}% bound; "
                      "1 sigma {}: noise {}, bias {}, scale {})\n",
                      to_string(t.verdict), turn_name(t), num(t.t_start_s, 6), num(t.t_end_s, 6), num(t.measured_deg, 7),
                      num(t.error_deg), num(t.bound_deg), 100 * confidence, num(t.sigma_deg), num(t.sigma_noise_deg),
                      num(t.sigma_bias_deg), num(t.sigma_scale_deg));
  }
  for (const auto& n : notes) os << "note: " << n << "\n";
}

std::string ValidationReport::to_json() const {
  using nlohmann::json;
  auto n = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  const auto& s = statics;
  json j = {{"status", to_string(verdict())},
            {"message", message},
            {"calibration", calibration},
            {"confidence", confidence},
            {"static",
             {{"intervals", s.intervals},
              {"gravity_mps2", n(s.gravity_mps2)},
              {"norm_minus_g_before_mps2", {{"mean", n(s.mean_before)}, {"rms", n(s.rms_before)}, {"max", n(s.max_before)}}},
              {"norm_minus_g_after_mps2", {{"mean", n(s.mean_after)}, {"rms", n(s.rms_after)}, {"max", n(s.max_after)}}},
              {"noise_floor_mps2", n(s.noise_floor)},
              {"limit_mps2", n(s.limit_mps2)},
              {"verdict", to_string(s.verdict)},
              {"not_checked", s.not_checked},
              {"direction_change_deg", {{"rms", n(s.direction_rms_deg)}, {"max", n(s.direction_max_deg)}}}}},
            {"notes", notes}};
  if (rebiased)
    j["rebias_radps"] = {{"value", {n(rebias_radps[0]), n(rebias_radps[1]), n(rebias_radps[2])}},
                         {"std_error", {n(rebias_se_radps[0]), n(rebias_se_radps[1]), n(rebias_se_radps[2])}}};
  j["turns"] = json::array();
  for (const auto& t : turns)
    j["turns"].push_back({{"axis", std::string(1, "xyz"[t.expected.axis])},
                          {"stated_deg", t.expected.angle_deg},
                          {"t_start_s", t.t_start_s},
                          {"t_end_s", t.t_end_s},
                          {"measured_deg", n(t.measured_deg)},
                          {"error_deg", n(t.error_deg)},
                          {"sigma_deg", {{"total", n(t.sigma_deg)}, {"noise", n(t.sigma_noise_deg)},
                                         {"bias", n(t.sigma_bias_deg)}, {"scale", n(t.sigma_scale_deg)}}},
                          {"bound_deg", n(t.bound_deg)},
                          {"verdict", to_string(t.verdict)}});
  return j.dump(2);
}

}  // namespace stend::calibration
