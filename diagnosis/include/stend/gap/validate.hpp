// `stend gap validate`: does the diagnoser name an effect that was withheld from the model?
//
// Many-seed runs use a segment-level generator: the designed experiment (orientations on the sim
// three-axis table × a temperature up- and down-sweep, a die that lags the chamber) is pushed
// through the vocabulary's forward model (ErrorModel::measure — the simulator's code path) with a
// known true model, and each segment mean gets the noise of a segment mean: white noise of the
// sim_imu default density plus a Gauss–Markov bias instability (stend/model/noise.hpp) evaluated
// at the segment times, with the floor estimated from 8 batch means as build_input does.
//
// For each candidate and size multiple m (the planted effect's RMS over the segment rows that
// the fitted model cannot absorb = m × the averaged noise floor) the model is fitted WITHOUT it
// and diagnosed blind. Reported: top-1 accuracy (the first selected term is the planted one or a
// declared alias of it), the planted term's rank, held-out gap closed, recovered vs planted size
// with 95 % interval coverage, the confusion matrix; null runs (false positives), out-of-vocabulary
// runs (must end "unexplained", no name given).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "stend/gap/gap.hpp"

namespace stend::gap {

struct ValidationDesign {
  // Table positions (tilt h, rotation δ) [deg]; default: 6 axis-up/down + 8 tumble positions.
  std::vector<std::pair<double, double>> positions;
  std::vector<double> setpoints_c = {0.0, 20.0, 40.0, 60.0, 40.0, 20.0};  // up-sweep, then down
  double hold_s = 300.0;        // after each setpoint change, before the first position
  double die_lag_s = 120.0;     // die temperature time constant
  double record_s = 20.0;       // averaging window per position
  double move_s = 10.0;         // between positions
  double rate_hz = 100.0;
  double noise_density = 0.00392266;    // m/s^2/√Hz (sim_imu default)
  double bias_instability = 0.0;        // GM σ [m/s^2]; 0 = 0.3 × the white floor of a mean
  double bias_correlation_s = 600.0;
  double gravity = 9.80665;
};

ValidationDesign default_design();
// A design with n positions (tilt/rotation on a spiral) at one temperature, for the speed
// benchmark (100 positions).
ValidationDesign many_positions_design(int n);

// The model the planted effects are withheld from: bias + scale (accelerometer).
batch_lsq::ModelSpec validation_model();

// Segment-level data for one experiment: `truth` = the true model (terms and θ), noise from seed.
struct Planted {
  model::ErrorModel model;
  Eigen::VectorXd theta;
  // Out-of-vocabulary effect added to the measured means [m/s^2] per (segment, axis); empty none.
  std::vector<Eigen::Vector3d> extra;
};
GapInput generate(const ValidationDesign& design, const batch_lsq::ModelSpec& fit_model, const Planted& truth,
                  std::uint64_t seed);

struct ValidateOptions {
  int seeds = 20;                           // per (candidate, size)
  std::vector<double> sizes = {1, 2, 5, 10};  // multiples of the averaged noise floor
  int null_runs = 40;
  int oov_runs = 20;
  std::vector<std::string> only;            // candidate names; empty = all assessable
  GapOptions gap;                           // passed to diagnose (aliases off unless asked)
  std::uint64_t seed = 1;
  ValidationDesign design = default_design();
};

struct CandidateValidation {
  std::string term;
  bool identifiable = true;         // adds rank beyond the fitted model in this design
  std::vector<std::string> aliases; // declared beforehand (joint-design rank)
  struct BySize {
    double size = 0;                // multiple of the floor
    int runs = 0, top1 = 0, top1_strict = 0, coverage_n = 0, covered = 0;
    double mean_rank = 0;           // 1-based rank of the planted term among candidates
    double closed = 0;              // mean fraction of the explainable held-out gap closed
    double recovered_ratio = 0;     // mean recovered/planted (size parameter)
  };
  std::vector<BySize> by_size;
};

struct ValidationReport {
  std::vector<CandidateValidation> candidates;
  std::map<std::string, std::map<std::string, int>> confusion;  // planted → named (≥ 5× floor)
  int null_runs = 0, null_false_positives = 0;
  std::map<std::string, int> null_named;  // what the false positives named
  int oov_runs = 0, oov_unexplained = 0, oov_wrong_name = 0;
  double top1_at5 = 0;   // top-1 over identifiable candidates at sizes ≥ 5× floor
  double closed_at5 = 0; // mean explainable held-out gap closed, sizes ≥ 5×
  double coverage = 0;   // 95 % interval coverage of the recovered size, sizes ≥ 5×
  double false_positive_rate = 0;
  double floor_mps2 = 0; // averaged noise floor of a segment mean in the design
  double seconds = 0;
};

ValidationReport run_validation(const ValidateOptions& options);
void print_validation(std::ostream& os, const ValidationReport& report);
std::string validation_json(const ValidationReport& report, int indent = 2);

}  // namespace stend::gap
