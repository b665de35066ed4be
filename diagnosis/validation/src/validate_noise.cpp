// `stend gap validate`, noise-stage part: quantization, saturation and coloured noise planted at
// the sample level and diagnosed blind. See validate.hpp (NoiseStageValidation, noise_stage_run).
//
// The samples go through the simulator's own stages, never re-derived here: the noise of each axis
// is a model::NoiseChannel (white + Gauss–Markov + random walk, noise.hpp), the output stage is
// model::Saturation then model::Quantizer (output_stage.hpp), in that order as sim_imu applies
// them, with the saturation flag set as sim_imu sets it. The recording is then read back by
// build_input — the diagnoser's real path — and diagnosed.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <stdexcept>

#include "noise_validation.hpp"
#include "stend/diagnosis/validate.hpp"
#include "stend/noise/noise_model.hpp"
#include "stend/model/noise.hpp"
#include "stend/model/output_stage.hpp"

namespace stend::diagnosis {

namespace {

constexpr double kRate = 100.0;        // Hz
constexpr double kRecord = 30.0;       // s per position
constexpr double kLong = 600.0;        // s, the long +z window
const double kDensity = sim::SimImuConfig{}.accel_noise_density;  // m/s²/√Hz (sim_imu default)

double norm_sf(double z) { return 0.5 * std::erfc(z / std::sqrt(2.0)); }

const CandidateResult* find(const GapReport& r, const std::string& term) {
  for (const auto& c : r.candidates)
    if (c.noise_stage && c.term == term) return &c;
  return nullptr;
}

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// One static position of the run: the sensor axis pointing up, its length [s], its label.
struct Position {
  Eigen::Vector3d up;
  double seconds;
  std::string label;
};

// Six 30-s positions (±x, ±y, ±z up) and one 600-s +z window.
std::vector<Position> positions() {
  std::vector<Position> pos;
  for (int a = 0; a < 3; ++a)
    for (int sgn : {1, -1}) {
      Eigen::Vector3d u = Eigen::Vector3d::Zero();
      u[a] = sgn;
      pos.push_back({u, kRecord, std::string(sgn > 0 ? "+" : "-") + "xyz"[a] + " up"});
    }
  pos.push_back({Eigen::Vector3d(0, 0, 1), kLong, "+z up (long)"});
  return pos;
}

// True model parameters: bias [m/s²] and scale [1] at plausible MEMS values; for the saturation
// experiment a 51 mg z bias, so that only the +z-up segments come near the range.
std::vector<double> true_theta(const model::ErrorModel& m, const NoisePlant& plant, model::Rng& rng) {
  std::vector<double> theta(static_cast<std::size_t>(m.size()));
  for (std::size_t i = 0; i < theta.size(); ++i) theta[i] = (i < 3 ? 0.05 : 0.002) * rng.normal();
  if (std::isfinite(plant.headroom_sigma)) theta[2] = 0.5;
  return theta;
}

// The true mean reading of each position [m/s²].
std::vector<Eigen::Vector3d> true_means(const model::ErrorModel& m, const std::vector<double>& theta,
                                        const std::vector<Position>& pos) {
  std::vector<Eigen::Vector3d> mean(pos.size());
  for (std::size_t k = 0; k < pos.size(); ++k) {
    model::Stimulus<double> st;
    st.input = st.specific_force = physics::kStandardGravity * pos[k].up;
    st.gravity_up = pos[k].up;
    st.temperature_c = 25.0;
    mean[k] = m.measure<double>(theta.data(), st);
  }
  return mean;
}

// Noise of each axis: white at the sim_imu density plus the planted coloured part (a Gauss–Markov
// process whose Allan peak sits at τ = 30 s, a random walk sized at τ = 30 s); its truth into tr.
model::NoiseSpec noise_spec(const NoisePlant& plant, NoiseRunTruth& tr) {
  model::NoiseSpec ns;
  ns.white_density = kDensity;
  if (plant.bias_instability > 0) {
    tr.gm_correlation_s = kRecord / model::allan::kGaussMarkovPeakTau;
    tr.gm_sigma = plant.bias_instability * tr.floor / model::allan::kGaussMarkovPeakDeviation;
    ns.bias_instability.push_back({tr.gm_sigma, tr.gm_correlation_s});
  }
  if (plant.random_walk > 0) {
    tr.rw_coefficient = plant.random_walk * tr.floor * std::sqrt(3.0 / kRecord);  // K²τ/3 at τ = 30 s
    ns.random_walk = tr.rw_coefficient;
  }
  return ns;
}

// An empty simulated accelerometer recording with the run's range and LSB [m/s²] in its header.
Recording empty_recording(const NoiseRunTruth& tr) {
  Recording rec;
  rec.dir = "validation (sample level, noise stage)";
  rec.header.status = RunStatus::kComplete;
  rec.header.experiment_name = "gap validate noise stage";
  rec.header.gravity_mps2 = physics::kStandardGravity;
  rec.header.clock = "simulated";
  rec.header.info.output_rate_hz = kRate;
  rec.header.info.accel_range_mps2 = tr.range;
  rec.header.info.accel_lsb_mps2 = tr.lsb;
  rec.header.info.has_gyro = false;
  rec.header.truth_columns = {"f_x_mps2", "f_y_mps2", "f_z_mps2", "w_x_radps", "w_y_radps", "w_z_radps", "die_c"};
  return rec;
}

// The sample generator: each axis its own noise channel of one random generator, then the output
// stage (saturation, then the quantizer) as sim_imu applies them, with its saturation flag.
struct SampleStage {
  model::Rng& rng;
  std::array<model::NoiseChannel, 3> noise;
  model::Saturation sat;
  model::Quantizer quant;
};

// One position's samples (100 Hz, times continuing at k_global), its truth rows (start, middle,
// end) and its segment, appended to rec; returns the number of samples.
std::int64_t record_position(const Position& p, const Eigen::Vector3d& mean, int id, int count, SampleStage& stage,
                             std::int64_t& k_global, Recording& rec) {
  const double dt = 1.0 / kRate;
  Segment seg;
  seg.id = id;
  seg.step = 0;
  seg.kind = SegmentKind::kOrientation;
  seg.label = p.label;
  seg.orientation = id;
  seg.orientation_count = count;
  seg.t_start_s = static_cast<double>(k_global) * dt;
  const auto n = static_cast<std::int64_t>(std::lround(p.seconds * kRate));
  const Eigen::Vector3d f = physics::kStandardGravity * p.up;
  const std::vector<double> row = {f[0], f[1], f[2], 0.0, 0.0, 0.0, 25.0};
  rec.truth_t.push_back(seg.t_start_s + 0.5 * dt);
  rec.truth.push_back(row);
  for (std::int64_t i = 0; i < n; ++i) {
    ImuSample s;
    s.t_s = static_cast<double>(++k_global) * dt;
    s.temperature_c = 25.0;
    for (int a = 0; a < 3; ++a) {
      bool saturated = false;
      const double v = stage.sat.apply(mean[a] + stage.noise[static_cast<std::size_t>(a)].step(stage.rng), saturated);
      s.accel_counts[a] = stage.quant.counts(v);
      s.accel_mps2[a] = stage.quant.value(s.accel_counts[a]);
      if (saturated) s.flags |= kAccelSaturated;
    }
    rec.samples.push_back(s);
  }
  seg.t_end_s = static_cast<double>(k_global) * dt;
  rec.truth_t.push_back(0.5 * (seg.t_start_s + seg.t_end_s));
  rec.truth.push_back(row);
  rec.truth_t.push_back(seg.t_end_s - 0.5 * dt);
  rec.truth.push_back(row);
  rec.segments.push_back(seg);
  return n;
}

}  // namespace

Recording noise_stage_run(const NoisePlant& plant, std::uint64_t seed, NoiseRunTruth* truth_out) {
  const double dt = 1.0 / kRate;
  const estimation::ModelSpec spec = validation_model();
  const double settle = spec.processing.extraction.settle_s;
  NoiseRunTruth tr;
  tr.sigma = model::WhiteNoise::sigma_from_density(kDensity, dt);
  tr.floor = tr.sigma / std::sqrt((kRecord - 2 * settle) * kRate);
  model::Rng rng(seed);
  const std::vector<double> theta = true_theta(spec.model, plant, rng);
  const std::vector<Position> pos = positions();
  const std::vector<Eigen::Vector3d> mean = true_means(spec.model, theta, pos);
  double peak = 0.0;
  for (const auto& m : mean) peak = std::max(peak, m.cwiseAbs().maxCoeff());
  // Output stage: range = largest |true mean| + headroom (else 2 g), 16-bit quantizer.
  tr.range = std::isfinite(plant.headroom_sigma) ? peak + plant.headroom_sigma * tr.sigma : 2.0 * physics::kStandardGravity;
  tr.lsb = plant.lsb_over_sigma > 0 ? plant.lsb_over_sigma * tr.sigma : 2.0 * physics::kStandardGravity / 32768.0;
  const model::NoiseSpec ns = noise_spec(plant, tr);
  SampleStage stage{rng,
                    {model::NoiseChannel(ns, dt), model::NoiseChannel(ns, dt), model::NoiseChannel(ns, dt)},
                    model::Saturation(tr.range),
                    model::Quantizer(tr.lsb, 16)};
  for (auto& c : stage.noise) c.reset(rng);

  Recording rec = empty_recording(tr);
  std::size_t total = 0;
  for (const auto& p : pos) total += static_cast<std::size_t>(std::lround(p.seconds * kRate));
  rec.samples.reserve(total);
  std::int64_t k_global = 0;
  Eigen::Vector3d expected_clipped = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < pos.size(); ++k) {
    const auto n = record_position(pos[k], mean[k], static_cast<int>(k), static_cast<int>(pos.size()), stage,
                                   k_global, rec);
    // Expected clipped samples of white noise at the two range limits.
    for (int a = 0; a < 3; ++a)
      expected_clipped[a] += static_cast<double>(n) * (norm_sf((tr.range - mean[k][a]) / tr.sigma) +
                                                       norm_sf((tr.range + mean[k][a]) / tr.sigma));
  }
  tr.expected_clipped_fraction = expected_clipped / static_cast<double>(total);
  if (truth_out) *truth_out = tr;
  return rec;
}

