// Register-level models of I2C inertial sensors on an emulated bus (i2c_bus_model.hpp), each
// backed by stend::sim::SimImu: the counts are the simulated truth through the error model,
// noise, low-pass, saturation and quantization with the chip's full scale, sensitivity and
// temperature formula, at the output data rate its registers select.
//
//   Mpu6050I2c   — emulators/mpu6050's Mpu6050Model on the bus (WHO_AM_I 0x68, FIFO)
//   Adxl345Model — DEVID 0x00 = 0xE5, BW_RATE 0x2C, POWER_CTL 0x2D (Measure bit 3), INT_SOURCE
//                  0x30, DATA_FORMAT 0x31 (FULL_RES bit 3, range bits 1:0), DATAX0..DATAZ1
//                  0x32..0x37 (little-endian), FIFO_CTL 0x38 (mode bits 7:6: bypass, FIFO,
//                  stream), FIFO_STATUS 0x39 (entries bits 5:0, 32 deep). No gyro, no temperature.
//   Lsm6dsoModel — WHO_AM_I 0x0F = 0x6C, CTRL1_XL 0x10, CTRL2_G 0x11, CTRL3_C 0x12 (IF_INC bit
//                  2, BDU bit 6, SW_RESET bit 0), STATUS_REG 0x1E, OUT_TEMP_L 0x20 (256 LSB/°C,
//                  0 = 25 °C), OUTX_L_G 0x22.., OUTX_L_A 0x28.. (little-endian). FIFO:
//                  FIFO_CTRL3 0x09 (BDR_GY 7:4, BDR_XL 3:0), FIFO_CTRL4 0x0A (mode 2:0: 0 bypass,
//                  6 continuous), FIFO_STATUS1/2 0x3A/0x3B (unread words, OVR bit 6),
//                  FIFO_DATA_OUT_TAG 0x78 (tag bits 7:3: 0x01 gyro, 0x02 accel) + 6 data bytes
//                  0x79..0x7E; reads roll over from 0x7E to 0x78; 3 KiB ≈ 438 words; continuous
//                  mode drops the oldest words when full. BDR equal to the ODR only.
//   Bmi160Model  — CHIP_ID 0x00 = 0xD1, PMU_STATUS 0x03, DATA gyro 0x0C.., accel 0x12..
//                  (little-endian), SENSORTIME 0x18..0x1A, STATUS 0x1B, TEMPERATURE 0x20 (T = 23
//                  + raw/512), ACC_CONF 0x40, ACC_RANGE 0x41, GYR_CONF 0x42, GYR_RANGE 0x43, CMD
//                  0x7E (0x11 accel normal, 0x15 gyro normal, 0x10/0x14 suspend, 0xB0 FIFO
//                  flush, 0xB6 soft reset). FIFO, headerless: FIFO_CONFIG_1 0x47 (gyro bit 7,
//                  accel bit 6, header bit 4 — header mode not modelled), 12-byte frames gyro then
//                  accel (little-endian), FIFO_LENGTH 0x22/0x23 (bytes, 11 bits), FIFO_DATA 0x24,
//                  1024 bytes; when full the oldest frame is overwritten and INT_STATUS_1 (0x1D)
//                  ffull bit 5 is set if INT_EN_1 (0x51) enables it.
//   Icm42688Model — WHO_AM_I 0x75 = 0x47, DEVICE_CONFIG 0x11 (soft reset bit 0), TEMP_DATA1 0x1D
//                  (T = raw/132.48 + 25), ACCEL_DATA_X1 0x1F.., GYRO_DATA_X1 0x25.. (big-endian),
//                  INT_STATUS 0x2D (DATA_RDY bit 3, FIFO_FULL bit 1), FIFO_COUNTH/L 0x2E/0x2F
//                  (bytes, big-endian), FIFO_DATA 0x30, SIGNAL_PATH_RESET 0x4B (FIFO_FLUSH bit
//                  1), PWR_MGMT0 0x4E, GYRO_CONFIG0 0x4F, ACCEL_CONFIG0 0x50, FIFO_CONFIG 0x16
//                  (mode bits 7:6, stream = 01), FIFO_CONFIG1 0x5F (accel 0, gyro 1, temp 2).
//                  FIFO: 2048 bytes of 16-byte packets (header 0x68, accel, gyro big-endian,
//                  temperature int8 = raw/2.07 + 25, 2-byte timestamp); stream mode drops the
//                  oldest packet when full and sets FIFO_FULL. Bank 0 only.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>

#include "i2c_bus_model.hpp"
#include "mpu6050_model.hpp"
#include <stend/sim/imu.hpp>

namespace stend::emu {

using TruthFn = std::function<BenchTruth(double t_s)>;
TruthFn static_truth(const BenchTruth& t);

// The MPU-6050 model as an I2C target (register pointer, auto-increment, FIFO port).
class Mpu6050I2c final : public I2cTarget {
 public:
  explicit Mpu6050I2c(Mpu6050Model model) : m_(std::move(model)) {}
  void i2c_write(const std::uint8_t* data, std::size_t n, double now_s) override;
  void i2c_read(std::uint8_t* data, std::size_t n, double now_s) override;
  Mpu6050Model& model() { return m_; }

 private:
  Mpu6050Model m_;
  std::uint8_t ptr_ = 0;
};

// Common machinery of the register models below.
class RegisterImuModel : public I2cTarget {
 public:
  RegisterImuModel(sim::SimImuConfig physics, TruthFn truth) : physics_(std::move(physics)), truth_(std::move(truth)) {}
  void i2c_write(const std::uint8_t* data, std::size_t n, double now_s) override;
  void i2c_read(std::uint8_t* data, std::size_t n, double now_s) override;
  std::uint8_t peek(std::uint8_t reg) const { return regs_[reg]; }
  double output_rate_hz() const { return running() ? output_config(physics_).output_rate_hz : 0.0; }

