// `stend emulate` — start the emulated peers of the real drivers from the command line, print where
// to connect, and serve until Ctrl-C (or --duration-s):
//   stend emulate table     ACUTROL-style text-command table on 127.0.0.1 (1 or 3 axes)
//   stend emulate chamber   ATmega328 chamber (MODBUS RTU on a pty) or Watlow F4 (MODBUS TCP)
//   stend emulate bench-mcu the bench microcontroller with an MPU-6050 (MODBUS RTU on a pty)
//   stend emulate world     table + chamber + bench MCU sharing one simulated world, the twin of
//                           an in-process experiment (--twin), optionally writing a copy of a
//                           drivers experiment with the emulators' devices and port filled in.
#include "commands.hpp"

#include "stend/core/experiment.hpp"
#include "stend/recording/files.hpp"
#include "stend/physics/gravity.hpp"
#include "stend/core/plugin_host.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

#include "bench_world.hpp"
#include "chamber_emulator.hpp"
#include "table_text_server.hpp"

namespace stend::cli {
namespace {

constexpr int kMaxPort = 65535;  // TCP

std::atomic<bool> g_emulate_stop{false};
extern "C" void on_emulate_signal(int) { g_emulate_stop.store(true); }

// Serves until a signal or `duration_s` (0 = forever); `tick` runs every 100 ms.
void serve(double duration_s, const std::function<void(double)>& tick = {}) {
  g_emulate_stop = false;
  std::signal(SIGINT, on_emulate_signal);
  std::signal(SIGTERM, on_emulate_signal);
  std::fputs("serving; Ctrl-C to stop\n", stdout);
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  while (!g_emulate_stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (tick) tick(t);
    if (duration_s > 0.0 && t >= duration_s) break;
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
}

sim::AxisConfig table_axis(const std::string& name, double rate, double accel) {
  sim::AxisConfig a;
  a.name = name;
  a.unit = "deg";
  a.max_rate = rate;
  a.max_accel = accel;
  if (name == "tilt") {
    a.min = -90.0;
    a.max = 90.0;
  }
  return a;
}

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw InputError("cannot read " + path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
}

// ---- table ----

struct TableOpts {
  int axes = 1, port = 5025;
  double speed = 1.0, rate = 100.0, accel = 200.0, duration = 0.0;
};

// Serves a 1-axis (angle) or 3-axis (azimuth, tilt, rotation) text-command table.
ExitCode run_table(const TableOpts& t) {
  emu::TableTextConfig c;
  c.port = t.port;
  c.speed = t.speed;
  if (t.axes == 1) c.axes = {table_axis("angle", t.rate, t.accel)};
  else
    for (const char* n : {"azimuth", "tilt", "rotation"}) c.axes.push_back(table_axis(n, t.rate, t.accel));
  emu::TableTextServer server(c);
  std::printf("table (%d axis%s, ACUTROL-style text): tcp 127.0.0.1:%d\n", t.axes, t.axes == 1 ? "" : "es",
              server.port());
  std::printf("  driver config: {preset: acutrol, host: 127.0.0.1, port: %d}\n", server.port());
  serve(t.duration);
  return ExitCode::kOk;
}

void add_table_command(CLI::App* sub, std::vector<Command>& out) {
  auto t = std::make_shared<TableOpts>();
  auto* table = sub->add_subcommand("table", "Rate table speaking the ACUTROL-style text dialect (docs/text-command-tables.md)");
  table->add_option("--axes", t->axes, "1 (angle) or 3 (azimuth, tilt, rotation)")->check(CLI::IsMember({1, 3}));
  table->add_option("--port", t->port, "TCP port on 127.0.0.1 (0: any free port)")->check(within(0, kMaxPort));
  table->add_option("--speed", t->speed, "emulated seconds per wall second")->check(above(0));
  table->add_option("--max-rate-dps", t->rate, "axis speed limit, deg/s")->check(above(0));
  table->add_option("--max-accel-dps2", t->accel, "axis acceleration limit, deg/s^2")->check(above(0));
  table->add_option("--duration-s", t->duration, "stop after this long (0: until Ctrl-C)")->check(at_least(0));
  out.push_back({table, [t] { return run_table(*t); }});
}

// ---- chamber ----

struct ChamberOpts {
  std::string protocol = "atmega328", fault = "none";
  int port = 0;
  double speed = 1.0, initial = 22.0, fault_after = 0.0, duration = 0.0;
  bool published = false;
};

// The chamber server for the protocol (ATmega328 on a pty, or Watlow F4 on TCP), printing where to connect.
std::unique_ptr<emu::ChamberServerBase> start_chamber(const ChamberOpts& c, const emu::ChamberEmuConfig& ec) {
  if (c.protocol == "atmega328") {
    auto s = std::make_unique<emu::AtmegaChamberSlave>(ec);
    std::printf("chamber (ATmega328, MODBUS RTU slave 1): %s\n", s->device_path().c_str());
    std::printf("  driver config: {protocol: atmega328, transport: rtu, device: %s}\n", s->device_path().c_str());
    return s;
  }
  auto s = std::make_unique<emu::WatlowChamberServer>(ec, c.port);
  std::printf("chamber (Watlow F4, MODBUS TCP unit 1): tcp 127.0.0.1:%d\n", s->port());
  std::printf("  driver config: {protocol: watlow_f4, transport: tcp, port: %d}\n", s->port());
  return s;
}

// Injects the named fault into the chamber firmware.
void inject_fault(emu::ChamberServerBase& server, const std::string& fault) {
  server.with_firmware([&](emu::ChamberFirmware& f) {
    if (fault == "sensor_open") f.inject_sensor_fault(emu::SensorFault::kDisconnected);
    if (fault == "sensor_stuck") f.inject_sensor_fault(emu::SensorFault::kStuck);
    if (fault == "sensor_85") f.inject_sensor_fault(emu::SensorFault::kPowerOn);
    if (fault == "runaway") f.inject_heater_stuck_on(true);
    return 0;
  });
  std::printf("fault injected: %s\n", fault.c_str());
  std::fflush(stdout);
}

// Serves the chamber, injecting the fault (if any) after fault_after wall seconds.
ExitCode run_chamber(const ChamberOpts& c) {
  emu::ChamberEmuConfig ec;
  ec.plant.initial_c = c.initial;
  ec.speed = c.speed;
  ec.firmware_guards = !c.published;
  const std::unique_ptr<emu::ChamberServerBase> server = start_chamber(c, ec);
  bool injected = c.fault == "none";
  serve(c.duration, [&](double now) {
    if (injected || now < c.fault_after) return;
    injected = true;
    inject_fault(*server, c.fault);
  });
  return ExitCode::kOk;
}

void add_chamber_command(CLI::App* sub, std::vector<Command>& out) {
  auto c = std::make_shared<ChamberOpts>();
  auto* chamber = sub->add_subcommand("chamber", "Thermochamber controller (docs/thermochamber-modbus.md) on the sim plant and the paper's PID");
  chamber->add_option("--protocol", c->protocol, "atmega328 (MODBUS RTU on a pty) | watlow_f4 (MODBUS TCP)")
      ->check(CLI::IsMember({"atmega328", "watlow_f4"}));
  chamber->add_option("--port", c->port, "watlow_f4: TCP port on 127.0.0.1 (0: any free port)")->check(within(0, kMaxPort));
  chamber->add_option("--speed", c->speed, "emulated seconds per wall second")->check(above(0));
  const sim::ThermochamberConfig plant;  // its setpoint limits bound the power-on temperature too
  chamber->add_option("--initial-c", c->initial, "air temperature at power-on, degC")
      ->check(within(plant.min_c, plant.max_c));
  chamber->add_flag("--published-firmware", c->published, "no sensor check, no trips (the paper's firmware)");
  chamber->add_option("--fault", c->fault, "inject: none | sensor_open | sensor_stuck | sensor_85 | runaway")
      ->check(CLI::IsMember({"none", "sensor_open", "sensor_stuck", "sensor_85", "runaway"}));
  chamber->add_option("--fault-after-s", c->fault_after, "wall seconds before the fault")->check(at_least(0));
  chamber->add_option("--duration-s", c->duration, "stop after this long (0: until Ctrl-C)")->check(at_least(0));
  out.push_back({chamber, [c] { return run_chamber(*c); }});
}

// ---- bench-mcu ----

struct McuOpts {
  double tilt_deg = 0.0, duration = 0.0;
};

// Serves the bench MCU with a static MPU-6050 tilted about y by tilt_deg [deg] under standard gravity.
ExitCode run_bench_mcu(const McuOpts& m) {
  BenchTruth truth;
  truth.specific_force_mps2 = physics::gravity_specific_force(
      physics::Ry(m.tilt_deg * physics::kDegToRad), physics::kStandardGravity);
  sim::SimImuConfig imu;
  imu.seed = 1;
  emu::BenchMcuSlave slave(emu::BenchMcuConfig{}, emu::Mpu6050Model(imu, truth));
  std::printf("bench MCU (MODBUS RTU slave 1, MPU-6050): %s\n", slave.device_path().c_str());
  std::printf("  sensor config: {plugin: mpu6050_modbus, config: {device: %s}}\n", slave.device_path().c_str());
  serve(m.duration);
  return ExitCode::kOk;
}

void add_bench_mcu_command(CLI::App* sub, std::vector<Command>& out) {
  auto m = std::make_shared<McuOpts>();
  auto* mcu = sub->add_subcommand("bench-mcu", "Bench microcontroller with an MPU-6050 (docs/bench-mcu-modbus.md), static stimulus");
  mcu->add_option("--tilt-deg", m->tilt_deg, "the sensor tilted about y by this angle (standard gravity)")
      ->check(within(-360, 360));
  mcu->add_option("--duration-s", m->duration, "stop after this long (0: until Ctrl-C)")->check(at_least(0));
  out.push_back({mcu, [m] { return run_bench_mcu(*m); }});
}

// ---- world ----

struct WorldOpts {
  std::string twin;
  std::vector<std::string> write_config;
  double chamber_speed = 50.0, duration = 0.0;
  int table_port = 5025;
  bool firmware = false;
#ifdef STEND_BENCH_MCU_ELF
  std::string firmware_elf = STEND_BENCH_MCU_ELF;  // the build tree's firmware/bench_mcu
#else
  std::string firmware_elf;
#endif
};

// After the line naming `device`, a `slave_id` at the same indentation (the chamber is slave 2 of the
// firmware; the drivers file, written for a chamber of its own, gives none).
void add_slave_id_after(std::string& text, const std::string& device, int slave_id) {
  const std::size_t at = text.find("device: " + device);
  if (at == std::string::npos) return;
  const std::size_t line = text.rfind('\n', at) + 1;
  const std::size_t end = text.find('\n', at);
  const std::string indent = text.substr(line, at - line);
  text.insert(end == std::string::npos ? text.size() : end + 1, indent + "slave_id: " + std::to_string(slave_id) + "\n");
}

// Copies the drivers experiment `in` to `out` with the emulators' devices and table port in place
// of /dev/ttyUSB0 (bench MCU), /dev/ttyUSB1 (chamber) and port 5025.
void write_world_config(const emu::BenchWorld& bw, const std::string& in, const std::string& out) {
  std::string text = slurp(in);
  replace_all(text, "/dev/ttyUSB0", bw.mcu_device());
  replace_all(text, "/dev/ttyUSB1", bw.chamber_device());
  replace_all(text, "port: 5025", "port: " + std::to_string(bw.table_port()));
  if (bw.chamber_slave_id() != 1) add_slave_id_after(text, bw.chamber_device(), bw.chamber_slave_id());
  // Relative paths in the copy (estimation model) are resolved from its new folder.
  const auto from = std::filesystem::absolute(in).parent_path();
  replace_all(text, "model: models/", "model: " + (from / "models").string() + "/");
  write_file_atomic(out, text);
  std::printf("  wrote %s: run it with `stend run %s`\n", out.c_str(), out.c_str());
}

// Serves table, chamber and bench MCU in one world copied from the twin experiment's bench.
ExitCode run_world(const WorldOpts& w) {
  PluginHost host;
  host.scan(PluginHost::default_search_path({}));
  const Experiment twin = load_experiment(w.twin, host);
  auto cfg = emu::BenchWorldConfig::from_experiment(twin, w.chamber_speed);
  cfg.table_port = w.table_port;
  if (w.firmware) cfg.firmware_elf = w.firmware_elf;
  emu::BenchWorld bw(cfg);
  std::printf("bench world, twin of %s:\n", w.twin.c_str());
  std::printf("  bench MCU (MPU-6050, MODBUS RTU): %s%s\n", bw.mcu_device().c_str(),
              w.firmware ? ("  (firmware " + w.firmware_elf + " under simavr)").c_str() : "");
  if (w.firmware)
    std::printf("  chamber (the firmware's slave %d):  %s  (plant in wall time, driven by its PWM)\n", bw.chamber_slave_id(),
                bw.chamber_device().c_str());
  else
    std::printf("  chamber (ATmega328, MODBUS RTU):  %s  (plant at %gx)\n", bw.chamber_device().c_str(), w.chamber_speed);
  std::printf("  table (ACUTROL-style text):       tcp 127.0.0.1:%d\n", bw.table_port());
  if (w.write_config.size() == 2) write_world_config(bw, w.write_config[0], w.write_config[1]);
  serve(w.duration);
  return ExitCode::kOk;
}

void add_world_command(CLI::App* sub, std::vector<Command>& out) {
  auto w = std::make_shared<WorldOpts>();
  auto* world = sub->add_subcommand("world", "Table + chamber + bench MCU in one simulated world, the twin of an in-process bench");
  world->add_option("--twin", w->twin, "in-process experiment whose bench (sim_imu, sim_one_axis_table, sim_thermochamber) the world copies")
      ->required();
  world->add_option("--chamber-speed", w->chamber_speed, "the chamber's plant runs this many times faster than the wall clock (not with --firmware: its PID runs in wall time)")
      ->check(above(0));
  world->add_option("--table-port", w->table_port, "TCP port of the table on 127.0.0.1 (0: any free port)")
      ->check(within(0, kMaxPort));
  world->add_option("--write-config", w->write_config,
                    "IN OUT: copy the drivers experiment IN to OUT with /dev/ttyUSB0 (bench MCU), /dev/ttyUSB1 (chamber) "
                    "and port 5025 (table) replaced by the emulators'")
      ->expected(2);
  world->add_flag("--firmware", w->firmware,
                  "the bench MCU and the chamber controller are the real firmware (firmware/bench_mcu) under simavr, not the C++ emulations (docs/firmware.md)");
  world->add_option("--firmware-elf", w->firmware_elf, "the firmware image for --firmware (default: the build tree's bench_mcu.elf)");
  world->add_option("--duration-s", w->duration, "stop after this long (0: until Ctrl-C)")->check(at_least(0));
  out.push_back({world, [w] { return run_world(*w); }});
}

}  // namespace

void add_emulate_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("emulate", "Serve emulated devices (table, chamber, bench MCU, a whole bench) for the real drivers");
  sub->require_subcommand(1);
  add_table_command(sub, out);
  add_chamber_command(sub, out);
  add_bench_mcu_command(sub, out);
  add_world_command(sub, out);
}

}  // namespace stend::cli
