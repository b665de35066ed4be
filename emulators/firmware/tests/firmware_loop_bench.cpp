// Firmware in the loop, the long runs (docs/benchmarks.md, docs/firmware.md):
//   speed   — simavr's speed (simulated s per host s), unpaced: the chamber loop alone, and with
//             the MPU-6050 streaming at 1 kHz while a master drains the FIFO window;
//   stream  — a 1 kHz stream through the firmware for 60 s of simulated time, paced to the wall
//             clock, drained every 50 ms like the mpu6050_modbus driver: lost samples (must be 0);
//   pid     — the paper's step response: setpoint 10 °C below the air, the published PID on the
//             thermal plant (unpaced): time of the first zero crossing of the error and the
//             largest |error| after it (paper: ≈ 500 s, then within ±1 °C).
// Usage: firmware_loop_bench [speed|stream|pid|all] [pid seconds, default 900]
#include <stend/devices/bench_mcu_map.hpp>
#include <stend/devices/chamber_map.hpp>
#include <stend/devices/modbus_rtu.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "firmware_in_loop.hpp"

namespace {

namespace bm = stend::bench_mcu;
namespace cm = stend::chamber_map;
using stend::emu::FirmwareInTheLoop;
using stend::emu::FirmwareLoopConfig;
using stend::transport::ModbusRtuClient;
using stend::transport::ModbusRtuConfig;
using Clock = std::chrono::steady_clock;

stend::emu::Mpu6050Model level_mpu() {
  stend::BenchTruth t;
  t.specific_force_mps2 = {0.0, 0.0, 9.80665};
  stend::sim::SimImuConfig physics;
  physics.seed = 3;
  return stend::emu::Mpu6050Model(physics, t);
}

std::unique_ptr<FirmwareInTheLoop> make(double speed, double initial_c = 22.0) {
  FirmwareLoopConfig c;
  c.elf_path = STEND_BENCH_MCU_ELF;
  c.speed = speed;
  c.plant.initial_c = initial_c;  // ambient: the plant's default 22 °C
  return std::make_unique<FirmwareInTheLoop>(c, level_mpu());
}

ModbusRtuClient client(const std::string& path, int slave) {
  ModbusRtuConfig c;
  c.device = path;
  c.slave_id = slave;
  c.response_timeout_ms = 200;
  return ModbusRtuClient(c);
}

void start_stream(ModbusRtuClient& m) {
  m.write_register(bm::kHoldSmplrtDiv, 0);
  m.write_register(bm::kHoldDlpfCfg, 1);  // 1 kHz
  m.write_register(bm::kHoldCtrl, bm::kCtrlRun);
}

// Drains every waiting sample from sequence number s on; returns samples lost (gaps).
std::uint64_t drain(ModbusRtuClient& m, std::uint32_t& s, std::uint64_t& got) {
  std::uint64_t lost = 0;
  for (;;) {
    const auto w = m.read_input_registers(bm::kInWindowBase + static_cast<int>(s % bm::kWindowSeqModulo), bm::kWindowMaxWords);
    const std::uint32_t first = (static_cast<std::uint32_t>(w[2]) << 16) | w[3];
    lost += first - s;
    s = first + w[0];
    got += w[0];
    if (w[0] == 0 || w[1] == 0) return lost;
  }
}

double speed_of(FirmwareInTheLoop& fw, double seconds_wall) {
  const auto a = fw.stats();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds_wall));
  const auto b = fw.stats();
  return (b.simulated_s - a.simulated_s) / (b.wall_s - a.wall_s);
}

void bench_speed() {
  {
    auto fw = make(0.0);
    std::printf("speed, chamber loop only (sensor asleep): %.2f simulated s per host s\n", speed_of(*fw, 5.0));
  }
  auto fw = make(0.0);
  auto m = client(fw->device_path(), 1);
  start_stream(m);
  std::uint32_t s = 0;
  std::uint64_t got = 0;
  const auto a = fw->stats();
  const auto t_end = Clock::now() + std::chrono::seconds(5);
  while (Clock::now() < t_end) drain(m, s, got);
  const auto b = fw->stats();
  std::printf("speed, 1 kHz stream drained continuously: %.2f simulated s per host s (%llu samples)\n",
              (b.simulated_s - a.simulated_s) / (b.wall_s - a.wall_s), static_cast<unsigned long long>(got));
}

int bench_stream() {
  auto fw = make(1.0);
  auto m = client(fw->device_path(), 1);
  fw->wait_until_simulated(0.02, std::chrono::seconds(2));
  start_stream(m);
  const double t0 = fw->stats().simulated_s;
  std::uint32_t s = 0;
  std::uint64_t got = 0, lost = 0;
  while (fw->stats().simulated_s < t0 + 60.0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    lost += drain(m, s, got);
  }
  const auto in = m.read_input_registers(0, bm::kInCount);
  const auto st = fw->stats();
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  std::printf("stream, 1 kHz for 60 s simulated (%.1f s wall, busy %.1f s, lag given up %.2f s, load %.1f %.1f %.1f): "
              "%llu samples, %llu lost, OVERFLOWS %u\n",
              st.wall_s, st.busy_s, st.lag_given_up_s, load[0], load[1], load[2], static_cast<unsigned long long>(got),
              static_cast<unsigned long long>(lost), in[bm::kInOverflows]);
  return lost == 0 ? 0 : 1;
}

int bench_pid(double seconds) {
  const double initial = 35.0, step = 10.0;  // the paper's cooling leg: 35 °C air, setpoint 25 °C
  auto fw = make(0.0, initial);
  auto m = client(fw->device_path(), 2);
  fw->wait_until_simulated(0.02, std::chrono::seconds(2));
  const double t_run = fw->stats().simulated_s;
  m.write_register(cm::kHoldSetpoint, static_cast<std::uint16_t>(std::lround((initial - step) * 100.0)));
  m.write_register(cm::kHoldCtrl, cm::kCtrlRun);
  const double setpoint = initial - step;
  double t_zero = -1.0, worst_after = 0.0;
  const auto w0 = Clock::now();
  for (double t = 1.0; t <= seconds; t += 1.0) {
    fw->wait_until_simulated(t_run + t, std::chrono::seconds(60));
    const double err = fw->air_c() - setpoint;
    if (t_zero < 0.0 && err <= 0.0) t_zero = t;
    if (t_zero >= 0.0) worst_after = std::max(worst_after, std::fabs(err));
    if (static_cast<int>(t) % 100 == 0) std::printf("  t = %4.0f s  air %.2f °C  err %+.2f\n", t, fw->air_c(), err);
  }
  const double wall = std::chrono::duration<double>(Clock::now() - w0).count();
  std::printf("pid, %.0f °C step: error first zero at %.0f s, then |error| <= %.2f °C (paper: ~500 s, then ±1 °C); "
              "%.0f s simulated in %.1f s host\n", step, t_zero, worst_after, seconds, wall);
  return (t_zero > 0.0 && worst_after <= 1.0) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string what = argc > 1 ? argv[1] : "all";
  const double pid_s = argc > 2 ? std::atof(argv[2]) : 900.0;
  int rc = 0;
  if (what == "speed" || what == "all") bench_speed();
  if (what == "stream" || what == "all") rc |= bench_stream();
  if (what == "pid" || what == "all") rc |= bench_pid(pid_s);
  return rc;
}
