// `stend gap validate`: planted effects, null runs, out-of-vocabulary runs. See validate.hpp.
#include "stend/diagnosis/validate.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <numbers>
#include <ostream>
#include <set>

#include "segment_mean_noise.hpp"
#include "stend/model/noise.hpp"
#include "stend/physics/table_chain.hpp"

namespace stend::diagnosis {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using model::TermKind;
using model::TermSpec;

MatrixXd rows_block(const GapInput& in, const TermSpec& t) {
  model::ErrorModel m;
  m.instrument = in.spec.model.instrument;
  m.terms = {t};
  MatrixXd B(3 * static_cast<Eigen::Index>(in.segments.size()), m.size());
  for (std::size_t s = 0; s < in.segments.size(); ++s)
    B.middleRows(3 * static_cast<Eigen::Index>(s), 3) = m.regressor(in.segments[s].point.stimulus);
  return B;
}

double white_floor(const ValidationDesign& d) {
  const double sigma = model::WhiteNoise::sigma_from_density(d.noise_density, 1.0 / d.rate_hz);
  return sigma / std::sqrt(d.record_s * d.rate_hz);
}

bool same_effect(const std::string& named, const std::string& planted) {
  auto kind = [](const std::string& s) { return s.substr(0, s.find('(')); };
  return kind(named) == kind(planted);
}

// Stimulus of a generated segment: gravity through the table at h, δ [deg] (identity mount), die
// temperature [degC] approaching the setpoint sp [degC] with the die lag, mid-time [s], ramp direction.
model::Stimulus<double> generated_stimulus(const ValidationDesign& d, double h, double dl, double die, double sp,
                                           double mid, int dir) {
  model::Stimulus<double> st;
  const Eigen::Vector3d f = table_stimulus(st, 0.0, h * physics::kDegToRad, dl * physics::kDegToRad,
                                           Eigen::Matrix3d::Identity(), d.gravity);
  st.input = f;
  st.specific_force = f;
  st.gravity_up = f / f.norm();
  st.temperature_c = die;
  st.temperature_rate_cps = -(die - sp) / d.die_lag_s;
  st.time_s = mid;
  st.temperature_direction = dir;
  return st;
}

}  // namespace

ValidationDesign default_design() {
  ValidationDesign d;
  d.positions = {{0, 0},   {0, 180}, {0, -90}, {0, 90},  {90, 0},    {-90, 0},  {45, 0},
                 {-45, 0}, {0, 45},  {0, -45}, {45, 45}, {45, -135}, {-30, 120}, {60, -60}};
  return d;
}

ValidationDesign many_positions_design(int n) {
  ValidationDesign d;
  d.setpoints_c = {25.0};
  d.positions.clear();
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - 2.0 * (k + 0.5) / n, r = std::sqrt(1 - z * z), phi = golden * k;
    const Eigen::Vector3d up(r * std::cos(phi), r * std::sin(phi), z);
    const auto [h, dl] = physics::paper_table_pointing(up);
    d.positions.push_back({h * physics::kRadToDeg, dl * physics::kRadToDeg});
  }
  return d;
}

estimation::ModelSpec validation_model() {
  estimation::ModelSpec s;
  s.model.instrument = model::Instrument::kAccelerometer;
  s.model.terms = {TermSpec{TermKind::kBias, 1, 25.0}, TermSpec{TermKind::kScale, 1, 25.0}};
  s.source = "bias + scale (validation model)";
  return s;
}

