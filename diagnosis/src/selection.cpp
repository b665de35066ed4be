// Which effect, and how far the gap shrinks: every candidate against the model as given, their
// significance and aliases, forward selection on the held-out gap, the verdict. See steps.hpp
// (explain_gap) and candidate_tests.hpp (one candidate).
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "candidate_tests.hpp"
#include "noise_stage.hpp"
#include "stend/stats/hypothesis_tests.hpp"
#include "steps.hpp"
#include "text.hpp"

namespace stend::diagnosis {

namespace {

// A candidate is significant when the family's false-discovery rule rejects its p value, BIC
// favours it and it lowers the held-out gap.
bool significant(const CandidateResult& r, bool rejected) {
  return r.evaluated && rejected && r.delta_bic < 0 && r.heldout_improvement > 0;
}

// The candidates (not yet used) the family's rule rejects: Benjamini–Yekutieli at level alpha over
// the p values of those evaluated (dependence between the candidates — scale with gravity_error,
// cross-axis with table angles — is allowed by the rule; with no real effect it bounds the chance
// of naming any).
std::vector<bool> family_rejections(const std::vector<Evaluation>& evals, const std::vector<bool>& used, double alpha,
                                    FamilyRule rule) {
  std::vector<double> p;
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < evals.size(); ++i)
    if (!used[i] && evals[i].result.evaluated) {
      p.push_back(evals[i].result.p_value);
      idx.push_back(i);
    }
  std::vector<bool> rej(p.size(), false);
  if (rule == FamilyRule::kBonferroni)
    for (std::size_t k = 0; k < p.size(); ++k) rej[k] = std::isfinite(p[k]) && p[k] < alpha / static_cast<double>(p.size());
  else
    rej = stats::benjamini_yekutieli(p, alpha);
  std::vector<bool> out(evals.size(), false);
  for (std::size_t k = 0; k < idx.size(); ++k) out[idx[k]] = rej[k];
  return out;
}

// One row of the selection table: held-out RMS and its floor, in-sample RMS [unit].
Step make_step(int step, const std::string& added, const Rows& rows, const CurrentModel& model) {
  Step s;
  s.step = step;
  s.added = added;
  s.heldout_rms = rms_finite(model.heldout, &s.floor_rms);
  s.rows = static_cast<int>(rows.y.size());
  s.heldout_rows = static_cast<int>(model.heldout.err.array().isFinite().count());
  s.in_sample_rms = std::sqrt((rows.y - model.columns * model.fit.lsq.min_norm_solution).squaredNorm() /
                              static_cast<double>(rows.y.size()));
  return s;
}

// Every candidate not yet used, against the current model; used slots stay empty.
std::vector<Evaluation> evaluate_all(const CandidateSearch& search, const CurrentModel& model, const GlsStep& gls,
                                     const std::vector<bool>& used) {
  std::vector<Evaluation> out;
  for (std::size_t i = 0; i < search.candidates.size(); ++i)
    out.push_back(used[i] ? Evaluation{} : evaluate(search, model, gls, i));
  return out;
}

// Significance of each evaluated candidate under the family's rule.
void mark_significant(std::vector<Evaluation>& evals, double alpha, FamilyRule rule) {
  const std::vector<bool> rej = family_rejections(evals, std::vector<bool>(evals.size(), false), alpha, rule);
  for (std::size_t i = 0; i < evals.size(); ++i) evals[i].result.significant = significant(evals[i].result, rej[i]);
}

// Pairwise aliases among evaluated candidates of different kinds: the joint design has a lower
// rank than the two designs apart; each names the other and what would separate them.
void candidate_aliases(const CandidateSearch& search, const MatrixXd& model_columns, std::vector<Evaluation>& evals) {
  const VectorXd& w = search.rows.w;
  const MatrixXd As = scale_rows(model_columns, w);
  const int model_rank = rank_of(As);
  const std::size_t n = search.candidates.size();
  std::vector<int> rank_with(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (evals[i].result.evaluated) rank_with[i] = rank_of(hstack(As, scale_rows(search.columns[i], w)));
  for (std::size_t i = 0; i < n; ++i) {
    if (!evals[i].result.evaluated) continue;
    const Candidate& ci = search.candidates[i];
    for (std::size_t j = i + 1; j < n; ++j) {
      const Candidate& cj = search.candidates[j];
      if (!evals[j].result.evaluated || ci.term.kind == cj.term.kind) continue;
      const int joint =
          rank_of(hstack(hstack(As, scale_rows(search.columns[i], w)), scale_rows(search.columns[j], w)));
      if (joint >= rank_with[i] + rank_with[j] - model_rank) continue;
      evals[i].result.aliases.push_back(cj.name);
      evals[j].result.aliases.push_back(ci.name);
      const std::string separate = separating_experiment(ci.term.kind, cj.term.kind);
      evals[i].result.separate.push_back(separate);
      evals[j].result.separate.push_back(separate);
    }
  }
}

// First-pass results ranked: significant first, then by held-out improvement.
std::vector<CandidateResult> ranked(const std::vector<Evaluation>& evals) {
  std::vector<CandidateResult> out;
  for (const auto& e : evals) out.push_back(e.result);
  std::stable_sort(out.begin(), out.end(), [](const CandidateResult& a, const CandidateResult& b) {
    const double x = std::isfinite(a.heldout_improvement) ? a.heldout_improvement : -1e300;
    const double y = std::isfinite(b.heldout_improvement) ? b.heldout_improvement : -1e300;
    if (a.significant != b.significant) return a.significant;
    return x > y;
  });
  return out;
}

// The significant unused candidate with the largest held-out improvement; −1 when none.
int best_candidate(const std::vector<Evaluation>& evals, const std::vector<bool>& used, double alpha, FamilyRule rule) {
  const std::vector<bool> rej = family_rejections(evals, used, alpha, rule);
  int best = -1;
  double best_gain = 0;
  for (std::size_t i = 0; i < evals.size(); ++i) {
    const auto& r = evals[i].result;
    if (used[i] || !significant(r, rej[i])) continue;
    if (r.heldout_improvement > best_gain) {
      best_gain = r.heldout_improvement;
      best = static_cast<int>(i);
    }
  }
  return best;
}

// Near-collinear candidates: one candidate's part outside the current model lies (almost) within
// another's — the smallest canonical correlation of the smaller projected column space with the
// larger at least this. Such a pair is an alias on this design even when not exactly singular.
constexpr double kNearAliasCorrelation = 0.95;

// Orthonormal basis of the weighted candidate columns with the model projected out; directions
// below 1e-8 of the columns' own size (exactly aliased with the model) are dropped.
MatrixXd projected_basis(const CandidateSearch& sr, const MatrixXd& model_columns, std::size_t i) {
  const VectorXd sw = sr.rows.w.cwiseSqrt();
  MatrixXd C = sw.asDiagonal() * sr.columns[i];
  const double size = C.norm();
  if (model_columns.cols() > 0) {
    const MatrixXd Q = column_basis(sw.asDiagonal() * model_columns);
    C -= Q * (Q.transpose() * C);
  }
  Eigen::JacobiSVD<MatrixXd> svd(C, Eigen::ComputeThinU);
  int q = 0;
  while (q < svd.singularValues().size() && svd.singularValues()[q] > 1e-8 * size) ++q;
  return svd.matrixU().leftCols(q);
}

// Is the smaller of the two projected spaces (almost) inside the larger?
bool near_collinear(const MatrixXd& Ua, const MatrixXd& Ub) {
  if (Ua.cols() == 0 || Ub.cols() == 0) return false;
  const MatrixXd M = Ua.cols() <= Ub.cols() ? MatrixXd(Ua.transpose() * Ub) : MatrixXd(Ub.transpose() * Ua);
  Eigen::JacobiSVD<MatrixXd> svd(M);
  return svd.singularValues().minCoeff() >= kNearAliasCorrelation;
}

// Whether the recording excites what tells a term from its base term: a temperature spread for the
// terms that read the temperature, an input of known size apart from gravity (|f| not the same in
// every segment, e.g. centripetal on a rate table) for a wrong local g. Other terms need nothing
// beyond their own columns. Empty: excited; else what is missing.
std::string missing_excitation(const GapInput& in, model::TermKind k) {
  if (model::reads_temperature(k) && !has_temperature_spread(in.segments))
    return "it reads the temperature and this recording has no temperature spread";
  if (k == model::TermKind::kGravityError) {
    double lo = 1e300, hi = 0;
    for (const auto& s : in.segments) {
      const double f = s.point.stimulus.specific_force.norm();
      lo = std::min(lo, f);
      hi = std::max(hi, f);
    }
    if (!(hi - lo > 0.01 * hi)) return "a wrong local g needs a reference input apart from gravity, and every segment here sees |f| = g";
  }
  return {};
}

// Is candidate b significant beyond the current model plus candidate a — can the data tell b from
// a? Judged as any candidate is (candidate_tests.hpp): the largest p of the partial F test (shrunk
// by the residuals' lag-1 correlation), Newey–West and the GLS test under the segments' time
// covariance, below alpha, with BIC favouring b and a held-out gain beyond a. A bare F test on
// independent segment means would take a slow bias wander that follows the temperature for a
// temperature term. p is 1 when b adds no rank beyond them.
struct Beyond {
  double p = 1.0;
  bool significant = false;
};
Beyond significant_beyond(const CandidateSearch& sr, const CurrentModel& model, const std::vector<Evaluation>& evals,
                          std::size_t a, std::size_t b, double alpha) {
  CurrentModel with_a;
  with_a.terms = model.terms;
  with_a.terms.push_back(sr.candidates[a].term);
  with_a.columns = hstack(model.columns, sr.columns[a]);
  with_a.fit = solve(with_a.columns, sr.rows.y, sr.rows.w);
  if (!with_a.fit.lsq.ok()) return {};
  with_a.heldout = evals[a].heldout;
  const Evaluation e = evaluate(sr, with_a, gls_prepare(sr.covariance, sr.rows, with_a.columns), b);
  const CandidateResult& r = e.result;
  if (!r.evaluated || !std::isfinite(r.p_value)) return {};
  return {r.p_value, r.p_value < alpha && r.delta_bic < 0 && r.heldout_improvement > 0};
}

// More basic: earlier in the vocabulary's order (model::TermKind: scale before its temperature
// polynomial, cross-axis before the table angles, a wrong g last), and of one kind the lower order
// (a temperature polynomial of order 1 before order 2, which nests it).
bool more_basic(const model::TermSpec& a, const model::TermSpec& b) {
  if (a.kind != b.kind) return static_cast<int>(a.kind) < static_cast<int>(b.kind);
  return a.order < b.order;
}

// Among the candidates near-collinear with the best one on this design, the one the data can
// support, stepping down from the most basic: a member the data favour (held-out gain > 0, BIC < 0)
// and the recording excites is named unless the best one is excited and significant beyond it
// (significant_beyond), in which case the next more basic member is tried; the best itself when
// it is significant beyond every more basic member. So an order-1 temperature effect is named at
// order 1 unless the order-2 part is significant, and scale unless its temperature polynomial is.
// The others are listed as its aliases, with why and what experiment would separate them
// (report.alias_resolution, the named candidate's aliases).
std::size_t resolve_aliases(const CandidateSearch& sr, const CurrentModel& model, const std::vector<Evaluation>& evals,
                            const std::vector<bool>& used, std::size_t best, double alpha, GapReport& rep) {
  const MatrixXd Ub = projected_basis(sr, model.columns, best);
  std::vector<std::size_t> group;
  for (std::size_t j = 0; j < evals.size(); ++j) {
    if (j == best || used[j] || !evals[j].result.evaluated) continue;
    if (near_collinear(Ub, projected_basis(sr, model.columns, j))) group.push_back(j);
  }
  if (group.empty()) return best;
  std::vector<std::size_t> order = group;
  order.push_back(best);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return more_basic(sr.candidates[a].term, sr.candidates[b].term);
  });
  const std::string missing = missing_excitation(sr.input, sr.candidates[best].term.kind);
  std::string why, beyond;
  std::size_t named = best;
  for (std::size_t m : order) {
    if (m == best) break;
    const auto& r = evals[m].result;
    if (!(r.heldout_improvement > 0 && r.delta_bic < 0) || !missing_excitation(sr.input, sr.candidates[m].term.kind).empty())
      continue;
    const Beyond bt = missing.empty() ? significant_beyond(sr, model, evals, m, best, alpha) : Beyond{};
    const double p = bt.p;
    if (bt.significant) {
      beyond += (beyond.empty() ? "" : ", ") + sr.candidates[m].name + " (p " + fmt(p, 2) + ")";
      continue;
    }
    named = m;
    why = sr.candidates[best].name + " (the largest held-out gain) is not named: " +
          (missing.empty() ? "the data cannot tell it from " + sr.candidates[m].name + " (p " + fmt(p, 2) + " beyond it)"
                           : missing) +
          (beyond.empty() ? "" : " (it is significant beyond " + beyond + ")") + "; the more basic term " +
          sr.candidates[m].name + " is named";
    break;
  }
  if (named == best)
    why = beyond.empty() ? sr.candidates[best].name + " is the base term of the group"
                         : sr.candidates[best].name + " is significant beyond " + beyond;
  std::ostringstream os;
  os << sr.candidates[named].name << " stands for its near-collinear aliases on this design (";
  std::vector<std::size_t> others = group;
  if (named != best) {
    others.erase(std::remove(others.begin(), others.end(), named), others.end());
    others.insert(others.begin(), best);
  }
  for (std::size_t k = 0; k < others.size(); ++k) os << (k ? ", " : "") << sr.candidates[others[k]].name;
  os << "): " << why << ". Separate by: ";
  for (std::size_t k = 0; k < others.size(); ++k)
    os << (k ? "; " : "") << separating_experiment(sr.candidates[named].term.kind, sr.candidates[others[k]].term.kind);
  rep.alias_resolution.push_back(os.str());
  for (auto& c : rep.candidates)
    if (c.term == sr.candidates[named].name)
      for (std::size_t o : others)
        if (std::find(c.aliases.begin(), c.aliases.end(), sr.candidates[o].name) == c.aliases.end()) {
          c.aliases.push_back(sr.candidates[o].name);
          c.separate.push_back(separating_experiment(sr.candidates[named].term.kind, sr.candidates[o].term.kind));
        }
  return named;
}

