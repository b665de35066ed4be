// Tables of means without inputs (io's means_table: Magneto's input, a lab spreadsheet) through the
// unknown-orientation fit with the shipped configs/models/accel_unknown_orientations.yaml. The
// tables are generated from a planted truth (random orientations, bias, scale, misalignment, per-row
// noise) in g, in counts and in m/s^2, with and without the rows' n and sigma, and read the way
// `stend fit means.csv` reads them (io::open_dataset, the format detected). Checked: the parameters
// against the truth and their intervals' coverage over seeds; the fit equal to an independent
// reference (tests/ellipsoid_reference.py: the algebraic ellipsoid fit of Li & Griffiths as Magneto
// does it, refined by its own Gauss-Newton on the same cost in another parameterisation) in its
// offsets, its ellipsoid matrix Q and its standard errors; the stated noise reaching the fit (an
// overstated sigma widens the intervals, an understated one does not narrow them); a table with
// fewer rows than parameters refused with what is needed. The same n and sigma on the static_table
// format (known inputs) weight the known-orientation fit.
#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/estimation/linear_lsq.hpp>
#include <stend/io/formats.hpp>
#include <stend/io/importers.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>
#include <stend/testing/program.hpp>

#include <fmt/format.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <vector>

using namespace stend;
using namespace stend::ceres_nonlinear;

