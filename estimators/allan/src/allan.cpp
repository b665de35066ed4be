#include <stend/allan/allan.hpp>
#include <stend/allan/deviation_report.hpp>
#include <stend/physics/units.hpp>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <fmt/ostream.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <ostream>
#include <exception>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace stend::allan {

namespace {

constexpr int kTerms = 5;  // Q N B K R

// Regressor of the model: σ²(τ) = Σ_j c_j · basis_j(τ), c = (Q², N², B², K², R²).
std::array<double, kTerms> basis(double tau) {
  return {3.0 / (tau * tau), 1.0 / tau, kFlickerFloor * kFlickerFloor, tau / 3.0,
          tau * tau / 2.0};
}

NoiseType noise_of_term(int j) {
  switch (j) {
    case 0: return NoiseType::kQuantization;
    case 1: return NoiseType::kWhite;
    case 2: return NoiseType::kFlicker;
    default: return NoiseType::kRandomWalk;  // K, and the ramp R (closest EDF model)
  }
}

Coefficient* coefficient(NoiseModel& m, int j) { return &m.quantization + j; }
const Coefficient* coefficient(const NoiseModel& m, int j) { return &m.quantization + j; }

std::string fmt_value(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : "-"; }

}  // namespace

const char* to_string(Instrument i) {
  switch (i) {
    case Instrument::kAccelerometer: return "accelerometer";
    case Instrument::kGyroscope: return "gyroscope";
    case Instrument::kOther: return "other";
  }
  return "?";
}

Units units_for(Instrument instrument, const std::string& signal_unit) {
  Units u;
  switch (instrument) {
    case Instrument::kAccelerometer:
      if (signal_unit.empty() || signal_unit == "m/s^2") {
        return {"m/s^2", "m/s", "m/s^2/sqrt(Hz)", "m/s^2", "m/s^3/sqrt(Hz)", "m/s^3"};
      }
      break;
    case Instrument::kGyroscope:
      if (signal_unit.empty() || signal_unit == "rad/s") {
        return {"rad/s", "rad", "rad/s/sqrt(Hz)", "rad/s", "rad/s^2/sqrt(Hz)", "rad/s^2"};
      }
      break;
    case Instrument::kOther: break;
  }
  const std::string s = signal_unit.empty() ? "unit" : signal_unit;
  return {s, s + "*s", s + "/sqrt(Hz)", s, s + "/s/sqrt(Hz)", s + "/s"};
}

// ---------------------------------------------------------------------------------------------
// Options

std::string yaml_location(const std::string& file, const YAML::Node& n) {
  const YAML::Mark m = n.Mark();
  std::string loc = file.empty() ? std::string("<yaml>") : file;
  if (m.line >= 0) loc += fmt::format(":{}:{}", m.line + 1, m.column + 1);
  return loc;
}

namespace {

// The value of one Allan option, read as a number or a boolean; a bad value throws with its location.
struct OptionValue {
  const std::string& file;
  const std::string& key;
  const YAML::Node& v;

  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(fmt::format("{}: allan option '{}': {}", yaml_location(file, v), key, what));
  }
  double number() const {
    try {
      return v.as<double>();
    } catch (const YAML::Exception&) {
      fail("expected a number, got '" + (v.IsScalar() ? v.Scalar() : std::string("a non-scalar")) + "'");
    }
  }
  bool boolean() const {
    try {
      return v.as<bool>();
    } catch (const YAML::Exception&) {
      fail("expected true or false");
    }
  }
};

// Sets the option named value.key with its range check; false for an unknown name.
bool set_allan_option(AllanOptions& o, const OptionValue& value) {
  const std::string& key = value.key;
  if (key == "max_m") {
    const double m = value.number();
    if (!(m >= 1.0) || m > 9.2e18 || m != std::floor(m)) value.fail("must be an integer >= 1 (samples)");
    o.max_m = static_cast<std::uint64_t>(m);
  } else if (key == "confidence") {
    o.confidence = value.number();
    if (!(o.confidence > 0.0 && o.confidence < 1.0)) value.fail("must be in (0, 1), e.g. 0.683 or 0.95");
  } else if (key == "edf_from_model") {
    o.edf_from_model = value.boolean();
  } else if (key == "slope_tolerance") {
    o.slope_tolerance = value.number();
    if (!(o.slope_tolerance > 0.0 && o.slope_tolerance < 0.5)) value.fail("must be in (0, 0.5)");
  } else if (key == "min_readoff_edf") {
    o.min_readoff_edf = value.number();
    if (!(o.min_readoff_edf >= 0.0)) value.fail("must be >= 0");
  } else if (key == "min_readoff_points") {
    const double n = value.number();
    if (!(n >= 1.0 && n <= 64.0) || n != std::floor(n)) value.fail("must be an integer in 1 … 64");
    o.min_readoff_points = static_cast<int>(n);
  } else if (key == "t_begin_s") {
    o.t_begin_s = value.number();
  } else if (key == "t_end_s") {
    o.t_end_s = value.number();
  } else {
    return false;
  }
  return true;
}

}  // namespace