// Forward selection on the held-out gap: add the best significant candidate, refit, until the
// held-out errors reach the noise floor, none is significant or max_steps are taken. Step 1
// reuses the first pass. Fills report.steps / selected / at_floor; returns the final model.
CurrentModel forward_select(const CandidateSearch& search, CurrentModel model, const std::vector<Evaluation>& first,
                            const GapOptions& opt, GapReport& report) {
  std::vector<bool> used(search.candidates.size(), false);
  bool at_floor = at_noise_floor(model.heldout);
  for (int step = 1; step <= opt.max_steps && !at_floor; ++step) {
    const std::vector<Evaluation> evals =
        step == 1 ? first
                  : evaluate_all(search, model, gls_prepare(search.covariance, search.rows, model.columns), used);
    const int best = best_candidate(evals, used, opt.alpha, opt.family_rule);
    if (best < 0) break;
    const std::size_t b = resolve_aliases(search, model, evals, used, static_cast<std::size_t>(best), opt.alpha, report);
    used[b] = true;
    model.terms.push_back(search.candidates[b].term);
    model.columns = hstack(model.columns, search.columns[b]);
    model.fit = solve(model.columns, search.rows.y, search.rows.w);
    model.heldout = evals[b].heldout;
    report.steps.push_back(make_step(step, search.candidates[b].name, search.rows, model));
    report.selected.push_back(search.candidates[b].name);
    at_floor = at_noise_floor(model.heldout);
  }
  report.at_floor = at_floor;
  return model;
}

