// Placement of hand-placed faces as a candidate family. See steps.hpp (assess_placement) and
// gap.hpp (PlacementResult).
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>

#include "stend/physics/units.hpp"
#include "stend/stats/hypothesis_tests.hpp"
#include "steps.hpp"
#include "text.hpp"

namespace stend::diagnosis {

namespace {

// Hand placement on a bench is good to a few degrees; a fitted rotation beyond this is not a
// placement error but something else absorbed by the per-face freedom [deg].
constexpr double kPlausiblePlacement_deg = 5.0;
// The gap is "across the stated gravity directions" when at least this share of its square is.
constexpr double kAcrossShare = 0.9;

// Nominal-orientation data: the axes form (truth directions stated), every axis fitted, no table
// angles (a table's pose is known; its errors are the table candidates).
bool nominal_orientations(const GapInput& in) {
  if (in.magnitude || in.spec.model.instrument != model::Instrument::kAccelerometer || in.spec.axes.size() != 3)
    return false;
  for (const auto& s : in.segments)
    for (const auto& v : s.point.stimulus.table_df_dangle)
      if (v.norm() > 0) return false;
  return true;
}

// Two unit vectors across a face's stated gravity direction u (the rotations that move f; one
// about u itself is not seen).
std::pair<Eigen::Vector3d, Eigen::Vector3d> across_basis(const Eigen::Vector3d& u) {
  const Eigen::Vector3d seed = std::abs(u.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d e1 = (seed - seed.dot(u) * u).normalized();
  return {e1, u.cross(e1)};
}

// Columns of the per-face rotations across f: for a row of axis a of a segment on face k, row a
// of e_j × f for the two directions e_j across the face's stated gravity direction (δf = δθ × f)
// [unit/rad]. Only the rotations that move f are columns, so six faces placed once (18 rows) with
// bias + scale (6) leave exactly the 12 per-face angles: a determined, not an underdetermined fit.
MatrixXd placement_columns(const GapInput& in, const Rows& rows, const std::vector<int>& face_of_segment,
                           const std::vector<Eigen::Vector3d>& face_up) {
  MatrixXd P = MatrixXd::Zero(rows.y.size(), 2 * static_cast<Eigen::Index>(face_up.size()));
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const auto s = static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)]);
    const Eigen::Vector3d& f = in.segments[s].point.stimulus.specific_force;
    const int k = face_of_segment[s];
    const auto [e1, e2] = across_basis(face_up[static_cast<std::size_t>(k)]);
    const int a = rows.axis[static_cast<std::size_t>(r)];
    P(r, 2 * k) = e1.cross(f)[a];
    P(r, 2 * k + 1) = e2.cross(f)[a];
  }
  return P;
}

// Share of the squared residual (per segment, three axes) across the stated gravity direction.
double across_share(const GapInput& in, const Rows& rows, const VectorXd& residual) {
  std::map<int, Eigen::Vector3d> per_seg;
  for (Eigen::Index r = 0; r < residual.size(); ++r) {
    auto& v = per_seg.try_emplace(rows.seg[static_cast<std::size_t>(r)], Eigen::Vector3d::Zero()).first->second;
    v[rows.axis[static_cast<std::size_t>(r)]] = residual[r];
  }
  double across = 0, total = 0;
  for (const auto& [s, v] : per_seg) {
    const Eigen::Vector3d u = in.segments[static_cast<std::size_t>(s)].point.stimulus.specific_force.normalized();
    total += v.squaredNorm();
    across += (v - v.dot(u) * u).squaredNorm();
  }
  return total > 0 ? across / total : kNaN;
}