namespace {

// One noise-stage experiment: what is planted, the candidate that should name it, the sizes.
struct NoiseExperiment {
  std::string name, candidate, meaning;
  std::vector<double> sizes;
};

// The plant of an experiment at one size.
NoisePlant plant_of(const std::string& experiment, double size) {
  NoisePlant p;
  if (experiment == "quantization") p.lsb_over_sigma = size;
  if (experiment == "saturation") p.headroom_sigma = size;
  if (experiment == "bias_instability") p.bias_instability = size;
  if (experiment == "random_walk") p.random_walk = size;
  return p;
}

// Simulates and diagnoses blind through build_input, with consecutive seeds.
struct NoiseRunner {
  estimation::ModelSpec spec;
  GapOptions gopt;
  std::uint64_t seed;
  // False when the run could not be diagnosed (too few segments left: counted as not run).
  bool run(const NoisePlant& p, NoiseRunTruth& tr, GapReport& rep) {
    const Recording rec = noise_stage_run(p, seed++, &tr);
    try {
      const GapInput in = build_input(rec, spec);
      rep = diagnose(in, gopt);
    } catch (const std::exception&) {
      return false;
    }
    return rep.ok || !rep.candidates.empty();
  }
};

// The planted value the candidate's size is compared with, and the scale that maps its size onto
// it (0.664 B flicker floor against the 0.617 σ Gauss–Markov peak); counts named / right kinds.
std::pair<double, double> planted_size(const NoiseExperiment& e, const CandidateResult& c, const NoiseRunTruth& tr,
                                       NoiseStageValidation::BySize& b) {
  if (e.name == "quantization") return {tr.lsb, 1.0};
  if (e.name == "saturation") {
    const int a = c.axis.empty() || c.axis == "-" ? 2 : c.axis[0] - 'x';
    return {tr.expected_clipped_fraction[a], 1.0};
  }
  const bool bi = c.size_param.rfind("bias_instability", 0) == 0;
  const bool rw = c.size_param.rfind("random_walk", 0) == 0;
  if (bi || rw) ++b.kind_named;
  if ((bi && e.name == "bias_instability") || (rw && e.name == "random_walk")) ++b.kind_right;
  if (e.name == "random_walk" && rw) return {tr.rw_coefficient, 1.0};
  if (e.name == "bias_instability" && bi)
    return {tr.gm_sigma, noise::kFlickerFloor / model::allan::kGaussMarkovPeakDeviation};
  return {kNaN, 1.0};
}

// noise_seeds runs at one size: detections, kind, recovered/planted and interval coverage.
NoiseStageValidation::BySize validate_noise_size(const NoiseExperiment& e, double size, int seeds, NoiseRunner& runner) {
  NoiseStageValidation::BySize b;
  b.size = size;
  std::vector<double> ratios;
  for (int sd = 0; sd < seeds; ++sd) {
    NoiseRunTruth tr;
    GapReport rep;
    if (!runner.run(plant_of(e.name, size), tr, rep)) continue;
    const CandidateResult* c = find(rep, e.candidate);
    if (!c) continue;
    ++b.runs;
    b.detected += c->significant ? 1 : 0;
    if (!c->significant || !std::isfinite(c->size)) continue;
    const auto [planted, scale] = planted_size(e, *c, tr, b);
    if (!(planted > 0)) continue;
    ratios.push_back(scale * c->size / planted);
    ++b.ci_checked;
    b.ci_covered += (scale * c->ci_lo <= planted && planted <= scale * c->ci_hi) ? 1 : 0;
  }
  b.recovered_ratio = median(ratios);
  return b;
}

// Null runs: nothing planted; any significant noise-stage candidate is a false positive.
NoiseStageValidation noise_null(int runs, NoiseRunner& runner) {
  NoiseStageValidation v;
  v.experiment = "null";
  v.size_meaning = "nothing planted (white noise, 2 g range, LSB = 2 g/2^15)";
  NoiseStageValidation::BySize b;
  for (const char* n : {"quantization", "saturation", "coloured_noise"}) v.false_positives[n] = 0;
  for (int i = 0; i < runs; ++i) {
    NoiseRunTruth tr;
    GapReport rep;
    if (!runner.run(NoisePlant{}, tr, rep)) continue;
    ++b.runs;
    bool any = false;
    for (const auto& c : rep.candidates)
      if (c.noise_stage && c.significant) {
        ++v.false_positives[c.term];
        any = true;
      }
    b.detected += any ? 1 : 0;
  }
  v.by_size.push_back(b);
  return v;
}

}  // namespace