// The named explanation: the first selected term, when it closed at least explain_fraction of the
// excess squared held-out gap above the floor.
std::string explanation(const GapReport& rep, double explain_fraction) {
  if (rep.steps.size() < 2) return {};
  const Step& s0 = rep.steps[0];
  const Step& s1 = rep.steps[1];
  const double excess = s0.heldout_rms * s0.heldout_rms - s0.floor_rms * s0.floor_rms;
  const double closed = s0.heldout_rms * s0.heldout_rms - s1.heldout_rms * s1.heldout_rms;
  return excess > 0 && closed >= explain_fraction * excess ? s1.added : std::string();
}

// The plain-words verdict: at the floor already, unexplained, or (partly) explained by the
// selected terms; RMS in the display unit.
std::string statement(const GapReport& rep, bool at_floor_as_given) {
  std::ostringstream st;
  const double dpu = rep.display_per_unit;
  if (at_floor_as_given) {
    st << "The model as given is at the noise floor on held-out data (" << fmt(rep.steps[0].heldout_rms * dpu, 3)
       << " " << rep.display_unit << " held-out RMS vs " << fmt(rep.steps[0].floor_rms * dpu, 3)
       << " expected from noise): no gap to explain.";
    std::string significant;
    for (const CandidateResult& c : rep.candidates)
      if (c.significant && c.evaluated && !c.noise_stage) significant += (significant.empty() ? "" : ", ") + c.term;
    if (!significant.empty())
      st << " Significant by their own tests: " << significant
         << "; what they would add is within the noise of held-out prediction, so none is named.";
    return st.str();
  }
  if (rep.selected.empty()) {
    st << "UNEXPLAINED: the held-out gap is " << fmt(rep.unexplained_heldout_rms * dpu, 3) << " "
       << rep.display_unit << " RMS, " << fmt(rep.unexplained_over_floor, 3)
       << "x the noise floor, and no candidate in the vocabulary explains it significantly.";
    return st.str();
  }
  if (rep.explanation.empty()) st << "PARTLY EXPLAINED: ";
  st << "Adding ";
  for (std::size_t i = 0; i < rep.selected.size(); ++i) st << (i ? ", then " : "") << rep.selected[i];
  st << " takes the held-out gap from " << fmt(rep.steps[0].heldout_rms * dpu, 3) << " to "
     << fmt(rep.unexplained_heldout_rms * dpu, 3) << " " << rep.display_unit << " RMS ("
     << fmt(rep.unexplained_over_floor, 3) << "x the noise floor). ";
  if (rep.at_floor)
    st << "What remains is at the noise floor.";
  else
    st << "UNEXPLAINED remainder: " << fmt(rep.unexplained_over_floor, 3)
       << "x the noise floor is left that no further candidate explains significantly.";
  return st.str();
}

