// `stend export` of a Ceres 3-axis calibration (accelerometer + gyroscope with g-sensitivity) on a
// simulated run of configs/multi_position_38.yaml, read back by each target's own conventions:
// IMU-TK's CalibratedTriad::load, Octave's `load` of the .mat, a PX4 .params file, Kalibr's yaml
// keys and types through yaml-cpp. The exported numbers must equal the fit's, and applying each
// format's correction to readings made by the planted error model must give back the true input.
// Also: a failed Ceres fit and an absent source are refused with a non-zero exit naming them.
#include "stend/estimators/builtin.hpp"
#include "stend/model/terms.hpp"
#include "stend/reporting/results.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/program.hpp"

#include <gtest/gtest.h>
#include <matio.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using stend::testing::ProgramOutput;
using stend::testing::read_text;
using stend::testing::run_command;
using stend::testing::run_stend;

namespace {

const std::string kSrc = STEND_SOURCE_DIR;
constexpr double kG = 9.80665;

// Planted errors of configs/multi_position_38.yaml: y = (I + diag(s) + C)·u + b (+ G·f).
const Eigen::Vector3d kAccelBias(0.05, -0.03, 0.027);
const Eigen::Matrix3d kAccelA = (Eigen::Matrix3d() << 1.002, 0.001, -0.002,  //
                                 0.0015, 0.999, 0.003,                       //
                                 0.0055, 0.0002, 1.0007)
                                    .finished();
const Eigen::Vector3d kGyroBias(0.01, -0.015, 0.02);
const Eigen::Matrix3d kGyroA = (Eigen::Matrix3d() << 1.01, 0.004, -0.003,  //
                                0.005, 0.992, 0.002,                       //
                                -0.004, 0.006, 1.012)
                                   .finished();
const Eigen::Matrix3d kGyroG = (Eigen::Matrix3d() << 1e-4, 0, 0, 0, -1e-4, 0, 5e-5, 0, 1e-4).finished();

// The fitted calibration y = A·u + b + G·f of one instrument, evaluated through the vocabulary's
// ErrorModel with the parameters the run's results hold (independent of the exporter's code path).
struct Fitted {
  Eigen::Matrix3d A, G;
  Eigen::Vector3d b;
};
Fitted fitted(const fs::path& run, const std::string& prefix, bool gyro) {
  const auto rr = stend::reporting::load_run_results(run, stend::estimators::builtin());
  stend::model::ErrorModel m;
  m.instrument = gyro ? stend::model::Instrument::kGyroscope : stend::model::Instrument::kAccelerometer;
  for (auto k : {stend::model::TermKind::kBias, stend::model::TermKind::kScale, stend::model::TermKind::kCrossAxis})
    m.terms.push_back({k});
  if (gyro) m.terms.push_back({stend::model::TermKind::kGSensitivity});
  std::vector<double> theta;
  for (const auto& p : m.params()) {
    const auto* r = rr.find("ceres_nonlinear", prefix + p.name);
    theta.push_back(r && r->identifiable ? r->value : 0.0);  // unknown orientations: held at 0
  }
  auto y = [&](const Eigen::Vector3d& u, const Eigen::Vector3d& f) {
    stend::model::Stimulus<double> s;
    s.input = u;
    s.specific_force = gyro ? f : u;
    return Eigen::Vector3d(m.measure<double>(theta.data(), s));
  };
  Fitted out;
  out.b = y(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (int j = 0; j < 3; ++j) {
    out.A.col(j) = y(Eigen::Vector3d::Unit(j), Eigen::Vector3d::Zero()) - out.b;
    out.G.col(j) = gyro ? Eigen::Vector3d(y(Eigen::Vector3d::Zero(), Eigen::Vector3d::Unit(j)) - out.b) : Eigen::Vector3d::Zero();
  }
  return out;
}

// IMU-TK's CalibratedTriad::load: 9 numbers (misalignment T, row-major), 9 (scale K), 3 (bias B),
// read with operator>>.
struct ImuTkTriad {
  Eigen::Matrix3d T, K;
  Eigen::Vector3d B;
};
ImuTkTriad load_imutk(const fs::path& file) {
  std::ifstream in(file);
  double v[21];
  for (double& x : v) EXPECT_TRUE(in >> x) << file;
  return {Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(v), Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(v + 9),
          Eigen::Vector3d(v[18], v[19], v[20])};
}

// A QGroundControl / PX4 .params file: '#' comments, then tab-separated vehicle-id, component-id,
// name, value, type (6 = INT32, 9 = REAL32).
std::map<std::string, double> load_px4_params(const fs::path& file) {
  std::map<std::string, double> out;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cols;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, '\t');) cols.push_back(c);
    EXPECT_EQ(cols.size(), 5u) << line;
    if (cols.size() != 5) continue;
    EXPECT_TRUE(cols[4] == "6" || cols[4] == "9") << line;
    out[cols[2]] = std::stod(cols[3]);
  }
  return out;
}

