// The noise-model fit of an Allan curve: model curve with the sensor's output stage, generalized
// least squares on the octave points with their covariance (each point's EDF, the correlation of
// overlapping estimates that share samples), model selection among Q N B K R and a Gauss–Markov
// bias, Fisher uncertainties, upper bounds, slope read-offs (see fit_noise_model in allan.hpp).
#include "stend/noise/noise_model.hpp"

#include <stend/model/noise.hpp>
#include <stend/physics/units.hpp>

#include <Eigen/Dense>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "model_curve.hpp"
#include "stend/stats/gls.hpp"

namespace stend::noise {

namespace {

constexpr double kTermPenalty = 6.6349;   // χ²₁ 99 % quantile: penalty per parameter
constexpr double kPlateauOverWalk = 10.828;  // χ²₁ 99.9 %: deviance B or G must gain over K in its place
constexpr double kMinClusters = 4.0;      // points with fewer clusters (N/m) are not fitted
constexpr double kCoverage = 0.95;        // level of the coefficients' intervals (z = stats::kZ95)
constexpr int kMaxFilteredM = 32;         // an unstated filter may flatten points up to this m

Coefficient* coefficient(NoiseModel& m, int j) { return m.coefficients() + j; }
const Coefficient* coefficient(const NoiseModel& m, int j) { return m.coefficients() + j; }

struct FitPoint {
  double tau, m, avar, adev, edf, lo, hi;
  std::array<double, kTerms> a;  // basis at τ (G at the current τc)
  NoiseType noise;               // noise type of the EDF and of the correlation with other points
};

// The fitted points and the lower Cholesky factor L of their correlation matrix: the covariance
// of the AVAR estimates is Σ = S·L·Lᵀ·S with S = diag(model·√(2/ν)), so whitening by (L·S)⁻¹ makes
// the octave points, which share samples, independent for the least squares, the deviance and
// the Fisher information (generalized least squares).
struct FitSet {
  std::vector<FitPoint> pts;
  Eigen::MatrixXd L;
  // x ← L⁻¹x by forward substitution, a column at a time: element j solved, then removed from the
  // elements below it as one vectorised axpy with L's column j (both contiguous; no temporary).
  // The sizes are a few tens of points, where this beats a blocked solver, and each element sees
  // the same operations in the same order as a scalar loop would.
  void whiten_in_place(Eigen::MatrixXd& x) const {
    const Eigen::Index n = L.rows();
    for (Eigen::Index q = 0; q < x.cols(); ++q) {
      auto col = x.col(q);
      for (Eigen::Index j = 0; j < n; ++j) {
        col(j) /= L(j, j);
        col.tail(n - j - 1) -= col(j) * L.col(j).tail(n - j - 1);
      }
    }
  }
  Eigen::MatrixXd whiten(Eigen::MatrixXd x) const {
    whiten_in_place(x);
    return x;
  }
};

// Correlation of two points' AVAR estimates: the mean of the correlations for each point's noise
// type in a record of n_samples (avar_correlation); shrunk towards the identity until
// positive definite.
void set_correlation(FitSet& set, double n_samples) {
  const auto& pts = set.pts;
  const int n = static_cast<int>(pts.size());
  Eigen::MatrixXd R = Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < i; ++j) {
      const auto &p = pts[static_cast<std::size_t>(i)], &q = pts[static_cast<std::size_t>(j)];
      const double a = avar_correlation(p.noise, p.m, q.m, n_samples);  // the same type: computed once
      R(i, j) = R(j, i) = 0.5 * (a + (q.noise == p.noise ? a : avar_correlation(q.noise, p.m, q.m, n_samples)));
    }
  }
  set.L = stats::shrunk_cholesky(std::move(R));
}

// The basis of every term at each point, G at τc.
void set_basis(FitSet& set, const WhiteTerm& white, double tc) {
  for (auto& p : set.pts) p.a = basis(p.tau, p.m, white, tc);
}

// G's column at τc (0: no G); the other terms do not depend on τc.
void set_tc(FitSet& set, double tc) {
  for (auto& p : set.pts) p.a[kGm] = gm_basis(p.tau, tc);
}

