// Register-level model of an InvenSense MPU-6050, backed by stend::sim::SimImu for the counts.
// Modelled: WHO_AM_I (0x75), PWR_MGMT_1 (0x6B, DEVICE_RESET bit 7, SLEEP bit 6, reset value
// 0x40), SMPLRT_DIV (0x19), CONFIG (0x1A, DLPF_CFG bits 2:0), GYRO_CONFIG (0x1B, FS_SEL bits 4:3),
// ACCEL_CONFIG (0x1C, AFS_SEL bits 4:3), FIFO_EN (0x23: TEMP 7, XG 6, YG 5, ZG 4, ACCEL 3),
// INT_STATUS (0x3A: DATA_RDY 0, FIFO_OFLOW 4; cleared by reading), data registers
// ACCEL_XOUT_H 0x3B .. GYRO_ZOUT_L 0x48 (big-endian int16, TEMP_OUT: T = raw/340 + 36.53),
// USER_CTRL (0x6A: FIFO_EN 6, FIFO_RESET 2 self-clearing), FIFO_COUNTH/L (0x72/0x73), FIFO_R_W
// (0x74: a burst read pops FIFO bytes and does not advance the register pointer). The FIFO holds
// 1024 bytes in register order of the enabled sources; when full, the oldest bytes are dropped
// and FIFO_OFLOW is set (as the part: the frame alignment is lost, the host resets the FIFO).
// Sample rate = gyro output rate / (1 + SMPLRT_DIV), gyro output rate 8 kHz when DLPF_CFG is 0
// or 7, else 1 kHz. DLPF_CFG 1..6 low-pass the physics at 184/94/44/21/10/5 Hz; DLPF_CFG 0
// (260 Hz) is treated as unfiltered.
#pragma once

#include <stend/sdk.hpp>

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>

#include <stend/sim/imu.hpp>

namespace stend::emu {

namespace mpu6050 {
inline constexpr std::uint8_t kSmplrtDiv = 0x19, kConfig = 0x1A, kGyroConfig = 0x1B,
                              kAccelConfig = 0x1C, kFifoEn = 0x23, kIntEnable = 0x38, kIntStatus = 0x3A,
                              kAccelXoutH = 0x3B, kGyroZoutL = 0x48, kUserCtrl = 0x6A,
                              kPwrMgmt1 = 0x6B, kFifoCountH = 0x72, kFifoCountL = 0x73, kFifoRW = 0x74,
                              kWhoAmI = 0x75;
inline constexpr std::uint8_t kSleep = 0x40, kDeviceReset = 0x80;
inline constexpr std::uint8_t kUserFifoEn = 0x40, kUserFifoReset = 0x04;
inline constexpr std::uint8_t kIntDataRdy = 0x01, kIntFifoOflow = 0x10;
inline constexpr std::size_t kFifoBytes = 1024;
}  // namespace mpu6050

class Mpu6050Model {
 public:
  using TruthFn = std::function<BenchTruth(double t_s)>;
  // `physics` supplies noise and errors; its range, rate and low-pass are replaced by the
  // register settings. `truth` is the static stimulus the sensor sits in.
  Mpu6050Model(sim::SimImuConfig physics, BenchTruth truth, std::uint8_t who_am_i = 0x68);
  // Stimulus evaluated at each sample instant (seconds since power-on). It is called from the
  // thread that drives the model (e.g. the bench MCU emulator's), so it must be thread-safe if
  // another thread changes it: e.g. capture a std::shared_ptr<TruthCell> (truth_cell.hpp).
  Mpu6050Model(sim::SimImuConfig physics, TruthFn truth, std::uint8_t who_am_i = 0x68);

  std::uint8_t read(std::uint8_t reg) const;  // no side effects
  void read_burst(std::uint8_t reg, std::uint8_t* out, std::size_t n) const;  // no side effects
  void write(std::uint8_t reg, std::uint8_t value);
  // An I2C read as the part does it: from register `reg` on, auto-incrementing (except at
  // FIFO_R_W, which pops FIFO bytes), INT_STATUS cleared by reading it. `reg` is left at the
  // next register.
  void i2c_read(std::uint8_t& reg, std::uint8_t* out, std::size_t n);

  // Advance the part's clock to t_s (seconds since power-on). For each sample instant passed
  // while awake, latches the sample into 0x3B..0x48 (and the FIFO when enabled) and calls
  // data_ready (the INT pin).
  void advance(double t_s, const std::function<void()>& data_ready);

  double sample_rate_hz() const;
  bool asleep() const { return (regs_[mpu6050::kPwrMgmt1] & mpu6050::kSleep) != 0; }
  std::size_t fifo_size() const { return fifo_.size(); }

 private:
  void rebuild(double t_s);
  void reset_registers();

  sim::SimImuConfig physics_;
  TruthFn truth_;
  std::uint8_t who_am_i_;
  std::array<std::uint8_t, 128> regs_{};
  std::deque<std::uint8_t> fifo_;
  std::unique_ptr<sim::SimImu> imu_;  // null while asleep or after a configuration change
  double now_s_ = 0.0;
};

}  // namespace stend::emu