 protected:
  virtual void reset_registers() = 0;                         // power-on values
  virtual bool writable(std::uint8_t reg) const = 0;
  virtual void on_write(std::uint8_t /*reg*/, std::uint8_t /*value*/) {}  // after storing
  virtual std::uint8_t on_read(std::uint8_t reg) { return regs_[reg]; }   // side effects
  virtual bool auto_increment() const { return true; }
  virtual bool fifo_port(std::uint8_t /*reg*/) const { return false; }  // reads do not advance the pointer
  virtual std::uint8_t next_register(std::uint8_t reg) const { return static_cast<std::uint8_t>(reg + 1); }
  virtual void after_read(std::uint8_t /*first*/, std::size_t /*n*/) {}
  virtual bool running() const = 0;
  virtual bool restarts(std::uint8_t reg) const = 0;  // writing it restarts the signal chain
  virtual sim::SimImuConfig output_config(sim::SimImuConfig c) const = 0;
  virtual void latch(const ImuSample& s, double t_s) = 0;

  void restart() { imu_.reset(); }
  std::array<std::uint8_t, 256> regs_{};

 private:
  void advance(double t_s);
  sim::SimImuConfig physics_;
  TruthFn truth_;
  std::unique_ptr<sim::SimImu> imu_;
  double now_s_ = 0.0;
  std::uint8_t ptr_ = 0;
};

class Adxl345Model final : public RegisterImuModel {
 public:
  Adxl345Model(sim::SimImuConfig physics, TruthFn truth, int devid = 0xE5);
  std::size_t fifo_entries() const { return fifo_.size(); }

 private:
  void reset_registers() override;
  bool writable(std::uint8_t reg) const override;
  void on_write(std::uint8_t reg, std::uint8_t value) override;
  std::uint8_t on_read(std::uint8_t reg) override;
  void after_read(std::uint8_t first, std::size_t n) override;
  bool running() const override { return (regs_[0x2D] & 0x08) != 0; }
  bool restarts(std::uint8_t reg) const override { return reg == 0x2C || reg == 0x2D || reg == 0x31; }
  sim::SimImuConfig output_config(sim::SimImuConfig c) const override;
  void latch(const ImuSample& s, double t_s) override;
  void show_front();

  int devid_;
  std::deque<std::array<std::uint8_t, 6>> fifo_;
};

class Lsm6dsoModel final : public RegisterImuModel {
 public:
  Lsm6dsoModel(sim::SimImuConfig physics, TruthFn truth, int who_am_i = 0x6C);

 private:
  void reset_registers() override;
  bool writable(std::uint8_t reg) const override { return (reg >= 0x07 && reg <= 0x19) || reg == 0x01; }
  void on_write(std::uint8_t reg, std::uint8_t value) override;
  std::uint8_t on_read(std::uint8_t reg) override;
  bool auto_increment() const override { return (regs_[0x12] & 0x04) != 0; }
  void after_read(std::uint8_t first, std::size_t n) override;
  std::uint8_t next_register(std::uint8_t reg) const override { return reg == 0x7E ? 0x78 : static_cast<std::uint8_t>(reg + 1); }
  bool running() const override { return (regs_[0x10] >> 4) != 0 || (regs_[0x11] >> 4) != 0; }
  bool restarts(std::uint8_t reg) const override { return reg == 0x10 || reg == 0x11; }
  sim::SimImuConfig output_config(sim::SimImuConfig c) const override;
  void latch(const ImuSample& s, double t_s) override;
  void show_word();
  int who_;
  std::deque<std::array<std::uint8_t, 7>> fifo_;
};

class Bmi160Model final : public RegisterImuModel {
 public:
  Bmi160Model(sim::SimImuConfig physics, TruthFn truth, int chip_id = 0xD1);

 private:
  void reset_registers() override;
  bool writable(std::uint8_t reg) const override { return reg >= 0x40 && reg != 0x7F; }
  bool fifo_port(std::uint8_t reg) const override { return reg == 0x24; }
  void on_write(std::uint8_t reg, std::uint8_t value) override;
  std::uint8_t on_read(std::uint8_t reg) override;
  bool running() const override { return (regs_[0x03] & 0x30) == 0x10; }  // accelerometer normal
  bool restarts(std::uint8_t reg) const override { return reg >= 0x40 && reg <= 0x43; }
  sim::SimImuConfig output_config(sim::SimImuConfig c) const override;
  void latch(const ImuSample& s, double t_s) override;
  int chip_id_;
  std::deque<std::uint8_t> fifo_;
};

class Icm42688Model final : public RegisterImuModel {
 public:
  Icm42688Model(sim::SimImuConfig physics, TruthFn truth, int who_am_i = 0x47);

 private:
  void reset_registers() override;
  bool writable(std::uint8_t reg) const override { return reg == 0x11 || reg == 0x14 || reg == 0x16 || (reg >= 0x4B && reg <= 0x65) || reg == 0x76; }
  void on_write(std::uint8_t reg, std::uint8_t value) override;
  std::uint8_t on_read(std::uint8_t reg) override;
  bool running() const override { return (regs_[0x4E] & 0x03) >= 2 || ((regs_[0x4E] >> 2) & 0x03) == 3; }
  bool restarts(std::uint8_t reg) const override { return reg >= 0x4E && reg <= 0x50; }
  sim::SimImuConfig output_config(sim::SimImuConfig c) const override;
  void latch(const ImuSample& s, double t_s) override;
  bool fifo_port(std::uint8_t reg) const override { return reg == 0x30; }
  int who_;
  std::deque<std::uint8_t> fifo_;
};

}  // namespace stend::emu