namespace {

constexpr double kG = 9.80665;      // the fit's |g|: the table states none (standard gravity)
constexpr double kLsbPerG = 16384;  // counts per g of the counts tables (--accel-lsb 1/16384g)
constexpr int kParameters = 9;      // bias 3, scale 3, cross yx zx zy

// The planted truth in the vocabulary's order (bias xyz [m/s^2], scale xyz, cross xy xz yx yz zx zy):
// the cross terms xy, xz, yz are 0, the unknown-orientation fit's frame convention.
const std::vector<double> kTruth = {0.12, -0.08, 0.2, 0.015, -0.02, 0.008, 0.0, 0.0, 0.006, 0.0, -0.005, 0.003};
const std::vector<std::string> kFitted = {"bias_x",  "bias_y",   "bias_z",   "scale_x", "scale_y",
                                          "scale_z", "cross_yx", "cross_zx", "cross_zy"};

std::size_t truth_index(const std::string& name) {
  static const std::vector<std::string> all = {"bias_x",   "bias_y",   "bias_z",   "scale_x",  "scale_y",  "scale_z",
                                               "cross_xy", "cross_xz", "cross_yx", "cross_yz", "cross_zx", "cross_zy"};
  return static_cast<std::size_t>(std::find(all.begin(), all.end(), name) - all.begin());
}

enum class Unit { kInG, kInCounts, kInMps2 };

// What a generated table holds and states.
struct TableSpec {
  int rows = 178;
  Unit unit = Unit::kInG;
  bool n = true;          // a column n (samples per row)
  bool sigma = true;      // a sigma: per axis (sigma_x, …) or one per row
  bool per_axis = true;
  std::uint64_t seed = 1;
  double stated_sigma_factor = 1.0;  // the sigma written, × the true one (an overstated or understated table)
  char delimiter = ',';
  bool named = true;  // a column-name line (without one: three columns, Magneto's form)
};

// A generated table of means: its text, and per row the true standard error of its mean per axis [m/s^2].
struct Table {
  std::string text;
  std::vector<Eigen::Vector3d> se;
};

double file_unit(Unit u) { return u == Unit::kInG ? kG : u == Unit::kInCounts ? kG / kLsbPerG : 1.0; }

// Rows at random orientations, measure(truth, g·d) plus the error of a mean of n samples of spread
// sigma. What the table does not state is the same on every row (so that weighting the rows the same
// is right for it): n = 400 without an n column, sigma 2 mg without a sigma column.
Table make_table(const TableSpec& t) {
  std::mt19937_64 rng(t.seed);
  std::normal_distribution<double> unit_normal(0.0, 1.0);
  std::uniform_real_distribution<double> sigma_mg(0.5, 3.0);
  std::uniform_int_distribution<int> count(50, 2000);
  const model::ErrorModel m = accelerometer_model();
  const double u = file_unit(t.unit);
  Table out;
  const std::string d(1, t.delimiter);
  if (t.named) {
    out.text = fmt::format("ax{0}ay{0}az", d);
    if (t.n) out.text += d + "n";
    if (t.sigma) out.text += t.per_axis ? fmt::format("{0}sigma_x{0}sigma_y{0}sigma_z", d) : d + "sigma";
    out.text += "\n";
  }
  for (int k = 0; k < t.rows; ++k) {
    Eigen::Vector3d dir(unit_normal(rng), unit_normal(rng), unit_normal(rng));
    dir.normalize();
    const double n = t.n ? count(rng) : 400.0;
    Eigen::Vector3d sigma = Eigen::Vector3d::Constant(2e-3 * kG);
    if (t.sigma && t.per_axis) sigma = Eigen::Vector3d(sigma_mg(rng), sigma_mg(rng), sigma_mg(rng)) * 1e-3 * kG;
    if (t.sigma && !t.per_axis) sigma = Eigen::Vector3d::Constant(sigma_mg(rng) * 1e-3 * kG);
    const Eigen::Vector3d se = sigma / std::sqrt(n);
    model::Stimulus<double> s;
    s.input = dir * kG;
    s.specific_force = s.input;
    const Eigen::Vector3d y = m.measure<double>(kTruth.data(), s) +
                              Eigen::Vector3d(unit_normal(rng), unit_normal(rng), unit_normal(rng)).cwiseProduct(se);
    out.se.push_back(se);
    const Eigen::Vector3d v = y / u;
    out.text += fmt::format("{:.10g}{}{:.10g}{}{:.10g}", v.x(), d, v.y(), d, v.z());
    if (t.n) out.text += fmt::format("{}{}", d, static_cast<int>(n));
    const Eigen::Vector3d stated = sigma * t.stated_sigma_factor / u;
    if (t.sigma)
      out.text += t.per_axis ? fmt::format("{0}{1:.6g}{0}{2:.6g}{0}{3:.6g}", d, stated.x(), stated.y(), stated.z())
                             : fmt::format("{}{:.6g}", d, stated.x());
    out.text += "\n";
  }
  return out;
}

io::ImportOptions options_for(Unit u) {
  io::ImportOptions o;
  if (u == Unit::kInG) o.set("accel_unit", "g");
  if (u == Unit::kInCounts) o.set("accel_lsb", "1/16384g");
  return o;
}

const ModelFileOptions& shipped_model() {
  static const ModelFileOptions m =
      load_model_file(stend::testing::source_path("configs/models/accel_unknown_orientations.yaml").string());
  return m;
}

// A generated table written, read as `stend fit` reads it (format detected), and fitted.
struct Fitted {
  Recording rec;
  std::string format;
  ModelFileFit fit;
  Table table;
};

Fitted fit_table(const TableSpec& spec, const std::filesystem::path& dir) {
  Fitted f;
  f.table = make_table(spec);
  const auto file = dir / fmt::format("means-{}.csv", spec.seed);
  stend::testing::write_text(file, f.table.text);
  f.rec = io::open_dataset({file}, "auto", options_for(spec.unit), &f.format);
  f.fit = fit_model_file(f.rec, shipped_model());
  return f;
}

// The fitted ellipsoid in the fit's invariants: centre b [m/s^2] and Q [1] with
// (y − b)ᵀ Q (y − b) = g² on it (the fit's correction u = M y + c: b = −M⁻¹c, Q = MᵀM).
struct Ellipsoid {
  Eigen::Vector3d b;
  Eigen::Matrix3d Q;
};

Ellipsoid ellipsoid_of(const CalibrationResult& r) {
  const Eigen::Vector3d c = r.correct(Eigen::Vector3d::Zero());
  Eigen::Matrix3d M;
  for (int i = 0; i < 3; ++i) M.col(i) = r.correct(Eigen::Vector3d::Unit(i)) - c;
  return {-M.inverse() * c, M.transpose() * M};
}

struct Reference {
  Ellipsoid fit, algebraic;
  Eigen::Vector3d se_b;
  Eigen::Matrix3d se_Q;
  int iterations = 0;
};

Eigen::Vector3d vec3(const nlohmann::json& j) { return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()}; }
Eigen::Matrix3d mat3(const nlohmann::json& j) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i) m.row(i) = vec3(j[static_cast<std::size_t>(i)]).transpose();
  return m;
}

