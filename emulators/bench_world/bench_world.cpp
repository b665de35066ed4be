#include "bench_world.hpp"

#ifdef STEND_HAVE_FIRMWARE_LOOP
#include "firmware_in_loop.hpp"
#endif

#include <stend/physics/gravity.hpp>
#include <stend/physics/table_chain.hpp>

#include <stdexcept>

#include <stend/devices/bench_mcu_map.hpp>

#include <stend/sim/one_axis_table.hpp>
#include <stend/sim/thermochamber.hpp>

namespace stend::emu {

namespace {
constexpr double kFirstReadingS = 1.2;  // simulated: the firmware's first DS18B20 reading (firmware/bench_mcu/chamber.c)
}  // namespace

BenchWorldConfig BenchWorldConfig::from_experiment(const Experiment& e, double chamber_speed) {
  BenchWorldConfig c;
  if (e.sensor.plugin != "sim_imu")
    throw std::invalid_argument("bench world: the twin's sensor must be sim_imu (got '" + e.sensor.plugin + "')");
  c.imu = sim::SimImuConfig::from(e.sensor.params);
  // A noise stream independent of the in-process bench's (which uses salt 1): the two runs are
  // two experiments on the same sensor model, not a replay.
  if (c.imu.seed == 0) c.imu.seed = static_cast<std::int64_t>((e.seed * 1000003u + 101) & 0x7fffffffffffffffULL);
  bool table = false, chamber = false;
  for (const FixtureDecl& f : e.fixtures) {
    if (f.plugin == "sim_one_axis_table") {
      const sim::OneAxisTableConfig t = sim::OneAxisTableConfig::from(f.params);
      c.table_axis = t.axis();
      c.table_tilt_deg = t.axis_tilt_deg;
      table = true;
    } else if (f.plugin == "sim_thermochamber") {
      c.chamber.plant = sim::ThermochamberConfig::from(f.params);
      chamber = true;
    } else {
      throw std::invalid_argument("bench world: no emulator for fixture plugin '" + f.plugin +
                                  "' (the world has sim_one_axis_table and sim_thermochamber)");
    }
  }
  if (!table || !chamber)
    throw std::invalid_argument("bench world: the twin needs a sim_one_axis_table and a sim_thermochamber");
  if (!e.mounted_on.empty() && e.mounted_on != "base") {
    const int i = [&] {
      for (std::size_t k = 0; k < e.fixtures.size(); ++k)
        if (e.fixtures[k].id == e.mounted_on) return static_cast<int>(k);
      return -1;
    }();
    if (i < 0) throw std::invalid_argument("bench world: mounting on an unknown fixture");
  }
  c.chamber.speed = chamber_speed;
  c.gravity_mps2 = e.gravity.resolved_mps2;
  c.latitude_deg = e.gravity.latitude_deg;
  c.heading_deg = e.base_heading_deg;
  c.R_sensor_from_mount = e.R_sensor_from_mount;
  return c;
}

bool BenchWorldConfig::IsValid(std::string* error) const {
  std::string why;
  if (!imu.IsValid(&why)) return invalid(error, "sensor: " + why);
  if (!table_axis.IsValid(&why)) return invalid(error, "table axis '" + table_axis.name + "': " + why);
  if (!chamber.IsValid(&why)) return invalid(error, "chamber: " + why);
  if (!(gravity_mps2 > 0.0)) return invalid(error, "gravity_mps2 must be > 0");
  if (!(table_port >= 0 && table_port <= 65535)) return invalid(error, "table_port must be 0..65535 (0: any free port)");
  return true;
}

BenchWorld::BenchWorld(const BenchWorldConfig& c) : c_(require_valid(c, "bench world")) {
  tilt_rad_ = c.table_tilt_deg * physics::kDegToRad;
  earth_local_ = physics::Rz(c.heading_deg * physics::kDegToRad) * physics::earth_rate_local(c.latitude_deg);
  TableTextConfig tc;
  tc.axes = {c.table_axis};
  tc.port = c.table_port;
  tc.identity = "Stend,BenchWorldTable,0,0.1";
  table_ = std::make_unique<TableTextServer>(tc);
  BenchMcuConfig mc;
  mcu_epoch_ = std::chrono::steady_clock::now();
  Mpu6050Model mpu(c.imu, Mpu6050Model::TruthFn([this](double t) { return truth(t); }));
  if (c.firmware_elf.empty()) {
    chamber_ = std::make_unique<AtmegaChamberSlave>(c.chamber);
    mcu_ = std::make_unique<BenchMcuSlave>(mc, std::move(mpu));
    return;
  }
#ifdef STEND_HAVE_FIRMWARE_LOOP
  // The firmware is also the chamber's controller (slave 2: the paper's PID on its DS18B20, the
  // heater and Peltier PWM driving the plant), in wall time like the MCU; the chamber driver gets
  // a port of its own in front of the same UART.
  FirmwareLoopConfig fc;
  fc.elf_path = c.firmware_elf;
  fc.plant = c.chamber.plant;
  fc.host_ports = 2;
  fw_ = std::make_shared<FirmwareInTheLoop>(fc, std::move(mpu));
  fw_plant_ = fw_.get();
  // Powered up a moment before the drivers connect, as on a bench: the first control cycle (1 s)
  // has read the DS18B20 (the temperature registers read 0 until then).
  if (!fw_->wait_until_simulated(kFirstReadingS, std::chrono::seconds(10)))
    throw IoError("bench world: the firmware under simavr did not reach its first control cycle in 10 s");
#else
  throw std::invalid_argument("bench world: this build has no firmware in the loop (install simavr, libsimavr-dev "
                              "and gcc-avr: scripts/install-deps.sh, then rebuild)");
#endif
}

BenchWorld::~BenchWorld() {
  mcu_.reset();
  fw_.reset();
}

const std::string& BenchWorld::mcu_device() const {
#ifdef STEND_HAVE_FIRMWARE_LOOP
  if (fw_) return fw_->device_path(0);
#endif
  return mcu_->device_path();
}

const std::string& BenchWorld::chamber_device() const {
#ifdef STEND_HAVE_FIRMWARE_LOOP
  if (fw_) return fw_->device_path(1);
#endif
  return chamber_->device_path();
}

int BenchWorld::chamber_slave_id() const { return fw_ ? bench_mcu::kFirmwareChamberSlave : 1; }

BenchTruth BenchWorld::truth(double t) {
  BenchTruth b;
  b.t_s = t;
  // The table's emulated time for this instant (the table runs at wall speed).
  const double table_t = table_->emulated_now() -
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - mcu_epoch_).count() + t;
  const sim::AxisState s = table_->state_at(0, table_t);
  const physics::TableMotion<double> m =
      physics::paper_table_motion(tilt_rad_, s.position * physics::kDegToRad, s.velocity * physics::kDegToRad);
  const Eigen::Matrix3d& M = c_.R_sensor_from_mount;
  const Eigen::Matrix3d R = M * m.R_top_from_base;
  b.R_sensor_from_local = R;
  b.specific_force_mps2 = physics::gravity_specific_force(R, c_.gravity_mps2);
  b.angular_rate_radps = M * m.omega_top_radps + R * earth_local_;
#ifdef STEND_HAVE_FIRMWARE_LOOP
  if (fw_plant_ != nullptr) {  // the plant the firmware's PWM drives
    b.air_temperature_c = fw_plant_->air_c();
    b.die_temperature_c = fw_plant_->die_c();
    return b;
  }
#endif
  chamber_->with_firmware([&](ChamberFirmware& f) {
    b.air_temperature_c = f.air_c();
    b.die_temperature_c = f.die_c();
    return 0;
  });
  return b;
}

}  // namespace stend::emu
