// Register map of the bench microcontroller's MODBUS RTU slave (docs/bench-mcu-modbus.md).
// Shared by the driver (sensors/mpu6050) and its emulator (emulators/bench_mcu).
#pragma once

#include <stend/devices/i2c_bench_mcu.hpp>  // the I2C passthrough window (kHoldI2c*, kInI2c*)

#include <cstdint>

namespace stend::bench_mcu {

// Holding registers (FC 03 read, FC 06 write).
inline constexpr int kHoldCtrl = 0x0000;         // bit0 RUN; bit1 FIFO reset (self-clearing)
inline constexpr int kHoldSmplrtDiv = 0x0001;    // MPU-6050 SMPLRT_DIV (0..255)
inline constexpr int kHoldDlpfCfg = 0x0002;      // MPU-6050 CONFIG.DLPF_CFG (0..6)
inline constexpr int kHoldGyroFsSel = 0x0003;    // 0..3 → ±250/500/1000/2000 °/s
inline constexpr int kHoldAccelFsSel = 0x0004;   // 0..3 → ±2/4/8/16 g
inline constexpr int kHoldCount = 5;             // MPU-6050 streaming block; the I2C window follows at 0x0010
inline constexpr std::uint16_t kCtrlRun = 1u << 0;
inline constexpr std::uint16_t kCtrlFifoReset = 1u << 1;

// Input registers (FC 04).
inline constexpr int kInStatus = 0x0000;         // bit0 running, bit1 overflow since last read, bit2 asleep
inline constexpr int kInWhoAmI = 0x0001;         // MPU-6050 WHO_AM_I as read from the sensor
inline constexpr int kInFifoCount = 0x0002;      // samples waiting
inline constexpr int kInFifoCapacity = 0x0003;   // samples
inline constexpr int kInOverflows = 0x0004;      // samples dropped since RUN (saturates at 0xFFFF)
inline constexpr int kInFirmware = 0x0005;       // 0xMMmm
inline constexpr int kInBootCount = 0x0006;      // power-ons and resets since manufacture (wraps at 0xFFFF)
inline constexpr int kInCount = 7;
inline constexpr std::uint16_t kStatusRunning = 1u << 0;
inline constexpr std::uint16_t kStatusOverflow = 1u << 1;
inline constexpr std::uint16_t kStatusAsleep = 1u << 2;

// FIFO window: reading input registers at kInWindowBase + (s mod kWindowSeqModulo) acknowledges
// (discards) every sample older than sequence number s and returns, without consuming them,
// up to kWindowMaxSamples samples from s on:
//   word 0: n, samples in this window; word 1: samples still waiting after them;
//   words 2,3: sequence number of the first sample (high, low) — larger than s if s was lost;
//   then n × 7 words: ax ay az temp gx gy gz (int16, the MPU-6050's counts).
// A repeated read (after a CRC error or time-out) returns the same samples again.
inline constexpr int kInWindowBase = 0x4000;
inline constexpr std::uint32_t kWindowSeqModulo = 0x4000;
inline constexpr int kWindowHeaderWords = 4;
inline constexpr int kWordsPerSample = 7;
inline constexpr int kWindowMaxSamples = 17;  // 4 + 7·17 = 123 ≤ 125 registers per FC 04
inline constexpr int kWindowMaxWords = kWindowHeaderWords + kWordsPerSample * kWindowMaxSamples;

inline constexpr std::uint16_t kFirmwareVersion = 0x0100;

}  // namespace stend::bench_mcu