// One candidate model: the terms in `mask`, τc for G.
struct Candidate {
  unsigned mask = 0;
  double tc = 0.0;
  std::array<double, kTerms> c{};  // squares of the coefficients (σ_G² for G)
  double deviance = std::numeric_limits<double>::infinity();
  bool valid = false;
  // Parameters for the penalty: one per term, τc for G, and one more for R, which competes with K
  // for the same rise at long τ and is named only when it beats K's explanation by the penalty.
  int parameters() const { return __builtin_popcount(mask) + ((mask >> kGm) & 1u ? 1 : 0) + ((mask >> kRamp) & 1u ? 1 : 0); }
  double score() const { return deviance + kTermPenalty * parameters(); }
};

double model_at(const FitPoint& p, const std::array<double, kTerms>& c) {
  double v = 0.0;
  for (int j = 0; j < kTerms; ++j) v += c[j] * p.a[j];
  return v;
}

// Deviance of correlated Gamma points: the signed deviance residuals e_i = ±√(ν (r − 1 − ln r)),
// r = AVAR/model (each ≈ N(0, 1)), whitened: D = ‖L⁻¹ e‖² (without correlation the Gamma
// deviance Σ ν (r − 1 − ln r)).
double deviance(const FitSet& set, const std::array<double, kTerms>& c) {
  const auto& pts = set.pts;
  Eigen::VectorXd e(static_cast<int>(pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double mv = model_at(pts[i], c);
    if (!(mv > 0.0)) return std::numeric_limits<double>::infinity();
    const double r = pts[i].avar / mv;
    e(static_cast<int>(i)) = std::copysign(std::sqrt(std::max(0.0, pts[i].edf * (r - 1.0 - std::log(r)))), r - 1.0);
  }
  return set.whiten(e).squaredNorm();
}

// Fisher scoring for the terms in `mask` (basis already at τc): generalized least squares with
// the covariance at the current model (σ_i = model_i·√(2/ν_i), correlation L·Lᵀ), repeated;
// invalid when a coefficient is not positive.
Candidate fit_terms(const FitSet& set, unsigned mask, double tc) {
  const auto& pts = set.pts;
  Candidate cand;
  cand.mask = mask;
  cand.tc = tc;
  std::vector<int> cols;
  for (int j = 0; j < kTerms; ++j)
    if (mask & (1u << j)) cols.push_back(j);
  const int n = static_cast<int>(pts.size()), k = static_cast<int>(cols.size());
  if (k == 0 || k > n) return cand;
  Eigen::MatrixXd Ab(n, k + 1);  // [A | b], whitened together
  Eigen::VectorXd scale(k);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(n, k);
  qr.setThreshold(1e-12);
  std::vector<double> v(pts.size());
  for (int i = 0; i < n; ++i) v[i] = pts[i].avar;
  for (int iter = 0; iter < 12; ++iter) {
    for (int i = 0; i < n; ++i) {
      const double w = std::sqrt(pts[i].edf / 2.0) / v[i];
      for (int q = 0; q < k; ++q) Ab(i, q) = w * pts[i].a[cols[q]];
      Ab(i, k) = w * pts[i].avar;
    }
    set.whiten_in_place(Ab);
    for (int q = 0; q < k; ++q) {
      scale(q) = Ab.col(q).norm();
      if (!(scale(q) > 0.0)) return cand;
      Ab.col(q) /= scale(q);
    }
    qr.compute(Ab.leftCols(k));
    if (qr.rank() < k) return cand;
    const Eigen::VectorXd x = qr.solve(Ab.col(k));
    std::array<double, kTerms> c{};
    for (int q = 0; q < k; ++q) c[cols[q]] = x(q) / scale(q);
    double change = 0.0;
    for (int i = 0; i < n; ++i) {
      const double mv = model_at(pts[i], c);
      if (!(mv > 0.0)) return cand;
      change = std::max(change, std::abs(mv / v[i] - 1.0));
      v[i] = mv;
    }
    cand.c = c;
    if (change < 1e-9) break;
  }
  for (int q = 0; q < k; ++q)
    if (!(cand.c[cols[q]] > 0.0)) return cand;
  cand.deviance = deviance(set, cand.c);
  cand.valid = std::isfinite(cand.deviance);
  return cand;
}

// The τc grid: 2 nodes per octave over the fitted τ range widened by 4× each way, from l0 = ln τc
// of the first node in steps of `step`.
struct TcGrid {
  double l0 = 0.0, step = 0.0;
  int nodes = 0;
};

TcGrid tc_grid(const FitSet& set) {
  const auto& pts = set.pts;
  TcGrid g;
  g.l0 = std::log(pts.front().tau / 4.0);
  const double l1 = std::log(pts.back().tau * 4.0);
  g.nodes = std::max(4, static_cast<int>(std::ceil((l1 - g.l0) / std::log(2.0) * 2.0)));
  g.step = (l1 - g.l0) / g.nodes;
  return g;
}

// Best τc on the grid for the terms in `mask` (which contains G).
Candidate fit_with_gm(FitSet& set, unsigned mask, const TcGrid& grid) {
  Candidate best;
  for (int i = 0; i <= grid.nodes; ++i) {
    const double tc = std::exp(grid.l0 + grid.step * i);
    set_tc(set, tc);
    Candidate c = fit_terms(set, mask, tc);
    if (c.valid && c.deviance < best.deviance) best = c;
  }
  return best;
}

// Golden-section refinement of ln τc within one grid step either side of the candidate's τc.
Candidate refine_gm(FitSet& set, Candidate best, double step) {
  auto at = [&](double l) {
    set_tc(set, std::exp(l));
    return fit_terms(set, best.mask, std::exp(l));
  };
  double a = std::log(best.tc) - step, b = std::log(best.tc) + step;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 20; ++it) {
    const double x1 = b - g * (b - a), x2 = a + g * (b - a);
    const Candidate c1 = at(x1), c2 = at(x2);
    if (c1.valid && c1.deviance < best.deviance) best = c1;
    if (c2.valid && c2.deviance < best.deviance) best = c2;
    if (c1.deviance < c2.deviance) b = x2;
    else a = x1;
  }
  return best;
}