constexpr const char* kPython = "/usr/bin/python3";

// Why the reference cannot run here ("" when it can): Debian's python3 with NumPy.
std::string reference_absent() {
  if (!std::filesystem::exists(kPython)) return std::string(kPython) + " is absent";
  if (stend::testing::run_command(std::string(kPython) + " -c 'import numpy' 2>&1").code != 0)
    return std::string(kPython) + " has no NumPy (apt-get install python3-numpy)";
  return {};
}

// The reference on the means the fit saw, each row's standard error as the table states it
// (weighting "none" | "relative" | "absolute").
Reference reference_fit(const Fitted& f, const std::string& weighting, const std::filesystem::path& dir) {
  std::string csv = "ax,ay,az,se_x,se_y,se_z\n";
  for (std::size_t k = 0; k < f.fit.accel.intervals.size(); ++k) {
    const Eigen::Vector3d y = f.fit.accel.intervals[k].accel.mean, se = f.table.se[k];
    csv += fmt::format("{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", y.x(), y.y(), y.z(), se.x(), se.y(), se.z());
  }
  const auto rows = dir / "reference-rows.csv";
  stend::testing::write_text(rows, csv);
  const auto out = stend::testing::run_command(
      fmt::format("{} {} {} {:.17g} {}", kPython,
                  stend::testing::shell_quote(
                      stend::testing::source_path("estimators/ceres_nonlinear/tests/ellipsoid_reference.py").string()),
                  stend::testing::shell_quote(rows.string()), kG, weighting));
  EXPECT_EQ(out.code, 0) << out.text;
  const nlohmann::json j = nlohmann::json::parse(out.text);
  Reference r;
  r.fit = {vec3(j["b"]), mat3(j["Q"])};
  r.algebraic = {vec3(j["algebraic"]["b"]), mat3(j["algebraic"]["Q"])};
  r.se_b = vec3(j["se_b"]);
  r.se_Q = mat3(j["se_Q"]);
  r.iterations = j["iterations"].get<int>();
  return r;
}

// How far two ellipsoids lie apart in the reference's standard errors: the largest |Δ|/SE over b and Q.
double apart(const Ellipsoid& a, const Ellipsoid& b, const Reference& ref) {
  const double db = (a.b - b.b).cwiseQuotient(ref.se_b).cwiseAbs().maxCoeff();
  const double dq = (a.Q - b.Q).cwiseQuotient(ref.se_Q).cwiseAbs().maxCoeff();
  return std::max(db, dq);
}

// The weighting a table's columns ask for (processing::HeldMean).
std::string weighting_of(const TableSpec& t) {
  return t.n && t.sigma ? "absolute" : t.n || t.sigma ? "relative" : "none";
}

// "in counts, n and sigma per axis" for the figures printed.
std::string columns_of(const TableSpec& t) {
  const char* unit = t.unit == Unit::kInG ? "g" : t.unit == Unit::kInCounts ? "counts" : "m/s^2";
  const std::string sigma = t.per_axis ? "sigma per axis" : "sigma per row";
  const std::string stated = t.n && t.sigma ? "n and " + sigma : t.n ? "n only" : t.sigma ? sigma + " only" : "no n, no sigma";
  return fmt::format("in {}, {}", unit, stated);
}

// (θ̂ − θ)ᵀ C⁻¹ (θ̂ − θ) over the fitted parameters: χ² with 9 degrees of freedom when the fit is right.
double mahalanobis(const CalibrationResult& r) {
  Eigen::VectorXd d(kParameters);
  for (int k = 0; k < kParameters; ++k) {
    const auto& name = kFitted[static_cast<std::size_t>(k)];
    d[k] = r.parameter(name).value - kTruth[truth_index(name)];
  }
  return d.dot(r.covariance.ldlt().solve(d));
}

}  // namespace

// ------------------------------------------------------------------------------------------------