// The fitted rotation of each face across its f [deg] (the columns are already across f).
void face_angles(const GapInput& in, const std::vector<int>& face_of_segment, const VectorXd& theta, int p0,
                 PlacementResult& pr) {
  std::vector<std::string> names(static_cast<std::size_t>(pr.faces));
  for (std::size_t s = 0; s < in.segments.size(); ++s)
    names[static_cast<std::size_t>(face_of_segment[s])] = in.segments[s].orientation_name;
  double sq = 0;
  pr.max_deg = 0;
  for (int k = 0; k < pr.faces; ++k) {
    const double deg = theta.segment(p0 + 2 * k, 2).norm() * physics::kRadToDeg;
    pr.face_deg.emplace_back(names[static_cast<std::size_t>(k)], deg);
    sq += deg * deg;
    if (deg > pr.max_deg) {
      pr.max_deg = deg;
      pr.max_face = names[static_cast<std::size_t>(k)];
    }
  }
  pr.rms_deg = std::sqrt(sq / pr.faces);
}

// The verdict of the family, in words, added to the statement.
std::string placement_statement(const PlacementResult& pr, const GapReport& rep) {
  std::ostringstream os;
  os << "PLACEMENT: faces placed off by " << fmt(pr.rms_deg, 2) << " degrees RMS (largest " << fmt(pr.max_deg, 2)
     << " deg, " << pr.max_face << ")";
  if (pr.significant)
    os << " explain the remaining gap in-sample (partial F p " << fmt(pr.p_value, 2) << ", to "
       << fmt(pr.in_sample_after * rep.display_per_unit, 3) << " " << rep.display_unit
       << " RMS); a per-face rotation cannot be tested held out (each face's is seen only in that face).";
  else
    os << " would account for the remaining gap: " << fmt(100 * pr.across_share, 3)
       << " % of it lies across the stated gravity directions, where a rotation acts. This session cannot test it "
          "(no degree of freedom is left with a rotation per face) — place each face twice, re-placing the sensor, "
          "or add tilted positions, to test it.";
  if (!pr.aliases.empty()) {
    os << " On this design ";
    for (std::size_t i = 0; i < pr.aliases.size(); ++i)
      os << (i ? (i + 1 == pr.aliases.size() ? " and " : ", ") : "") << pr.aliases[i];
    os << (pr.aliases.size() > 1 ? " lie" : " lies")
       << " within the per-face rotations (a misalignment of the sensor axes is one setting of them): the data "
          "cannot tell "
       << (pr.aliases.size() > 1 ? "them" : "it")
       << " from a placement error. Place the faces again with fresh placements, or add tilted positions, to "
          "separate them.";
  }
  return os.str();
}

}  // namespace