// B and G both make the plateau, so choosing between them is a choice of its shape (flat over
// decades, or rising as τ/τc then falling as 1/√τ), not of one more term: the shape that fits
// better (the lower deviance) is kept, τc not counted against G.
Candidate plateau_shape(FitSet& set, const Candidate& with_b, const TcGrid& grid) {
  const Candidate with_g = fit_with_gm(set, (with_b.mask & ~(1u << 2)) | (1u << kGm), grid);
  return with_g.valid && with_g.deviance < with_b.deviance ? with_g : with_b;
}

// A random walk and a plateau look alike over a finite τ range: G's rising flank is a random walk
// of K² = 2σ²/τc, and the walk of a short record often ends in low points that look like G's fall
// or B's flat top. A model that holds G or B but not K is compared with the same model with K in
// their place, the simpler explanation of a rise (G with τc → ∞ is K): the plateau is kept only
// when it lowers the deviance by more than a 0.1 % likelihood-ratio test allows, i.e. when the
// data show it level off or fall.
Candidate walk_or_plateau(FitSet& set, const Candidate& best) {
  const unsigned plateau = (1u << kGm) | (1u << 2), walk = 1u << 3;
  if (!(best.mask & plateau) || (best.mask & walk)) return best;
  set_tc(set, 0.0);
  const Candidate with_k = fit_terms(set, (best.mask & ~plateau) | walk, 0.0);
  set_tc(set, best.tc);
  return with_k.valid && with_k.deviance - best.deviance <= kPlateauOverWalk ? with_k : best;
}

// The candidate with the least penalised deviance over every non-empty subset of the terms.
// The basis of terms other than G must be set (set_basis); G's column is left at the best τc.
Candidate select_model(FitSet& set) {
  Candidate best;
  set_tc(set, 0.0);
  for (unsigned mask = 1; mask < (1u << kGm); ++mask) {
    const Candidate c = fit_terms(set, mask, 0.0);
    if (c.valid && c.score() < best.score()) best = c;
  }
  const TcGrid grid = tc_grid(set);
  for (unsigned mask = 1u << kGm; mask < (1u << kTerms); ++mask) {
    if (__builtin_popcount(mask) + 1 > static_cast<int>(set.pts.size()) - 1) continue;
    if (mask & (1u << 2)) continue;  // B and G both make the plateau: the data cannot split them
    // The deviance is ≥ 0: a model whose penalty alone reaches the best score cannot win.
    if (kTermPenalty * Candidate{mask}.parameters() >= best.score()) continue;
    const Candidate c = fit_with_gm(set, mask, grid);
    if (c.valid && c.score() < best.score()) best = c;
  }
  if ((best.mask >> 2) & 1u) best = plateau_shape(set, best, grid);
  if ((best.mask >> kGm) & 1u) best = refine_gm(set, best, grid.step);
  best = walk_or_plateau(set, best);
  set_tc(set, best.tc);
  return best;
}