// The layouts, read the way `stend fit` reads them: detected as means_table, each row a static point.
TEST(MeansTable, IsDetectedAndEachRowIsAStaticPointOfTheFit) {
  const stend::testing::TempDir dir("means-layout");
  for (const TableSpec& spec : {TableSpec{.unit = Unit::kInG}, TableSpec{.unit = Unit::kInCounts, .per_axis = false},
                                TableSpec{.unit = Unit::kInMps2, .n = false, .sigma = false, .delimiter = '\t'},
                                TableSpec{.unit = Unit::kInG, .n = false, .delimiter = ' '},
                                TableSpec{.unit = Unit::kInG, .n = false, .sigma = false, .delimiter = ' ', .named = false}}) {
    const Fitted f = fit_table(spec, dir.path());
    SCOPED_TRACE(f.table.text.substr(0, f.table.text.find('\n')));
    EXPECT_EQ(f.format, "means_table");
    ASSERT_TRUE(f.fit.ok()) << f.fit.text;
    EXPECT_EQ(f.fit.accel.intervals.size(), static_cast<std::size_t>(spec.rows));
    EXPECT_LT(mahalanobis(f.fit.accel), 27.9);  // the χ²(9) 99.9 % quantile
  }
}

// The fit equals the reference: the same minimum of the same cost, found by Ceres (this fit, a lower
// triangular scale and cross-axis form) and by the reference's Gauss-Newton (an upper triangular
// R, Q = RᵀR). Tolerance: Ceres stops when a step lowers the cost by less than 1e-12 of it, and near
// the minimum a remaining distance δ costs ½δᵀHδ: δ in standard errors is then below
// √(1e-12 · dof) ≈ 1.3e-5 (dof = 169); both fits are checked to 1e-4 standard errors, and their
// standard errors (the same covariance in other coordinates) to 1e-4 relative.
TEST(MeansTable, FitEqualsTheReferenceEllipsoidFit) {
  if (const std::string why = reference_absent(); !why.empty()) GTEST_SKIP() << "the reference fit needs NumPy: " << why;
  const stend::testing::TempDir dir("means-reference");
  for (const TableSpec& spec :
       {TableSpec{.unit = Unit::kInG}, TableSpec{.unit = Unit::kInG, .n = false, .sigma = false, .seed = 2},
        TableSpec{.unit = Unit::kInCounts, .sigma = false, .seed = 3},
        TableSpec{.unit = Unit::kInMps2, .n = false, .per_axis = false, .seed = 4}}) {
    const std::string weighting = weighting_of(spec);
    SCOPED_TRACE(weighting);
    const Fitted f = fit_table(spec, dir.path());
    ASSERT_TRUE(f.fit.ok()) << f.fit.text;
    const Reference ref = reference_fit(f, weighting, dir.path());
    const Ellipsoid ours = ellipsoid_of(f.fit.accel);
    const double d = apart(ours, ref.fit, ref);
    Eigen::Vector3d se_ratio;
    for (int a = 0; a < 3; ++a)
      se_ratio[a] = f.fit.accel.parameter(kFitted[static_cast<std::size_t>(a)]).std_error / ref.se_b[a];
    std::cout << fmt::format("[means_table] {} rows {} (weighting {}): fit vs reference {:.2e} SE (b {:.2e} m/s^2, Q "
                             "{:.2e}), bias SE ratio {:.8f} {:.8f} {:.8f}; the algebraic fit (Magneto) {:.2f} SE "
                             "away; reference {} iterations\n",
                             spec.rows, columns_of(spec), weighting, d, (ours.b - ref.fit.b).cwiseAbs().maxCoeff(),
                             (ours.Q - ref.fit.Q).cwiseAbs().maxCoeff(), se_ratio[0], se_ratio[1], se_ratio[2],
                             apart(ref.algebraic, ref.fit, ref), ref.iterations);
    EXPECT_LT(d, 1e-4);
    EXPECT_LT((se_ratio.array() - 1.0).abs().maxCoeff(), 1e-4);
    EXPECT_LT(apart(ref.algebraic, ref.fit, ref), 5.0);  // the reference's start: near, not equal
  }
}

