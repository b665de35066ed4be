// The alignment of a recording to its procedure, on recordings written here from a known motion
// (stills at stated faces, turns, rate legs, moves between them) with gyro bias and noise: the
// steps are found where they were done, the truth is what was stated, and a procedure that does
// not fit the recording is refused naming the step.
#include <stend/alignment/align.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/truth_columns.hpp>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace stend::alignment {
namespace {

constexpr double kG = 9.81;

// No plugins: a procedure file names no sensor and no fixture.
class NoPlugins final : public PluginCatalogue {
 public:
  const stend_plugin_info* find(const std::string&) const override { return nullptr; }
  std::vector<std::string> names() const override { return {}; }
};

Experiment procedure(const std::string& steps) {
  const std::string text = "experiment: {name: t}\nbench: {gravity: {latitude_deg: 49.6, height_m: 300}}\nprocedure:\n" + steps;
  return parse_experiment(text, "procedure.yaml", NoPlugins{});
}

// A motion played at 100 Hz into the observer: the sensor's attitude (world from sensor) changes by
// body rates; readings are f = Rᵀ·(0, 0, g) and ω plus a gyro bias and white noise.
class Motion {
 public:
  explicit Motion(unsigned seed = 1) : rng_(seed) {}

  void still(double s) { play(s, Eigen::Vector3d::Zero()); }
  // Turn about a sensor axis by angle_deg, accelerating and braking (a hand turn).
  void turn(const Eigen::Vector3d& axis, double angle_deg, double s) {
    const double peak = 2.0 * angle_deg * physics::kDegToRad / s;  // triangular rate profile
    const int n = static_cast<int>(s * kRate);
    for (int i = 0; i < n; ++i) {
      const double x = (i + 0.5) / n;
      sample(axis * peak * (x < 0.5 ? 2 * x : 2 * (1 - x)));
    }
  }
  void leg(const Eigen::Vector3d& axis, double rate_dps, double s) {
    ramp(axis, 0.0, rate_dps, 1.0);
    play(s, axis * rate_dps * physics::kDegToRad);
    ramp(axis, rate_dps, 0.0, 1.0);
  }
  // Move so that the sensor direction `up` points up, in one second.
  void face(const Eigen::Vector3d& up) {
    const Eigen::Vector3d u0 = R_.transpose() * Eigen::Vector3d::UnitZ();
    Eigen::Vector3d n = up.cross(u0);
    double angle = std::atan2(n.norm(), up.dot(u0));
    if (n.norm() < 1e-9) n = (std::abs(u0.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(u0);
    if (angle < 1e-9) return;
    turn(n.normalized(), angle / physics::kDegToRad, 1.0);
  }
  Observer& observer() { return obs_; }
  double t() const { return t_; }

 private:
  static constexpr double kRate = 100.0;
  void ramp(const Eigen::Vector3d& axis, double from_dps, double to_dps, double s) {
    const int n = static_cast<int>(s * kRate);
    for (int i = 0; i < n; ++i) sample(axis * (from_dps + (to_dps - from_dps) * (i + 0.5) / n) * physics::kDegToRad);
  }
  void play(double s, const Eigen::Vector3d& w) {
    for (int i = 0; i < static_cast<int>(s * kRate); ++i) sample(w);
  }
  void sample(const Eigen::Vector3d& w) {
    ImuSample x;
    x.t_s = t_;
    x.accel_mps2 = R_.transpose() * Eigen::Vector3d(0, 0, kG) + noise(0.01);
    x.gyro_radps = w + Eigen::Vector3d(0.01, -0.02, 0.005) + noise(0.002);
    obs_.add(&x, 1);
    if (w.norm() > 0) R_ = R_ * Eigen::AngleAxisd(w.norm() / kRate, w.normalized()).toRotationMatrix();
    t_ += 1.0 / kRate;
  }
  Eigen::Vector3d noise(double sigma) {
    std::normal_distribution<double> n(0.0, sigma);
    return {n(rng_), n(rng_), n(rng_)};
  }
  std::mt19937 rng_;
  Observer obs_;
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  double t_ = 0.0;
};

const Eigen::Vector3d kX = Eigen::Vector3d::UnitX(), kY = Eigen::Vector3d::UnitY(), kZ = Eigen::Vector3d::UnitZ();

// Six faces by hand, then three 360° turns (x positive, y negative, z positive), stills between.
Motion ferraris_session() {
  Motion m;
  for (const Eigen::Vector3d& up : {kZ, Eigen::Vector3d(-kZ), kX, Eigen::Vector3d(-kX), kY, Eigen::Vector3d(-kY)}) {
    m.face(up);
    m.still(4.0);
  }
  m.face(kZ);
  m.still(3.0);
  for (const auto& [axis, angle] : {std::pair{kX, 360.0}, std::pair{kY, -360.0}, std::pair{kZ, 360.0}}) {
    m.turn(axis, angle, 4.0);
    m.still(3.0);
  }
  return m;
}

const char* kFerraris =
    "  - faces: {list: ['+z up', '-z up', '+x up', '-x up', '+y up', '-y up'], label: six faces}\n"
    "  - turns: {axis: '+x', angle_deg: 360, label: x turn}\n"
    "  - turns: {axis: y, angle_deg: 360, label: y turn}\n"
    "  - turns: {axis: '+z', angle_deg: 360, direction: positive, label: z turn}\n";

std::vector<const Segment*> of_kind(const Alignment& a, SegmentKind k) {
  std::vector<const Segment*> out;
  for (const auto& s : a.segments)
    if (s.kind == k) out.push_back(&s);
  return out;
}

// The held truth row at time t (the first row at or after it).
std::vector<double> truth_at(const Alignment& a, double t) {
  for (std::size_t i = 0; i < a.truth_t.size(); ++i)
    if (a.truth_t[i] >= t - 1e-9) return a.truth[i];
  return {};
}

TEST(Alignment, FindsFacesAndTurnsWhereTheyWereDone) {
  Motion m = ferraris_session();
  const Experiment exp = procedure(kFerraris);
  const Alignment a = align(exp, m.observer().finish(), {});
  const auto faces = of_kind(a, SegmentKind::kOrientation);
  const auto turns = of_kind(a, SegmentKind::kRotation);
  ASSERT_EQ(faces.size(), 6u) << a.summary();
  ASSERT_EQ(turns.size(), 3u) << a.summary();
  // The faces come at 5k s (the sensor starts +z up; then a move of 1 s before each still of 4 s).
  for (std::size_t k = 0; k < 6; ++k) {
    EXPECT_NEAR(faces[k]->t_start_s, 5.0 * static_cast<double>(k), 0.25);
    EXPECT_GT(faces[k]->t_end_s - faces[k]->t_start_s, 3.5);
    EXPECT_EQ(faces[k]->orientation, static_cast<int>(k));
  }
  // Truth: f = g·up of the stated face, in the sensor frame; the Earth rate's vertical part.
  const std::vector<double> f0 = truth_at(a, faces[2]->t_start_s);  // '+x up'
  ASSERT_EQ(f0.size(), 9u);
  EXPECT_NEAR(f0[0], exp.gravity.resolved_mps2, 1e-9);
  EXPECT_EQ(f0[1], 0.0);
  EXPECT_NEAR(f0[3], 7.2921150e-5 * std::sin(49.6 * physics::kDegToRad), 1e-12);
  EXPECT_TRUE(std::isnan(f0[6]));
  // Turns: +360 about x, −360 about y (sign from the data), +360 about z; each turn's segment
  // spans the whole motion (4 s) and its truth lies strictly inside it.
  const double expect[3][3] = {{360, 0, 0}, {0, -360, 0}, {0, 0, 360}};
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(turns[k]->t_end_s - turns[k]->t_start_s, 4.0, 0.25);
    const std::vector<double> r = truth_at(a, 0.5 * (turns[k]->t_start_s + turns[k]->t_end_s));
    for (int i = 0; i < 3; ++i) EXPECT_EQ(r[static_cast<std::size_t>(6 + i)], expect[k][i]) << "turn " << k;
    EXPECT_TRUE(std::isnan(r[0]));
  }
  // The still before the turns (+z up again) and those between them are kept as detected stills,
  // with the Earth rate's vertical part along their measured gravity and no specific force.
  const auto detected = of_kind(a, SegmentKind::kDetected);
  EXPECT_EQ(detected.size(), 4u) << a.summary();
  for (const Segment* d : detected) {
    const std::vector<double> r = truth_at(a, d->t_start_s);
    EXPECT_TRUE(std::isnan(r[0]));
    EXPECT_NEAR(Eigen::Vector3d(r[3], r[4], r[5]).norm(), 7.2921150e-5 * std::sin(49.6 * physics::kDegToRad), 1e-9);
  }
  for (std::size_t i = 0; i + 1 < a.segments.size(); ++i) {
    EXPECT_EQ(a.segments[i].id, static_cast<int>(i));
    EXPECT_LE(a.segments[i].t_end_s, a.segments[i + 1].t_start_s + 1e-9);
  }
}

TEST(Alignment, AFaceOutOfOrderIsRefusedNamingTheStepAndWhatWasFound) {
  Motion m = ferraris_session();
  // '+x up' and '-z up' swapped: face 2 ('+x up') finds +x up only after -z, then '-z up' has nothing left.
  const Experiment exp = procedure("  - faces: {list: ['+z up', '+x up', '-z up', '-x up'], label: four faces}\n");
  try {
    align(exp, m.observer().finish(), {});
    FAIL() << "aligned a procedure the recording does not follow";
  } catch (const AlignmentError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("procedure.yaml:4:"), std::string::npos) << what;
    EXPECT_NE(what.find("face 3 of 4 ('-z up')"), std::string::npos) << what;
    EXPECT_NE(what.find("the stills there:"), std::string::npos) << what;
  }
}

TEST(Alignment, ATurnOfAnotherAngleIsNotMatched) {
  Motion m = ferraris_session();
  const Experiment exp = procedure(std::string(kFerraris) + "  - turns: {axis: '+x', angle_deg: 180, label: half turn}\n");
  EXPECT_THROW(align(exp, m.observer().finish(), {}), AlignmentError);
}

TEST(Alignment, RateLegsCarryTheirRateAndTheStatedUp) {
  Motion m;
  m.still(3.0);
  for (double r : {25.0, -25.0, 100.0}) {
    m.leg(kZ, r, 5.0);
    m.still(2.0);
  }
  const Experiment exp = procedure("  - rate_legs: {axis: '+z', rates_dps: [25, -25, 100], up: '+z', record_s: 4}\n");
  const Alignment a = align(exp, m.observer().finish(), {});
  const auto legs = of_kind(a, SegmentKind::kRate);
  ASSERT_EQ(legs.size(), 3u) << a.summary();
  const double rates[3] = {25, -25, 100};
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(legs[k]->rate, rates[k]);
    EXPECT_GT(legs[k]->t_end_s - legs[k]->t_start_s, 4.5);
    const std::vector<double> r = truth_at(a, legs[k]->t_start_s);
    // the table's rate about the axis, plus the Earth rate's vertical part (the axis is up)
    EXPECT_NEAR(r[5], rates[k] * physics::kDegToRad + 7.2921150e-5 * std::sin(49.6 * physics::kDegToRad), 1e-12);
    EXPECT_NEAR(r[2], exp.gravity.resolved_mps2, 1e-9);
  }
}

