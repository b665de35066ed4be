// The gap's linear problem over segment means. See linear_problem.hpp.
#include "linear_problem.hpp"

#include <Eigen/QR>
#include <algorithm>

namespace stend::diagnosis {

std::string term_label(const model::TermSpec& t) {
  std::string s = model::term_name(t.kind);
  if (t.kind == model::TermKind::kBiasTemperature || t.kind == model::TermKind::kScaleTemperature)
    s += "(order " + std::to_string(t.order) + ")";
  return s;
}

const Eigen::Vector3d& measured(const GapInput& in, const SegmentData& s) {
  return s.point.axes(in.spec.model.instrument).mean;
}

MatrixXd term_columns(const GapInput& in, const Rows& rows, const model::TermSpec& t) {
  model::ErrorModel m;
  m.instrument = in.spec.model.instrument;
  m.terms = {t};
  MatrixXd B(rows.y.size(), m.size());
  std::vector<Eigen::Matrix<double, 3, Eigen::Dynamic>> per_seg(in.segments.size());
  for (std::size_t s = 0; s < in.segments.size(); ++s) per_seg[s] = m.regressor(in.segments[s].point.stimulus);
  for (Eigen::Index r = 0; r < rows.y.size(); ++r) {
    const auto& R = per_seg[static_cast<std::size_t>(rows.seg[static_cast<std::size_t>(r)])];
    if (rows.dir.empty())
      B.row(r) = R.row(rows.axis[static_cast<std::size_t>(r)]);
    else
      B.row(r) = rows.dir[static_cast<std::size_t>(r)].transpose() * R;
  }
  return B;
}

MatrixXd hstack(const MatrixXd& a, const MatrixXd& b) {
  MatrixXd m(std::max(a.rows(), b.rows()), a.cols() + b.cols());
  if (a.cols()) m.leftCols(a.cols()) = a;
  if (b.cols()) m.rightCols(b.cols()) = b;
  return m;
}

MatrixXd scale_rows(const MatrixXd& A, const VectorXd& w) { return w.cwiseSqrt().asDiagonal() * A; }

MatrixXd unit_columns(const MatrixXd& A) {
  MatrixXd S = A;
  for (Eigen::Index j = 0; j < S.cols(); ++j) {
    const double nj = S.col(j).norm();
    if (nj > 0) S.col(j) /= nj;
  }
  return S;
}

int rank_of(const MatrixXd& A) {
  if (A.cols() == 0) return 0;
  Eigen::ColPivHouseholderQR<MatrixXd> qr(unit_columns(A));
  qr.setThreshold(1e-9);
  return static_cast<int>(qr.rank());
}

MatrixXd column_basis(const MatrixXd& A) {
  Eigen::ColPivHouseholderQR<MatrixXd> qr(A);
  qr.setThreshold(1e-10);
  return MatrixXd(qr.householderQ()).leftCols(qr.rank());
}

Fit solve(const MatrixXd& A, const VectorXd& y, const VectorXd& w, const std::vector<std::string>& names,
          const std::vector<std::string>& units, bool known_variance) {
  estimation::LsqProblem pr;
  pr.design = A;
  pr.observations = y;
  pr.weights = w;
  pr.names = names;
  pr.units = units;
  estimation::LsqOptions o;
  o.observations_per_parameter_warning = 0.0;
  o.known_variance = known_variance;
  Fit f;
  f.lsq = estimation::solve_lsq(pr, o);
  if (f.lsq.ok()) {
    f.rss = f.lsq.rss;
    f.rank = f.lsq.rank;
  }
  return f;
}

ParamLabels param_labels(const GapInput& in, const std::vector<model::TermSpec>& terms) {
  model::ErrorModel m;
  m.instrument = in.spec.model.instrument;
  m.terms = terms;
  ParamLabels l;
  for (const auto& p : m.params()) {
    l.names.push_back(p.name);
    l.units.push_back(p.unit);
  }
  return l;
}

}  // namespace stend::diagnosis