// Honest intervals: over 30 seeds per kind of table, the truth lies inside each parameter's 95 %
// interval about 95 % of the time (270 parameters a kind: at least 88 %, 4 binomial standard
// deviations below 95 %), and the standard errors are the spread of the estimates, not the zero
// spread of held values (the median bias standard error within 0.6…1.6 of the estimates' own spread).
TEST(MeansTable, IntervalsCoverTheTruthOverSeeds) {
  const stend::testing::TempDir dir("means-coverage");
  constexpr int kSeeds = 30;
  for (TableSpec spec : {TableSpec{.rows = 60, .unit = Unit::kInG}, TableSpec{.rows = 60, .unit = Unit::kInG, .n = false, .sigma = false},
                         TableSpec{.rows = 60, .unit = Unit::kInCounts, .sigma = false},
                         TableSpec{.rows = 60, .unit = Unit::kInMps2, .n = false, .per_axis = false}}) {
    const std::string weighting = weighting_of(spec);
    int inside = 0;
    std::vector<double> se, error;
    for (int s = 0; s < kSeeds; ++s) {
      spec.seed = 100 + static_cast<std::uint64_t>(s);
      const Fitted f = fit_table(spec, dir.path());
      ASSERT_TRUE(f.fit.ok()) << f.fit.text;
      for (const auto& name : kFitted) {
        const auto& p = f.fit.accel.parameter(name);
        const double truth = kTruth[truth_index(name)];
        inside += p.lower <= truth && truth <= p.upper;
      }
      se.push_back(f.fit.accel.parameter("bias_x").std_error);
      error.push_back(f.fit.accel.parameter("bias_x").value - kTruth[0]);
    }
    std::nth_element(se.begin(), se.begin() + kSeeds / 2, se.end());
    double ss = 0.0;
    for (double e : error) ss += e * e;
    const double spread = std::sqrt(ss / kSeeds);
    const int total = kSeeds * kParameters;
    std::cout << fmt::format("[means_table] coverage {} (weighting {}): {}/{} parameters in their 95 % intervals; bias_x "
                             "median SE {:.3g} m/s^2, spread of the estimates {:.3g} m/s^2\n",
                             columns_of(spec), weighting, inside, total, se[kSeeds / 2], spread);
    EXPECT_GE(inside, static_cast<int>(0.88 * total)) << weighting;
    EXPECT_GT(se[kSeeds / 2], 0.6 * spread) << weighting;
    EXPECT_LT(se[kSeeds / 2], 1.6 * spread) << weighting;
  }
}

// The stated noise reaches the fit as a-priori sigmas, widened by the residuals only: a table whose
// sigma is overstated ten times gets intervals ten times as wide (χ² far below 1 does not narrow
// them), one understated ten times the intervals of the residuals' scatter (χ² far above 1).
TEST(MeansTable, StatedNoiseWeighsTheFitAndNeverNarrowsIt) {
  const stend::testing::TempDir dir("means-stated");
  const Fitted right = fit_table({.seed = 7}, dir.path());
  const Fitted over = fit_table({.seed = 7, .stated_sigma_factor = 10.0}, dir.path());
  const Fitted under = fit_table({.seed = 7, .stated_sigma_factor = 0.1}, dir.path());
  for (const Fitted* f : {&right, &over, &under}) ASSERT_TRUE(f->fit.ok()) << f->fit.text;
  EXPECT_TRUE(right.fit.accel.whitened);
  EXPECT_NEAR(right.fit.accel.sigma, 1.0, 0.2);  // whitened residuals: 1 as expected
  // The same minimum (the weights scaled alike); the a-priori covariance scaled by max(1, χ²):
  // SE ∝ stated × max(1, σ_whitened).
  const double s = right.fit.accel.sigma;
  for (const auto& name : kFitted) {
    SCOPED_TRACE(name);
    const double se = right.fit.accel.parameter(name).std_error;
    EXPECT_NEAR(over.fit.accel.parameter(name).std_error / se / (10.0 / std::max(1.0, s)), 1.0, 1e-4);
    EXPECT_NEAR(under.fit.accel.parameter(name).std_error / se / std::min(1.0, s), 1.0, 1e-4);
  }
  EXPECT_NE(right.fit.accel.uncertainty.find("sigma/√n"), std::string::npos) << right.fit.accel.uncertainty;
}