AllanOptions options_from_yaml(const YAML::Node& node, const std::string& file) {
  AllanOptions o;
  if (!node || node.IsNull()) return o;
  if (!node.IsMap()) throw std::runtime_error(yaml_location(file, node) + ": Allan options must be a mapping");
  static const std::vector<std::string> keys = {"max_m", "confidence", "edf_from_model",
                                                "slope_tolerance", "min_readoff_edf",
                                                "min_readoff_points", "t_begin_s", "t_end_s",
                                                "deviations", "tau"};
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    if (set_allan_option(o, OptionValue{file, key, v}) || is_deviation_key(key)) continue;
    std::string all;
    for (const auto& k : keys) all += (all.empty() ? "" : ", ") + k;
    throw std::runtime_error(fmt::format("{}: unknown allan option '{}' (known: {})",
                                         yaml_location(file, kv.first), key, all));
  }
  if (std::isfinite(o.t_begin_s) && std::isfinite(o.t_end_s) && !(o.t_end_s > o.t_begin_s)) {
    throw std::runtime_error(yaml_location(file, node) + ": allan options: t_end_s must be after t_begin_s");
  }
  return o;
}

// ---------------------------------------------------------------------------------------------
// Model

double NoiseModel::avar(double tau_s) const {
  const auto b = basis(tau_s);
  double v = 0.0;
  for (int j = 0; j < kTerms; ++j) {
    const double c = coefficient(*this, j)->fitted;
    v += c * c * b[j];
  }
  return v;
}

NoiseType NoiseModel::dominant(double tau_s) const {
  const auto b = basis(tau_s);
  int best = 1;
  double best_v = 0.0;
  for (int j = 0; j < kTerms; ++j) {
    const double c = coefficient(*this, j)->fitted;
    const double v = c * c * b[j];
    if (v > best_v) {
      best_v = v;
      best = j;
    }
  }
  return noise_of_term(best);
}

AllanCurve make_curve(const std::vector<OctaveVariance>& octaves, std::uint64_t samples,
                      double rate_hz, const ChannelInfo& channel, double confidence) {
  if (!(rate_hz > 0.0)) throw std::invalid_argument("Allan curve: the sample rate must be > 0");
  AllanCurve c;
  c.channel = channel;
  c.units = units_for(channel.instrument, channel.unit);
  if (c.channel.unit.empty()) c.channel.unit = c.units.signal;
  c.rate_hz = rate_hz;
  c.samples = samples;
  c.confidence = confidence;
  for (const auto& o : octaves) {
    AllanPoint p;
    p.m = o.m;
    p.terms = o.terms;
    p.tau_s = static_cast<double>(o.m) / rate_hz;
    p.avar = o.avar;
    p.adev = std::sqrt(std::max(0.0, o.avar));
    c.points.push_back(p);
  }
  assign_intervals(c, nullptr);
  return c;
}

void assign_intervals(AllanCurve& curve, const NoiseModel* model) {
  const double n_phase = static_cast<double>(curve.samples) + 1.0;
  for (auto& p : curve.points) {
    p.noise = model && model->ok ? model->dominant(p.tau_s) : NoiseType::kWhite;
    p.edf = stats::edf_overlapping_adev(p.noise, n_phase, static_cast<double>(p.m));
    const auto ci = stats::deviation_interval(p.adev, p.edf, curve.confidence);
    p.adev_lo = ci.lo;
    p.adev_hi = ci.hi;
  }
}

namespace {

struct FitPoint {
  double tau, avar, adev, edf, lo, hi;
  std::array<double, kTerms> a;
};

// Non-negative least squares min ‖W(A c − b)‖, c ≥ 0, for 5 unknowns: the optimum is the
// unconstrained solution on its support, so every support is tried (31 small solves).
struct NnlsResult {
  std::array<double, kTerms> c{};
  std::array<bool, kTerms> active{};
  double chi2 = 0.0;
  Eigen::MatrixXd cov;  // over the active columns, in c units
};

NnlsResult nnls(const std::vector<FitPoint>& pts, const std::vector<double>& w) {
  const int n = static_cast<int>(pts.size());
  Eigen::MatrixXd A(n, kTerms);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < kTerms; ++j) A(i, j) = w[i] * pts[i].a[j];
    b(i) = w[i] * pts[i].avar;
  }
  Eigen::VectorXd scale(kTerms);
  for (int j = 0; j < kTerms; ++j) {
    scale(j) = A.col(j).norm();
    if (scale(j) > 0.0) A.col(j) /= scale(j);
  }
  NnlsResult best;
  best.chi2 = b.squaredNorm();  // empty support
  for (int mask = 1; mask < (1 << kTerms); ++mask) {
    std::vector<int> cols;
    for (int j = 0; j < kTerms; ++j) {
      if (mask & (1 << j)) cols.push_back(j);
    }
    const int k = static_cast<int>(cols.size());
    if (k > n) continue;
    Eigen::MatrixXd As(n, k);
    for (int q = 0; q < k; ++q) As.col(q) = A.col(cols[q]);
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(As);
    qr.setThreshold(1e-12);
    if (qr.rank() < k) continue;
    const Eigen::VectorXd x = qr.solve(b);
    if ((x.array() <= 0.0).any()) continue;
    const double r = (As * x - b).squaredNorm();
    if (r < best.chi2) {
      best = NnlsResult{};
      best.chi2 = r;
      for (int q = 0; q < k; ++q) {
        best.c[cols[q]] = x(q) / scale(cols[q]);
        best.active[cols[q]] = true;
      }
      const Eigen::MatrixXd AtA = As.transpose() * As;
      Eigen::MatrixXd cov = AtA.inverse();
      for (int p = 0; p < k; ++p) {
        for (int q = 0; q < k; ++q) cov(p, q) /= scale(cols[p]) * scale(cols[q]);
      }
      best.cov = cov;
    }
  }
  return best;
}