Eigen::Matrix3d yaml_matrix(const YAML::Node& n) {
  EXPECT_TRUE(n.IsSequence());
  EXPECT_EQ(n.size(), 3u);
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(n[i].size(), 3u);
    for (int j = 0; j < 3; ++j) m(i, j) = n[i][j].as<double>();
  }
  return m;
}

class CeresExport : public ::testing::Test {
 protected:
  static inline std::unique_ptr<stend::testing::TempDir> tmp;
  static inline fs::path dir, known, unknown, six;
  // mp38: known orientations + rate table with g-sensitivity (the config's own fit) and an Allan
  // analysis of a still start for Kalibr's noise; mp38u: a copy fitted with unknown orientations + integration;
  // six: six positions, too few for the unknown-orientations fit (it fails).
  static void SetUpTestSuite() {
    tmp = std::make_unique<stend::testing::TempDir>("exports-ceres");
    dir = tmp->path();
    known = dir / "mp38";
    unknown = dir / "mp38u";
    six = dir / "six";
    // The 38-position config with 300 s still at the start (for the Allan analysis) and its model
    // path made absolute.
    std::string cfg = read_text(kSrc + "/configs/multi_position_38.yaml");
    cfg.replace(cfg.find("procedure:\n"), 11,
                "procedure:\n  - orientations: {fixture: table, list: [{tilt_deg: 0, rotation_deg: 0}], dwell_s: 1, "
                "record_s: 300, label: still}\n");
    const std::string model = "../estimators/ceres_nonlinear/examples/known_orientations.yaml";
    cfg.replace(cfg.find(model), model.size(), kSrc + "/estimators/ceres_nonlinear/examples/known_orientations.yaml");
    stend::testing::write_text(dir / "mp38.yaml", cfg);
    stend::testing::write_text(dir / "allan.yaml", "allan:\n  t_begin_s: 2\n  t_end_s: 300\n");
    ProgramOutput o = run_stend("run " + (dir / "mp38.yaml").string() + " --quiet --output " + dir.string() + " --name mp38");
    ASSERT_EQ(o.code, 0) << o.text;
    fs::copy(known, unknown, fs::copy_options::recursive);
    fs::remove(unknown / "ceres.json");
    o = run_stend("fit " + known.string() + " -m " + (dir / "allan.yaml").string());
    ASSERT_EQ(o.code, 0) << o.text;
    o = run_stend("fit " + unknown.string() + " -m " + kSrc + "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml");
    ASSERT_EQ(o.code, 0) << o.text;
    o = run_stend("run " + kSrc + "/configs/six_position.yaml --quiet --output " + dir.string() + " --name six");
    ASSERT_EQ(o.code, 0) << o.text;
    o = run_stend("fit " + six.string() + " -m " + kSrc + "/estimators/ceres_nonlinear/examples/unknown_orientations.yaml");
    ASSERT_EQ(o.code, 3) << o.text;
  }
  static void TearDownTestSuite() { tmp.reset(); }

