// Register map of the bench microcontroller's MODBUS RTU slave (docs/bench-mcu-modbus.md).
// Shared by the driver (sensors/mpu6050) and its emulator (emulators/bench_mcu).
#pragma once

#include <stend/devices/bench_mcu_regs.h>  // the numbers, shared with firmware/bench_mcu

#include <stend/devices/i2c_bench_mcu.hpp>  // the I2C passthrough window (kHoldI2c*, kInI2c*)

#include <cstdint>

namespace stend::bench_mcu {

// The firmware's slave ids (firmware/bench_mcu serves both maps on one line).
inline constexpr int kFirmwareSensorSlave = STEND_BMCU_SLAVE_SENSOR;
inline constexpr int kFirmwareChamberSlave = STEND_BMCU_SLAVE_CHAMBER;

// Holding registers (FC 03 read, FC 06 write).
inline constexpr int kHoldCtrl = STEND_BMCU_HOLD_CTRL;         // bit0 RUN; bit1 FIFO reset (self-clearing)
inline constexpr int kHoldSmplrtDiv = STEND_BMCU_HOLD_SMPLRT_DIV;    // MPU-6050 SMPLRT_DIV (0..255)
inline constexpr int kHoldDlpfCfg = STEND_BMCU_HOLD_DLPF_CFG;      // MPU-6050 CONFIG.DLPF_CFG (0..6)
inline constexpr int kHoldGyroFsSel = STEND_BMCU_HOLD_GYRO_FS_SEL;    // 0..3 → ±250/500/1000/2000 °/s
inline constexpr int kHoldAccelFsSel = STEND_BMCU_HOLD_ACCEL_FS_SEL;   // 0..3 → ±2/4/8/16 g
inline constexpr int kHoldCount = STEND_BMCU_HOLD_COUNT;             // MPU-6050 streaming block; the I2C window follows at 0x0010
inline constexpr std::uint16_t kCtrlRun = STEND_BMCU_CTRL_RUN;
inline constexpr std::uint16_t kCtrlFifoReset = STEND_BMCU_CTRL_FIFO_RESET;

// Input registers (FC 04).
inline constexpr int kInStatus = STEND_BMCU_IN_STATUS;         // bit0 running, bit1 overflow since last read, bit2 asleep
inline constexpr int kInWhoAmI = STEND_BMCU_IN_WHO_AM_I;         // MPU-6050 WHO_AM_I as read from the sensor
inline constexpr int kInFifoCount = STEND_BMCU_IN_FIFO_COUNT;      // samples waiting
inline constexpr int kInFifoCapacity = STEND_BMCU_IN_FIFO_CAPACITY;   // samples
inline constexpr int kInOverflows = STEND_BMCU_IN_OVERFLOWS;      // samples dropped since RUN (saturates at 0xFFFF)
inline constexpr int kInFirmware = STEND_BMCU_IN_FIRMWARE;       // 0xMMmm
inline constexpr int kInBootCount = STEND_BMCU_IN_BOOT_COUNT;      // power-ons and resets since manufacture (wraps at 0xFFFF)
inline constexpr int kInCount = STEND_BMCU_IN_COUNT;
inline constexpr std::uint16_t kStatusRunning = STEND_BMCU_STATUS_RUNNING;
inline constexpr std::uint16_t kStatusOverflow = STEND_BMCU_STATUS_OVERFLOW;
inline constexpr std::uint16_t kStatusAsleep = STEND_BMCU_STATUS_ASLEEP;

// FIFO window: reading input registers at kInWindowBase + (s mod kWindowSeqModulo) acknowledges
// (discards) every sample older than sequence number s and returns, without consuming them,
// up to kWindowMaxSamples samples from s on:
//   word 0: n, samples in this window; word 1: samples still waiting after them;
//   words 2,3: sequence number of the first sample (high, low) — larger than s if s was lost;
//   then n × 7 words: ax ay az temp gx gy gz (int16, the MPU-6050's counts).
// A repeated read (after a CRC error or time-out) returns the same samples again.
inline constexpr int kInWindowBase = STEND_BMCU_IN_WINDOW_BASE;
inline constexpr std::uint32_t kWindowSeqModulo = STEND_BMCU_WINDOW_SEQ_MODULO;
inline constexpr int kWindowHeaderWords = STEND_BMCU_WINDOW_HEADER_WORDS;
inline constexpr int kWordsPerSample = STEND_BMCU_WORDS_PER_SAMPLE;
inline constexpr int kWindowMaxSamples = STEND_BMCU_WINDOW_MAX_SAMPLES;  // 4 + 7·17 = 123 ≤ 125 registers per FC 04
inline constexpr int kWindowMaxWords = kWindowHeaderWords + kWordsPerSample * kWindowMaxSamples;

inline constexpr std::uint16_t kFirmwareVersion = STEND_BMCU_FIRMWARE_VERSION;

}  // namespace stend::bench_mcu