// σ of each selected coefficient (and of τc) from the inverse Fisher information JᵀΣ⁻¹J of the
// generalized least squares, J = ∇model over θ = (c_j/ĉ_j…, ln τc), times D/dof when above 1.
void fisher_uncertainties(const FitSet& set, const Candidate& cand, NoiseModel& model) {
  const auto& pts = set.pts;
  std::vector<int> cols;
  for (int j = 0; j < kTerms; ++j)
    if (cand.mask & (1u << j)) cols.push_back(j);
  const bool gm = (cand.mask >> kGm) & 1u;
  const int k = static_cast<int>(cols.size()) + (gm ? 1 : 0);
  Eigen::MatrixXd J(static_cast<int>(pts.size()), k);
  const double h = 1e-4;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const FitPoint& p = pts[i];
    Eigen::VectorXd g(k);
    // θ_q = c_q / ĉ_q (relative, so every column is of order 1 and F is well scaled).
    for (std::size_t q = 0; q < cols.size(); ++q) g(static_cast<int>(q)) = cand.c[cols[q]] * p.a[cols[q]];
    if (gm) {
      const double up = model::allan::gauss_markov(1.0, cand.tc * std::exp(h), p.tau);
      const double dn = model::allan::gauss_markov(1.0, cand.tc * std::exp(-h), p.tau);
      g(k - 1) = cand.c[kGm] * (up - dn) / (2.0 * h);
    }
    J.row(static_cast<int>(i)) = std::sqrt(p.edf / 2.0) / model_at(p, cand.c) * g.transpose();
  }
  const Eigen::MatrixXd Jw = set.whiten(J);
  const Eigen::MatrixXd F = Jw.transpose() * Jw;
  const Eigen::MatrixXd cov = F.completeOrthogonalDecomposition().pseudoInverse();
  model.dof = static_cast<int>(pts.size()) - k;
  model.chi2_reduced = model.dof > 0 ? cand.deviance / model.dof : kNaN;
  const double inflate = std::isfinite(model.chi2_reduced) ? std::max(1.0, model.chi2_reduced) : 1.0;
  for (std::size_t q = 0; q < cols.size(); ++q) {
    Coefficient* c = coefficient(model, cols[q]);
    const double var_c = cov(static_cast<int>(q), static_cast<int>(q)) * inflate * cand.c[cols[q]] * cand.c[cols[q]];
    c->fitted_sigma = std::sqrt(std::max(0.0, var_c)) / (2.0 * c->fitted);
  }
  if (gm) {
    model.correlation_time.fitted = cand.tc;
    model.correlation_time.fitted_sigma = cand.tc * std::sqrt(std::max(0.0, cov(k - 1, k - 1) * inflate));
  }
}

// Leading points an unstated output filter may have flattened: m ≤ kMaxFilteredM and the slope to
// the next point flatter than −½ + tolerance. Returns how many to leave out.
std::size_t filtered_prefix(const std::vector<FitPoint>& pts, double tolerance) {
  std::size_t i = 0;
  while (i + 3 < pts.size() && pts[i].m <= kMaxFilteredM) {
    const double slope = (std::log(pts[i + 1].adev) - std::log(pts[i].adev)) /
                         (std::log(pts[i + 1].tau) - std::log(pts[i].tau));
    if (!(slope > -0.5 + tolerance)) break;
    ++i;
  }
  return i;
}

