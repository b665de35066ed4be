// Firmware in the loop: the bench microcontroller's real firmware (firmware/bench_mcu, the .elf
// avr-gcc built) running on simavr's ATmega328P, with its peripherals modelled against simavr's
// API and backed by Stend's twin:
//   - MPU-6050 on the TWI bus (address 0x68): the register model of emulators/mpu6050 (counts
//     from stend::sim::SimImu, its FIFO), advanced to the simulated instant of every START;
//   - DS18B20 on pin 11 (PB3): a 1-Wire slave decoding the firmware's slots by their length in
//     CPU cycles (reset, presence, write 0/1, read slots), SKIP ROM, CONVERT T, READ SCRATCHPAD
//     with the Dallas CRC-8, reading the thermal plant's air temperature;
//   - thermal plant (stend::sim::plant_step, the sim_thermochamber equations) driven by the PWM
//     duties the firmware sets in Timer1 (OCR1B heater pin 10, OCR1A Peltier pin 9);
//   - USART0 bridged to a pseudo-terminal: a host driver opens device_path() like /dev/ttyUSB0.
// Simulated time is paced to the wall clock × speed (the host drivers' time-outs are wall time);
// a simulation starved of CPU catches up at most 2× faster than the wall clock, and gives up a lag
// beyond 0.5 s (docs/firmware.md, Pacing).
// Fault injection: corrupted replies and requests (CRC errors on the line), silence (time-outs),
// DS18B20 open / CRC error / power-on value, MPU-6050 absent, a reset of the MCU.
#pragma once

#include <stend/sim/thermochamber.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "mpu6050_model.hpp"

namespace stend::emu {

enum class Ds18b20Fault { kNone, kOpen, kCrcError, kPowerOnValue };

struct FirmwareLoopConfig {
  std::string elf_path;           // bench_mcu.elf (CMake: STEND_BENCH_MCU_ELF)
  double speed = 1.0;             // simulated seconds per wall second; 0 = unpaced (as fast as simavr runs)
  sim::ThermochamberConfig plant; // the chamber around the sensor
  std::uint64_t seed = 1;         // fault-injection random stream
  // Pseudo-terminals in front of the one UART: 2 gives a second host driver its own port (the
  // bench world's chamber driver, slave 2, beside the sensor's, slave 1), the requests of both
  // taking turns on the line one transaction at a time, as behind a two-port RS-485 hub.
  int host_ports = 1;

  // An .elf path, a speed >= 0, one or two host ports.
  bool IsValid(std::string* error = nullptr) const;
};

struct FirmwareLoopStats {
  double simulated_s = 0.0;       // simulated time since power-on [s]
  double wall_s = 0.0;            // wall time since construction [s]
  double busy_s = 0.0;            // wall time spent simulating (not waiting for the wall clock) [s]
  double lag_given_up_s = 0.0;    // paced: lag beyond 0.5 s given up, not caught up [s] (the MCU's clock fell behind)
  std::uint64_t bytes_to_mcu = 0, bytes_from_mcu = 0;
  std::uint64_t corrupted_requests = 0, corrupted_replies = 0, dropped_requests = 0;
  std::uint64_t resets = 0;       // resets of the part: reset_mcu(), the AVR watchdog, a crash
};

class FirmwareInTheLoop {
 public:
  // Loads the .elf (throws InputError naming the file when it cannot), opens the pty,
  // starts the simulation thread.
  FirmwareInTheLoop(FirmwareLoopConfig config, Mpu6050Model mpu);
  ~FirmwareInTheLoop();
  FirmwareInTheLoop(const FirmwareInTheLoop&) = delete;
  FirmwareInTheLoop& operator=(const FirmwareInTheLoop&) = delete;

  const std::string& device_path(int port = 0) const;  // the pty's slave end (port < host_ports)

  // Line faults: each reply (request) burst gets one byte flipped with this probability.
  void set_reply_corrupt_probability(double p);
  void set_request_corrupt_probability(double p);
  void go_silent(std::chrono::milliseconds d);  // requests are lost on the line for `d` (wall time)
  void set_ds18b20_fault(Ds18b20Fault f);
  void set_mpu_present(bool present);           // false: the MPU-6050 does not ACK its address
  void reset_mcu();                             // pulse the RESET pin (BOOT_COUNT goes up)
  // Hang the firmware: the CPU jumps into a tight loop with interrupts off (avr-libc's _exit), as
  // a bug would leave it; only the AVR's hardware watchdog (250 ms) gets it out, by a reset.
  void hang_mcu();

  int heater_pwm() const;   // Timer1 duty on pin 10, 0..255 (0 while the output is disconnected)
  int peltier_pwm() const;  // pin 9
  double air_c() const;     // the plant's air temperature [°C]
  double die_c() const;     // the sensor die's temperature in the plant [°C]
  // Blocks until the simulation has reached `t_s` simulated seconds (or `timeout` wall time passed).
  bool wait_until_simulated(double t_s, std::chrono::milliseconds timeout) const;
  FirmwareLoopStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stend::emu