  static ProgramOutput export_to(const fs::path& run, const std::string& format, const fs::path& out,
                                 const std::string& extra = "") {
    return run_stend("export " + run.string() + " --to " + format + " -o " + out.string() + " " + extra);
  }
};

TEST_F(CeresExport, ImuTkFilesInvertTheFittedModel) {
  const ProgramOutput o = export_to(known, "imutk", dir / "k");
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("accelerometer calibration from ceres.json (--from auto)"), std::string::npos) << o.text;
  EXPECT_NE(o.text.find("g-sensitivity"), std::string::npos) << o.text;  // IMU-TK has no G: said
  for (const auto& [file, prefix, gyro] : {std::tuple{"k_acc.calib", "accel_", false}, {"k_gyro.calib", "gyro_", true}}) {
    const ImuTkTriad t = load_imutk(dir / file);
    const Fitted f = fitted(known, prefix, gyro);
    for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(t.T(i, i), 1.0) << file;
    EXPECT_TRUE((t.K - Eigen::Matrix3d(t.K.diagonal().asDiagonal())).isZero(0.0)) << file;
    // IMU-TK: x = T·K·(raw − B) is the inverse of the fitted raw = A·x + b.
    EXPECT_LT((t.T * t.K * f.A - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12) << file;
    EXPECT_LT((t.B - f.b).cwiseAbs().maxCoeff(), 1e-15) << file;
    // Readings made by the planted model are brought back to the true input to the fit's accuracy
    // (≤ 1 mm/s² here; a transposed cross-axis pair would leave 5 mm/s² at 1 g).
    const Eigen::Matrix3d A = gyro ? kGyroA : kAccelA;
    const Eigen::Vector3d b = gyro ? kGyroBias : kAccelBias;
    for (const Eigen::Vector3d& u : {Eigen::Vector3d(0, 0, kG), Eigen::Vector3d(kG, 0, 0), Eigen::Vector3d(0, -kG, 0),
                                    Eigen::Vector3d(5.0, -5.0, 5.0)}) {
      const Eigen::Vector3d raw = A * u + b;
      EXPECT_LT((t.T * t.K * (raw - t.B) - u).norm(), 1.5e-4 * u.norm() + 2e-4) << file << " u=" << u.transpose();
      EXPECT_GT((raw - u).norm(), 3e-3 * u.norm()) << "the planted error is visible";
    }
  }
}