TEST(Alignment, ALegAtAnotherRateIsRefused) {
  Motion m;
  m.still(3.0);
  m.leg(kZ, 25.0, 5.0);
  m.still(2.0);
  const Experiment exp = procedure("  - rate_legs: {axis: '+z', rates_dps: [50]}\n");
  try {
    align(exp, m.observer().finish(), {});
    FAIL();
  } catch (const AlignmentError& e) {
    EXPECT_NE(std::string(e.what()).find("the steady rates there:"), std::string::npos) << e.what();
  }
}

TEST(Alignment, TheProcedureNeedsTheSite) {
  Motion m = ferraris_session();
  const Experiment exp = parse_experiment("experiment: {name: t}\nbench: {}\nprocedure:\n  - still: {count: 2}\n", "p.yaml", NoPlugins{});
  EXPECT_THROW(align(exp, m.observer().finish(), {}), AlignmentError);
}

TEST(Alignment, AnObservedStepCannotRunOnABench) {
  const Experiment exp = procedure(kFerraris);
  EXPECT_THROW(require_runnable(exp), ExperimentError);
  // and it reads back as the same procedure from its resolved YAML
  const Experiment again = parse_experiment(exp.resolved_yaml, "resolved.yaml", NoPlugins{});
  EXPECT_EQ(again.resolved_yaml, exp.resolved_yaml);
}

}  // namespace
}  // namespace stend::alignment
