// Simulated 3-axis accelerometer + 3-axis gyroscope + temperature sensor (defaults: InvenSense
// MPU-6050). Deterministic errors come from the error-model vocabulary (stend::model::ErrorModel),
// random errors from stend/model/noise.hpp, the digital output from stend/model/output_stage.hpp:
//
//   y = ErrorModel::measure(θ, stimulus) + noise  ─►  low-pass  ─►  saturate  ─►  quantize
//
// See README.md for every configuration key.
#pragma once

#include <stend/model/noise.hpp>
#include <stend/model/output_stage.hpp>
#include <stend/model/terms.hpp>
#include <stend/fields.hpp>
#include <stend/physics/units.hpp>
#include <stend/sdk.hpp>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace stend::sim {

// Deterministic error parameters of one triad, SI (accelerometer: m/s²; gyroscope: rad/s).
struct TriadErrors {
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();           // [unit]
  Eigen::Vector3d scale = Eigen::Vector3d::Zero();          // [1]
  Eigen::Matrix3d cross_axis = Eigen::Matrix3d::Zero();     // [1], zero diagonal; (i,j) = m_ij
  Eigen::Vector3d nonlinear_k2 = Eigen::Vector3d::Zero();   // [1/unit]
  Eigen::Vector3d nonlinear_k3 = Eigen::Vector3d::Zero();   // [1/unit²]
  Eigen::Vector3d odd_quadratic = Eigen::Vector3d::Zero();  // [1/unit]
  std::vector<std::vector<double>> bias_tc{{0.0}, {0.0}, {0.0}};   // row i, column k: (T−T0)^(k+1)
  std::vector<std::vector<double>> scale_tc{{0.0}, {0.0}, {0.0}};  // same, relative
  Eigen::Vector3d thermal_lag = Eigen::Vector3d::Zero();    // [unit/(degC/s)]
  Eigen::Vector3d time_drift = Eigen::Vector3d::Zero();     // [unit/s]
  Eigen::Matrix3d g_sensitivity = Eigen::Matrix3d::Zero();  // gyro only, [(rad/s)/(m/s²)]
};

struct SimImuConfig {
  TriadErrors accel, gyro;
  double temperature_reference_c = 25.0;

  // Noise (see stend/model/noise.hpp for the conventions).
  double accel_noise_density = 400.0 * physics::kMicroG;      // m/s²/√Hz, one-sided (400 µg/√Hz)
  double accel_bias_instability_mps2 = 5e-4;                  // GM stationary σ
  double accel_bias_correlation_s = 100.0;
  double accel_random_walk = 2e-5;                            // m/s²/√s
  double gyro_noise_density = 0.005 * physics::kDegPerSecond;  // rad/s/√Hz, one-sided (0.005 deg/s/√Hz)
  double gyro_bias_instability_radps = 5e-5;
  double gyro_bias_correlation_s = 100.0;
  double gyro_random_walk = 1e-6;                             // rad/s/√s

  // Output stage.
  double accel_range_g = 2.0;
  double gyro_range_dps = 250.0;
  double accel_lsb_mps2 = 0.0;  // 0 = range / 2^(bits−1)
  double gyro_lsb_radps = 0.0;
  std::int64_t output_bits = 16;
  double output_rate_hz = 1000.0;
  double lowpass_hz = 0.0;  // 0 = off
  double temperature_offset_c = 36.53;     // T = counts / counts_per_c + offset
  double temperature_counts_per_c = 340.0;
  double temperature_noise_c = 0.0;

  std::int64_t seed = 0;  // 0 = the host picks (from the experiment seed)
  std::string vendor = "InvenSense", model = "MPU-6050", serial = "", who_am_i = "0x68";

  // Every parameter of the sim_imu plugin: its schema and the reader of its Params.
  static const stend::fields::Table<SimImuConfig>& fields();
  static SimImuConfig from(const Params& p) { return fields().read(p); }  // throws std::invalid_argument
  // Rate, bits, ranges, LSBs, low-pass below Nyquist, temperature scale, seed, the shapes of the
  // temperature coefficients and zero cross-axis diagonals.
  bool IsValid(std::string* error = nullptr) const;
};

class SimImu final : public Sensor {
 public:
  // Used when `seed` is 0 and the host did not replace it (direct construction).
  static constexpr std::uint64_t kFallbackSeed = 0x5EEDF00DULL;

  explicit SimImu(const Params& p);
  explicit SimImu(const SimImuConfig& c);

  SensorIdentity identity() const override;
  SensorInfo info() const override;
  void start(double t0_s) override;
  void acquire(double t_s, const TruthSource& truth, std::vector<ImuSample>& out) override;

  // The deterministic models as simulated (terms whose parameters are all zero are left out) and
  // their flat parameter vectors.
  const model::ErrorModel& accel_model() const { return accel_model_; }
  const std::vector<double>& accel_theta() const { return accel_theta_; }
  const model::ErrorModel& gyro_model() const { return gyro_model_; }
  const std::vector<double>& gyro_theta() const { return gyro_theta_; }
  const SimImuConfig& config() const { return c_; }
  model::NoiseSpec accel_noise() const;
  model::NoiseSpec gyro_noise() const;

 private:
  void sample(double t, const BenchTruth& truth, ImuSample& s);

  SimImuConfig c_;
  std::uint64_t seed_ = kFallbackSeed;
  double dt_ = 1e-3;
  model::ErrorModel accel_model_, gyro_model_;
  std::vector<double> accel_theta_, gyro_theta_;
  model::Rng rng_;
  std::array<model::NoiseChannel, 6> noise_;  // accel x y z, gyro x y z
  int draws_ = 0;                             // normals per sample, drawn at once into z_
  std::array<double, 6 * 8> z_{};
  std::array<model::Biquad, 6> lowpass_;
  bool lowpass_on_ = false;
  model::Saturation accel_sat_, gyro_sat_;
  model::Quantizer accel_q_, gyro_q_, temp_q_;

  double t0_ = 0.0;
  std::int64_t next_k_ = 1;  // index of the next sample: t = t0 + k·dt
  bool first_ = true;
  double prev_die_c_ = 0.0;
};

}  // namespace stend::sim