GapInput generate(const ValidationDesign& d, const estimation::ModelSpec& fit_model, const Planted& truth,
                  std::uint64_t seed) {
  GapInput in = generated_input(fit_model, "validation generator (segment level)");
  model::Rng rng(seed);
  const double dt = 1.0 / d.rate_hz;
  const double sigma = model::WhiteNoise::sigma_from_density(d.noise_density, dt);
  const double se = white_floor(d);
  const double bi = d.bias_instability > 0 ? d.bias_instability : 0.3 * se;
  SegmentMeanNoise mean_noise(rng, se, sigma, bi, d.bias_correlation_s);
  double t = 0.0;
  double die = 22.0, prev_sp = kNaN;
  int seg_id = 0;
  std::map<std::string, int> og;
  std::vector<double> levels;
  for (double sp : d.setpoints_c) {
    const double t_change = t, die_start = die;
    const int dir = std::isfinite(prev_sp) ? (sp > prev_sp ? 1 : -1) : 0;
    prev_sp = sp;
    t += d.hold_s;
    const int level = temperature_group(levels, sp);
    double t_last_orient = t_change;
    for (const auto& [h, dl] : d.positions) {
      t += d.move_s;
      SegmentData s;
      auto& p = s.point;
      const double mid = time_segment(s, seg_id++, t, d.record_s, d.rate_hz);
      const double decay = std::exp(-(mid - t_change) / d.die_lag_s);
      die = sp + (die_start - sp) * decay;
      p.stimulus = generated_stimulus(d, h, dl, die, sp, mid, dir);
      measure_segment(truth, mean_noise, rng, mid, s);
      p.segment.label = "T" + std::to_string(static_cast<int>(sp)) + " h" + std::to_string(static_cast<int>(h)) + " d" +
                std::to_string(static_cast<int>(dl));
      char name[64];
      std::snprintf(name, sizeof name, "h=%g d=%g", h, dl);
      s.orientation = orientation_group(og, name);
      s.orientation_name = name;
      s.setpoint_c = sp;
      s.temperature_group = level;
      s.ramp_direction = dir;
      s.time_since_change_s = t - std::max(t_last_orient, t_change);
      t_last_orient = t + d.record_s;
      s.averaging_s = d.record_s;
      in.segments.push_back(s);
      t += d.record_s;
    }
  }
  in.twin_sample_std = Eigen::Vector3d::Constant(sigma);
  return in;
}