void local_slopes(const std::vector<FitPoint>& pts, std::vector<double>& slope) {
  const std::size_t n = pts.size();
  slope.assign(n, kNaN);
  if (n < 2) return;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1;
    const std::size_t b = i + 1 == n ? n - 1 : i + 1;
    slope[i] = (std::log(pts[b].adev) - std::log(pts[a].adev)) /
               (std::log(pts[b].tau) - std::log(pts[a].tau));
  }
}

// Read-off on a slope line: value_i = adev_i · (τ_ref/τ_i)^target, pooled over the points
// whose local slope is within tolerance of `target` (log-mean weighted by EDF).
Readoff slope_readoff(const char* name, const std::string& unit, const std::vector<FitPoint>& pts,
                      const std::vector<double>& slope, double target, double tau_ref,
                      const AllanOptions& opt) {
  Readoff r;
  r.name = name;
  r.unit = unit;
  double sw = 0.0, swl = 0.0;
  int count = 0;
  std::size_t best = pts.size();
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (!(pts[i].edf >= opt.min_readoff_edf)) continue;
    if (!(std::abs(slope[i] - target) <= opt.slope_tolerance)) continue;
    const double v = pts[i].adev * std::pow(tau_ref / pts[i].tau, target);
    sw += pts[i].edf;
    swl += pts[i].edf * std::log(v);
    ++count;
    if (best == pts.size() || pts[i].edf > pts[best].edf) best = i;
    if (!std::isfinite(r.tau_lo_s)) r.tau_lo_s = pts[i].tau;
    r.tau_hi_s = pts[i].tau;
  }
  if (count < std::max(1, opt.min_readoff_points)) {
    r.note = fmt::format(
        "no slope {:+.1f} region (>= {} points with |slope - {:+.1f}| <= {:.2f} and edf >= {:g}) "
        "in the measured tau range",
        target, std::max(1, opt.min_readoff_points), target, opt.slope_tolerance, opt.min_readoff_edf);
    r.tau_lo_s = r.tau_hi_s = kNaN;
    return r;
  }
  r.found = true;
  r.value = std::exp(swl / sw);
  r.lo = r.value * pts[best].lo / pts[best].adev;
  r.hi = r.value * pts[best].hi / pts[best].adev;
  return r;
}

// The unit of every coefficient and read-off, from the curve's units.
void set_units(NoiseModel& model, const Units& u) {
  model.quantization.unit = u.quantization;
  model.white.unit = u.white;
  model.bias_instability.unit = u.bias;
  model.random_walk.unit = u.random_walk;
  model.rate_ramp.unit = u.ramp;
  model.white_line.unit = u.white;
  model.random_walk_line.unit = u.random_walk;
  model.bias_floor.unit = u.bias;
}

// Points with a positive, finite Allan variance from at least one term, with the basis at τ.
std::vector<FitPoint> usable_points(const AllanCurve& curve) {
  std::vector<FitPoint> pts;
  for (const auto& p : curve.points) {
    if (!(p.avar > 0.0) || !std::isfinite(p.avar) || p.terms < 1) continue;
    pts.push_back({p.tau_s, p.avar, p.adev, kNaN, kNaN, kNaN, basis(p.tau_s)});
  }
  return pts;
}

// Averaging factor m = τ·rate of a point (samples per cluster).
double averaging_factor(const FitPoint& p, const AllanCurve& curve) { return std::round(p.tau * curve.rate_hz); }

// Iteratively reweighted non-negative fit of the term coefficients to the Allan variances:
// Var(σ̂²) ≈ 2σ⁴/EDF with σ² from the current model (8 passes); fills the fitted coefficients and,
// with opt.edf_from_model, the points' EDF from the dominant term.
NnlsResult reweighted_fit(std::vector<FitPoint>& pts, const AllanCurve& curve, const AllanOptions& opt,
                          NoiseModel& model) {
  const double n_phase = static_cast<double>(curve.samples) + 1.0;
  for (auto& p : pts) p.edf = stats::edf_overlapping_adev(NoiseType::kWhite, n_phase, averaging_factor(p, curve));
  NnlsResult fit;
  std::vector<double> w(pts.size());
  for (int iter = 0; iter < 8; ++iter) {
    for (std::size_t i = 0; i < pts.size(); ++i) {
      double v = pts[i].avar;
      if (iter > 0) {
        double mv = 0.0;
        for (int j = 0; j < kTerms; ++j) mv += fit.c[j] * pts[i].a[j];
        if (mv > 0.0) v = mv;
      }
      const double edf = std::isfinite(pts[i].edf) && pts[i].edf > 0 ? pts[i].edf : 1.0;
      w[i] = std::sqrt(edf / 2.0) / v;
    }
    fit = nnls(pts, w);
    for (int j = 0; j < kTerms; ++j) coefficient(model, j)->fitted = std::sqrt(fit.c[j]);
    if (opt.edf_from_model && iter >= 2) {
      model.ok = true;  // dominant() needs it
      for (auto& p : pts) p.edf = stats::edf_overlapping_adev(model.dominant(p.tau), n_phase, averaging_factor(p, curve));
    }
  }
  return fit;
}

// Degrees of freedom, reduced χ², and each active coefficient's σ: σ(c) from the covariance
// (inflated by χ²_red when above 1), σ(√c) = σ(c) / (2√c).
void fit_uncertainties(const NnlsResult& fit, std::size_t points, NoiseModel& model) {
  int active = 0;
  for (int j = 0; j < kTerms; ++j) active += fit.active[j] ? 1 : 0;
  model.dof = static_cast<int>(points) - active;
  model.chi2_reduced = model.dof > 0 ? fit.chi2 / model.dof : kNaN;
  const double inflate = std::isfinite(model.chi2_reduced) ? std::max(1.0, model.chi2_reduced) : 1.0;
  int q = 0;
  for (int j = 0; j < kTerms; ++j) {
    if (!fit.active[j]) continue;
    const double var_c = fit.cov(q, q) * inflate;
    ++q;
    Coefficient* c = coefficient(model, j);
    c->fitted_sigma = c->fitted > 0 ? std::sqrt(std::max(0.0, var_c)) / (2.0 * c->fitted) : kNaN;
  }
}