TEST_F(CeresExport, UnknownOrientationsKeepTheFrameConventionAndSayIt) {
  const ProgramOutput o = export_to(unknown, "imutk", dir / "u");
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("held at 0 by the Ceres fit's frame convention"), std::string::npos) << o.text;
  const ImuTkTriad t = load_imutk(dir / "u_acc.calib");
  const Fitted f = fitted(unknown, "accel_", false);
  EXPECT_LT((t.T * t.K * f.A - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  // The x axis defines the frame: A, and so T, are lower-triangular.
  EXPECT_DOUBLE_EQ(t.T(0, 1), 0.0);
  EXPECT_DOUBLE_EQ(t.T(0, 2), 0.0);
  EXPECT_DOUBLE_EQ(t.T(1, 2), 0.0);
  // Scale factors do not depend on the frame convention.
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(1.0 / t.K(k, k), kAccelA(k, k), 1e-3) << k;
}

TEST_F(CeresExport, MatlabFileLoadsInOctaveWithTheFittedValues) {
  const fs::path mat = dir / "k.mat";
  const ProgramOutput o = export_to(known, "matlab", mat);
  ASSERT_EQ(o.code, 0) << o.text;
  const Fitted a = fitted(known, "accel_", false), g = fitted(known, "gyro_", true);
  // MATLAB's layout: AxesMisalignment(i, j) = 100·A(i, j) [%], ConstantBias = b, gyro
  // AccelerationBias = diag(G); NoiseDensity per axis = the Allan N of that axis.
  const auto rr = stend::reporting::load_run_results(known, stend::estimators::builtin());
  if (run_command("command -v octave-cli").code != 0)
    GTEST_SKIP() << "octave-cli not installed (scripts/install-deps.sh installs Debian's octave): the .mat file was "
                    "written but not loaded in Octave";
  const std::string script =
      "s = load('" + mat.string() +
      "'); p = {s.accelparams, s.gyroparams}; for k = 1:2, M = p{k}.AxesMisalignment; "
      "for i = 1:3, for j = 1:3, printf('%.17g\\n', M(i, j)); end; end; "
      "printf('%.17g\\n', p{k}.ConstantBias); printf('%.17g\\n', p{k}.NoiseDensity); end; "
      "printf('%.17g\\n', s.gyroparams.AccelerationBias); printf('%s\\n', class(s.stend_info.serial));";
  const ProgramOutput oc = run_command("octave-cli --no-gui --norc --eval " + stend::testing::shell_quote(script));
  ASSERT_EQ(oc.code, 0) << oc.text;
  std::istringstream in(oc.text);
  for (const auto* f : {&a, &g}) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double v = NAN;
        ASSERT_TRUE(in >> v) << oc.text;
        EXPECT_NEAR(v, 100.0 * f->A(i, j), 1e-12) << i << j;
      }
    for (int k = 0; k < 3; ++k) {
      double v = NAN;
      ASSERT_TRUE(in >> v) << oc.text;
      EXPECT_NEAR(v, f->b[k], 1e-15);
    }
    for (int k = 0; k < 3; ++k) {
      double v = NAN;
      ASSERT_TRUE(in >> v) << oc.text;
      const auto* n = rr.find("allan", std::string("N_") + (f == &a ? "a" : "g") + "xyz"[k]);
      ASSERT_NE(n, nullptr);
      EXPECT_DOUBLE_EQ(v, n->identifiable ? n->value : 0.0);
    }
  }
  for (int k = 0; k < 3; ++k) {
    double v = NAN;
    ASSERT_TRUE(in >> v) << oc.text;
    EXPECT_NEAR(v, g.G(k, k), 1e-18);
    EXPECT_NEAR(v, kGyroG(k, k), 3e-5) << k;  // the planted g-sensitivity, not zero
  }
  std::string cls;
  in >> cls;
  EXPECT_EQ(cls, "char");
}

TEST_F(CeresExport, Px4StaticCalibrationFollowsPx4sCorrection) {
  const fs::path f = dir / "k.params";
  const ProgramOutput o = export_to(known, "px4", f, "--px4-id 2621474");
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("cross-axis"), std::string::npos) << o.text;       // PX4 cannot hold them: said
  EXPECT_NE(o.text.find("gyro offsets only"), std::string::npos) << o.text;  // nor gyro scale factors
  const auto p = load_px4_params(f);
  const Fitted a = fitted(known, "accel_", false), g = fitted(known, "gyro_", true);
  EXPECT_EQ(p.at("CAL_ACC0_ID"), 2621474);
  EXPECT_EQ(p.at("CAL_GYRO0_ID"), 2621474);
  const char* ax[] = {"X", "Y", "Z"};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(p.at(std::string("CAL_ACC0_") + ax[k] + "OFF"), a.b[k], 1e-8);
    EXPECT_NEAR(p.at(std::string("CAL_ACC0_") + ax[k] + "SCALE"), 1.0 / a.A(k, k), 1e-7);
    EXPECT_NEAR(p.at(std::string("CAL_GYRO0_") + ax[k] + "OFF"), g.b[k], 1e-8);
  }
  // PX4 corrects (raw − OFF)·SCALE: a reading of the planted model along one axis comes back to the
  // true value up to the cross-axis terms PX4 does not model.
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d u = kG * Eigen::Vector3d::Unit(k);
    const Eigen::Vector3d raw = kAccelA * u + kAccelBias;
    const double corrected = (raw[k] - p.at(std::string("CAL_ACC0_") + ax[k] + "OFF")) * p.at(std::string("CAL_ACC0_") + ax[k] + "SCALE");
    EXPECT_NEAR(corrected, kG, 2e-3) << k;
  }
}

