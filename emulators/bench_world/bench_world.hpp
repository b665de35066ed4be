// One simulated bench world served over the real protocols: a one-axis table (sim physics:
// SimAxis, finite speed, settling) as an ACUTROL-style text-command server on 127.0.0.1, the
// paper's chamber (sim_thermochamber plant under the published PID) as the ATmega328 MODBUS RTU
// slave on a pty, and the bench microcontroller (MODBUS RTU on a pty) reading an MPU-6050 register
// model whose stimulus follows the table and the chamber: the chamber stands on the table and the
// sensor in the chamber, as in configs/paper_mpu6050_z.yaml.
//
//   R_sensor_from_local = M · Ry(δ(t))·Rx(h),  f = R·(0, 0, g),  ω = M·δ̇·e_y + R·ω_earth
//   (stend/physics: paper_table_motion, gravity_specific_force)
//   air / die temperature from the chamber's plant.
// The table and the sensor run in wall time; the chamber's plant may run faster (chamber_speed).
// With firmware_elf the bench MCU and the chamber controller are the real firmware under simavr
// (emulators/firmware): slave 1 on mcu_device(), slave 2 on chamber_device(), one UART behind
// both ports, the plant driven by the firmware's PWM in wall time (chamber_speed does not apply).
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/physics/units.hpp>
#include <stend/sim/motion_profile.hpp>

#include <Eigen/Core>
#include <chrono>
#include <memory>
#include <string>

#include "bench_mcu_slave.hpp"
#include "chamber_emulator.hpp"
#include <stend/sim/imu.hpp>
#include "table_text_server.hpp"

namespace stend::emu {

class FirmwareInTheLoop;

struct BenchWorldConfig {
  sim::SimImuConfig imu;            // the sensor's error model and noise (its rate/range/low-pass
                                    // come from the registers the driver writes)
  sim::AxisConfig table_axis;       // the table's rotation axis δ (deg)
  double table_tilt_deg = 0.0;      // h, set beforehand
  ChamberEmuConfig chamber;         // plant and firmware; chamber.speed = its time scale
  double gravity_mps2 = physics::kStandardGravity;
  double latitude_deg = 0.0;
  double heading_deg = 0.0;
  Eigen::Matrix3d R_sensor_from_mount = Eigen::Matrix3d::Identity();
  int table_port = 0;               // 0: ephemeral
  std::string firmware_elf;         // non-empty: the bench MCU and the chamber controller are the real
                                    // firmware (firmware/bench_mcu) under simavr (emulators/firmware)
                                    // instead of the C++ emulations

  // The physics of an in-process experiment whose bench is sim_imu + sim_one_axis_table +
  // sim_thermochamber (e.g. configs/paper_mpu6050_z.yaml), so the world is that bench's twin.
  // Throws std::invalid_argument naming what does not fit.
  static BenchWorldConfig from_experiment(const Experiment& sim_exp, double chamber_speed);
  // The sensor (SimImuConfig), the table's axis (AxisConfig) and the chamber (ChamberEmuConfig)
  // valid, a positive gravity, a table port 0..65535.
  bool IsValid(std::string* error = nullptr) const;
};

class BenchWorld {
 public:
  explicit BenchWorld(const BenchWorldConfig& c);
  ~BenchWorld();

  int table_port() const { return table_->port(); }
  const std::string& chamber_device() const;  // with firmware_elf: the firmware's second host port
  int chamber_slave_id() const;               // 1, or the firmware's chamber slave (2) with firmware_elf
  const std::string& mcu_device() const;
  TableTextServer& table() { return *table_; }
  AtmegaChamberSlave& chamber() { return *chamber_; }  // the C++ emulation (absent with firmware_elf)
  BenchMcuSlave& mcu() { return *mcu_; }  // the C++ emulation (absent with firmware_elf)
  FirmwareInTheLoop* firmware() { return fw_.get(); }  // with firmware_elf: the MCU and the chamber

  // What the sensor experiences at wall time `t_since_mcu_power_on_s` (thread-safe).
  BenchTruth truth(double t_since_mcu_power_on_s);

 private:
  BenchWorldConfig c_;
  double tilt_rad_ = 0.0;  // h
  Eigen::Vector3d earth_local_;
  std::unique_ptr<TableTextServer> table_;
  std::unique_ptr<AtmegaChamberSlave> chamber_;
  std::chrono::steady_clock::time_point mcu_epoch_;
  std::unique_ptr<BenchMcuSlave> mcu_;  // last: its thread reads the others, so it stops first
  std::shared_ptr<FirmwareInTheLoop> fw_;  // or the firmware in the loop (shared_ptr: complete only where built)
  // Its plant for truth(), called from the firmware's own thread: kept while fw_ is destroyed (its
  // thread is joined before its state goes).
  FirmwareInTheLoop* fw_plant_ = nullptr;
};

}  // namespace stend::emu
