// Emulated rate-table controller speaking the ACUTROL-style text dialect (docs/text-command-tables.md)
// on a TCP port of 127.0.0.1, backed by the simulated table physics (stend::sim::SimAxis: finite
// speed and acceleration, settling, encoder quantization). Emulated time = wall time × speed.
//
//   :POS a,v   position mode, move axis a to v deg        :POS? a   → measured position
//   :RATE a,v  rate mode at v deg/s                       :RATE? a  → measured rate
//   :STOP a    decelerate and hold                        :SYST:ERR? → 0,"No error" | code,"text"
//   *IDN?      → identity line
// Axes are numbered from 1. Set commands do not reply; errors queue for :SYST:ERR?.
// Fault injection: silence (requests read, never answered), a peer that disappears (connections
// and listener closed, then listening again on the same port), garbled replies.
#pragma once

#include <stend/sim/motion_profile.hpp>

#include "stend/emulators/tcp_server.hpp"  // emulators/common: the loopback accept/serve loop

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace stend::emu {

struct TableTextConfig {
  std::vector<sim::AxisConfig> axes;  // one per table axis, in controller order (1, 2, …)
  double speed = 1.0;                 // emulated seconds per wall second
  int port = 0;                       // 0: an ephemeral port (see port())
  std::string identity = "Stend,TableEmulator,0,0.1";
  std::uint64_t seed = 1;

  // Some axes (each AxisConfig::IsValid), a positive speed, a port 0..65535.
  bool IsValid(std::string* error = nullptr) const;
};

class TableTextServer {
 public:
  explicit TableTextServer(TableTextConfig c);  // listens and starts the thread
  ~TableTextServer();
  TableTextServer(const TableTextServer&) = delete;
  TableTextServer& operator=(const TableTextServer&) = delete;

  int port() const { return tcp_.port(); }
  double emulated_now() const;
  // Exact state of axis i (0-based) at the current emulated time (thread-safe).
  sim::AxisState state(std::size_t i) const;
  // Exact state of axis i at emulated time t (the plan is exact at any time since the last command).
  sim::AxisState state_at(std::size_t i, double t) const;
  double commanded(std::size_t i) const;

  void go_silent(std::chrono::milliseconds d);
  void disconnect_for(std::chrono::milliseconds d) { tcp_.disconnect_for(d); }
  void garble_next(int replies);  // the next replies come back as line noise
  std::uint64_t connections() const { return connections_.load(); }
  std::uint64_t commands() const { return commands_.load(); }

 private:
  void run();
  std::string execute(const std::string& line);  // reply ("" = none); locked by the caller
  void advance_locked() const;

  TableTextConfig c_;
  mutable std::mutex mutex_;
  mutable std::vector<sim::SimAxis> axes_;
  std::deque<std::string> errors_;
  std::chrono::steady_clock::time_point t0_;
  LoopbackTcpServer tcp_;               // the listener and its clients (any number)
  std::map<int, std::string> inbox_;    // per client fd: bytes received after the last full line
  std::atomic<std::int64_t> silent_until_ns_{0};
  std::atomic<int> garble_{0};
  std::atomic<std::uint64_t> connections_{0}, commands_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace stend::emu