// Held out much worse than in-sample: say why. If the model were right, the held-out mean square
// would be the held-out floor² (the row floor² plus the training fit's prediction variance) and
// the in-sample one row floor²·(1 − p/n); a ratio within 1.5× of that is the small design, beyond
// it the in-sample fit absorbs what it cannot predict across folds.
constexpr double kHeldoutOverInSample = 3.0;
void explain_heldout_ratio(const GapReport& rep, int rank_first, int rank_last, const Rows& rows,
                           std::vector<std::string>& notes) {
  const double n = static_cast<double>(rows.y.size());
  const double row_floor = std::sqrt(rows.w.cwiseInverse().mean());
  std::vector<std::size_t> steps = {0};
  if (rep.steps.size() > 1) steps.push_back(rep.steps.size() - 1);
  for (std::size_t k : steps) {
    const Step& s = rep.steps[k];
    if (!(s.heldout_rms > kHeldoutOverInSample * s.in_sample_rms)) continue;
    const double p = k == 0 ? rank_first : rank_last;
    const double expected = s.floor_rms / (row_floor * std::sqrt(std::max(1e-12, 1.0 - p / n)));
    const double ratio = s.heldout_rms / s.in_sample_rms;
    std::ostringstream os;
    os << "held-out gap " << fmt(s.heldout_rms * rep.display_per_unit, 3) << " " << rep.display_unit << " is "
       << fmt(ratio, 3) << "x the in-sample gap " << fmt(s.in_sample_rms * rep.display_per_unit, 3) << " "
       << rep.display_unit << (k == 0 ? " (model as given)" : " (after " + s.added + ")") << ": ";
    if (ratio <= 1.5 * expected)
      os << "what noise gives on this small design (" << p << " parameters on " << n
         << " rows: the fit takes up noise in-sample, the held-out predictions carry their own error; expected ratio "
         << fmt(expected, 3) << ")";
    else
      os << "the fit absorbs in-sample what it cannot predict across folds (an effect aliased with the fitted terms "
            "on the whole design, not within the training folds; expected ratio from noise "
         << fmt(expected, 3) << ")";
    notes.push_back(os.str());
  }
}

}  // namespace