// Fewer rows than the fit needs: the table is refused as input (InputError: `stend fit` exits 2),
// saying how many rows it needs — 9 with n and sigma (a-priori sigmas need no residual), 10 without
// (one degree of freedom for the spread).
TEST(MeansTable, TooFewRowsAreRefusedWithWhatIsNeeded) {
  const stend::testing::TempDir dir("means-few");
  auto refusal = [&](const TableSpec& spec) -> std::string {
    try {
      const Fitted f = fit_table(spec, dir.path());
      return "(not refused) " + f.fit.text;
    } catch (const InputError& e) {
      return e.what();
    }
  };
  EXPECT_NE(refusal({.rows = 8, .seed = 11})
                .find("too few rows in the table of means: 8 for 9 accelerometer parameters; give at least 9 rows"),
            std::string::npos)
      << refusal({.rows = 8, .seed = 11});
  const Fitted nine = fit_table({.rows = 9, .seed = 12}, dir.path());
  EXPECT_TRUE(nine.fit.ok()) << nine.fit.text;
  EXPECT_NE(refusal({.rows = 9, .n = false, .sigma = false, .seed = 12}).find("give at least 10 rows"), std::string::npos)
      << refusal({.rows = 9, .n = false, .sigma = false, .seed = 12});
}

// The static_table format (known inputs) takes the same n and sigma columns: the known-orientation
// fit weighs its rows by sigma/√n, and an overstated sigma widens the intervals as above.
TEST(MeansTable, StaticTableRowsAreWeightedByTheirStatedNoise) {
  const stend::testing::TempDir dir("static-stated");
  const model::ErrorModel m = accelerometer_model();
  auto table = [&](double factor) {
    std::mt19937_64 rng(21);
    std::normal_distribution<double> unit_normal(0.0, 1.0);
    std::uniform_real_distribution<double> sigma_mg(0.5, 3.0);
    std::string csv = "f_x_mps2,f_y_mps2,f_z_mps2,a_x_mps2,a_y_mps2,a_z_mps2,n,sigma_mps2\n";
    for (int k = 0; k < 40; ++k) {
      Eigen::Vector3d dir3(unit_normal(rng), unit_normal(rng), unit_normal(rng));
      model::Stimulus<double> s;
      s.input = dir3.normalized() * kG;
      s.specific_force = s.input;
      const double sigma = sigma_mg(rng) * 1e-3 * kG, n = 200;
      const Eigen::Vector3d y = m.measure<double>(kTruth.data(), s) +
                                Eigen::Vector3d(unit_normal(rng), unit_normal(rng), unit_normal(rng)) * sigma / std::sqrt(n);
      csv += fmt::format("{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{},{:.6g}\n", s.input.x(), s.input.y(),
                         s.input.z(), y.x(), y.y(), y.z(), n, sigma * factor);
    }
    const auto file = dir / fmt::format("static-{}.csv", factor);
    stend::testing::write_text(file, csv);
    std::string format;
    const Recording rec = io::open_dataset({file}, "auto", {}, &format);
    EXPECT_EQ(format, "static_table");
    CalibrationOptions o;
    o.processing.intervals = processing::IntervalSource::kSegments;
    o.gravity_mps2 = kG;
    return calibrate_accelerometer_known_orientations(rec, o);
  };
  const CalibrationResult right = table(1.0), over = table(10.0);
  ASSERT_TRUE(right.ok()) << right.report();
  ASSERT_TRUE(over.ok()) << over.report();
  EXPECT_TRUE(right.whitened);
  EXPECT_NEAR(right.sigma, 1.0, 0.25);
  EXPECT_NE(right.uncertainty.find("sigma/√n"), std::string::npos) << right.uncertainty;
  for (const char* name : {"bias_x", "scale_y", "cross_zx"}) {
    SCOPED_TRACE(name);
    EXPECT_NEAR(over.parameter(name).std_error / right.parameter(name).std_error / (10.0 / std::max(1.0, right.sigma)),
                1.0, 1e-4);
  }
}
