// Plugin entry of sim_imu: the configuration schema and the factory.
#include <stend/sdk.hpp>

#include <cmath>

#include <stend/sim/imu.hpp>

namespace {

constexpr double kU = NAN;  // unbounded

// Defaults must equal SimImuConfig's (tests/sim_imu_test.cpp checks it).
const stend_param_spec kParams[] = {
    // --- deterministic accelerometer errors (the error-model vocabulary, SI) ---
    {"accel_bias_mps2", "vec3", "m/s^2", "[0, 0, 0]", -100.0, 100.0, nullptr,
     "bias b_i (term 'bias')"},
    {"accel_scale", "vec3", "1", "[0, 0, 0]", -0.5, 0.5, nullptr,
     "scale-factor error s_i: y_i = (1 + s_i)·u_i (term 'scale')"},
    {"accel_cross_axis", "mat3", "1", "[[0, 0, 0], [0, 0, 0], [0, 0, 0]]", -0.5, 0.5, nullptr,
     "cross-axis m_ij (row i = output axis, column j = input axis), zero diagonal (term 'cross_axis')"},
    {"accel_nonlinear_k2", "vec3", "1/(m/s^2)", "[0, 0, 0]", -1.0, 1.0, nullptr, "k2_i·u_i² (term 'nonlinear_k2')"},
    {"accel_nonlinear_k3", "vec3", "1/(m/s^2)^2", "[0, 0, 0]", -1.0, 1.0, nullptr, "k3_i·u_i³ (term 'nonlinear_k3')"},
    {"accel_odd_quadratic", "vec3", "1/(m/s^2)", "[0, 0, 0]", -1.0, 1.0, nullptr,
     "q_i·u_i·|u_i| (term 'odd_quadratic')"},
    {"accel_bias_tc", "matrix3", "m/s^2/degC^k", "[[0], [0], [0]]", kU, kU, nullptr,
     "bias temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1) (term 'bias_temperature', order = columns)"},
    {"accel_scale_tc", "matrix3", "1/degC^k", "[[0], [0], [0]]", kU, kU, nullptr,
     "scale temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1)·u_i (term 'scale_temperature')"},
    {"accel_thermal_lag", "vec3", "(m/s^2)/(degC/s)", "[0, 0, 0]", kU, kU, nullptr,
     "l_i·dT/dt, T = die temperature (term 'thermal_lag')"},
    {"accel_time_drift", "vec3", "m/s^2/s", "[0, 0, 0]", kU, kU, nullptr, "r_i·t since start (term 'time_drift')"},
    // --- deterministic gyroscope errors (rad/s) ---
    {"gyro_bias_radps", "vec3", "rad/s", "[0, 0, 0]", -10.0, 10.0, nullptr, "bias b_i (term 'bias')"},
    {"gyro_scale", "vec3", "1", "[0, 0, 0]", -0.5, 0.5, nullptr, "scale-factor error s_i (term 'scale')"},
    {"gyro_cross_axis", "mat3", "1", "[[0, 0, 0], [0, 0, 0], [0, 0, 0]]", -0.5, 0.5, nullptr,
     "cross-axis m_ij, zero diagonal (term 'cross_axis')"},
    {"gyro_nonlinear_k2", "vec3", "1/(rad/s)", "[0, 0, 0]", -1.0, 1.0, nullptr, "k2_i·u_i² (term 'nonlinear_k2')"},
    {"gyro_nonlinear_k3", "vec3", "1/(rad/s)^2", "[0, 0, 0]", -1.0, 1.0, nullptr, "k3_i·u_i³ (term 'nonlinear_k3')"},
    {"gyro_odd_quadratic", "vec3", "1/(rad/s)", "[0, 0, 0]", -1.0, 1.0, nullptr,
     "q_i·u_i·|u_i| (term 'odd_quadratic')"},
    {"gyro_bias_tc", "matrix3", "rad/s/degC^k", "[[0], [0], [0]]", kU, kU, nullptr,
     "bias temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1)"},
    {"gyro_scale_tc", "matrix3", "1/degC^k", "[[0], [0], [0]]", kU, kU, nullptr,
     "scale temperature coefficients: row = axis, column k = coefficient of (T−T0)^(k+1)·u_i"},
    {"gyro_thermal_lag", "vec3", "(rad/s)/(degC/s)", "[0, 0, 0]", kU, kU, nullptr, "l_i·dT/dt (term 'thermal_lag')"},
    {"gyro_time_drift", "vec3", "rad/s/s", "[0, 0, 0]", kU, kU, nullptr, "r_i·t since start (term 'time_drift')"},
    {"gyro_g_sensitivity", "mat3", "(rad/s)/(m/s^2)", "[[0, 0, 0], [0, 0, 0], [0, 0, 0]]", -1.0, 1.0, nullptr,
     "G_ij: gyro axis i responds to specific force f_j (term 'g_sensitivity')"},
    {"temperature_reference_c", "number", "degC", "25", -100.0, 200.0, nullptr,
     "T0 of the temperature terms"},
    // --- noise (stend/model/noise.hpp) ---
    {"accel_noise_density", "number", "m/s^2/sqrt(Hz)", "0.00392266", 0.0, 1.0, nullptr,
     "white noise, one-sided density (datasheet convention; 400 µg/√Hz); σ = density·√(rate/2) before the low-pass"},
    {"accel_bias_instability_mps2", "number", "m/s^2", "0.0005", 0.0, 10.0, nullptr,
     "bias instability: stationary σ of a first-order Gauss–Markov process (Allan deviation peak ≈ 0.617·σ)"},
    {"accel_bias_correlation_s", "number", "s", "100", 1e-3, 1e7, nullptr,
     "correlation time of the bias instability"},
    {"accel_random_walk", "number", "m/s^2/sqrt(s)", "2e-5", 0.0, 1.0, nullptr,
     "bias random walk K: Var[b(t) − b(0)] = K²·t (m/s^2.5)"},
    {"gyro_noise_density", "number", "rad/s/sqrt(Hz)", "8.72664626e-5", 0.0, 0.1, nullptr,
     "white noise, one-sided density (0.005 °/s/√Hz)"},
    {"gyro_bias_instability_radps", "number", "rad/s", "5e-5", 0.0, 1.0, nullptr,
     "bias instability: stationary σ of a first-order Gauss–Markov process"},
    {"gyro_bias_correlation_s", "number", "s", "100", 1e-3, 1e7, nullptr,
     "correlation time of the gyro bias instability"},
    {"gyro_random_walk", "number", "rad/s/sqrt(s)", "1e-6", 0.0, 0.1, nullptr,
     "gyro bias random walk K: Var[b(t) − b(0)] = K²·t (rad/s^1.5)"},
    // --- output stage ---
    {"accel_range_g", "number", "g", "2", 1e-3, 1000.0, nullptr,
     "full scale ±range (g = 9.80665 m/s²); beyond it the output saturates and is flagged"},
    {"gyro_range_dps", "number", "deg/s", "250", 1e-3, 1e5, nullptr, "full scale ±range"},
    {"accel_lsb_mps2", "number", "m/s^2", "0", 0.0, 100.0, nullptr,
     "one count; 0 = full scale / 2^(output_bits−1) (16384 LSB/g at ±2 g)"},
    {"gyro_lsb_radps", "number", "rad/s", "0", 0.0, 10.0, nullptr,
     "one count; 0 = full scale / 2^(output_bits−1) (131.072 LSB/(°/s) at ±250 °/s)"},
    {"output_bits", "integer", "", "16", 2.0, 32.0, nullptr, "signed output word length"},
    {"output_rate_hz", "number", "Hz", "1000", 1e-3, 1e6, nullptr, "output data rate"},
    {"lowpass_hz", "number", "Hz", "0", 0.0, 5e5, nullptr,
     "2nd-order Butterworth low-pass cutoff at the output rate; 0 = off; must be below rate/2"},
    {"temperature_offset_c", "number", "degC", "36.53", -100.0, 200.0, nullptr,
     "temperature reading = counts / temperature_counts_per_c + offset"},
    {"temperature_counts_per_c", "number", "1/degC", "340", 1e-6, 1e6, nullptr, "temperature sensitivity"},
    {"temperature_noise_c", "number", "degC", "0", 0.0, 10.0, nullptr, "white noise on the temperature reading"},
    // --- identity and reproducibility ---
    {"seed", "integer", "", "0", 0.0, kU, nullptr,
     "noise seed; 0 = chosen by the host from the experiment seed"},
    {"vendor", "string", "", "InvenSense", kU, kU, nullptr, "reported vendor"},
    {"model", "string", "", "MPU-6050", kU, kU, nullptr, "reported model"},
    {"serial", "string", "", "\"\"", kU, kU, nullptr, "reported serial number"},
    {"who_am_i", "string", "", "\"0x68\"", kU, kU, nullptr, "reported identity register"},
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "sim_imu", "0.1.0",
                    "Simulated 3-axis accelerometer + gyroscope + temperature (MPU-6050 defaults)", kParams,
                    stend::sim::SimImu)