void assess_placement(const GapInput& in, const Rows& rows, const std::vector<model::TermSpec>& terms, const MatrixXd& A,
                      const GapOptions& opt, GapReport& rep) {
  PlacementResult& pr = rep.placement;
  if (!nominal_orientations(in)) {
    pr.reason = "not nominal-orientation data (a table's angles, the magnitude form or a gyroscope)";
    return;
  }
  if (rep.at_floor || rep.steps.empty()) {
    pr.reason = "no gap left above the floor";
    return;
  }
  std::vector<int> face_of_segment;
  std::map<int, int> face_index;
  for (const auto& s : in.segments)
    face_of_segment.push_back(face_index.try_emplace(s.orientation, static_cast<int>(face_index.size())).first->second);
  pr.faces = static_cast<int>(face_index.size());
  // Each face's stated gravity direction: the mean of its segments' (nominal) directions.
  std::vector<Eigen::Vector3d> face_up(static_cast<std::size_t>(pr.faces), Eigen::Vector3d::Zero());
  for (std::size_t s = 0; s < in.segments.size(); ++s)
    face_up[static_cast<std::size_t>(face_of_segment[s])] += in.segments[s].point.stimulus.specific_force.normalized();
  for (auto& u : face_up) u.normalize();
  const Fit base = solve(A, rows.y, rows.w);
  const Fit with =
      solve(hstack(A, placement_columns(in, rows, face_of_segment, face_up)), rows.y, rows.w, {}, {}, true);
  if (!base.lsq.ok() || !with.lsq.ok()) {
    pr.reason = "fit with the face rotations failed: " + (base.lsq.ok() ? with.lsq.message : base.lsq.message);
    return;
  }
  pr.assessed = true;
  pr.added_rank = with.rank - base.rank;
  pr.dof = static_cast<int>(rows.y.size()) - with.rank;
  pr.across_share = across_share(in, rows, base.lsq.residuals);
  pr.in_sample_after = std::sqrt(with.lsq.residuals.squaredNorm() / static_cast<double>(rows.y.size()));
  face_angles(in, face_of_segment, with.lsq.min_norm_solution, static_cast<int>(A.cols()), pr);
  const bool plausible = pr.max_deg <= kPlausiblePlacement_deg;
  if (pr.added_rank > 0 && pr.dof > 0 && with.rss > 0) {
    const double k = static_cast<double>(rows.y.size());
    pr.p_value = stats::nested_f_test(base.rss, with.rss, pr.added_rank, pr.dof).p_value;
    pr.delta_bic = k * std::log(with.rss / base.rss) + pr.added_rank * std::log(k);
    pr.significant = pr.p_value < opt.alpha && pr.delta_bic < 0 && plausible;
    pr.reason = "partial F test of a rotation per face with the final model, in-sample (p " + fmt(pr.p_value, 2) +
                "; " + fmt(100 * pr.across_share, 3) +
                " % of the remaining squared gap lies across the stated gravity directions, where a rotation acts)";
  } else {
    pr.consistent = pr.added_rank > 0 && plausible && pr.across_share >= kAcrossShare;
    pr.reason = "no degree of freedom left with a rotation per face: judged by where the gap lies (" +
                fmt(100 * pr.across_share, 3) + " % across the stated gravity directions) and the angles' size";
  }
  if (!plausible) pr.reason += "; the fitted rotations (largest " + fmt(pr.max_deg, 2) + " deg) exceed what hand placement gives";
  if (pr.significant || pr.consistent) {
    // Which sensor terms lie within the per-face rotations here (with the model as given)? Six
    // faces placed once: each face's across-f rows are free, so a misalignment is one of their
    // settings; a named term there may be a placement error as well.
    const std::size_t given = in.spec.model.terms.size();
    MatrixXd AP = MatrixXd(rows.y.size(), 0);
    for (std::size_t k = 0; k < given && k < terms.size(); ++k) AP = hstack(AP, term_columns(in, rows, terms[k]));
    AP = hstack(AP, placement_columns(in, rows, face_of_segment, face_up));
    const int rank_ap = rank_of(scale_rows(AP, rows.w));
    const auto within = [&](const model::TermSpec& t) {
      const MatrixXd C = term_columns(in, rows, t);
      return C.norm() > 0 && rank_of(scale_rows(hstack(AP, C), rows.w)) == rank_ap;
    };
    bool has_cross = false;
    for (std::size_t k = 0; k < terms.size(); ++k) {
      has_cross = has_cross || terms[k].kind == model::TermKind::kCrossAxis;
      if (k >= given && k - given < rep.selected.size() && within(terms[k])) pr.aliases.push_back(rep.selected[k - given]);
    }
    if (!has_cross && within(model::TermSpec{model::TermKind::kCrossAxis, 1, 25.0})) pr.aliases.push_back("cross_axis");
    if (rep.selected.empty())
      rep.statement = "No sensor term of the vocabulary explains the held-out gap of " +
                      fmt(rep.unexplained_heldout_rms * rep.display_per_unit, 3) + " " + rep.display_unit + " RMS (" +
                      fmt(rep.unexplained_over_floor, 3) + "x the noise floor) significantly. ";
    else
      rep.statement += " ";
    rep.statement += placement_statement(pr, rep);
  }
}

}  // namespace stend::diagnosis
