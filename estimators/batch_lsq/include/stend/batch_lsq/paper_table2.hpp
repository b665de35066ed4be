// Reproduction of the paper's Table 2 fit (Aksenov: MPU6050, Z channel, table angle 0…44°, one
// temperature) with the error-model vocabulary: accelerometer, axis z, terms bias, scale and
// cross_axis (→ bias_z, scale_z, cross_zx, cross_zy = the paper's Δa_z, δM, μ33, μ34), specific
// force f = g·[−sin δ cos h, sin h, cos δ cos h] (stend::physics::paper_table).
// See docs/paper-reproduction.md for the discussion of every difference.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "stend/batch_lsq/batch_lsq.hpp"

namespace stend::batch_lsq::paper {

struct Table2Row {
  double angle_deg = 0.0;  // table rotation δ
  double a_z_mps2 = 0.0;   // Z output
};

// The paper's reported fit (no uncertainty given; g and tilt h not stated).
struct PaperTable2Fit {
  double scale = 0.0007;     // δM
  double cross_zx = 0.0055;  // μ33 (sign convention of δ not fixed in the paper)
  double cross_zy = 0.0002;  // μ34
  double bias_mps2 = 0.027;  // Δa_z
};

// Taganrog (Southern Federal University's engineering campus) / Rostov-on-Don latitude.
inline constexpr double kPaperLatitudeDeg = 47.2;

// CSV with header "angle_deg,a_z_mps2"; '#' lines are comments. Throws InputError naming file and
// line.
std::vector<Table2Row> load_table2_csv(const std::filesystem::path& file);
// datasets/paper_table2/table2.csv of the source tree this library was built from.
std::filesystem::path default_table2_csv();

ModelSpec table2_model();
std::vector<processing::StaticPoint> table2_points(const std::vector<Table2Row>& rows, double g_mps2,
                                                   double tilt_h_deg);

struct Table2Case {
  std::string label;
  double g_mps2 = 0.0;
  double tilt_h_deg = 0.0;
  FitResult fit;
  // g-free combinations (identical for every assumed g): the Z sensitivity g·(1 + scale_z)
  // [m/s²] and g·cross_zx [m/s²] (the sin δ amplitude). Valid when fit.ok.
  estimation::Combination g_one_plus_scale;
  estimation::Combination g_cross_zx;
};

struct Table2Reproduction {
  std::vector<Table2Row> rows;
  std::vector<Table2Case> cases;  // [0] normal gravity 47.2°N h=0, [1] standard gravity h=0, [2] h=1°
  PaperTable2Fit paper;
  // The paper's parameters (μ33 with the sign that best fits) evaluated on Table 2.
  double paper_rms_normal_g = 0.0;  // RMS residual with g = normal gravity at 47.2°N [m/s²]
  double paper_best_g = 0.0;        // g that best fits the paper's parameters to the table
  double paper_rms_best_g = 0.0;    // RMS residual at that g
  double g_implied_by_paper_scale = 0.0;  // g with g·(1+δM_paper) = fitted g·(1+scale_z)
  double bias_scale_correlation = 0.0;    // correlation of bias_z and scale_z (case 0)
};

Table2Reproduction reproduce_table2(const std::vector<Table2Row>& rows);
void print_table2_report(std::ostream& os, const Table2Reproduction& r);

}  // namespace stend::batch_lsq::paper