// End of the fitted points: those averaged over fewer than kMinClusters clusters (N/m < 4, EDF
// about 1–2) are left out of the fit (kept for the bounds and read-offs): their χ² with one or two
// degrees of freedom is far from the likelihood's Gaussian approximation, and in a random walk
// such a point often falls an order of magnitude low, which the strong correlation with its
// neighbour reads as a significant turn. At least 3 points are fitted.
std::size_t fitted_end(const std::vector<FitPoint>& pts, std::uint64_t samples, std::size_t first) {
  std::size_t end = pts.size();
  while (end > first + 3 && static_cast<double>(samples) / pts[end - 1].m < kMinClusters) --end;
  return end;
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

// The power-law noise type nearest to the measured local ADEV slope at τ (−1, −½, 0, +½).
NoiseType noise_of_slope(const std::vector<FitPoint>& pts, const std::vector<double>& slope, double tau) {
  std::size_t i = 0;
  while (i + 1 < pts.size() && pts[i].tau < tau) ++i;
  const double s = slope[i];
  if (!(s >= -0.75)) return NoiseType::kQuantization;
  if (s < -0.25) return NoiseType::kWhite;
  if (s < 0.25) return NoiseType::kFlicker;
  return NoiseType::kRandomWalk;
}

// Read-off on a slope line: value_i = adev_i · (τ_ref/τ_i)^target, pooled over the points
// whose local slope is within tolerance of `target` (log-mean weighted by EDF).
Readoff slope_readoff(const char* name, const std::string& unit, const std::vector<FitPoint>& pts,
                      const std::vector<double>& slope, double target, double tau_ref,
                      const AnalysisOptions& opt) {
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

void set_units(NoiseModel& model, const Units& u) {
  model.quantization.unit = u.quantization;
  model.white.unit = u.white;
  model.bias_instability.unit = u.bias;
  model.random_walk.unit = u.random_walk;
  model.rate_ramp.unit = u.ramp;
  model.gauss_markov.unit = u.gauss_markov;
  model.correlation_time.unit = "s";
  model.white_line.unit = u.white;
  model.random_walk_line.unit = u.random_walk;
  model.bias_floor.unit = u.bias;
}

std::vector<FitPoint> usable_points(const AllanCurve& curve) {
  std::vector<FitPoint> pts;
  for (const auto& p : curve.points) {
    if (!(p.avar > 0.0) || !std::isfinite(p.avar) || p.terms < 1) continue;
    pts.push_back({p.tau_s, static_cast<double>(p.m), p.avar, p.adev, kNaN, kNaN, kNaN, {}, NoiseType::kWhite});
  }
  return pts;
}

// EDF of each point for the noise type `type_at(τ)`. The output filter leaves ρ =
// white.independent() independent values per sample: the EDF is Greenhall's for ρ·N samples at
// ρ·m (at least 1) per cluster — unchanged where m ≫ 1/ρ, lower at the shortest τ, where
// neighbouring filtered samples repeat each other.
template <class TypeAt>
void set_edf(std::vector<FitPoint>& pts, const AllanCurve& curve, const WhiteTerm& white, TypeAt type_at) {
  const double rho = white.independent();
  const double n_phase = rho * static_cast<double>(curve.samples) + 1.0;
  for (auto& p : pts) {
    p.noise = type_at(p.tau);
    p.edf = edf_overlapping_adev(p.noise, n_phase, std::max(1.0, rho * p.m));
    if (!(std::isfinite(p.edf) && p.edf > 0.0)) p.edf = 1.0;
  }
}

// Each point's interval at `confidence` from its EDF (for the read-offs; the fit uses the EDF).
void set_intervals(std::vector<FitPoint>& pts, double confidence) {
  for (auto& p : pts) {
    const auto ci = deviation_interval(p.adev, p.edf, confidence);
    p.lo = ci.lo;
    p.hi = ci.hi;
  }
}

// Where each term dominates the fitted variance inside [τ_min, τ_max] (400 log-spaced τ) [s].
void mark_dominance(const NoiseModel& model, const WhiteTerm& white, NoiseModel& out) {
  const int grid = 400;
  const double l0 = std::log(model.tau_min_s), l1 = std::log(model.tau_max_s);
  for (int g = 0; g <= grid; ++g) {
    const double tau = std::exp(l0 + (l1 - l0) * g / grid);
    const auto b = basis(tau, std::max(1.0, std::round(tau * model.rate_hz)), white, model.correlation_time.fitted);
    int best = -1;
    double best_v = 0.0;
    for (int j = 0; j < kTerms; ++j) {
      const double c = coefficient(model, j)->fitted;
      if (c * c * b[j] > best_v) {
        best_v = c * c * b[j];
        best = j;
      }
    }
    if (best < 0) continue;
    Coefficient* c = coefficient(out, best);
    c->dominates = true;
    if (!std::isfinite(c->tau_lo_s)) c->tau_lo_s = tau;
    c->tau_hi_s = tau;
  }
}

// Identified coefficients get value ± σ and the 95 % interval; every linear term gets the largest
// value whose term alone stays below every measured upper limit (G: the largest such σ over τc in
// the fitted range, where the data can see a Gauss–Markov bias). The upper limits are each point's
// 95 % limit, the level of the intervals.
void identify_and_bound(const std::vector<FitPoint>& pts, const WhiteTerm& white, NoiseModel& model) {
  std::vector<double> upper(pts.size());  // each point's upper limit, computed once
  for (std::size_t i = 0; i < pts.size(); ++i)
    upper[i] = std::isfinite(pts[i].edf) ? deviation_interval(pts[i].adev, pts[i].edf, kCoverage).hi : pts[i].adev;
  auto bound_of = [&](int j, double tc) {
    double bound = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double a = basis(pts[i].tau, pts[i].m, white, tc)[j];
      if (a > 0.0) bound = std::min(bound, upper[i] * upper[i] / a);
    }
    return std::sqrt(bound);
  };
  for (int j = 0; j < NoiseModel::kCoefficients; ++j) {
    Coefficient* c = coefficient(model, j);
    if (c->identified) {
      c->value = c->fitted;
      c->sigma = c->fitted_sigma;
      // Normal interval; for the linear terms (c² a weighted sum of AVAR points, χ² with
      // Satterthwaite's EDF c²/(2σ²)) widened to the χ² interval, which reaches further up when
      // few long-τ points decide the coefficient.
      c->lo = std::max(0.0, c->value - stats::kZ95 * c->sigma);
      c->hi = c->value + stats::kZ95 * c->sigma;
      if (j < NoiseModel::kCoefficients - 1) {
        const auto ci = deviation_interval(c->value, c->value * c->value / (2.0 * c->sigma * c->sigma), kCoverage);
        c->lo = std::min(c->lo, ci.lo);
        c->hi = std::max(c->hi, ci.hi);
      }
    }
  }
  for (int j = 0; j < kGm; ++j) coefficient(model, j)->upper_bound = bound_of(j, 0.0);
  double gm = 0.0;
  for (const auto& p : pts) gm = std::max(gm, bound_of(kGm, p.tau / model::allan::kGaussMarkovPeakTau));
  model.gauss_markov.upper_bound = gm;
}

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

std::string term_names(unsigned mask) {
  static const char* names[kTerms] = {"Q", "N", "B", "K", "R", "G"};
  std::string s;
  for (int j = 0; j < kTerms; ++j)
    if (mask & (1u << j)) s += (s.empty() ? "" : "+") + std::string(names[j]);
  return s;
}

NoiseModel failed_model(NoiseModel model, std::string message) {
  model.ok = false;
  model.message = std::move(message);
  for (int j = 0; j < NoiseModel::kCoefficients; ++j) coefficient(model, j)->failed = true;
  return model;
}

}  // namespace