namespace {

// One designed experiment as the validation sees it: how to simulate it, the model fitted, what is
// planted, and how many null / out-of-vocabulary runs it gets.
struct Experiment {
  std::string name;                    // CandidateValidation::experiment
  std::string tag;                     // short key for the confusion matrix ("" = none)
  estimation::ModelSpec fit_model;
  std::function<GapInput(const Planted&, std::uint64_t)> make;
  double floor = 0;                    // averaged white floor of a segment mean [unit]
  double bias_sigma = 0.05, scale_sigma = 0.002;  // the true model's own part [unit], [1]
  std::vector<std::string> plant;      // term kinds to plant; empty = every candidate kind
  bool list_not_excited = true;        // keep rows (no runs) for candidates this design cannot excite
  int null_runs = 0, oov_runs = 0;
  std::size_t oov_period = 1;          // segments per repeat of the out-of-vocabulary pattern
  std::size_t oov_segments = 0;
};

// Counters behind the summary figures (totals and per experiment).
struct Tally {
  int top1_n = 0, top1_ok = 0, cov_n = 0, cov_ok = 0, closed_n = 0;
  double closed_sum = 0;
};

// The true model's own part (the fitted model's terms) at plausible MEMS values: normal with
// bias_sigma [unit] for bias terms, scale_sigma [1] for the others.
Planted base_truth(const Experiment& ex, model::Rng& r) {
  Planted p;
  p.model = ex.fit_model.model;
  p.theta = VectorXd::Zero(p.model.size());
  for (std::size_t k = 0; k < p.model.terms.size(); ++k) {
    const int off = p.model.offset(k), n = model::param_count(p.model.terms[k]);
    const double s = p.model.terms[k].kind == TermKind::kBias ? ex.bias_sigma : ex.scale_sigma;
    for (int i = 0; i < n; ++i) p.theta[off + i] = s * r.normal();
  }
  return p;
}

// The design of a term list on the rows of `in` (3 per segment).
MatrixXd rows_design(const GapInput& in, const std::vector<TermSpec>& terms) {
  MatrixXd A(3 * static_cast<Eigen::Index>(in.segments.size()), 0);
  for (const auto& t : terms) {
    const MatrixXd B = rows_block(in, t);
    MatrixXd C(A.rows(), A.cols() + B.cols());
    C << A, B;
    A = C;
  }
  return A;
}

// What the runs of one experiment share.
struct Context {
  const Experiment& ex;
  const ValidateOptions& o;
  GapOptions gopt;                                  // blind runs: no alias analysis
  GapInput probe;                                   // one run of the design (ranks, regressors)
  std::map<std::string, CandidateResult> declared;  // the probe's candidates, by name
  MatrixXd A0;                                      // the fitted model's design on the probe
  Eigen::ColPivHouseholderQR<MatrixXd> qr0;         // of A0
};

// The random state and the figures every run adds to.
struct Sinks {
  model::Rng& prng;
  std::uint64_t& seed;
  ValidationReport& rep;
  Tally& tally;
};

// Alias pairs and identifiability, declared beforehand from one run of the design (rank only, no
// noise involved), and the baseline design for sizing a planted effect's unabsorbable part.
Context probe_design(const Experiment& ex, const ValidateOptions& o, model::Rng& prng, std::uint64_t& seed) {
  Context cx{ex, o, o.gap, ex.make(base_truth(ex, prng), seed++), {}, {}, {}};
  GapOptions aopt = o.gap;
  aopt.check_aliases = true;
  aopt.max_steps = 0;
  for (const auto& c : diagnose(cx.probe, aopt).candidates) cx.declared[c.term] = c;
  cx.gopt.check_aliases = false;
  cx.A0 = rows_design(cx.probe, ex.fit_model.model.terms);
  cx.qr0.compute(cx.A0);
  return cx;
}

// One planted candidate per kind (temperature polynomials at order 2), restricted to --only and to
// the experiment's plant list; those the design cannot excite are listed in ev.not_excited.
std::vector<Candidate> planted_candidates(const Context& cx, ExperimentValidation& ev) {
  const auto& only = cx.o.only;
  const auto& kinds_to_plant = cx.ex.plant;
  std::vector<Candidate> plant;
  std::set<int> kinds;
  for (const auto& c : default_candidates(cx.ex.fit_model.model)) {
    const std::string kname = model::term_name(c.term.kind);
    if (!only.empty() && std::find(only.begin(), only.end(), c.name) == only.end() &&
        std::find(only.begin(), only.end(), kname) == only.end())
      continue;
    if (!kinds_to_plant.empty() && std::find(kinds_to_plant.begin(), kinds_to_plant.end(), kname) == kinds_to_plant.end())
      continue;
    const bool temp = c.term.kind == TermKind::kBiasTemperature || c.term.kind == TermKind::kScaleTemperature;
    if (temp && c.term.order != 2) continue;
    if (kinds.count(static_cast<int>(c.term.kind))) continue;
    kinds.insert(static_cast<int>(c.term.kind));
    if (rows_block(cx.probe, c.term).norm() == 0.0) {
      ev.not_excited.push_back(c.name);
      if (!cx.ex.list_not_excited) continue;
    }
    plant.push_back(c);
  }
  return plant;
}

// Planted parameters of candidate columns C: standard normal, scaled so the part of C·θ the model
// cannot absorb (all of it when not identifiable) has an RMS of size × floor [unit]; empty when
// the effect is zero.
VectorXd planted_parameters(const Context& cx, const MatrixXd& C, bool identifiable, double size, model::Rng& prng) {
  VectorXd th(C.cols());
  for (Eigen::Index i = 0; i < th.size(); ++i) th[i] = prng.normal();
  const VectorXd eff = C * th;
  const VectorXd orth = eff - cx.A0 * cx.qr0.solve(eff);
  const double rms_o = std::sqrt(orth.squaredNorm() / static_cast<double>(orth.size()));
  const double rms_e = std::sqrt(eff.squaredNorm() / static_cast<double>(eff.size()));
  const double base = identifiable && rms_o > 1e-9 * rms_e ? rms_o : rms_e;
  if (!(base > 0)) return {};
  return th * (size * cx.ex.floor / base);
}

// 1-based rank of the planted term among the evaluated static candidates (one past the last when
// absent).
int planted_rank(const GapReport& r, const std::string& planted) {
  int rank = 0, pos = 0;
  for (const auto& cr : r.candidates) {
    if (cr.noise_stage || !cr.evaluated) continue;
    ++pos;
    if (same_effect(cr.term, planted) && rank == 0) rank = pos;
  }
  return rank > 0 ? rank : pos + 1;
}

// Fraction of the excess squared held-out gap above the floor that the selection closed, in [0, 1].
double closed_fraction(const GapReport& r) {
  const double h0 = r.steps.front().heldout_rms, f0 = r.steps.front().floor_rms;
  const double exq = h0 * h0 - f0 * f0;
  const double cl = h0 * h0 - r.unexplained_heldout_rms * r.unexplained_heldout_rms;
  return exq > 0 ? std::clamp(cl / exq, 0.0, 1.0) : 1.0;
}

// Running sums of one (candidate, size) cell.
struct SizeSums {
  CandidateValidation::BySize bs;
  double rank_sum = 0, closed = 0, ratio_sum = 0;
  int ratio_n = 0;
};

// Interval coverage and recovered/planted ratio of the candidate's reported size parameter.
void score_size(const GapReport& r, const Candidate& c, const VectorXd& th, bool counted, SizeSums& ss, Tally& tally,
                model::Instrument inst) {
  const auto info = model::param_info(c.term, inst);
  for (const auto& cr : r.candidates)
    if (cr.term == c.name && std::isfinite(cr.size)) {
      for (std::size_t k = 0; k < info.size(); ++k)
        if (info[k].name == cr.size_param) {
          const double planted = th[static_cast<Eigen::Index>(k)];
          ++ss.bs.coverage_n;
          const bool in_ci = cr.ci_lo <= planted && planted <= cr.ci_hi;
          ss.bs.covered += in_ci ? 1 : 0;
          if (planted != 0) {
            ss.ratio_sum += cr.size / planted;
            ++ss.ratio_n;
          }
          if (counted) {
            ++tally.cov_n;
            tally.cov_ok += in_ci ? 1 : 0;
          }
        }
    }
}

// Scores one blind diagnosis of a planted run: top-1 (strict, or an alias declared beforehand),
// rank, gap closed, coverage; runs at ≥ 5× the floor go into the confusion matrix and, when the
// candidate is identifiable, into the tally.
void score_run(const GapReport& r, const Context& cx, const Candidate& c, const CandidateValidation& cv,
               const VectorXd& th, double size, SizeSums& ss, Sinks& out) {
  const bool counted = cv.identifiable && size >= 5;
  ++ss.bs.runs;
  const std::string named = r.selected.empty() ? "(none)" : r.selected.front();
  bool alias_ok = false;
  for (const auto& a : cv.aliases) alias_ok = alias_ok || same_effect(named, a);
  const bool strict = same_effect(named, c.name);
  ss.bs.top1_strict += strict ? 1 : 0;
  ss.bs.top1 += (strict || alias_ok) ? 1 : 0;
  ss.rank_sum += planted_rank(r, c.name);
  if (!r.steps.empty()) {
    const double frac = closed_fraction(r);
    ss.closed += frac;
    if (counted) {
      out.tally.closed_sum += frac;
      ++out.tally.closed_n;
    }
  }
  score_size(r, c, th, counted, ss, out.tally, cx.ex.fit_model.model.instrument);
  if (size >= 5) {
    const std::string key = cx.ex.tag.empty() ? c.name : c.name + " [" + cx.ex.tag + "]";
    out.rep.confusion[key][named] += 1;
    if (cv.identifiable) {
      ++out.tally.top1_n;
      out.tally.top1_ok += (strict || alias_ok) ? 1 : 0;
    }
  }
}

// Seeds runs of the candidate planted at `size` × the floor, each diagnosed blind.
CandidateValidation::BySize validate_size(const Context& cx, const Candidate& c, const CandidateValidation& cv,
                                          const MatrixXd& C, double size, Sinks& out) {
  SizeSums ss;
  ss.bs.size = size;
  for (int sd = 0; sd < cx.o.seeds; ++sd) {
    Planted truth = base_truth(cx.ex, out.prng);
    const VectorXd th = planted_parameters(cx, C, cv.identifiable, size, out.prng);
    if (th.size() == 0) break;
    truth.model.terms.push_back(c.term);
    VectorXd full(truth.theta.size() + th.size());
    full << truth.theta, th;
    truth.theta = full;
    const GapReport r = diagnose(cx.ex.make(truth, out.seed++), cx.gopt);
    if (r.ok) score_run(r, cx, c, cv, th, size, ss, out);
  }
  if (ss.bs.runs > 0) {
    ss.bs.mean_rank = ss.rank_sum / ss.bs.runs;
    ss.bs.closed = ss.closed / ss.bs.runs;
    ss.bs.recovered_ratio = ss.ratio_n ? ss.ratio_sum / ss.ratio_n : kNaN;
  }
  return ss.bs;
}

// One planted candidate at every size: identifiability and aliases as declared by the probe.
CandidateValidation validate_candidate(const Context& cx, const Candidate& c, Sinks& out) {
  CandidateValidation cv;
  cv.term = c.name;
  cv.experiment = cx.ex.name;
  const auto dit = cx.declared.find(c.name);
  cv.identifiable = dit != cx.declared.end() && dit->second.evaluated;
  if (dit != cx.declared.end()) cv.aliases = dit->second.aliases;
  const MatrixXd C = rows_block(cx.probe, c.term);
  for (double m : cx.o.sizes) cv.by_size.push_back(validate_size(cx, c, cv, C, m, out));
  return cv;
}

// Null runs: the true model is the fitted one; any term named or reported significant is a false
// positive (claims_an_effect).
void null_runs(const Context& cx, ExperimentValidation& ev, Sinks& out) {
  for (int i = 0; i < cx.ex.null_runs; ++i) {
    const GapReport r = diagnose(cx.ex.make(base_truth(cx.ex, out.prng), out.seed++), cx.gopt);
    if (!r.ok) continue;
    ++ev.null_runs;
    if (!claims_an_effect(r)) continue;
    ++ev.null_false_positives;
    std::string what = "(significant, not named)";
    if (!r.selected.empty())
      what = r.selected.front();
    else
      for (const auto& c : r.candidates)
        if (!c.noise_stage && c.significant) {
          what = c.term + " (significant, not named)";
          break;
        }
    ++out.rep.null_named[what + (cx.ex.tag.empty() ? "" : " [" + cx.ex.tag + "]")];
  }
}

// Out of vocabulary: the z reading jumps by 8× the floor in one segment of every repeat of the
// pattern (a part that shifts at that table position), something no term of the vocabulary
// describes. The first 6 segments of a repeat are left clean.
void oov_runs(const Context& cx, ExperimentValidation& ev, Sinks& out) {
  const std::size_t per = cx.ex.oov_period;
  for (int i = 0; i < cx.ex.oov_runs; ++i) {
    Planted p = base_truth(cx.ex, out.prng);
    p.extra.assign(cx.ex.oov_segments, Eigen::Vector3d::Zero());
    const std::size_t where = 6 + static_cast<std::size_t>(i) % (per > 6 ? per - 6 : 1);
    for (std::size_t s = 0; s < p.extra.size(); ++s)
      if (s % per == where % per) p.extra[s][2] = 8.0 * cx.ex.floor * (i % 2 ? 1.0 : -1.0);
    const GapReport r = diagnose(cx.ex.make(p, out.seed++), cx.gopt);
    if (!r.ok) continue;
    ++ev.oov_runs;
    if (r.explanation.empty() && !r.at_floor) ++ev.oov_unexplained;
    if (!r.explanation.empty()) ++ev.oov_wrong_name;
  }
}

// The experiment's summary figures from its tally, added to the totals and the report.
void summarize(ExperimentValidation& ev, const Tally& tally, Tally& total, ValidationReport& rep) {
  ev.planted_at5 = tally.top1_n;
  ev.top1_ok_at5 = tally.top1_ok;
  ev.top1_at5 = tally.top1_n ? static_cast<double>(tally.top1_ok) / tally.top1_n : kNaN;
  ev.coverage = tally.cov_n ? static_cast<double>(tally.cov_ok) / tally.cov_n : kNaN;
  ev.closed_at5 = tally.closed_n ? tally.closed_sum / tally.closed_n : kNaN;
  total.top1_n += tally.top1_n;
  total.top1_ok += tally.top1_ok;
  total.cov_n += tally.cov_n;
  total.cov_ok += tally.cov_ok;
  total.closed_n += tally.closed_n;
  total.closed_sum += tally.closed_sum;
  rep.null_runs += ev.null_runs;
  rep.null_false_positives += ev.null_false_positives;
  rep.oov_runs += ev.oov_runs;
  rep.oov_unexplained += ev.oov_unexplained;
  rep.oov_wrong_name += ev.oov_wrong_name;
  rep.experiments.push_back(ev);
}

// Declares aliases and identifiability from a probe of the design (rank only), plants each candidate at
// each size in the experiment, fits the model without it and diagnoses blind; appends the
// CandidateValidation rows, the confusion entries and the null / out-of-vocabulary runs.
// `done(f)` is told the share of this experiment done, after each candidate.
void validate_experiment(const Experiment& ex, const ValidateOptions& o, model::Rng& prng, std::uint64_t& seed,
                         ValidationReport& rep, Tally& total, const std::function<void(double)>& done) {
  ExperimentValidation ev;
  ev.experiment = ex.name;
  ev.unit = ex.fit_model.model.instrument == model::Instrument::kGyroscope ? "rad/s" : "m/s^2";
  ev.floor = ex.floor;
  Tally tally;
  Sinks out{prng, seed, rep, tally};
  const Context cx = probe_design(ex, o, prng, seed);
  const std::vector<Candidate> candidates = planted_candidates(cx, ev);
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    rep.candidates.push_back(validate_candidate(cx, candidates[i], out));
    done(static_cast<double>(i + 1) / static_cast<double>(candidates.size() + 1));  // null + oov runs: one more share
  }
  null_runs(cx, ev, out);
  oov_runs(cx, ev, out);
  summarize(ev, tally, total, rep);
}

