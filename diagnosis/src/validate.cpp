// `stend gap validate`: planted effects, null runs, out-of-vocabulary runs. See validate.hpp.
#include "stend/gap/validate.hpp"

#include <nlohmann/json.hpp>

#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <ostream>
#include <set>

#include "stend/geometry.hpp"
#include "stend/model/noise.hpp"

namespace stend::gap {

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
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - 2.0 * (k + 0.5) / n, r = std::sqrt(1 - z * z), phi = golden * k;
    const Eigen::Vector3d up(r * std::cos(phi), r * std::sin(phi), z);
    // f = g·[−sin δ cos h, sin h, cos δ cos h]
    const double h = std::asin(std::clamp(up[1], -1.0, 1.0)) / geometry::kDegToRad;
    const double dl = std::atan2(-up[0], up[2]) / geometry::kDegToRad;
    d.positions.push_back({h, dl});
  }
  return d;
}

batch_lsq::ModelSpec validation_model() {
  batch_lsq::ModelSpec s;
  s.model.instrument = model::Instrument::kAccelerometer;
  s.model.terms = {TermSpec{TermKind::kBias, 1, 25.0}, TermSpec{TermKind::kScale, 1, 25.0}};
  s.source = "bias + scale (validation model)";
  return s;
}

GapInput generate(const ValidationDesign& d, const batch_lsq::ModelSpec& fit_model, const Planted& truth,
                  std::uint64_t seed) {
  GapInput in;
  in.spec = fit_model;
  in.source = "validation generator (segment level)";
  in.truth_source = "generator truth";
  in.floor_source = "batch means of 8 blocks (generator: white floor × sqrt(chi2_7/7))";
  model::Rng rng(seed);
  const double dt = 1.0 / d.rate_hz;
  const double sigma = model::WhiteNoise::sigma_from_density(d.noise_density, dt);
  const double se = white_floor(d);
  const double bi = d.bias_instability > 0 ? d.bias_instability : 0.3 * se;
  Eigen::Vector3d gm;
  for (int a = 0; a < 3; ++a) gm[a] = bi * rng.normal();
  double t = 0.0, t_prev_mid = 0.0;
  double die = 22.0, prev_sp = kNaN;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  int seg_id = 0;
  std::map<std::string, int> og;
  std::vector<double> levels;
  for (double sp : d.setpoints_c) {
    const double t_change = t, die_start = die;
    const int dir = std::isfinite(prev_sp) ? (sp > prev_sp ? 1 : -1) : 0;
    prev_sp = sp;
    t += d.hold_s;
    int level = -1;
    for (std::size_t i = 0; i < levels.size(); ++i)
      if (std::abs(levels[i] - sp) <= 2.0) level = static_cast<int>(i);
    if (level < 0) {
      levels.push_back(sp);
      level = static_cast<int>(levels.size()) - 1;
    }
    double t_last_orient = t_change;
    for (const auto& [h, dl] : d.positions) {
      t += d.move_s;
      SegmentData s;
      auto& p = s.point;
      p.segment_id = seg_id++;
      p.t_start_s = t;
      p.t_end_s = t + d.record_s;
      p.samples_used = static_cast<std::size_t>(d.record_s * d.rate_hz);
      const double mid = t + 0.5 * d.record_s;
      const double decay = std::exp(-(mid - t_change) / d.die_lag_s);
      die = sp + (die_start - sp) * decay;
      auto& st = p.stimulus;
      const Eigen::Vector3d f = table_stimulus(st, 0.0, h * geometry::kDegToRad, dl * geometry::kDegToRad, I, d.gravity);
      st.input = f;
      st.specific_force = f;
      st.gravity_up = f / f.norm();
      st.temperature_c = die;
      st.temperature_rate_cps = -(die - sp) / d.die_lag_s;
      st.time_s = mid;
      st.temperature_direction = dir;
      Eigen::Vector3d y = truth.model.measure<double>(truth.theta.data(), st);
      if (!truth.extra.empty()) y += truth.extra[static_cast<std::size_t>(p.segment_id) % truth.extra.size()];
      // Bias instability between segment mid-times (exact GM step), white noise of the mean.
      const double phi = std::exp(-(mid - t_prev_mid) / d.bias_correlation_s);
      t_prev_mid = mid;
      for (int a = 0; a < 3; ++a) {
        gm[a] = phi * gm[a] + bi * std::sqrt(1 - phi * phi) * rng.normal();
        y[a] += gm[a] + se * rng.normal();
        double chi = 0;
        for (int k = 0; k < 7; ++k) {
          const double z = rng.normal();
          chi += z * z;
        }
        s.mean_std_error[a] = se * std::sqrt(chi / 7.0);
        s.raw_std[a] = sigma;
      }
      p.measured = y;
      p.measured_std_error = Eigen::Vector3d::Constant(se);
      p.label = "T" + std::to_string(static_cast<int>(sp)) + " h" + std::to_string(static_cast<int>(h)) + " d" +
                std::to_string(static_cast<int>(dl));
      char name[64];
      std::snprintf(name, sizeof name, "h=%g d=%g", h, dl);
      auto it = og.find(name);
      if (it == og.end()) it = og.emplace(name, static_cast<int>(og.size())).first;
      s.orientation = it->second;
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

ValidationReport run_validation(const ValidateOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  ValidationReport rep;
  const ValidationDesign& d = o.design;
  const batch_lsq::ModelSpec fit_model = validation_model();
  const double floor = white_floor(d);
  rep.floor_mps2 = floor;
  model::Rng prng(o.seed * 7919 + 17);
  std::uint64_t seed = o.seed * 1000003;

  // The true model's own part: bias + scale at plausible MEMS values.
  auto base_truth = [&](model::Rng& r) {
    Planted p;
    p.model = fit_model.model;
    p.theta = VectorXd(p.model.size());
    for (int i = 0; i < 3; ++i) p.theta[i] = 0.05 * r.normal();
    for (int i = 3; i < 6; ++i) p.theta[i] = 0.002 * r.normal();
    return p;
  };

  // Alias pairs and identifiability, declared beforehand from the design (no noise involved).
  GapOptions gopt = o.gap;
  std::vector<Candidate> cands = default_candidates(fit_model.model);
  const GapInput probe = generate(d, fit_model, base_truth(prng), seed++);
  GapOptions aopt = gopt;
  aopt.check_aliases = true;
  aopt.max_steps = 0;
  const GapReport arep = diagnose(probe, aopt);
  std::map<std::string, CandidateResult> declared;
  for (const auto& c : arep.candidates) declared[c.term] = c;
  gopt.check_aliases = false;

  // Baseline design (rows: 3 per segment) for sizing the planted effect's unabsorbable part.
  const MatrixXd A0 = [&] {
    MatrixXd A(3 * static_cast<Eigen::Index>(probe.segments.size()), 0);
    for (const auto& t : fit_model.model.terms) {
      const MatrixXd B = rows_block(probe, t);
      MatrixXd C(A.rows(), A.cols() + B.cols());
      C << A, B;
      A = C;
    }
    return A;
  }();
  const Eigen::ColPivHouseholderQR<MatrixXd> qr0(A0);

  // One planted candidate per kind (temperature polynomials at order 2).
  std::vector<Candidate> plant;
  std::set<int> kinds;
  for (const auto& c : cands) {
    if (!o.only.empty() && std::find(o.only.begin(), o.only.end(), c.name) == o.only.end() &&
        std::find(o.only.begin(), o.only.end(), std::string(model::term_name(c.term.kind))) == o.only.end())
      continue;
    const bool temp = c.term.kind == TermKind::kBiasTemperature || c.term.kind == TermKind::kScaleTemperature;
    if (temp && c.term.order != 2) continue;
    if (kinds.count(static_cast<int>(c.term.kind))) continue;
    kinds.insert(static_cast<int>(c.term.kind));
    plant.push_back(c);
  }

  int top1_n = 0, top1_ok = 0, cov_n = 0, cov_ok = 0, closed_n = 0;
  double closed_sum = 0;
  for (const auto& c : plant) {
    CandidateValidation cv;
    cv.term = c.name;
    const auto dit = declared.find(c.name);
    cv.identifiable = dit != declared.end() && dit->second.evaluated;
    if (dit != declared.end()) cv.aliases = dit->second.aliases;
    const MatrixXd C = rows_block(probe, c.term);
    const auto info = model::param_info(c.term, model::Instrument::kAccelerometer);
    for (double m : o.sizes) {
      CandidateValidation::BySize bs;
      bs.size = m;
      double rank_sum = 0, closed = 0, ratio_sum = 0;
      int ratio_n = 0;
      for (int sd = 0; sd < o.seeds; ++sd) {
        Planted truth = base_truth(prng);
        VectorXd th(C.cols());
        for (Eigen::Index i = 0; i < th.size(); ++i) th[i] = prng.normal();
        const VectorXd eff = C * th;
        const VectorXd orth = eff - A0 * qr0.solve(eff);
        const double rms_o = std::sqrt(orth.squaredNorm() / static_cast<double>(orth.size()));
        const double rms_e = std::sqrt(eff.squaredNorm() / static_cast<double>(eff.size()));
        const double base = cv.identifiable && rms_o > 1e-9 * rms_e ? rms_o : rms_e;
        if (!(base > 0)) break;
        th *= m * floor / base;
        truth.model.terms.push_back(c.term);
        VectorXd full(truth.theta.size() + th.size());
        full << truth.theta, th;
        truth.theta = full;
        const GapInput in = generate(d, fit_model, truth, seed++);
        const GapReport r = diagnose(in, gopt);
        if (!r.ok) continue;
        ++bs.runs;
        const std::string named = r.selected.empty() ? "(none)" : r.selected.front();
        bool alias_ok = false;
        for (const auto& a : cv.aliases) alias_ok = alias_ok || same_effect(named, a);
        const bool strict = same_effect(named, c.name);
        bs.top1_strict += strict ? 1 : 0;
        bs.top1 += (strict || alias_ok) ? 1 : 0;
        int rank = 0, pos = 0;
        for (const auto& cr : r.candidates) {
          if (cr.noise_stage || !cr.evaluated) continue;
          ++pos;
          if (same_effect(cr.term, c.name) && rank == 0) rank = pos;
        }
        rank_sum += rank > 0 ? rank : pos + 1;
        if (!r.steps.empty()) {
          const double h0 = r.steps.front().heldout_rms, f0 = r.steps.front().floor_rms;
          const double ex = h0 * h0 - f0 * f0;
          const double cl = h0 * h0 - r.unexplained_heldout_rms * r.unexplained_heldout_rms;
          const double frac = ex > 0 ? std::clamp(cl / ex, 0.0, 1.0) : 1.0;
          closed += frac;
          if (cv.identifiable && m >= 5) {
            closed_sum += frac;
            ++closed_n;
          }
        }
        for (const auto& cr : r.candidates)
          if (cr.term == c.name && std::isfinite(cr.size)) {
            for (std::size_t k = 0; k < info.size(); ++k)
              if (info[k].name == cr.size_param) {
                const double planted = th[static_cast<Eigen::Index>(k)];
                ++bs.coverage_n;
                const bool in_ci = cr.ci_lo <= planted && planted <= cr.ci_hi;
                bs.covered += in_ci ? 1 : 0;
                if (planted != 0) {
                  ratio_sum += cr.size / planted;
                  ++ratio_n;
                }
                if (cv.identifiable && m >= 5) {
                  ++cov_n;
                  cov_ok += in_ci ? 1 : 0;
                }
              }
          }
        if (m >= 5) {
          rep.confusion[c.name][named] += 1;
          if (cv.identifiable) {
            ++top1_n;
            top1_ok += (strict || alias_ok) ? 1 : 0;
          }
        }
      }
      if (bs.runs > 0) {
        bs.mean_rank = rank_sum / bs.runs;
        bs.closed = closed / bs.runs;
        bs.recovered_ratio = ratio_n ? ratio_sum / ratio_n : kNaN;
      }
      cv.by_size.push_back(bs);
    }
    rep.candidates.push_back(cv);
  }
  rep.top1_at5 = top1_n ? static_cast<double>(top1_ok) / top1_n : kNaN;
  rep.coverage = cov_n ? static_cast<double>(cov_ok) / cov_n : kNaN;
  rep.closed_at5 = closed_n ? closed_sum / closed_n : kNaN;

  // Null runs.
  for (int i = 0; i < o.null_runs; ++i) {
    const GapReport r = diagnose(generate(d, fit_model, base_truth(prng), seed++), gopt);
    if (!r.ok) continue;
    ++rep.null_runs;
    rep.null_false_positives += r.selected.empty() ? 0 : 1;
    if (!r.selected.empty()) ++rep.null_named[r.selected.front()];
  }
  rep.false_positive_rate = rep.null_runs ? static_cast<double>(rep.null_false_positives) / rep.null_runs : kNaN;

  // Out of vocabulary: the z reading jumps by 8× the floor at one table position only (a part that
  // shifts at that position), something no term of the vocabulary describes.
  for (int i = 0; i < o.oov_runs; ++i) {
    Planted p = base_truth(prng);
    const std::size_t per = d.positions.size();
    p.extra.assign(per * d.setpoints_c.size(), Eigen::Vector3d::Zero());
    const std::size_t where = 6 + static_cast<std::size_t>(i) % (per > 6 ? per - 6 : 1);
    for (std::size_t s = 0; s < p.extra.size(); ++s)
      if (s % per == where % per) p.extra[s][2] = 8.0 * floor * (i % 2 ? 1.0 : -1.0);
    const GapReport r = diagnose(generate(d, fit_model, p, seed++), gopt);
    if (!r.ok) continue;
    ++rep.oov_runs;
    if (r.explanation.empty() && !r.at_floor) ++rep.oov_unexplained;
    if (!r.explanation.empty()) ++rep.oov_wrong_name;
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

void print_validation(std::ostream& os, const ValidationReport& r) {
  char line[512];
  os << "stend gap validate — segment-level generator, model bias + scale, averaged noise floor "
     << r.floor_mps2 * 1000 / 9.80665 << " mg (" << r.floor_mps2 << " m/s^2)\n\n";
  os << "planted effect                 ident  size  runs  top-1  strict  mean rank  closed  recovered/planted  CI cover\n";
  for (const auto& c : r.candidates)
    for (const auto& b : c.by_size) {
      std::snprintf(line, sizeof line, "%-30s %-5s  %4gx  %4d  %5.2f  %6.2f  %9.2f  %6.2f  %17.3f  %8s\n", c.term.c_str(),
                    c.identifiable ? "yes" : "no", b.size, b.runs, b.runs ? double(b.top1) / b.runs : 0.0,
                    b.runs ? double(b.top1_strict) / b.runs : 0.0, b.mean_rank, b.closed, b.recovered_ratio,
                    b.coverage_n ? (std::to_string(b.covered) + "/" + std::to_string(b.coverage_n)).c_str() : "-");
      os << line;
    }
  os << "\nalias pairs declared beforehand (joint-design rank):\n";
  for (const auto& c : r.candidates)
    if (!c.aliases.empty()) {
      os << "  " << c.term << ":";
      for (const auto& a : c.aliases) os << " " << a << ";";
      os << "\n";
    }
  os << "\nconfusion (planted >= 5x floor → first named):\n";
  for (const auto& [p, m] : r.confusion) {
    os << "  " << p << " →";
    for (const auto& [n, k] : m) os << " " << n << ":" << k;
    os << "\n";
  }
  std::snprintf(line, sizeof line,
                "\ntop-1 (identifiable, >= 5x floor): %.3f   [target >= 0.9]\n"
                "explainable held-out gap closed (>= 5x): %.3f   [target >= 0.8]\n"
                "95%% interval coverage of the recovered size (>= 5x): %.3f\n"
                "null runs: %d, false positives %d (rate %.3f)   [target <= 0.05]\n"
                "out of vocabulary: %d runs, %d said unexplained, %d named a term\n"
                "time: %.1f s\n",
                r.top1_at5, r.closed_at5, r.coverage, r.null_runs, r.null_false_positives, r.false_positive_rate,
                r.oov_runs, r.oov_unexplained, r.oov_wrong_name, r.seconds);
  os << line;
  if (!r.null_named.empty()) {
    os << "false positives named:";
    for (const auto& [n, k] : r.null_named) os << " " << n << ":" << k;
    os << "\n";
  }
}

std::string validation_json(const ValidationReport& r, int indent) {
  using nlohmann::json;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["schema"] = "stend.gap_validate/1";
  j["noise_floor_mps2"] = r.floor_mps2;
  json cs = json::array();
  for (const auto& c : r.candidates) {
    json sz = json::array();
    for (const auto& b : c.by_size)
      sz.push_back({{"size_over_floor", b.size}, {"runs", b.runs}, {"top1", b.top1}, {"top1_strict", b.top1_strict},
                    {"mean_rank", num(b.mean_rank)}, {"closed", num(b.closed)},
                    {"recovered_over_planted", num(b.recovered_ratio)}, {"ci_covered", b.covered},
                    {"ci_checked", b.coverage_n}});
    cs.push_back({{"term", c.term}, {"identifiable", c.identifiable}, {"aliases", c.aliases}, {"by_size", sz}});
  }
  j["candidates"] = cs;
  j["confusion"] = r.confusion;
  j["summary"] = {{"top1_at_5x", num(r.top1_at5)},
                  {"closed_at_5x", num(r.closed_at5)},
                  {"coverage_at_5x", num(r.coverage)},
                  {"null_runs", r.null_runs},
                  {"null_false_positives", r.null_false_positives},
                  {"null_named", r.null_named},
                  {"false_positive_rate", num(r.false_positive_rate)},
                  {"oov_runs", r.oov_runs},
                  {"oov_unexplained", r.oov_unexplained},
                  {"oov_wrong_name", r.oov_wrong_name},
                  {"seconds", r.seconds}};
  return j.dump(indent);
}

}  // namespace stend::gap
