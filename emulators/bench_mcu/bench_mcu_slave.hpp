// Emulated bench microcontroller: reads an MPU-6050 register model on every data-ready, buffers
// the samples in a FIFO ring and serves them as a MODBUS RTU slave (libmodbus) on the master end
// of a pseudo-terminal pair; the driver opens device_path(), the slave end, like /dev/ttyUSB0.
// Register map: docs/bench-mcu-modbus.md (sensors/mpu6050/bench_mcu_map.hpp).
// I2C passthrough window (docs/bench-mcu-modbus.md): commands written to holding register
// I2C_CMD run on the MCU's I2C bus — the MPU-6050 model at `mpu_address` and, when given, the
// targets of an emulated I2C bus (emulators/i2c) — with status and data in input registers.
// Fault injection for tests: corrupted replies (bad CRC), periods of silence, stalls and restarts.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "i2c_bus_model.hpp"
#include "mpu6050_model.hpp"
#include "stend/emulators/pty_modbus_slave.hpp"

namespace stend::emu {

struct BenchMcuConfig {
  int slave_id = 1;
  std::size_t fifo_depth = 1024;  // samples buffered in the MCU's RAM
  std::uint64_t seed = 1;         // fault-injection random stream
  std::uint8_t mpu_address = 0x68;  // the MPU-6050's 7-bit address on the MCU's I2C bus
  std::uint16_t boot_count = 1;     // BOOT_COUNT at power-on; restart() adds one

  // A slave address 1..247, a FIFO of at least one sample, a 7-bit MPU address.
  bool IsValid(std::string* error = nullptr) const;
};

struct BenchMcuStats {
  std::uint64_t requests = 0, replies = 0, corrupted = 0, ignored = 0, exceptions = 0;
};

class BenchMcuSlave {
 public:
  BenchMcuSlave(BenchMcuConfig config, Mpu6050Model mpu);  // opens the pty, starts the thread
  // The same, with more sensors on the MCU's I2C bus, reachable through the I2C window.
  BenchMcuSlave(BenchMcuConfig config, Mpu6050Model mpu, std::shared_ptr<EmulatedI2cBus> i2c_bus);
  ~BenchMcuSlave();
  BenchMcuSlave(const BenchMcuSlave&) = delete;
  BenchMcuSlave& operator=(const BenchMcuSlave&) = delete;

  const std::string& device_path() const { return rtu_.device_path(); }
  // Each read reply (FC 03/04) gets one data byte flipped with this probability.
  void set_corrupt_probability(double p) { corrupt_p_.store(p); }
  // Read and drop every request for `d` from now (the sensor keeps sampling into the FIFO).
  void go_silent(std::chrono::milliseconds d);
  // Stop serving for `d` from now, then answer every request that arrived meanwhile, in order (the
  // MCU busy elsewhere; the sensor keeps sampling into the FIFO). Replies to requests the client
  // gave up on arrive late, as they do on a real line.
  void stall(std::chrono::milliseconds d);
  // A reset of the MCU: FIFO, sequence numbers and holding registers cleared, sampling stopped,
  // BOOT_COUNT incremented.
  void restart();
  BenchMcuStats stats() const;

 private:
  void run();
  void produce();
  void handle(const std::uint8_t* req, int len);
  bool window(int address, int count);
  void apply_ctrl();
  void reset();
  void run_i2c_command();

  BenchMcuConfig c_;
  Mpu6050Model mpu_;
  std::shared_ptr<EmulatedI2cBus> i2c_bus_;  // may be null
  PtyModbusRtu rtu_;          // the pty pair and the RTU context (emulators/common)
  void* mapping_ = nullptr;  // modbus_mapping_t*
  std::chrono::steady_clock::time_point power_on_;

  // MCU state (slave thread only)
  std::deque<std::array<std::int16_t, 7>> fifo_;
  std::uint32_t front_seq_ = 0;  // sequence number of fifo_.front()
  std::uint32_t next_seq_ = 0;   // sequence number of the next sample
  std::uint32_t sent_seq_ = 0;   // one past the last sample a window returned (reached the host, maybe unacknowledged)
  std::uint32_t overflows_ = 0;  // samples dropped before any window returned them (docs/bench-mcu-modbus.md)
  bool overflow_flag_ = false;
  bool running_ = false;
  std::uint16_t boot_count_ = 1;
  std::uint64_t rng_;

  std::atomic<double> corrupt_p_{0.0};
  std::atomic<std::int64_t> silent_until_ns_{0};
  std::atomic<std::int64_t> stalled_until_ns_{0};
  std::atomic<bool> restart_pending_{false};
  std::atomic<bool> stop_{false};
  mutable std::mutex stats_mutex_;
  BenchMcuStats stats_;
  std::thread thread_;
};

}  // namespace stend::emu