// The static tumble × temperature design with the accelerometer bias + scale model.
Experiment static_experiment(const ValidateOptions& o) {
  const ValidationDesign& d = o.design;
  Experiment e;
  e.name = "static tumble x temperature, accel bias+scale";
  e.fit_model = validation_model();
  e.make = [&d = o.design, fm = e.fit_model](const Planted& p, std::uint64_t s) { return generate(d, fm, p, s); };
  e.floor = white_floor(d);
  e.null_runs = o.null_runs;
  e.oov_runs = o.oov_runs;
  e.oov_period = d.positions.size();
  e.oov_segments = d.positions.size() * d.setpoints_c.size();
  return e;
}

// The same static design with a bias-only model: scale itself, and a wrong local g (a common scale
// on a static design: declared alias).
Experiment static_bias_only_experiment(const ValidateOptions& o) {
  Experiment e;
  e.name = "static tumble x temperature, accel bias only";
  e.tag = "static, bias only";
  e.fit_model = validation_model();
  e.fit_model.model.terms = {TermSpec{TermKind::kBias, 1, 25.0}};
  e.fit_model.source = "bias (validation model)";
  e.make = [&d = o.design, fm = e.fit_model](const Planted& p, std::uint64_t s) { return generate(d, fm, p, s); };
  e.floor = white_floor(o.design);
  e.plant = {"scale", "gravity_error"};
  return e;
}

