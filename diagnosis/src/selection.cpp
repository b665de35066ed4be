// Which effect, and how far the gap shrinks: every candidate against the model as given, their
// significance and aliases, forward selection on the held-out gap, the verdict. See steps.hpp
// (explain_gap) and candidate_tests.hpp (one candidate).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "candidate_tests.hpp"
#include "noise_stage.hpp"
#include "steps.hpp"
#include "text.hpp"

namespace stend::diagnosis {

namespace {

// A candidate is significant when its p value is below the per-candidate level, BIC favours it
// and it lowers the held-out gap.
bool significant(const CandidateResult& r, double alpha_each) {
  return r.evaluated && std::isfinite(r.p_value) && r.p_value < alpha_each && r.delta_bic < 0 &&
         r.heldout_improvement > 0;
}

// One row of the selection table: held-out RMS and its floor, in-sample RMS [unit].
Step make_step(int step, const std::string& added, const Rows& rows, const CurrentModel& model) {
  Step s;
  s.step = step;
  s.added = added;
  s.heldout_rms = rms_finite(model.heldout, &s.floor_rms);
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

// Significance of each evaluated candidate at α / (number evaluated) (Bonferroni).
void mark_significant(std::vector<Evaluation>& evals, double alpha) {
  int evaluated = 0;
  for (const auto& e : evals) evaluated += e.result.evaluated ? 1 : 0;
  for (auto& e : evals) e.result.significant = significant(e.result, alpha / std::max(1, evaluated));
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

// The significant unused candidate with the largest held-out improvement (α split over those
// evaluated); −1 when none.
int best_candidate(const std::vector<Evaluation>& evals, const std::vector<bool>& used, double alpha) {
  int evaluated = 0;
  for (std::size_t i = 0; i < evals.size(); ++i) evaluated += !used[i] && evals[i].result.evaluated ? 1 : 0;
  int best = -1;
  double best_gain = 0;
  for (std::size_t i = 0; i < evals.size(); ++i) {
    const auto& r = evals[i].result;
    if (used[i] || !significant(r, alpha / std::max(1, evaluated))) continue;
    if (r.heldout_improvement > best_gain) {
      best_gain = r.heldout_improvement;
      best = static_cast<int>(i);
    }
  }
  return best;
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
    const int best = best_candidate(evals, used, opt.alpha);
    if (best < 0) break;
    const auto b = static_cast<std::size_t>(best);
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

}  // namespace

void explain_gap(const GapInput& in, const Rows& rows, const GapOptions& opt, GapReport& rep) {
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
  as_given.heldout = cross_validate(as_given.columns, rows);
  const SegmentCovariance covariance = estimate_segment_covariance(in, rows, all_columns);
  const CandidateSearch search{in, rows, candidates, columns, covariance};
  rep.steps.push_back(make_step(0, "", rows, as_given));
  const bool at_floor_as_given = at_noise_floor(as_given.heldout);
  std::vector<Evaluation> evals = evaluate_all(search, as_given, gls_prepare(covariance, rows, as_given.columns),
                                               std::vector<bool>(candidates.size(), false));
  mark_significant(evals, opt.alpha);
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
  rep.ok = true;
}

}  // namespace stend::diagnosis