std::vector<NoiseStageValidation> run_noise_validation(const ValidateOptions& o) {
  std::vector<NoiseStageValidation> out;
  if (o.noise_seeds <= 0 && o.noise_null_runs <= 0) return out;
  NoiseRunner runner{validation_model(), o.gap, o.seed * 2654435761ULL + 99991};
  runner.gopt.check_aliases = false;
  runner.gopt.max_steps = 1;
  const std::vector<NoiseExperiment> exps = {
      {"quantization", "quantization", "LSB / white sample std", {0.5, 1, 2, 5, 10}},
      {"saturation", "saturation", "headroom: range - largest |true mean|, in white sample std", {4, 3, 2, 1, 0}},
      {"bias_instability", "coloured_noise", "Gauss-Markov Allan peak (tau = 30 s) / white floor of a segment mean",
       {1, 2, 5, 10}},
      {"random_walk", "coloured_noise", "random-walk Allan deviation at 30 s / white floor of a segment mean",
       {1, 2, 5, 10}},
  };
  if (o.noise_seeds > 0)
    for (const auto& e : exps) {
      NoiseStageValidation v;
      v.experiment = e.name;
      v.candidate = e.candidate;
      v.size_meaning = e.meaning;
      for (double size : e.sizes) v.by_size.push_back(validate_noise_size(e, size, o.noise_seeds, runner));
      out.push_back(v);
    }
  if (o.noise_null_runs > 0) out.push_back(noise_null(o.noise_null_runs, runner));
  return out;
}