// Confidence interval of each point's ADEV with its final EDF (for upper bounds and read-offs).
void point_intervals(std::vector<FitPoint>& pts, double confidence) {
  for (auto& p : pts) {
    const auto ci = stats::deviation_interval(p.adev, p.edf, confidence);
    p.lo = ci.lo;
    p.hi = ci.hi;
  }
}

// Where each term dominates the fitted variance inside [τ_min, τ_max] (400 log-spaced τ) [s].
void mark_dominance(const NnlsResult& fit, NoiseModel& model) {
  const int grid = 400;
  const double l0 = std::log(model.tau_min_s), l1 = std::log(model.tau_max_s);
  for (int g = 0; g <= grid; ++g) {
    const double tau = std::exp(l0 + (l1 - l0) * g / grid);
    const auto b = basis(tau);
    int best = -1;
    double best_v = 0.0;
    for (int j = 0; j < kTerms; ++j) {
      const double v = fit.c[j] * b[j];
      if (v > best_v) {
        best_v = v;
        best = j;
      }
    }
    if (best < 0) continue;
    Coefficient* c = coefficient(model, best);
    c->dominates = true;
    if (!std::isfinite(c->tau_lo_s)) c->tau_lo_s = tau;
    c->tau_hi_s = tau;
  }
}

// A coefficient is identified where it dominates and is ≥ 2σ; each gets the largest value
// compatible with every measured upper limit (term alone).
void identify_and_bound(const std::vector<FitPoint>& pts, NoiseModel& model) {
  for (int j = 0; j < kTerms; ++j) {
    Coefficient* c = coefficient(model, j);
    c->identified = c->dominates && std::isfinite(c->fitted_sigma) && c->fitted >= 2.0 * c->fitted_sigma;
    if (c->identified) {
      c->value = c->fitted;
      c->sigma = c->fitted_sigma;
    }
    double bound = std::numeric_limits<double>::infinity();
    for (const auto& p : pts) {
      const double hi = std::isfinite(p.hi) ? p.hi : p.adev;
      bound = std::min(bound, hi * hi / p.a[j]);
    }
    c->upper_bound = std::sqrt(bound);
  }
}

// Bias-instability read-off at the ADEV minimum (ADEV / 0.664); found only for a flat minimum
// inside the measured τ range.
void read_bias_floor(const std::vector<FitPoint>& pts, const Units& u, Readoff& r) {
  r.unit = u.bias;
  std::size_t imin = 0;
  for (std::size_t i = 1; i < pts.size(); ++i) {
    if (pts[i].adev < pts[imin].adev) imin = i;
  }
  r.tau_lo_s = r.tau_hi_s = pts[imin].tau;
  r.value = pts[imin].adev / kFlickerFloor;
  r.lo = pts[imin].lo / kFlickerFloor;
  r.hi = pts[imin].hi / kFlickerFloor;
  if (imin + 1 == pts.size()) {
    r.note = fmt::format("ADEV still falling at tau_max = {:.4g} s: no flat minimum; B <= {:.4g} {}",
                         pts[imin].tau, r.value, u.bias);
  } else if (imin == 0) {
    r.note = "ADEV rises from the smallest tau: no flat minimum";
  } else {
    r.found = true;
  }
}

}  // namespace

NoiseModel fit_noise_model(const AllanCurve& curve, const AllanOptions& opt) {
  NoiseModel model;
  const Units& u = curve.units;
  set_units(model, u);
  std::vector<FitPoint> pts = usable_points(curve);
  if (pts.size() < 2) {
    model.message = fmt::format("fit failed: {} usable Allan point(s), need at least 2",
                                pts.size());
    return model;
  }
  model.tau_min_s = pts.front().tau;
  model.tau_max_s = pts.back().tau;
  const NnlsResult fit = reweighted_fit(pts, curve, opt, model);
  model.ok = true;
  fit_uncertainties(fit, pts.size(), model);
  point_intervals(pts, curve.confidence);
  mark_dominance(fit, model);
  identify_and_bound(pts, model);
  std::vector<double> slope;
  local_slopes(pts, slope);
  model.white_line = slope_readoff(model.white_line.name, u.white, pts, slope, -0.5, 1.0, opt);
  model.random_walk_line =
      slope_readoff(model.random_walk_line.name, u.random_walk, pts, slope, 0.5, 3.0, opt);
  read_bias_floor(pts, u, model.bias_floor);
  if (model.dof <= 0) model.message = "as many active terms as points: no residual check";
  return model;
}

ChannelResult analyze(const OverlappingAllanStream& stream, double rate_hz,
                      const ChannelInfo& channel, const AllanOptions& options) {
  ChannelResult r;
  r.curve = make_curve(stream.octaves(), stream.samples(), rate_hz, channel, options.confidence);
  const bool constant = !r.curve.points.empty() &&
                        std::all_of(r.curve.points.begin(), r.curve.points.end(),
                                    [](const AllanPoint& p) { return p.avar == 0.0; });
  if (constant) {  // nothing to fit: say so rather than fit zeros
    set_units(r.model, r.curve.units);
    r.model.message = fmt::format("fit failed: the signal is constant over {} samples (every Allan variance is 0)",
                                  stream.samples());
    return r;
  }
  r.model = fit_noise_model(r.curve, options);
  if (options.edf_from_model && r.model.ok) assign_intervals(r.curve, &r.model);
  return r;
}

