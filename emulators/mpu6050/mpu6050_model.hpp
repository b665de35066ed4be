// Register-level model of an InvenSense MPU-6050, backed by stend::sim::SimImu for the counts.
// Modelled: WHO_AM_I (0x75), PWR_MGMT_1 (0x6B, SLEEP bit 6, reset value 0x40), SMPLRT_DIV (0x19),
// CONFIG (0x1A, DLPF_CFG bits 2:0), GYRO_CONFIG (0x1B, FS_SEL bits 4:3), ACCEL_CONFIG (0x1C,
// AFS_SEL bits 4:3), data registers ACCEL_XOUT_H 0x3B .. GYRO_ZOUT_L 0x48 (big-endian int16,
// TEMP_OUT: T = raw/340 + 36.53). Sample rate = gyro output rate / (1 + SMPLRT_DIV), gyro output
// rate 8 kHz when DLPF_CFG is 0 or 7, else 1 kHz. DLPF_CFG 1..6 low-pass the physics at
// 184/94/44/21/10/5 Hz; DLPF_CFG 0 (260 Hz) is treated as unfiltered.
#pragma once

#include <stend/sdk.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>

#include "sim_imu.hpp"

namespace stend::emu {

namespace mpu6050 {
inline constexpr std::uint8_t kSmplrtDiv = 0x19, kConfig = 0x1A, kGyroConfig = 0x1B,
                              kAccelConfig = 0x1C, kAccelXoutH = 0x3B, kGyroZoutL = 0x48,
                              kPwrMgmt1 = 0x6B, kWhoAmI = 0x75;
inline constexpr std::uint8_t kSleep = 0x40;
}  // namespace mpu6050

class Mpu6050Model {
 public:
  // `physics` supplies noise and errors; its range, rate and low-pass are replaced by the
  // register settings. `truth` is the static stimulus the sensor sits in.
  Mpu6050Model(sim::SimImuConfig physics, BenchTruth truth, std::uint8_t who_am_i = 0x68);

  std::uint8_t read(std::uint8_t reg) const { return regs_[reg & 0x7F]; }
  void read_burst(std::uint8_t reg, std::uint8_t* out, std::size_t n) const;
  void write(std::uint8_t reg, std::uint8_t value);

  // Advance the part's clock to t_s (seconds since power-on). For each sample instant passed
  // while awake, latches the sample into 0x3B..0x48 and calls data_ready (the INT pin).
  void advance(double t_s, const std::function<void()>& data_ready);

  double sample_rate_hz() const;
  bool asleep() const { return (regs_[mpu6050::kPwrMgmt1] & mpu6050::kSleep) != 0; }

 private:
  void rebuild(double t_s);

  sim::SimImuConfig physics_;
  BenchTruth truth_;
  std::array<std::uint8_t, 128> regs_{};
  std::unique_ptr<sim::SimImu> imu_;  // null while asleep or after a configuration change
  double now_s_ = 0.0;
};

}  // namespace stend::emu