// The rate table with the gyroscope bias + scale model.
Experiment rate_gyro_experiment(const ValidateOptions& o) {
  const RateDesign& rd = o.rate_design;
  Experiment g;
  g.name = "rate table, gyro bias+scale";
  g.tag = "rate, gyro";
  g.fit_model = rate_model(model::Instrument::kGyroscope);
  g.make = [&rd = o.rate_design, fm = g.fit_model](const Planted& p, std::uint64_t s) {
    return generate_rate(rd, fm, p, s);
  };
  g.floor = rate_white_floor(rd, model::Instrument::kGyroscope);
  g.bias_sigma = 0.01;  // rad/s (≈ 0.6 deg/s)
  g.list_not_excited = false;
  g.null_runs = o.rate_null_runs >= 0 ? o.rate_null_runs : (o.null_runs + 1) / 2;
  g.oov_runs = o.rate_oov_runs >= 0 ? o.rate_oov_runs : (o.oov_runs + 1) / 2;
  g.oov_period = rd.axes.size() * rd.rates_dps.size();
  g.oov_segments = g.oov_period;
  return g;
}

// The accelerometer off the axis: the centripetal ω×(ω×r) at a known r is an input of known
// size apart from gravity, so a wrong local g no longer hides in the scale; with one mount it
// still hides in scale + a radius error (g and r off by the same fraction), a second mount at
// another known offset separates that too.
Experiment rate_accel_experiment(const ValidateOptions& o) {
  const RateDesign& ra = o.rate_accel_design;
  Experiment a;
  a.name = ra.remount_offsets_m.empty() ? "rate table, accel bias+scale (off axis)"
                                        : "rate table, accel bias+scale (off axis, two mounts)";
  a.tag = "rate, accel";
  a.fit_model = rate_model(model::Instrument::kAccelerometer);
  a.make = [&ra = o.rate_accel_design, fm = a.fit_model](const Planted& p, std::uint64_t s) {
    return generate_rate(ra, fm, p, s);
  };
  a.floor = rate_white_floor(ra, model::Instrument::kAccelerometer);
  a.plant = {"lever_arm", "gravity_error"};
  a.list_not_excited = false;
  return a;
}

}  // namespace