namespace noise_stage {

void print_validation(std::ostream& os, const std::vector<NoiseStageValidation>& v, double seconds) {
  if (v.empty()) return;
  char line[512];
  os << "\nnoise-stage candidates — sample level (six 30-s positions + 600 s +z, 100 Hz, white sigma 0.0277 m/s^2;\n"
        "noise.hpp NoiseChannel -> output_stage.hpp Saturation -> Quantizer -> build_input -> diagnose)\n";
  os << "experiment         size  runs  detected  kind named/right  recovered/planted  CI cover\n";
  for (const auto& e : v) {
    if (e.experiment == "null") continue;
    for (const auto& b : e.by_size) {
      std::snprintf(line, sizeof line, "%-16s %6g  %4d  %8.2f  %16s  %17.3f  %8s\n", e.experiment.c_str(), b.size,
                    b.runs, b.runs ? double(b.detected) / b.runs : 0.0,
                    e.candidate == "coloured_noise"
                        ? (std::to_string(b.kind_named) + "/" + std::to_string(b.kind_right)).c_str()
                        : "-",
                    b.recovered_ratio,
                    b.ci_checked ? (std::to_string(b.ci_covered) + "/" + std::to_string(b.ci_checked)).c_str() : "-");
      os << line;
    }
  }
  os << "sizes:";
  for (const auto& e : v)
    if (e.experiment != "null") os << " " << e.experiment << " = " << e.size_meaning << ";";
  os << "\n";
  for (const auto& e : v) {
    if (e.experiment != "null" || e.by_size.empty()) continue;
    const auto& b = e.by_size.front();
    os << "null runs: " << b.runs << ", any noise candidate significant " << b.detected << " (rate "
       << (b.runs ? double(b.detected) / b.runs : 0.0) << ")   [target <= 0.05]; per candidate:";
    for (const auto& [n, k] : e.false_positives) os << " " << n << " " << k;
    os << "\n";
  }
  std::snprintf(line, sizeof line, "noise-stage time: %.1f s\n", seconds);
  os << line;
}

void add_json(nlohmann::json& j, const std::vector<NoiseStageValidation>& v, double seconds) {
  using nlohmann::json;
  auto num = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
  json a = json::array();
  for (const auto& e : v) {
    json sz = json::array();
    for (const auto& b : e.by_size)
      sz.push_back({{"size", b.size}, {"runs", b.runs}, {"detected", b.detected}, {"kind_named", b.kind_named},
                    {"kind_right", b.kind_right}, {"ci_checked", b.ci_checked}, {"ci_covered", b.ci_covered},
                    {"recovered_over_planted", num(b.recovered_ratio)}});
    a.push_back({{"experiment", e.experiment}, {"candidate", e.candidate}, {"size_meaning", e.size_meaning},
                 {"by_size", sz}, {"false_positives", e.false_positives}});
  }
  j["noise_stage"] = a;
  j["noise_stage_seconds"] = seconds;
}

}  // namespace noise_stage

}  // namespace stend::diagnosis