ChannelResult analyze(const double* y, std::size_t n, std::size_t stride, double rate_hz,
                      const ChannelInfo& channel, const AllanOptions& options) {
  OverlappingAllanStream s(options.max_m, n);
  s.add(y, n, stride == 0 ? 1 : stride);
  return analyze(s, rate_hz, channel, options);
}

// ---------------------------------------------------------------------------------------------
// Recordings and Kalibr

KalibrParameters kalibr_parameters(const std::vector<ChannelResult>& channels, double rate_hz) {
  KalibrParameters k;
  k.update_rate = rate_hz;
  for (Instrument inst : {Instrument::kAccelerometer, Instrument::kGyroscope}) {
    double n_sum = 0.0, k_sum = 0.0;
    int n_count = 0, k_count = 0, axes = 0;
    bool n_all = true, k_all = true, k_bound = false;
    for (const auto& c : channels) {
      if (c.curve.channel.instrument != inst) continue;
      ++axes;
      const NoiseModel& m = c.model;
      if (m.white.identified) {
        n_sum += m.white.value;
        ++n_count;
      } else if (m.white_line.found) {
        n_sum += m.white_line.value;
        ++n_count;
        n_all = false;
      } else {
        n_all = false;
      }
      if (m.random_walk.identified) {
        k_sum += m.random_walk.value;
      } else if (m.random_walk_line.found) {
        k_sum += m.random_walk_line.value;
        k_all = false;
      } else {
        k_sum += m.random_walk.upper_bound;
        k_all = false;
        k_bound = true;
      }
      ++k_count;
    }
    if (axes == 0) continue;
    const double nd = n_count > 0 ? n_sum / n_count : kNaN;
    const double rw = k_count > 0 ? k_sum / k_count : kNaN;
    if (inst == Instrument::kAccelerometer) {
      k.accelerometer_noise_density = nd;
      k.accelerometer_random_walk = rw;
      k.accelerometer_noise_identified = n_all && n_count == axes;
      k.accelerometer_random_walk_identified = k_all;
      k.accelerometer_random_walk_is_upper_bound = k_bound;
    } else {
      k.gyroscope_noise_density = nd;
      k.gyroscope_random_walk = rw;
      k.gyroscope_noise_identified = n_all && n_count == axes;
      k.gyroscope_random_walk_identified = k_all;
      k.gyroscope_random_walk_is_upper_bound = k_bound;
    }
  }
  return k;
}

namespace {

// Sample index range [i0, i1) inside the options' time window [t_begin_s, t_end_s] [s].
IndexRange selected_range(const SampleSource& src, const AllanOptions& options) {
  IndexRange r{0, src.size()};
  if (std::isfinite(options.t_begin_s)) r.first = lower_bound_time(src, options.t_begin_s);
  if (std::isfinite(options.t_end_s)) {
    r.last = lower_bound_time(src, std::nextafter(options.t_end_s, std::numeric_limits<double>::infinity()));
  }
  r.last = std::max(r.first, r.last);
  return r;
}

// Sampling of the selected range, from one pass over time stamps and flags: the rate [Hz] (the
// header's, or 1 / the median of the first kMedianIntervals sample intervals), lost-sample flags
// and intervals off 1/rate by more than 50 %.
struct Sampling {
  double rate_hz = 0.0;
  double t_begin_s = kNaN, t_end_s = kNaN;
  std::uint64_t gaps = 0, irregular = 0;
};
constexpr std::size_t kMedianIntervals = 1u << 16;

Sampling scan_sampling(const SampleSource& src, IndexRange range, double header_rate_hz,
                       const std::string& source) {
  Sampling s;
  s.rate_hz = header_rate_hz;
  std::vector<double> dt;  // intervals [s] seen before the rate is known
  double prev_t = kNaN;
  auto count_irregular = [&](double d) {
    if (d > 1.5 / s.rate_hz || d < 0.5 / s.rate_hz) ++s.irregular;
  };
  auto fix_rate = [&] {
    if (s.rate_hz > 0.0 || dt.empty()) return;
    std::vector<double> sorted = dt;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double median_dt = sorted[sorted.size() / 2];
    if (!(median_dt > 0.0)) {
      throw std::runtime_error(fmt::format(
          "Allan: {}: no output rate in the header and the timestamps do not increase", source));
    }
    s.rate_hz = 1.0 / median_dt;
    for (double d : dt) count_irregular(d);
  };
  for_each_chunk(src, range.first, range.last, [&](const ImuSample* chunk, std::size_t n, std::uint64_t first) {
    for (std::size_t i = 0; i < n; ++i) {
      const double t = chunk[i].t_s;
      if (first + i > range.first) {
        if (chunk[i].flags & kGapBefore) ++s.gaps;
        const double d = t - prev_t;
        if (s.rate_hz > 0.0) count_irregular(d); else dt.push_back(d);
        if (dt.size() == kMedianIntervals) fix_rate();
      } else {
        s.t_begin_s = t;
      }
      prev_t = t;
    }
  });
  fix_rate();
  s.t_end_s = prev_t;
  return s;
}

void add_sampling_warnings(const Sampling& s, AllanReport& report) {
  if (s.gaps > 0) {
    report.warnings.push_back(fmt::format(
        "{} sample(s) flagged with lost samples before them; Allan deviation assumes uniform "
        "sampling, so intervals near those gaps are distorted",
        s.gaps));
  }
  if (s.irregular > 0) {
    report.warnings.push_back(fmt::format(
        "{} sample interval(s) deviate by more than 50 % from 1/rate = {:.6g} s", s.irregular,
        1.0 / s.rate_hz));
  }
}

// Allan curve and noise model of channel ch (0..2 accelerometer [m/s²], 3..5 gyroscope [rad/s])
// over samples `range`, read a column chunk at a time (reads serialised by `read_lock`: a store
// need not allow concurrent reads).
ChannelResult analyze_channel(const SampleSource& src, IndexRange range, int ch, double rate,
                              const AllanOptions& options, std::mutex& read_lock) {
  static const char* names[6] = {"ax", "ay", "az", "gx", "gy", "gz"};
  static constexpr Channel columns[6] = {Channel::kAx, Channel::kAy, Channel::kAz,
                                         Channel::kGx, Channel::kGy, Channel::kGz};
  std::vector<double> buf(kDefaultChunkSamples);
  OverlappingAllanStream s(options.max_m, range.size());
  for (std::uint64_t i = range.first; i < range.last;) {
    const auto take = static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), range.last - i));
    {
      std::lock_guard lock(read_lock);
      src.read_column(columns[ch], i, take, buf.data());
    }
    s.add(buf.data(), take);
    i += take;
  }
  ChannelInfo info;
  info.name = names[ch];
  info.instrument = ch < 3 ? Instrument::kAccelerometer : Instrument::kGyroscope;
  return analyze(s, rate, info, options);
}