bool ValidateOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& what) {
    if (why) *why = what;
    return false;
  };
  if (seeds < 1) return fail("seeds: must be >= 1");
  if (sizes.empty()) return fail("sizes: give at least one multiple of the noise floor");
  for (double s : sizes)
    if (!(s > 0)) return fail("sizes: every multiple of the noise floor must be > 0");
  if (null_runs < 0 || oov_runs < 0 || noise_seeds < 0 || noise_null_runs < 0 || design_runs < 0)
    return fail("null_runs, oov_runs, noise_seeds, noise_null_runs and design_runs must be >= 0");
  if (std::string g; !gap.IsValid(&g)) return fail("gap." + g);
  return true;
}

ValidationReport run_validation(const ValidateOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  ValidationReport rep;
  rep.floor_mps2 = white_floor(o.design);
  model::Rng prng(o.seed * 7919 + 17);
  std::uint64_t seed = o.seed * 1000003;
  Tally total;
  std::vector<Experiment> exps = {static_experiment(o)};
  if (o.more_designs) {
    exps.push_back(static_bias_only_experiment(o));
    exps.push_back(rate_gyro_experiment(o));
    exps.push_back(rate_accel_experiment(o));
  }
  // Progress: each experiment one share, the noise stage one more.
  const double shares = static_cast<double>(exps.size() + 1);
  const auto progress = [&o, shares](double share, double within, const std::string& stage) {
    if (o.on_progress) o.on_progress((share + within) / shares, stage);
  };
  for (std::size_t k = 0; k < exps.size(); ++k) {
    progress(static_cast<double>(k), 0.0, exps[k].name);
    validate_experiment(exps[k], o, prng, seed, rep, total,
                        [&](double within) { progress(static_cast<double>(k), within, exps[k].name); });
  }
  progress(static_cast<double>(exps.size()), 0.0, "design cases and noise stage");
  rep.design_cases = run_design_cases(o.design_runs, o.seed, o.gap);
  rep.top1_at5 = total.top1_n ? static_cast<double>(total.top1_ok) / total.top1_n : kNaN;
  rep.coverage = total.cov_n ? static_cast<double>(total.cov_ok) / total.cov_n : kNaN;
  rep.closed_at5 = total.closed_n ? total.closed_sum / total.closed_n : kNaN;
  rep.false_positive_rate = rep.null_runs ? static_cast<double>(rep.null_false_positives) / rep.null_runs : kNaN;
  {  // Noise-stage candidates, sample level (validate_noise.cpp).
    const auto tn = std::chrono::steady_clock::now();
    rep.noise_stage = run_noise_validation(o);
    rep.noise_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tn).count();
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

bool targets_met(const ValidationReport& r) {
  int noise_null_runs = 0, noise_null_flags = 0;
  for (const auto& n : r.noise_stage)
    if (n.experiment == "null")
      for (const auto& b : n.by_size) {
        noise_null_runs += b.runs;
        noise_null_flags += b.detected;  // runs in which any noise candidate fired
      }
  const bool noise_ok = noise_null_runs == 0 || noise_null_flags <= 0.05 * noise_null_runs;
  // A figure that was not measured (NaN: no run at 5x, no null run) does not meet its target.
  const bool cases_ok = std::all_of(r.design_cases.begin(), r.design_cases.end(), design_case_met);
  return r.top1_at5 >= 0.9 && r.closed_at5 >= 0.8 && r.false_positive_rate <= 0.05 && r.oov_wrong_name == 0 &&
         noise_ok && cases_ok;
}

}  // namespace stend::diagnosis
