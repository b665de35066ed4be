// Noise- and output-stage candidates of `stend gap` (quantization, saturation, coloured noise):
// planted at the sample level through the simulator's noise and output-stage code
// (noise_stage_run: model::NoiseChannel → Saturation → Quantizer), read back by build_input and
// diagnosed blind. Known truth: the planted LSB, range, Gauss–Markov σ and random-walk K.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include "stend/model/noise.hpp"
#include <sstream>
#include <string>

#include <stend/sim/imu.hpp>  // the real simulated sensor (sim/)
#include "stend/diagnosis/gap.hpp"
#include "stend/diagnosis/validate.hpp"
#include "../src/noise_stage.hpp"  // SegmentEvidence (the stage's per-window reduction)

#include <random>

namespace stend::diagnosis {
namespace {

struct Outcome {
  CandidateResult q, s, c;
  NoiseRunTruth truth;
};

Outcome diagnose_run(const NoisePlant& p, std::uint64_t seed) {
  Outcome o;
  const Recording rec = noise_stage_run(p, seed, &o.truth);
  const GapInput in = build_input(rec, validation_model());
  GapOptions opt;
  opt.check_aliases = false;
  opt.max_steps = 1;
  const GapReport r = diagnose(in, opt);
  for (const auto& c : r.candidates) {
    if (!c.noise_stage) continue;
    if (c.term == "quantization") o.q = c;
    if (c.term == "saturation") o.s = c;
    if (c.term == "coloured_noise") o.c = c;
  }
  return o;
}

constexpr int kSeeds = 10;

TEST(GapNoiseStage, NullRunsRarelyNameANoiseCandidate) {
  int fq = 0, fs = 0, fc = 0;
  const int n = 40;
  for (int i = 0; i < n; ++i) {
    const Outcome o = diagnose_run(NoisePlant{}, 1000 + static_cast<std::uint64_t>(i));
    ASSERT_TRUE(o.q.evaluated && o.s.evaluated && o.c.evaluated) << o.c.reason;
    fq += o.q.significant;
    fs += o.s.significant;
    fc += o.c.significant;
  }
  // Each test is at level 0.05/3; ≤ 5 % of the null runs may name one.
  EXPECT_LE(fq, n / 20);
  EXPECT_LE(fs, n / 20);
  EXPECT_LE(fc, n / 20);
}

TEST(GapNoiseStage, QuantizationDetectedWhenTheNoiseDoesNotDither) {
  for (double m : {5.0, 10.0}) {
    int det = 0, covered = 0;
    for (int i = 0; i < kSeeds; ++i) {
      const Outcome o = diagnose_run(NoisePlant{m, kNaN, 0, 0}, 2000 + static_cast<std::uint64_t>(i));
      det += o.q.significant;
      EXPECT_NEAR(o.q.size, o.truth.lsb, 1e-9 * o.truth.lsb);
      covered += o.q.ci_lo <= o.truth.lsb && o.truth.lsb <= o.q.ci_hi;
    }
    EXPECT_GE(det, 9) << "LSB = " << m << " x sample std";
    EXPECT_EQ(covered, kSeeds);
  }
  // Half an LSB per std: the noise dithers, the means are unbiased — not named.
  int det = 0;
  for (int i = 0; i < kSeeds; ++i) det += diagnose_run(NoisePlant{0.5, kNaN, 0, 0}, 2100 + static_cast<std::uint64_t>(i)).q.significant;
  EXPECT_LE(det, 1);
}

TEST(GapNoiseStage, SaturationDetectedWhenTailsClip) {
  for (double h : {1.0, 0.0}) {
    int det = 0, covered = 0;
    for (int i = 0; i < kSeeds; ++i) {
      const Outcome o = diagnose_run(NoisePlant{0, h, 0, 0}, 3000 + static_cast<std::uint64_t>(i));
      det += o.s.significant;
      const int a = o.s.axis[0] - 'x';
      ASSERT_GE(a, 0);
      const double expected = o.truth.expected_clipped_fraction[a];
      covered += o.s.ci_lo <= expected && expected <= o.s.ci_hi;
    }
    EXPECT_GE(det, 9) << "headroom " << h << " sample std";
    EXPECT_GE(covered, 7) << "headroom " << h;
  }
}

TEST(GapNoiseStage, RandomWalkDetectedNamedAndSized) {
  for (double m : {5.0, 10.0}) {
    int det = 0, named = 0, covered = 0;
    for (int i = 0; i < kSeeds; ++i) {
      const Outcome o = diagnose_run(NoisePlant{0, kNaN, 0, m}, 4000 + static_cast<std::uint64_t>(i));
      det += o.c.significant;
      if (o.c.size_param == "random_walk K") {
        ++named;
        covered += o.c.ci_lo <= o.truth.rw_coefficient && o.truth.rw_coefficient <= o.c.ci_hi;
      }
    }
    EXPECT_GE(det, 9) << m << "x";
    EXPECT_GE(named, 8) << m << "x";
    EXPECT_GE(covered, 6) << m << "x";
  }
}

TEST(GapNoiseStage, BiasInstabilityDetectedAndNamed) {
  for (double m : {5.0, 10.0}) {
    int det = 0, named = 0;
    std::string last;
    for (int i = 0; i < kSeeds; ++i) {
      const Outcome o = diagnose_run(NoisePlant{0, kNaN, m, 0}, 5000 + static_cast<std::uint64_t>(i));
      det += o.c.significant;
      named += o.c.size_param == "bias_instability B";
      if (o.c.size_param != "bias_instability B") last = o.c.reason;
    }
    EXPECT_GE(det, 9) << m << "x";
    EXPECT_GE(named, 8) << m << "x: " << last;
  }
}

TEST(GapNoiseStage, ValidationReportHasTheNoiseSection) {
  ValidateOptions o;
  o.noise_seeds = 2;
  o.noise_null_runs = 3;
  ValidationReport r;
  r.noise_stage = run_noise_validation(o);
  ASSERT_EQ(r.noise_stage.size(), 5u);
  EXPECT_EQ(r.noise_stage.back().experiment, "null");
  EXPECT_EQ(r.noise_stage.back().by_size.front().runs, 3);
  for (const auto& e : r.noise_stage)
    for (const auto& b : e.by_size) EXPECT_EQ(b.runs, e.experiment == "null" ? 3 : 2) << e.experiment;
  std::ostringstream os;
  print_validation(os, r);
  EXPECT_NE(os.str().find("noise-stage candidates"), std::string::npos);
  const auto j = nlohmann::json::parse(validation_json(r));
  ASSERT_TRUE(j.contains("noise_stage"));
  EXPECT_EQ(j["noise_stage"].size(), 5u);
}

// End to end through the real simulated sensor (sim/: its noise, saturation and
// quantizer as configured): six 30-s positions and 600 s +z up at 100 Hz, recorded, read back by
// build_input and diagnosed.
class PiecewiseTruth : public TruthSource {
 public:
  std::vector<std::pair<double, Eigen::Vector3d>> until;  // (end time, specific force)
  BenchTruth at(double t) const override {
    BenchTruth b;
    b.t_s = t;
    for (const auto& [te, f] : until)
      if (t <= te) {
        b.specific_force_mps2 = f;
        break;
      }
    if (t > until.back().first) b.specific_force_mps2 = until.back().second;
    return b;
  }
};

Recording sim_run(const sim::SimImuConfig& c) {
  const double g = 9.80665;
  PiecewiseTruth truth;
  Recording rec;
  rec.dir = "sim_imu (in memory)";
  rec.header.gravity_mps2 = g;
  rec.header.truth_columns = {"f_x_mps2", "f_y_mps2", "f_z_mps2", "w_x_radps", "w_y_radps", "w_z_radps", "die_c"};
  double t = 0;
  int id = 0;
  for (int a = 0; a < 3; ++a)
    for (int sgn : {1, -1}) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero();
      f[a] = sgn * g;
      truth.until.push_back({t + 30.0, f});
      t += 30.0;
    }
  truth.until.push_back({t + 600.0, Eigen::Vector3d(0, 0, g)});
  double t0 = 0;
  for (const auto& [te, f] : truth.until) {
    Segment s;
    s.id = id++;
    s.kind = stend::SegmentKind::kOrientation;
    s.label = "p" + std::to_string(s.id);
    s.t_start_s = t0;
    s.t_end_s = te;
    rec.segments.push_back(s);
    for (double tt : {t0 + 0.005, 0.5 * (t0 + te), te - 0.005}) {
      rec.truth_t.push_back(tt);
      rec.truth.push_back({f[0], f[1], f[2], 0, 0, 0, 25.0});
    }
    t0 = te;
  }
  sim::SimImu imu(c);
  rec.header.info = imu.info();
  imu.start(0.0);
  for (int k = 1; k <= static_cast<int>(std::lround(t0)); ++k) imu.acquire(static_cast<double>(k), truth, rec.samples);
  return rec;
}

sim::SimImuConfig quiet_config() {
  sim::SimImuConfig c;
  c.output_rate_hz = 100.0;
  c.accel_bias_instability_mps2 = 0.0;
  c.accel_random_walk = 0.0;
  c.accel.bias = Eigen::Vector3d(0.03, -0.02, 0.04);
  c.seed = 7;
  return c;
}

std::vector<CandidateResult> noise_candidates(const Recording& rec) {
  GapOptions opt;
  opt.check_aliases = false;
  opt.max_steps = 1;
  std::vector<CandidateResult> out;
  for (const auto& c : diagnose(build_input(rec, validation_model()), opt).candidates)
    if (c.noise_stage) out.push_back(c);
  return out;  // quantization, saturation, coloured_noise
}

TEST(GapNoiseStage, EndToEndThroughTheSimulatedSensor) {
  const double sigma = model::WhiteNoise::sigma_from_density(quiet_config().accel_noise_density, 0.01);
  {  // white noise only: nothing named
    const auto c = noise_candidates(sim_run(quiet_config()));
    ASSERT_EQ(c.size(), 3u);
    EXPECT_FALSE(c[0].significant) << c[0].reason;
    EXPECT_FALSE(c[1].significant) << c[1].reason;
    EXPECT_FALSE(c[2].significant) << c[2].reason;
  }
  {  // an LSB of 8 sample std: quantization, sized by the sensor's LSB
    auto cfg = quiet_config();
    cfg.accel_lsb_mps2 = 8 * sigma;
    const auto c = noise_candidates(sim_run(cfg));
    EXPECT_TRUE(c[0].significant) << c[0].reason;
    EXPECT_NEAR(c[0].size, cfg.accel_lsb_mps2, 1e-12);
  }
  {  // z bias 0.5 m/s², range 1 g + 0.5 m/s²: the +z-up segments clip, the others keep 17 std
    auto cfg = quiet_config();
    cfg.accel.bias[2] = 0.5;
    cfg.accel_range_g = (9.80665 + 0.5) / 9.80665;
    const auto c = noise_candidates(sim_run(cfg));
    EXPECT_TRUE(c[1].significant) << c[1].reason;
    EXPECT_GT(c[1].size, 0.0);
  }
  {  // random walk at 8x the white floor of a 26-s mean (Allan deviation at 30 s)
    auto cfg = quiet_config();
    cfg.accel_random_walk = 8 * sigma / std::sqrt(2600.0) * std::sqrt(3.0 / 30.0);
    const auto c = noise_candidates(sim_run(cfg));
    EXPECT_TRUE(c[2].significant) << c[2].reason;
    EXPECT_EQ(c[2].size_param, "random_walk K") << c[2].reason;
    EXPECT_LE(c[2].ci_lo, cfg.accel_random_walk * 1.5);
    EXPECT_GE(c[2].ci_hi, cfg.accel_random_walk / 1.5);
  }
}

// A window's value lattice: a quantized axis gives its LSB as the smallest spacing; an axis with
// more distinct values than any 16-bit output has gives none, in bounded memory.
TEST(GapNoiseStage, ValueLatticeOfAQuantizedAndAnUnquantizedWindow) {
  constexpr std::size_t n = 200'000;
  constexpr double lsb = 0.01;
  std::mt19937_64 gen(5);
  std::normal_distribution<double> normal;
  noise_stage::SegmentEvidence e(n, /*accel=*/true);
  for (std::size_t i = 0; i < n; ++i) {
    ImuSample s;
    s.accel_mps2[0] = lsb * std::round(3.0 * normal(gen));  // quantized, a few dozen levels
    s.accel_mps2[1] = 0.03 * normal(gen);                     // unquantized
    s.accel_mps2[2] = 9.81;                                   // constant
    e.add(s);
  }
  SegmentData d;
  e.fill(d);
  EXPECT_NEAR(d.value_step[0], lsb, 1e-12);
  EXPECT_GT(d.distinct_values[0], 10.0);
  EXPECT_TRUE(std::isnan(d.value_step[1]));
  EXPECT_TRUE(std::isnan(d.distinct_values[1]));
  EXPECT_EQ(d.distinct_values[2], 1.0);
}

}  // namespace
}  // namespace stend::diagnosis
