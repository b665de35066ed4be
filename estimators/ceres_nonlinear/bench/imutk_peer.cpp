// Helper of bench/imutk_vs_stend.sh: the steps around running IMU-TK beside `stend fit`.
//
//   stend_imutk_peer export RUN ACC_TXT GYRO_TXT
//       the run's samples as IMU-TK text files (`t x y z`, SI: m/s², rad/s; io::export_imutk)
//   stend_imutk_peer residual RUN STEND_FIT_JSON IMUTK_PREFIX
//       one residual for both calibrations on the same intervals: RMS over the static intervals
//       of the Stend fit (its JSON, "accelerometer.intervals") of |calibrated interval mean| − g,
//       g = the fit's gravity. Stend: the fit's accelerometer model (ErrorModel::correct); IMU-TK:
//       PREFIX_acc.calib, a = T·K·(ȳ − b) as IMU-TK applies it. Prints
//       `residual_mps2 raw <r> stend <r> imutk <r>`.
#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/io/importers.hpp>
#include <stend/recording/recording.hpp>

#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using stend::processing::StaticPoint;

// IMU-TK's calibration file: misalignment T (3×3), scale K (3×3), bias b (3), row-major.
struct ImuTkTriad {
  Eigen::Matrix3d t, k;
  Eigen::Vector3d b;
  Eigen::Vector3d correct(const Eigen::Vector3d& y) const { return t * k * (y - b); }
};

ImuTkTriad read_imutk_calib(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file + ": cannot open");
  ImuTkTriad c;
  for (int i = 0; i < 9; ++i) in >> c.t(i / 3, i % 3);
  for (int i = 0; i < 9; ++i) in >> c.k(i / 3, i % 3);
  for (int i = 0; i < 3; ++i) in >> c.b[i];
  if (!in) throw std::runtime_error(file + ": expected 21 numbers (T 3×3, K 3×3, b 3)");
  return c;
}

// The accelerometer part of a `stend fit --json` result: its intervals (by time) and its model.
struct StendAccel {
  stend::model::ErrorModel model = stend::ceres_nonlinear::accelerometer_model();
  std::vector<double> theta;
  std::vector<std::pair<double, double>> intervals_s;
  double gravity_mps2 = 0.0;
};

StendAccel read_stend_fit(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file + ": cannot open");
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& a = j.at("accelerometer");
  if (!a.at("ok").get<bool>()) throw std::runtime_error(file + ": the accelerometer fit failed");
  StendAccel s;
  s.gravity_mps2 = a.at("gravity_mps2").get<double>();
  for (const auto& iv : a.at("intervals")) s.intervals_s.emplace_back(iv.at("t_start_s"), iv.at("t_end_s"));
  for (const auto& info : s.model.params()) {
    double value = std::nan("");
    for (const auto& p : a.at("parameters"))
      if (p.at("name").get<std::string>() == info.name) value = p.at("fixed").get<bool>() ? 0.0 : p.at("value").get<double>();
    if (!std::isfinite(value)) throw std::runtime_error(file + ": no value for accelerometer parameter " + info.name);
    s.theta.push_back(value);
  }
  return s;
}

// Mean accelerometer reading [m/s²] of the samples with t in [t0, t1].
Eigen::Vector3d mean_accel(const stend::Recording& rec, double t0, double t1) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& s : rec.samples)
    if (s.t_s >= t0 && s.t_s <= t1) {
      sum += s.accel_mps2;
      ++n;
    }
  if (n == 0) throw std::runtime_error("no samples in a static interval of the fit");
  return sum / n;
}

template <class Correct>
double norm_rms(const std::vector<Eigen::Vector3d>& means, double g, Correct correct) {
  double sum = 0.0;
  for (const auto& m : means) sum += std::pow(correct(m).norm() - g, 2);
  return std::sqrt(sum / static_cast<double>(means.size()));
}

int residual(const std::string& run, const std::string& fit_json, const std::string& imutk_prefix) {
  const stend::Recording rec = stend::Recording::open(run);
  const StendAccel stend_fit = read_stend_fit(fit_json);
  const ImuTkTriad imutk = read_imutk_calib(imutk_prefix + "_acc.calib");
  std::vector<Eigen::Vector3d> means;
  for (const auto& [t0, t1] : stend_fit.intervals_s) means.push_back(mean_accel(rec, t0, t1));
  const double g = stend_fit.gravity_mps2;
  const double raw = norm_rms(means, g, [](const Eigen::Vector3d& y) { return y; });
  const double stend_r = norm_rms(means, g, [&](const Eigen::Vector3d& y) {
    return stend_fit.model.correct(stend_fit.theta.data(), y, stend::model::Stimulus<double>{});
  });
  const double imutk_r = norm_rms(means, g, [&](const Eigen::Vector3d& y) { return imutk.correct(y); });
  std::printf("residual_mps2 raw %.6g stend %.6g imutk %.6g intervals %zu\n", raw, stend_r, imutk_r, means.size());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string cmd = argc > 1 ? argv[1] : "";
    if (cmd == "export" && argc == 5) {
      stend::io::export_imutk(stend::Recording::open(argv[2]), argv[3], argv[4]);
      return 0;
    }
    if (cmd == "residual" && argc == 5) return residual(argv[2], argv[3], argv[4]);
    std::fprintf(stderr,
                 "usage: stend_imutk_peer export RUN ACC_TXT GYRO_TXT\n"
                 "       stend_imutk_peer residual RUN STEND_FIT_JSON IMUTK_PREFIX\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stend_imutk_peer: %s\n", e.what());
    return 1;
  }
}
