// The identifiability rule every estimator applies, written once.
//
// A fit is judged by the information in its design, not by how large a standard error is relative
// to its value (a cross-axis term near zero has a huge relative error and may still be known to
// a few ppm):
//   - the design is singular (a singular value of the column-scaled design or Jacobian below
//     rank_tolerance · σ_max): the combination of parameters the data cannot see is named from the
//     singular vector ("bias_z + 0.98*scale_z") and the parameters it moves are withheld;
//   - otherwise every parameter is reported with its standard error and a verdict from its interval:
//     kDetermined when the interval's half-width at the fit's confidence (quantile × standard error,
//     the quantile Student t for the fit's degrees of freedom when the variance was estimated from
//     the residuals, normal when the sigmas are a priori: interval_quantile) is within the tolerance
//     scaled the same way (z × tolerance, z the normal quantile at that confidence), kImprecise when
//     it is wider (still reported, flagged). With many degrees of freedom t ≈ z and the rule is the
//     standard error against the tolerance; with 1 degree of freedom t = 12.7 at 95 %, and a
//     standard error within the tolerance is still imprecise.
//
// The tolerances are stated once, in the units people read (mg, °/s, ppm), and converted to each
// parameter's SI unit by the parameter's unit string (stend/model/terms.hpp). A model file may
// override them under `tolerances:` (read_tolerances).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace stend::yaml {
class MapReader;
}

namespace stend::estimation {

struct ParameterEstimate;

enum class Verdict {
  kDetermined,       // interval within the tolerance's interval (or no tolerance applies)
  kImprecise,        // reported, but the interval is wider than the tolerance's
  kNotIdentifiable,  // in a singular direction of the design: withheld
};
const char* to_string(Verdict v);  // "determined" | "imprecise" | "not identifiable"

// Precision tolerances (1 σ), each default written here once.
struct PrecisionTolerances {
  double accel_bias_mg = 1.0;             // accelerometer bias [mg]
  double gyro_bias_dps = 0.05;            // gyroscope bias [deg/s]
  double scale_cross_ppm = 1000.0;        // scale factor and cross-axis terms [ppm]
  double g_sensitivity_dps_per_g = 0.05;  // gyro g-sensitivity [(deg/s)/g]
  // A temperature coefficient of order k is judged by the change it makes over this span:
  // tolerance = (tolerance of its base quantity) / span^k.
  double temperature_span_c = 10.0;  // [degC]

  bool IsValid(std::string* error = nullptr) const;  // every tolerance finite and > 0
  bool equals(const PrecisionTolerances& o) const;
};

// The tolerance of a parameter in its own SI unit (the vocabulary's unit strings: "m/s^2",
// "rad/s", "1", "rad/s/(m/s^2)", "m/s^2/degC^2", …); NaN when none applies (angles, lever arms,
// Allan coefficients), and then the verdict is kDetermined once identified.
double tolerance_for(const std::string& unit, const PrecisionTolerances& t);
// The tolerance in display units, e.g. "1 mg", "0.05 deg/s", "1000 ppm"; "" when none applies.
std::string tolerance_text(const std::string& unit, const PrecisionTolerances& t);

// The degrees of freedom of a fit whose sigmas are a priori (its intervals use the normal quantile).
inline constexpr double kAPrioriDof = std::numeric_limits<double>::infinity();
// The two-sided quantile of a fit's intervals at `confidence`: Student t with `dof` degrees of
// freedom when the variance was estimated from the residuals, the normal quantile for kAPrioriDof.
// NaN for dof ≤ 0 (no residual to estimate a variance from). The one choice of every fit.
double interval_quantile(double confidence, double dof);

// How a fit formed its intervals: their confidence and the quantile (interval_quantile).
struct IntervalBasis {
  double confidence = 0.95;
  double quantile = NAN;
};

// The verdict of an identified parameter from its interval: kDetermined when the half-width
// b.quantile · std_error (SI) is within z · tolerance (z the normal quantile at b.confidence), or
// when no tolerance applies; else kImprecise (also for a half-width that is not a number).
Verdict precision_verdict(double std_error, const IntervalBasis& b, const std::string& unit,
                          const PrecisionTolerances& t);
// Sets e.tolerance, and for an identified parameter e.verdict and (for kImprecise) e.reason from
// e.std_error and the fit's interval basis.
void judge(ParameterEstimate& e, const PrecisionTolerances& t, const IntervalBasis& b);

// Fewer residual degrees of freedom than this are stated as a note in the fit's summary: the
// residual scatter and the intervals rest on only a few numbers.
inline constexpr int kFewDegreesOfFreedom = 5;

// A direction in parameter space as text, largest coefficient 1, coefficients below 5 % of it
// dropped: "bias_z + 0.98*scale_z". `v` in the parameters' own (unscaled) units.
std::string direction_text(const Eigen::VectorXd& v, const std::vector<std::string>& names);

// Reduced row echelon form of M (rows = combinations): leading coefficient 1, dust set to zero.
Eigen::MatrixXd reduced_row_echelon(Eigen::MatrixXd M);
// The unidentified combinations of a null space (basis: p × d columns in the parameters' own
// units), one per dimension, in reduced row echelon form so that equal singular values do not mix
// them: e.g. "bias_x - 0.12*cross_xz", "bias_z - 0.12*scale_z".
std::vector<std::string> null_space_text(const Eigen::MatrixXd& basis, const std::vector<std::string>& names);

// Reads an optional `tolerances:` mapping of `parent` (keys accel_bias_mg, gyro_bias_dps,
// scale_cross_ppm, g_sensitivity_dps_per_g, temperature_span_c; each > 0) into `t`.
inline constexpr const char* kTolerancesKey = "tolerances";
void read_tolerances(const yaml::MapReader& parent, PrecisionTolerances& t);

}  // namespace stend::estimation
