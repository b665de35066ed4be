// Emulated chamber controllers, backed by the sim_thermochamber plant (same equations and
// parameters, stend::sim::ThermochamberConfig) under the paper's PID loop:
//   ChamberFirmware   — the ATmega328 firmware: DS18B20 reading, the published PID with the
//                       tuning registers of docs/thermochamber-modbus.md, trips, watchdog.
//   AtmegaChamberSlave — that firmware as a MODBUS RTU slave on an openpty pair (device_path()).
//   WatlowChamberServer — a Watlow F4 register view (PV 100, SP 300, tenths °C) of the same
//                       firmware as a MODBUS TCP server on 127.0.0.1 (port()).
// Emulated time = wall time × speed since construction. Fault injection: sensor failure (open
// wire reads −127 °C, stuck reading, 85 °C power-on value), runaway (heater relay welded on), CRC
// corruption (RTU), silence, slave exceptions, a TCP peer that disappears and comes back.
#pragma once

#include <stend/sim/thermochamber.hpp>  // sim/: ThermochamberConfig (the plant)
#include "stend/emulators/pty_modbus_slave.hpp"  // emulators/common: the RTU slave's pty pair
#include "stend/emulators/tcp_server.hpp"        // emulators/common: the loopback accept/serve loop

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace stend::emu {

enum class SensorFault { kNone, kDisconnected, kStuck, kPowerOn };

struct ChamberEmuConfig {
  sim::ThermochamberConfig plant;  // plant parameters, control period, ambient, initial
  double speed = 1.0;              // emulated seconds per wall second
  bool firmware_guards = true;     // false: the published firmware (no sensor check, no trips)
  int slave_id = 1;
  std::uint64_t seed = 1;

  // What the firmware's plant needs (positive control period, heat capacity and conductance), a
  // positive speed, a slave address 1..247.
  bool IsValid(std::string* error = nullptr) const;
};

// The firmware and plant. Not thread-safe by itself (the servers lock around it).
class ChamberFirmware {
 public:
  explicit ChamberFirmware(const ChamberEmuConfig& c);

  void advance_to(double t_s);  // emulated time; runs every control cycle up to t_s
  double now() const { return now_; }

  // Register view (docs/thermochamber-modbus.md).
  std::uint16_t holding(int address) const { return hold_[static_cast<std::size_t>(address)]; }
  void write_holding(int address, std::uint16_t value);
  void fill_inputs(std::uint16_t* in) const;  // kInCount registers
  void master_seen() { last_master_ = now_; }

  // Watlow view: PV (°C, as the controller reads it) and setpoint.
  double reading_c() const { return raw_ / 16.0; }
  void set_setpoint_c(double c);  // also switches the loop on
  double setpoint_c() const;

  double air_c() const { return air_; }
  double die_c() const { return die_; }
  int heater_pwm() const { return heater_; }
  int peltier_pwm() const { return peltier_; }
  double integral() const { return integral_; }
  std::uint16_t status() const;

  void inject_sensor_fault(SensorFault f) { sensor_fault_ = f; stuck_raw_ = raw_; }
  void inject_heater_stuck_on(bool on) { heater_stuck_ = on; }

 private:
  void control();
  void integrate(double dt);

  ChamberEmuConfig c_;
  std::array<std::uint16_t, 12> hold_{};
  double now_ = 0.0, next_control_ = 0.0, last_master_ = 0.0;
  double air_, die_;  // plant air and die temperatures [°C]
  std::int16_t raw_ = 0, stuck_raw_ = 0;
  bool running_ = false;
  double integral_ = 0.0, err_prev_ = 0.0, u_ = 0.0;
  int heater_ = 0, peltier_ = 0;
  std::uint16_t faults_ = 0;  // latched status fault bits
  std::uint16_t sensor_errors_ = 0;
  std::uint32_t cycles_ = 0;
  SensorFault sensor_fault_ = SensorFault::kNone;
  bool heater_stuck_ = false;
};

struct ChamberEmuStats {
  std::uint64_t requests = 0, replies = 0, corrupted = 0, ignored = 0, exceptions = 0, connections = 0;
};

// Shared by the RTU and TCP servers: the firmware under a lock, advanced with wall time, and the
// fault switches.
class ChamberServerBase {
 public:
  virtual ~ChamberServerBase();
  ChamberServerBase(const ChamberServerBase&) = delete;
  ChamberServerBase& operator=(const ChamberServerBase&) = delete;

  // Runs f(firmware) under the lock after advancing it to the current emulated time.
  template <class F>
  auto with_firmware(F&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    fw_.advance_to(emulated_now());
    return f(fw_);
  }
  double emulated_now() const;
  void set_corrupt_probability(double p) { corrupt_p_.store(p); }  // RTU replies with a bad CRC
  void go_silent(std::chrono::milliseconds d);                    // requests read and dropped
  void reply_exception(int count, int code = 6);                  // next `count` requests: exception
  ChamberEmuStats stats() const;

 protected:
  explicit ChamberServerBase(const ChamberEmuConfig& c);
  bool silent() const;
  // Answers one request frame on ctx (modbus_t*); `watlow` selects the register view.
  void handle(void* ctx, const std::uint8_t* req, int len, bool watlow, int fd_for_raw, bool rtu);
  void count(std::uint64_t ChamberEmuStats::*field);

  ChamberEmuConfig c_;
  std::mutex mutex_;
  ChamberFirmware fw_;
  std::chrono::steady_clock::time_point t0_;
  void* mapping_ = nullptr;  // modbus_mapping_t*
  std::atomic<double> corrupt_p_{0.0};
  std::atomic<std::int64_t> silent_until_ns_{0};
  std::atomic<int> exceptions_left_{0};
  std::atomic<int> exception_code_{6};
  std::atomic<bool> stop_{false};
  std::uint64_t rng_;
  mutable std::mutex stats_mutex_;
  ChamberEmuStats stats_;
};

class AtmegaChamberSlave final : public ChamberServerBase {
 public:
  explicit AtmegaChamberSlave(const ChamberEmuConfig& c);  // opens the pty, starts the thread
  ~AtmegaChamberSlave() override;
  const std::string& device_path() const { return rtu_.device_path(); }

 private:
  void run();
  PtyModbusRtu rtu_;
  std::thread thread_;
};

class WatlowChamberServer final : public ChamberServerBase {
 public:
  // port 0: an ephemeral port (see port()).
  explicit WatlowChamberServer(const ChamberEmuConfig& c, int port = 0);
  ~WatlowChamberServer() override;
  int port() const { return tcp_.port(); }
  // Closes the connection and the listening socket; listens again on the same port after `d`.
  void disconnect_for(std::chrono::milliseconds d) { tcp_.disconnect_for(d); }

 private:
  void run();
  LoopbackTcpServer tcp_;  // one master at a time: the newest connection wins
  void* ctx_ = nullptr;    // modbus_t*, framing only: its socket is set to the master's fd per request
  std::thread thread_;
};

}  // namespace stend::emu