// Channels 0 … channels−1 on two threads (channel c on thread c mod 2, one stream per thread at
// a time so that memory stays at two streams' state).
std::vector<ChannelResult> analyze_channels(const SampleSource& src, IndexRange range, int channels,
                                            double rate, const AllanOptions& options) {
  std::vector<ChannelResult> out(static_cast<std::size_t>(channels));
  std::mutex read_lock;
  std::exception_ptr error[2];
  auto work = [&](int parity) {
    try {
      for (int ch = parity; ch < channels; ch += 2) {
        out[static_cast<std::size_t>(ch)] = analyze_channel(src, range, ch, rate, options, read_lock);
      }
    } catch (...) {
      error[parity] = std::current_exception();
    }
  };
  std::thread second(work, 1);
  work(0);
  second.join();
  for (const auto& e : error) if (e) std::rethrow_exception(e);
  return out;
}

}  // namespace

AllanReport analyze_recording(const Recording& rec, const AllanOptions& options) {
  AllanReport report;
  report.source = rec.dir.string();
  if (!rec.header.experiment_name.empty()) report.source += " (" + rec.header.experiment_name + ")";
  const SampleSource& src = rec.sample_source();
  const IndexRange range = selected_range(src, options);
  if (range.size() < 2) {
    throw std::runtime_error(fmt::format("Allan: {} has {} sample(s) in the selected time range",
                                         report.source, range.size()));
  }
  report.samples = range.size();
  const Sampling sampling = scan_sampling(src, range, rec.header.info.output_rate_hz, report.source);
  report.t_begin_s = sampling.t_begin_s;
  report.t_end_s = sampling.t_end_s;
  report.rate_hz = sampling.rate_hz;
  add_sampling_warnings(sampling, report);
  const int channels = rec.header.info.has_gyro ? 6 : 3;
  report.channels = analyze_channels(src, range, channels, sampling.rate_hz, options);
  report.kalibr = kalibr_parameters(report.channels, sampling.rate_hz);
  return report;
}

// ---------------------------------------------------------------------------------------------
// Text

std::ostream& operator<<(std::ostream& os, const AllanPoint& p) {
  os << fmt::format("tau {:.6g} s (m {}): adev {:.5g} [{:.5g}, {:.5g}], edf {:.4g} ({})", p.tau_s,
                    p.m, p.adev, p.adev_lo, p.adev_hi, p.edf, to_string(p.noise));
  return os;
}

std::ostream& operator<<(std::ostream& os, const AllanCurve& c) {
  os << fmt::format("Allan deviation of {} ({}, {}), {} samples at {:.6g} Hz, {:.1f} % intervals\n",
                    c.channel.name, to_string(c.channel.instrument), c.units.signal, c.samples,
                    c.rate_hz, 100.0 * c.confidence);
  os << fmt::format("  {:>12} {:>10} {:>12} {:>12} {:>12} {:>10}  {}\n", "tau [s]", "m", "adev",
                    "lo", "hi", "edf", "noise (EDF)");
  for (const auto& p : c.points) {
    os << fmt::format("  {:>12.6g} {:>10} {:>12.5g} {:>12.5g} {:>12.5g} {:>10.4g}  {}\n", p.tau_s,
                      p.m, p.adev, p.adev_lo, p.adev_hi, p.edf, to_string(p.noise));
  }
  return os;
}

std::ostream& operator<<(std::ostream& os, const Coefficient& c) {
  if (c.identified) {
    os << fmt::format("{} ({}) = {:.4g} ± {:.2g} {}  [dominates {:.3g} … {:.3g} s]", c.symbol,
                      c.name, c.value, c.sigma, c.unit, c.tau_lo_s, c.tau_hi_s);
  } else if (c.dominates) {
    os << fmt::format("{} ({}): not identified — dominates {:.3g} … {:.3g} s but the fit "
                      "{:.3g} ± {:.2g} is not significant; <= {:.3g} {}",
                      c.symbol, c.name, c.tau_lo_s, c.tau_hi_s, c.fitted, c.fitted_sigma,
                      c.upper_bound, c.unit);
  } else {
    os << fmt::format("{} ({}): not identified (no slope region in the measured tau range); "
                      "<= {:.3g} {}",
                      c.symbol, c.name, c.upper_bound, c.unit);
  }
  return os;
}