TEST_F(CeresExport, KalibrYamlHasWorstAxisNoiseAndScaleMisalignmentIntrinsics) {
  const fs::path f = dir / "imu.yaml";
  const ProgramOutput o = export_to(known, "kalibr", f);
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("Kalibr takes one number per sensor; worst axis"), std::string::npos) << o.text;
  const YAML::Node y = YAML::LoadFile(f.string());
  // Kalibr's keys and types: four doubles, a topic string, the rate.
  const auto rr = stend::reporting::load_run_results(known, stend::estimators::builtin());
  for (const auto& [key, sym] : {std::pair{"accelerometer_noise_density", "N_a"}, {"gyroscope_noise_density", "N_g"}}) {
    double worst = 0;
    for (const char* c : {"x", "y", "z"})
      if (const auto* p = rr.find("allan", std::string(sym) + c); p && p->identifiable) worst = std::max(worst, p->value);
    ASSERT_GT(worst, 0) << key;
    EXPECT_DOUBLE_EQ(y[key].as<double>(), worst) << key;
  }
  EXPECT_GT(y["accelerometer_random_walk"].as<double>(), 0);
  EXPECT_GT(y["gyroscope_random_walk"].as<double>(), 0);
  EXPECT_EQ(y["rostopic"].as<std::string>(), "/imu0");
  EXPECT_DOUBLE_EQ(y["update_rate"].as<double>(), 100.0);
  // Kalibr's scale-misalignment model: a = M_a·a_i + b, w = M_g·C_gyro_i·w_i + A·C_gyro_i·a_i + b
  // with M lower-triangular; the accelerometer defines the IMU frame (R below).
  EXPECT_EQ(y["model"].as<std::string>(), "scale-misalignment");
  const Eigen::Matrix3d Ma = yaml_matrix(y["accelerometers"]["M"]), Mg = yaml_matrix(y["gyroscopes"]["M"]);
  const Eigen::Matrix3d C = yaml_matrix(y["gyroscopes"]["C_gyro_i"]), Ag = yaml_matrix(y["gyroscopes"]["A"]);
  for (const Eigen::Matrix3d* m : {&Ma, &Mg}) {
    EXPECT_DOUBLE_EQ((*m)(0, 1), 0.0);
    EXPECT_DOUBLE_EQ((*m)(0, 2), 0.0);
    EXPECT_DOUBLE_EQ((*m)(1, 2), 0.0);
    EXPECT_GT(m->diagonal().minCoeff(), 0.9);
  }
  EXPECT_LT((C * C.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(C.determinant(), 1.0, 1e-12);
  const Fitted a = fitted(known, "accel_", false), g = fitted(known, "gyro_", true);
  const Eigen::Matrix3d R = Ma.inverse() * a.A;  // sensor frame → Kalibr's IMU frame
  EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((Mg * C * R - g.A).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((Ag * C * R - g.G).cwiseAbs().maxCoeff(), 1e-15);
}

TEST_F(CeresExport, FromSelectsTheSourceAndRefusesAnAbsentOne) {
  ProgramOutput o = export_to(known, "imutk", dir / "b", "--from batch_lsq");
  EXPECT_NE(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("no fit.json"), std::string::npos) << o.text;
  EXPECT_FALSE(fs::exists(dir / "b_acc.calib"));
  o = export_to(known, "imutk", dir / "c", "--from ceres");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find("(--from ceres)"), std::string::npos) << o.text;
}

TEST_F(CeresExport, FailedCeresFitIsRefusedNotExportedAsIdentity) {
  for (const char* format : {"imutk", "matlab", "px4"}) {
    const ProgramOutput o = export_to(six, format, dir / (std::string("six.") + format));
    EXPECT_NE(o.code, 0) << format << "\n" << o.text;
    EXPECT_NE(o.text.find("ceres.json: the fit failed"), std::string::npos) << format << "\n" << o.text;
  }
  EXPECT_FALSE(fs::exists(dir / "six.imutk_acc.calib"));
  EXPECT_FALSE(fs::exists(dir / "six.matlab"));
}

}  // namespace