double NoiseModel::avar(double tau_s) const {
  // Without a rate the white term is N²/τ (m = 1 at rate 1/τ).
  const double m = rate_hz > 0.0 ? std::max(1.0, std::round(tau_s * rate_hz)) : 1.0;
  const WhiteTerm w = rate_hz > 0.0 ? WhiteTerm(rate_hz, lowpass_hz) : WhiteTerm(1.0 / tau_s, 0.0);
  const auto b = basis(tau_s, m, w, correlation_time.fitted);
  double v = 0.0;
  for (int j = 0; j < kTerms; ++j) {
    const double c = coefficient(*this, j)->fitted;
    v += c * c * b[j];
  }
  return v;
}

NoiseType NoiseModel::dominant(double tau_s) const {
  const double m = rate_hz > 0.0 ? std::max(1.0, std::round(tau_s * rate_hz)) : 1.0;
  const auto b = basis(tau_s, m, WhiteTerm(rate_hz > 0.0 ? rate_hz : 1.0 / tau_s, 0.0), correlation_time.fitted);
  int best = 1;
  double best_v = 0.0;
  for (int j = 0; j < kTerms; ++j) {
    const double c = coefficient(*this, j)->fitted;
    if (c * c * b[j] > best_v) {
      best_v = c * c * b[j];
      best = j;
    }
  }
  return noise_of_term(best);
}