void explain_gap(const GapInput& in, Rows& rows, const GapOptions& opt, GapReport& rep) {
  const std::vector<Candidate> candidates =
      opt.candidates.empty() ? default_candidates(in.spec.model, has_temperature_spread(in.segments)) : opt.candidates;
  CurrentModel as_given;
  as_given.terms = in.spec.model.terms;
  as_given.columns = MatrixXd(rows.y.size(), 0);
  for (const auto& t : as_given.terms) as_given.columns = hstack(as_given.columns, term_columns(in, rows, t));
  std::vector<MatrixXd> columns;
  MatrixXd all_columns = as_given.columns;  // the most general model: the fixed effects of the covariance
  for (const auto& c : candidates) {
    columns.push_back(term_columns(in, rows, c.term));
    all_columns = hstack(all_columns, columns.back());
  }
  as_given.fit = solve(as_given.columns, rows.y, rows.w);
  if (!as_given.fit.lsq.ok()) {
    rep.message = "baseline fit failed: " + as_given.fit.lsq.message;
    return;
  }
  // The folds that fit the design (the model's and every candidate's training folds).
  CandidateSearchColumns fold_columns{as_given.columns, columns, {}, {}};
  const int model_rank = rank_of(scale_rows(as_given.columns, rows.w));
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    fold_columns.adds_rank.push_back(columns[i].norm() > 0 &&
                                     rank_of(scale_rows(hstack(as_given.columns, columns[i]), rows.w)) > model_rank);
    fold_columns.names.push_back(candidates[i].name);
  }
  if (!choose_folds(in, opt, fold_columns, rows, rep)) return;
  as_given.heldout = cross_validate(as_given.columns, rows);
  const SegmentCovariance covariance = estimate_segment_covariance(in, rows, all_columns);
  const CandidateSearch search{in, rows, candidates, columns, covariance};
  rep.steps.push_back(make_step(0, "", rows, as_given));
  const bool at_floor_as_given = at_noise_floor(as_given.heldout);
  std::vector<Evaluation> evals = evaluate_all(search, as_given, gls_prepare(covariance, rows, as_given.columns),
                                               std::vector<bool>(candidates.size(), false));
  mark_significant(evals, opt.alpha, opt.family_rule);
  if (opt.check_aliases) candidate_aliases(search, as_given.columns, evals);
  // Noise and output-stage candidates (they cannot move the static means' fit; judged on the
  // raw samples — tests, levels and sizes in noise_stage.hpp).
  const std::vector<CandidateResult> noise = noise_stage::candidates(in, in.spec.axes, rep.unit, opt.alpha);
  rep.candidates = ranked(evals);
  rep.candidates.insert(rep.candidates.end(), noise.begin(), noise.end());
  const CurrentModel last = forward_select(search, as_given, evals, opt, rep);
  double floor_rms = 0;
  rep.unexplained_heldout_rms = rms_finite(last.heldout, &floor_rms);
  rep.unexplained_over_floor = floor_rms > 0 ? rep.unexplained_heldout_rms / floor_rms : kNaN;
  rep.explanation = explanation(rep, opt.explain_fraction);
  rep.statement = statement(rep, at_floor_as_given);
  if (!at_floor_as_given) assess_placement(in, rows, last.terms, last.columns, opt, rep);
  // The first named term leads the ranking (it may be an alias's base term, not the top gain).
  if (!rep.selected.empty()) {
    const auto it = std::find_if(rep.candidates.begin(), rep.candidates.end(),
                                 [&](const CandidateResult& c) { return c.term == rep.selected.front(); });
    if (it != rep.candidates.end()) std::rotate(rep.candidates.begin(), it, it + 1);
  }
  if (!rep.fold_reason.empty()) rep.notes.push_back("held-out folds: " + rep.fold_reason);
  explain_heldout_ratio(rep, rep.fit.lsq.rank, last.fit.rank, rows, rep.notes);
  rep.ok = true;
}

}  // namespace stend::diagnosis