std::ostream& operator<<(std::ostream& os, const Readoff& r) {
  if (r.found) {
    os << fmt::format("{} = {:.4g} {} [{:.4g}, {:.4g}] from tau {:.3g} … {:.3g} s", r.name, r.value,
                      r.unit, r.lo, r.hi, r.tau_lo_s, r.tau_hi_s);
  } else {
    os << fmt::format("{}: not found — {}", r.name, r.note);
  }
  return os;
}

std::ostream& operator<<(std::ostream& os, const NoiseModel& m) {
  if (!m.ok) return os << "noise model: FIT FAILED — " << m.message << "\n";
  os << fmt::format("noise model over tau {:.3g} … {:.3g} s (reduced chi2 {:.3g}, {} dof):\n",
                    m.tau_min_s, m.tau_max_s, m.chi2_reduced, m.dof);
  for (int j = 0; j < kTerms; ++j) os << "  " << *coefficient(m, j) << "\n";
  os << "  read-offs: " << m.white_line << "\n";
  os << "             " << m.random_walk_line << "\n";
  os << "             " << m.bias_floor << "\n";
  if (!m.message.empty()) os << "  note: " << m.message << "\n";
  return os;
}

std::ostream& operator<<(std::ostream& os, const ChannelResult& r) {
  return os << r.curve << r.model;
}

namespace {
std::string kalibr_line(const char* key, double v, const char* unit, bool identified,
                        bool upper) {
  std::string status = identified ? "identified" : (upper ? "UPPER BOUND: not identified"
                                                          : "from slope read-off / partial");
  if (!std::isfinite(v)) status = "NOT AVAILABLE";
  return fmt::format("{}: {}  # [{}] {}\n", key, std::isfinite(v) ? fmt::format("{:.6g}", v) : "null",
                     unit, status);
}
}  // namespace

void write_kalibr_yaml(std::ostream& os, const KalibrParameters& k) {
  os << "# IMU noise parameters (Kalibr imu.yaml) from the Allan deviation, mean over axes\n";
  os << kalibr_line("accelerometer_noise_density", k.accelerometer_noise_density,
                    "m/s^2/sqrt(Hz)", k.accelerometer_noise_identified, false);
  os << kalibr_line("accelerometer_random_walk", k.accelerometer_random_walk, "m/s^3/sqrt(Hz)",
                    k.accelerometer_random_walk_identified,
                    k.accelerometer_random_walk_is_upper_bound);
  os << kalibr_line("gyroscope_noise_density", k.gyroscope_noise_density, "rad/s/sqrt(Hz)",
                    k.gyroscope_noise_identified, false);
  os << kalibr_line("gyroscope_random_walk", k.gyroscope_random_walk, "rad/s^2/sqrt(Hz)",
                    k.gyroscope_random_walk_identified, k.gyroscope_random_walk_is_upper_bound);
  os << fmt::format("update_rate: {:.6g}  # [Hz]\n", k.update_rate);
}

std::ostream& operator<<(std::ostream& os, const KalibrParameters& k) {
  write_kalibr_yaml(os, k);
  return os;
}

void write_summary_table(std::ostream& os, const AllanReport& r) {
  os << fmt::format("{:<4} {:>12} {:>12} {:>12} {:>12} {:>12} | {:>12} {:>12} {:>12}  {}\n", "axis",
                    "N", "K", "B", "Q", "R", "N@1s line", "K@3s line", "B=min/.664", "units");
  auto cell = [](const Coefficient& c) {
    return c.identified ? fmt::format("{:.4g}", c.value) : fmt::format("<={:.3g}", c.upper_bound);
  };
  auto rcell = [](const Readoff& x) {
    return x.found ? fmt::format("{:.4g}", x.value)
                   : (std::isfinite(x.value) ? fmt::format("<={:.3g}", x.value) : std::string("-"));
  };
  for (const auto& c : r.channels) {
    const auto& m = c.model;
    const auto& u = c.curve.units;
    os << fmt::format("{:<4} {:>12} {:>12} {:>12} {:>12} {:>12} | {:>12} {:>12} {:>12}  N {}, K {}, B {}, Q {}, R {}\n",
                      c.curve.channel.name, cell(m.white), cell(m.random_walk),
                      cell(m.bias_instability), cell(m.quantization), cell(m.rate_ramp),
                      rcell(m.white_line), rcell(m.random_walk_line), rcell(m.bias_floor), u.white,
                      u.random_walk, u.bias, u.quantization, u.ramp);
  }
  // Datasheet units.
  for (const auto& c : r.channels) {
    const auto& m = c.model;
    const double n = m.white.identified ? m.white.value : m.white_line.value;
    const double b = m.bias_floor.value;
    if (c.curve.channel.instrument == Instrument::kGyroscope) {
      // ARW: rad/√s → deg/√h is × 180/π × √3600.
      os << fmt::format("{:<4} ARW {} deg/sqrt(h), bias instability {} deg/h{}\n",
                        c.curve.channel.name, fmt_value(n * physics::kRadToDeg * 60.0),
                        fmt_value(b / physics::kDegPerHour),
                        m.bias_floor.found ? "" : " (upper bound)");
    } else if (c.curve.channel.instrument == Instrument::kAccelerometer) {
      os << fmt::format("{:<4} VRW {} m/s/sqrt(h) = {} ug/sqrt(Hz), bias instability {} ug{}\n",
                        c.curve.channel.name, fmt_value(n * 60.0),
                        fmt_value(n / physics::kMicroG),
                        fmt_value(b / physics::kMicroG),
                        m.bias_floor.found ? "" : " (upper bound)");
    }
  }
}