NoiseModel fit_noise_model(const AllanCurve& curve, const AnalysisOptions& opt) {
  NoiseModel model;
  set_units(model, curve.units);
  model.rate_hz = curve.rate_hz;
  model.lowpass_hz = opt.lowpass_hz;
  std::vector<FitPoint> all = usable_points(curve);
  if (all.size() < 3) {
    return failed_model(model, fmt::format("fit failed: {} usable Allan point(s) (AVAR > 0), need at least 3 "
                                           "(a constant or too short signal)", all.size()));
  }
  model.tau_min_s = all.front().tau;
  model.tau_max_s = all.back().tau;
  const WhiteTerm white(curve.rate_hz, opt.lowpass_hz);
  std::vector<double> slope;
  local_slopes(all, slope);
  set_edf(all, curve, white, [&](double tau) { return noise_of_slope(all, slope, tau); });
  const std::size_t skip = std::isnan(opt.lowpass_hz) ? filtered_prefix(all, opt.slope_tolerance) : 0;
  const std::size_t keep = fitted_end(all, curve.samples, skip);
  FitSet set{std::vector<FitPoint>(all.begin() + static_cast<std::ptrdiff_t>(skip),
                                   all.begin() + static_cast<std::ptrdiff_t>(keep)),
             {}};
  model.tau_fit_min_s = set.pts.front().tau;
  model.tau_fit_max_s = set.pts.back().tau;

  // The correlation from the noise types of the measured slopes (a model's own types would favour
  // it); the EDF from them, then again from the dominant term of the selected model.
  Candidate best;
  set_correlation(set, static_cast<double>(curve.samples));
  set_basis(set, white, 0.0);
  for (int pass = 0; pass < 2; ++pass) {
    best = select_model(set);
    if (!best.valid) break;
    for (int j = 0; j < kTerms; ++j) coefficient(model, j)->fitted = std::sqrt(best.c[j]);
    model.correlation_time.fitted = best.tc;
    model.ok = true;
    set_edf(set.pts, curve, white, [&](double tau) { return model.dominant(tau); });
  }
  if (!best.valid) return failed_model(model, "fit failed: no model with positive coefficients fits the Allan points");
  for (int j = 0; j < kTerms; ++j) {
    coefficient(model, j)->fitted = std::sqrt(best.c[j]);
    coefficient(model, j)->identified = (best.mask >> j) & 1u;
  }
  model.correlation_time.identified = model.gauss_markov.identified;
  fisher_uncertainties(set, best, model);
  model.selection = fmt::format(
      "{} (least D + {:.2f} x parameters over all term subsets; B or G only where they lower D by "
      "more than {:.2f} against K in their place; D = {:.4g})",
      term_names(best.mask), kTermPenalty, kPlateauOverWalk, best.deviance);
  NoiseModel snapshot = model;
  mark_dominance(snapshot, white, model);
  set_edf(all, curve, white, [&](double tau) { return model.dominant(tau); });
  set_intervals(all, curve.confidence);
  identify_and_bound(all, white, model);
  model.white_line = slope_readoff(model.white_line.name, curve.units.white, all, slope, -0.5, 1.0, opt);
  model.random_walk_line =
      slope_readoff(model.random_walk_line.name, curve.units.random_walk, all, slope, 0.5, 3.0, opt);
  read_bias_floor(all, curve.units, model.bias_floor);
  if (skip > 0) {
    model.message = fmt::format("output filter not stated: the {} shortest tau point(s) (flattened, slope > {:.2f}) "
                                "are left out of the fit",
                                skip, -0.5 + opt.slope_tolerance);
  }
  if (model.dof <= 0) model.message += (model.message.empty() ? "" : "; ") + std::string("as many parameters as points: no residual check");
  return model;
}

}  // namespace stend::noise
