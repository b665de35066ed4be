// The identifiability rule. See stend/estimation/identifiability.hpp.
#include "stend/estimation/identifiability.hpp"

#include "stend/estimation/report_section.hpp"
#include "stend/estimation/summary.hpp"
#include "stend/sdk.hpp"
#include "stend/stats/distributions.hpp"

#include <stend/physics/units.hpp>
#include <stend/yaml/reader.hpp>

#include <fmt/format.h>

#include <cmath>
#include <limits>

namespace stend::estimation {

namespace {


// A unit split into its base quantity and the power of degC it is divided by:
// "m/s^2/degC^2" → {"m/s^2", 2}, "1/degC" → {"1", 1}, "rad/s" → {"rad/s", 0}.
struct SplitUnit {
  std::string base;
  int per_degc = 0;
};
SplitUnit split_unit(const std::string& unit) {
  const auto at = unit.rfind("/degC");
  if (at == std::string::npos) return {unit, 0};
  const std::string power = unit.substr(at + 5);
  if (power.empty()) return {unit.substr(0, at), 1};
  if (power.size() >= 2 && power[0] == '^') return {unit.substr(0, at), std::atoi(power.c_str() + 1)};
  return {unit, 0};
}

// The base quantity's tolerance in SI and in display units (value, unit text).
struct BaseTolerance {
  double si = kNaN;
  double shown = kNaN;
  const char* unit = "";
};
BaseTolerance base_tolerance(const std::string& base, const PrecisionTolerances& t) {
  if (base == "m/s^2") return {t.accel_bias_mg * physics::kMilliG, t.accel_bias_mg, "mg"};
  if (base == "rad/s") return {t.gyro_bias_dps * physics::kDegPerSecond, t.gyro_bias_dps, "deg/s"};
  if (base == "1") return {t.scale_cross_ppm * 1e-6, t.scale_cross_ppm, "ppm"};
  if (base == "rad/s/(m/s^2)")
    return {t.g_sensitivity_dps_per_g * physics::kDegPerSecond / physics::kStandardGravity,
            t.g_sensitivity_dps_per_g, "(deg/s)/g"};
  return {};
}

bool positive_finite(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

const char* to_string(Verdict v) {
  switch (v) {
    case Verdict::kDetermined: return "determined";
    case Verdict::kImprecise: return "imprecise";
    case Verdict::kNotIdentifiable: break;
  }
  return "not identifiable";
}

bool PrecisionTolerances::IsValid(std::string* error) const {
  const std::pair<const char*, double> all[] = {{"accel_bias_mg", accel_bias_mg},
                                                {"gyro_bias_dps", gyro_bias_dps},
                                                {"scale_cross_ppm", scale_cross_ppm},
                                                {"g_sensitivity_dps_per_g", g_sensitivity_dps_per_g},
                                                {"temperature_span_c", temperature_span_c}};
  for (const auto& [name, v] : all)
    if (!positive_finite(v)) {
      if (error) *error = fmt::format("tolerance {} must be a finite number > 0, got {}", name, v);
      return false;
    }
  return true;
}

bool PrecisionTolerances::equals(const PrecisionTolerances& o) const {
  return accel_bias_mg == o.accel_bias_mg && gyro_bias_dps == o.gyro_bias_dps &&
         scale_cross_ppm == o.scale_cross_ppm && g_sensitivity_dps_per_g == o.g_sensitivity_dps_per_g &&
         temperature_span_c == o.temperature_span_c;
}

double tolerance_for(const std::string& unit, const PrecisionTolerances& t) {
  const SplitUnit u = split_unit(unit);
  return base_tolerance(u.base, t).si / std::pow(t.temperature_span_c, u.per_degc);
}

std::string tolerance_text(const std::string& unit, const PrecisionTolerances& t) {
  const SplitUnit u = split_unit(unit);
  const BaseTolerance b = base_tolerance(u.base, t);
  if (std::isnan(b.si)) return {};
  if (u.per_degc == 0) return fmt::format("{:g} {}", b.shown, b.unit);
  return fmt::format("{:g} {} over {:g} degC", b.shown, b.unit, t.temperature_span_c);
}

double interval_quantile(double confidence, double dof) {
  if (!(dof > 0.0)) return kNaN;
  const double p = 0.5 * (1.0 + confidence);
  return std::isinf(dof) ? stats::normal_quantile(p) : stats::student_t_quantile(p, dof);
}

namespace {

// z, the normal quantile at the basis' confidence: a tolerance (1 σ) as a half-width is z · tolerance.
double tolerance_quantile(const IntervalBasis& b) { return interval_quantile(b.confidence, kAPrioriDof); }

}  // namespace

Verdict precision_verdict(double std_error, const IntervalBasis& b, const std::string& unit,
                          const PrecisionTolerances& t) {
  const double tol = tolerance_for(unit, t);
  if (std::isnan(tol)) return Verdict::kDetermined;
  return b.quantile * std_error <= tolerance_quantile(b) * tol ? Verdict::kDetermined : Verdict::kImprecise;
}

void judge(ParameterEstimate& e, const PrecisionTolerances& t, const IntervalBasis& b) {
  e.tolerance = tolerance_for(e.unit, t);
  if (!e.identifiable) return;
  e.verdict = precision_verdict(e.std_error, b, e.unit, t);
  if (e.verdict != Verdict::kImprecise) return;
  const DisplayUnit du = display_unit(e.unit);  // the row's unit, as the tables show it
  e.reason = fmt::format("the {:g} % interval's half-width {:.3g} {} ({:.3g} × the standard error {:.3g}) exceeds "
                         "{:.3g} × the tolerance {}",
                         100.0 * b.confidence, b.quantile * e.std_error * du.scale, du.unit, b.quantile,
                         e.std_error * du.scale, tolerance_quantile(b), tolerance_text(e.unit, t));
}

std::string direction_text(const Eigen::VectorXd& v, const std::vector<std::string>& names) {
  Eigen::Index top = 0;
  const double mx = v.cwiseAbs().maxCoeff(&top);
  if (!(mx > 0.0)) return {};
  const double sign = v[top] < 0.0 ? -1.0 : 1.0;
  std::string s;
  for (Eigen::Index j = 0; j < v.size(); ++j) {
    const double c = sign * v[j] / mx;
    if (std::abs(c) < 0.05) continue;
    const std::string name = static_cast<std::size_t>(j) < names.size() ? names[static_cast<std::size_t>(j)]
                                                                          : "p" + std::to_string(j);
    s += s.empty() ? (c < 0 ? "-" : "") : (c < 0 ? " - " : " + ");
    if (std::abs(std::abs(c) - 1.0) > 5e-3) s += fmt::format("{:.2g}*", std::abs(c));
    s += name;
  }
  return s;
}

Eigen::MatrixXd reduced_row_echelon(Eigen::MatrixXd M) {
  const Eigen::Index rows = M.rows(), cols = M.cols();
  Eigen::Index r = 0;
  for (Eigen::Index c = 0; c < cols && r < rows; ++c) {
    Eigen::Index piv;
    const double best = M.col(c).tail(rows - r).cwiseAbs().maxCoeff(&piv);
    if (best < 1e-12) continue;
    piv += r;
    M.row(r).swap(M.row(piv));
    M.row(r) /= M(r, c);
    for (Eigen::Index i = 0; i < rows; ++i)
      if (i != r) M.row(i) -= M(i, c) * M.row(r);
    ++r;
  }
  for (Eigen::Index i = 0; i < rows; ++i) {
    const double mx = M.row(i).cwiseAbs().maxCoeff();
    for (Eigen::Index j = 0; j < cols; ++j)
      if (std::abs(M(i, j)) < 1e-10 * mx) M(i, j) = 0.0;
  }
  return M;
}

std::vector<std::string> null_space_text(const Eigen::MatrixXd& basis, const std::vector<std::string>& names) {
  std::vector<std::string> out;
  if (basis.cols() == 0) return out;
  const Eigen::MatrixXd rows = reduced_row_echelon(basis.transpose());
  for (Eigen::Index i = 0; i < rows.rows(); ++i)
    if (rows.row(i).cwiseAbs().maxCoeff() > 0.0) out.push_back(direction_text(rows.row(i).transpose(), names));
  return out;
}

void read_tolerances(const yaml::MapReader& parent, PrecisionTolerances& t) {
  if (!parent.has(kTolerancesKey)) return;
  const yaml::MapReader m(parent.get(kTolerancesKey), parent.file(), parent.child_path(kTolerancesKey),
                          "precision tolerances (1 sigma)",
                          {"accel_bias_mg", "gyro_bias_dps", "scale_cross_ppm", "g_sensitivity_dps_per_g",
                           "temperature_span_c"},
                          {}, parent.value_location(kTolerancesKey));
  auto read = [&](const char* key, double& v, const char* unit_words) {
    v = m.number(key, v, unit_words);
    if (!positive_finite(v)) m.fail_value(key, "must be > 0");
  };
  read("accel_bias_mg", t.accel_bias_mg, "in mg");
  read("gyro_bias_dps", t.gyro_bias_dps, "in deg/s");
  read("scale_cross_ppm", t.scale_cross_ppm, "in ppm");
  read("g_sensitivity_dps_per_g", t.g_sensitivity_dps_per_g, "in (deg/s)/g");
  read("temperature_span_c", t.temperature_span_c, "in degC");
}

}  // namespace stend::estimation