std::ostream& operator<<(std::ostream& os, const AllanReport& r) {
  os << fmt::format("Allan analysis of {}: {} samples at {:.6g} Hz, t = {:.6g} … {:.6g} s\n",
                    r.source, r.samples, r.rate_hz, r.t_begin_s, r.t_end_s);
  for (const auto& w : r.warnings) os << "WARNING: " << w << "\n";
  for (const auto& c : r.channels) os << "\n" << c;
  os << "\n";
  write_summary_table(os, r);
  os << "\n";
  write_kalibr_yaml(os, r.kalibr);
  return os;
}

// ---------------------------------------------------------------------------------------------
// JSON

namespace {
using nlohmann::json;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json to_json(const Coefficient& c) {
  return {{"symbol", c.symbol},   {"name", c.name},
          {"unit", c.unit},       {"identified", c.identified},
          {"value", num(c.value)}, {"sigma", num(c.sigma)},
          {"fitted", num(c.fitted)}, {"fitted_sigma", num(c.fitted_sigma)},
          {"dominates", c.dominates}, {"upper_bound", num(c.upper_bound)},
          {"dominates_tau_s", c.dominates ? json::array({c.tau_lo_s, c.tau_hi_s}) : json(nullptr)}};
}

json to_json(const Readoff& r) {
  return {{"name", r.name},     {"unit", r.unit},   {"found", r.found},
          {"value", num(r.value)}, {"lo", num(r.lo)}, {"hi", num(r.hi)},
          {"tau_s", json::array({num(r.tau_lo_s), num(r.tau_hi_s)})},
          {"note", r.note}};
}

json to_json(const ChannelResult& r) {
  json pts = json::array();
  for (const auto& p : r.curve.points) {
    pts.push_back({{"tau_s", p.tau_s},      {"m", p.m},           {"terms", p.terms},
                   {"avar", num(p.avar)},   {"adev", num(p.adev)}, {"adev_lo", num(p.adev_lo)},
                   {"adev_hi", num(p.adev_hi)}, {"edf", num(p.edf)},
                   {"noise", to_string(p.noise)}});
  }
  const NoiseModel& m = r.model;
  json model = {{"ok", m.ok},
                {"message", m.message},
                {"chi2_reduced", num(m.chi2_reduced)},
                {"dof", m.dof},
                {"tau_range_s", json::array({num(m.tau_min_s), num(m.tau_max_s)})},
                {"Q", to_json(m.quantization)},
                {"N", to_json(m.white)},
                {"B", to_json(m.bias_instability)},
                {"K", to_json(m.random_walk)},
                {"R", to_json(m.rate_ramp)},
                {"readoffs",
                 {{"N_line", to_json(m.white_line)},
                  {"K_line", to_json(m.random_walk_line)},
                  {"B_floor", to_json(m.bias_floor)}}}};
  return {{"channel", r.curve.channel.name},
          {"instrument", to_string(r.curve.channel.instrument)},
          {"unit", r.curve.units.signal},
          {"rate_hz", r.curve.rate_hz},
          {"samples", r.curve.samples},
          {"confidence", r.curve.confidence},
          {"points", pts},
          {"model", model}};
}

json to_json(const KalibrParameters& k) {
  return {{"accelerometer_noise_density", num(k.accelerometer_noise_density)},
          {"accelerometer_random_walk", num(k.accelerometer_random_walk)},
          {"gyroscope_noise_density", num(k.gyroscope_noise_density)},
          {"gyroscope_random_walk", num(k.gyroscope_random_walk)},
          {"update_rate", num(k.update_rate)},
          {"units",
           {{"accelerometer_noise_density", "m/s^2/sqrt(Hz)"},
            {"accelerometer_random_walk", "m/s^3/sqrt(Hz)"},
            {"gyroscope_noise_density", "rad/s/sqrt(Hz)"},
            {"gyroscope_random_walk", "rad/s^2/sqrt(Hz)"},
            {"update_rate", "Hz"}}},
          {"accelerometer_noise_identified", k.accelerometer_noise_identified},
          {"accelerometer_random_walk_identified", k.accelerometer_random_walk_identified},
          {"accelerometer_random_walk_is_upper_bound", k.accelerometer_random_walk_is_upper_bound},
          {"gyroscope_noise_identified", k.gyroscope_noise_identified},
          {"gyroscope_random_walk_identified", k.gyroscope_random_walk_identified},
          {"gyroscope_random_walk_is_upper_bound", k.gyroscope_random_walk_is_upper_bound}};
}
}  // namespace

void write_json(std::ostream& os, const ChannelResult& result, int indent) {
  os << to_json(result).dump(indent) << "\n";
}

void write_json(std::ostream& os, const AllanReport& r, int indent) {
  json ch = json::array();
  for (const auto& c : r.channels) ch.push_back(to_json(c));
  json j = {{"schema", kSchema},
            {"estimator", {{"name", kEstimatorName}, {"version", kEstimatorVersion}}},
            {"status", "ok"},
            {"source", r.source},
            {"rate_hz", r.rate_hz},
            {"samples", r.samples},
            {"t_range_s", json::array({num(r.t_begin_s), num(r.t_end_s)})},
            {"warnings", r.warnings},
            {"channels", ch},
            {"kalibr", to_json(r.kalibr)}};
  os << j.dump(indent) << "\n";
}

}  // namespace stend::allan
