#include "chamber_emulator.hpp"

#include <stend/errors.hpp>

#include <modbus.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <stend/devices/chamber_map.hpp>
#include "stend/emulators/splitmix.hpp"
#include "stend/emulators/steady_ns.hpp"

namespace stend::emu {
namespace {

namespace map = stend::chamber_map;

modbus_t* M(void* p) { return static_cast<modbus_t*>(p); }
modbus_mapping_t* MAP(void* p) { return static_cast<modbus_mapping_t*>(p); }

std::uint16_t s16(double v) {
  return static_cast<std::uint16_t>(static_cast<std::int16_t>(std::clamp(std::round(v), -32768.0, 32767.0)));
}
double from_s16(std::uint16_t v) { return static_cast<double>(static_cast<std::int16_t>(v)); }

}  // namespace

// ------------------------------------------------------------------------------------------------
bool ChamberEmuConfig::IsValid(std::string* error) const {
  if (!(plant.control_period_s > 0.0 && plant.heat_capacity_j_per_c > 0.0 && plant.conductance_w_per_c > 0.0))
    return invalid(error, "control period, heat capacity and conductance must be > 0");
  if (!(speed > 0.0)) return invalid(error, "speed must be > 0");
  if (!(slave_id >= 1 && slave_id <= 247)) return invalid(error, "slave_id must be 1..247");
  return true;
}

ChamberFirmware::ChamberFirmware(const ChamberEmuConfig& c) : c_(require_valid(c, "chamber emulator")) {
  const auto& p = c.plant;
  air_ = p.initial_c;
  die_ = p.initial_c + p.self_heating_c;
  raw_ = static_cast<std::int16_t>(std::round(air_ * 16.0));
  hold_[map::kHoldSetpoint] = s16(25.0 * 100.0);
  hold_[map::kHoldKp] = map::kDefaultKp;
  hold_[map::kHoldKi] = map::kDefaultKi;
  hold_[map::kHoldKd] = map::kDefaultKd;
  hold_[map::kHoldIStep] = map::kDefaultIStep;
  hold_[map::kHoldILimit] = map::kDefaultILimit;
  hold_[map::kHoldPeltierOffset] = map::kDefaultPeltierOffset;
  hold_[map::kHoldHeaterDivisor] = map::kDefaultHeaterDivisor;
  hold_[map::kHoldTripHigh] = s16(85.0 * 100.0);
  hold_[map::kHoldTripLow] = s16(-45.0 * 100.0);
}

void ChamberFirmware::write_holding(int address, std::uint16_t value) {
  if (address < 0 || address >= map::kHoldCount) return;
  if (address == map::kHoldCtrl) {
    if (value & map::kCtrlClearFault) faults_ = 0;
    const bool run = (value & map::kCtrlRun) != 0;
    if (run && !running_) {  // the loop starts from a fresh state
      integral_ = 0.0;
      err_prev_ = 0.0;
    }
    if (!run) heater_ = peltier_ = 0;
    running_ = run;
    hold_[0] = static_cast<std::uint16_t>(value & map::kCtrlRun);
    return;
  }
  hold_[static_cast<std::size_t>(address)] = value;
}

void ChamberFirmware::set_setpoint_c(double c) {
  write_holding(map::kHoldSetpoint, s16(c * 100.0));
  if (!running_) write_holding(map::kHoldCtrl, map::kCtrlRun);
}

double ChamberFirmware::setpoint_c() const { return from_s16(hold_[map::kHoldSetpoint]) / 100.0; }

std::uint16_t ChamberFirmware::status() const {
  return static_cast<std::uint16_t>((running_ ? map::kStatusRunning : 0) | faults_);
}

void ChamberFirmware::fill_inputs(std::uint16_t* in) const {
  in[map::kInStatus] = status();
  in[map::kInTempRaw] = static_cast<std::uint16_t>(raw_);
  in[map::kInHeaterPwm] = static_cast<std::uint16_t>(heater_);
  in[map::kInPeltierPwm] = static_cast<std::uint16_t>(peltier_);
  in[map::kInIntegral] = s16(integral_ * 100.0);
  in[map::kInOutput] = s16(u_);
  in[map::kInSensorErrors] = sensor_errors_;
  in[map::kInCycles] = static_cast<std::uint16_t>(cycles_ & 0xFFFF);
  in[map::kInFirmware] = map::kFirmwareVersion;
  in[map::kInSetpointActive] = hold_[map::kHoldSetpoint];
}

void ChamberFirmware::control() {
  ++cycles_;
  // The DS18B20 conversion.
  switch (sensor_fault_) {
    case SensorFault::kNone: raw_ = static_cast<std::int16_t>(std::clamp(std::round(air_ * 16.0), -880.0, 2000.0)); break;
    case SensorFault::kDisconnected: raw_ = map::kRawDisconnected; break;
    case SensorFault::kStuck: raw_ = stuck_raw_; break;
    case SensorFault::kPowerOn: raw_ = map::kRawPowerOn; break;
  }
  if (c_.firmware_guards) {
    if (raw_ == map::kRawDisconnected || raw_ == map::kRawPowerOn) {
      faults_ |= map::kStatusSensorFault;
      if (sensor_errors_ < 0xFFFF) ++sensor_errors_;
    }
    const double t = raw_ / 16.0;
    if (!(faults_ & map::kStatusSensorFault)) {
      if (t * 100.0 > from_s16(hold_[map::kHoldTripHigh])) faults_ |= map::kStatusTripHigh;
      if (t * 100.0 < from_s16(hold_[map::kHoldTripLow])) faults_ |= map::kStatusTripLow;
    }
    const double wd = hold_[map::kHoldWatchdog];
    if (wd > 0 && running_ && now_ - last_master_ > wd) faults_ |= map::kStatusWatchdog;
  }
  if (!running_ || (faults_ & map::kStatusFaultMask)) {
    heater_ = peltier_ = 0;
    u_ = 0.0;
    return;
  }
  // The published loop, with the gains from the tuning registers.
  const double err = raw_ / 16.0 - setpoint_c();
  const double ilim = hold_[map::kHoldILimit];
  integral_ = std::clamp(integral_ + hold_[map::kHoldIStep] / 1000.0 * err, -ilim, ilim);
  double u = hold_[map::kHoldKp] * err + hold_[map::kHoldKi] * integral_ - hold_[map::kHoldKd] * (err - err_prev_);
  err_prev_ = err;
  u = std::clamp(u, -255.0, 255.0);
  u_ = u;
  if (u > 0.0) {
    peltier_ = static_cast<int>(std::min(u + hold_[map::kHoldPeltierOffset], 255.0));
    heater_ = 0;
  } else {
    peltier_ = 0;
    heater_ = static_cast<int>(-u / std::max<double>(1.0, hold_[map::kHoldHeaterDivisor]));
  }
}

void ChamberFirmware::integrate(double dt) {
  // sim_thermochamber's plant, solved exactly for constant PWMs.
  sim::plant_step(c_.plant, heater_stuck_ ? 255 : heater_, peltier_, dt, air_, die_);
}

void ChamberFirmware::advance_to(double t_s) {
  for (;;) {  // as SimThermochamber::advance: a control cycle at every instant reached
    if (now_ >= next_control_ - 1e-9) {
      control();
      next_control_ += c_.plant.control_period_s;
    }
    if (now_ >= t_s) break;
    const double end = std::min(t_s, next_control_);
    integrate(end - now_);
    now_ = end;
  }
}

// ------------------------------------------------------------------------------------------------
ChamberServerBase::ChamberServerBase(const ChamberEmuConfig& c)
    : c_(c), fw_(c), t0_(std::chrono::steady_clock::now()), rng_(c.seed) {  // fw_ checks the config
  mapping_ = modbus_mapping_new(0, 0, 301, map::kInCount);
  if (mapping_ == nullptr) throw IoError("chamber emulator: libmodbus allocation failed");
}

ChamberServerBase::~ChamberServerBase() { modbus_mapping_free(MAP(mapping_)); }

double ChamberServerBase::emulated_now() const {
  return c_.speed * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

void ChamberServerBase::go_silent(std::chrono::milliseconds d) {
  silent_until_ns_ = steady_ns_after(d);
}

void ChamberServerBase::reply_exception(int n, int code) {
  exception_code_ = code;
  exceptions_left_ = n;
}

bool ChamberServerBase::silent() const { return steady_now_ns() < silent_until_ns_.load(); }

ChamberEmuStats ChamberServerBase::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

void ChamberServerBase::count(std::uint64_t ChamberEmuStats::*field) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++(stats_.*field);
}

void ChamberServerBase::handle(void* ctx, const std::uint8_t* req, int len, bool watlow, int fd, bool rtu) {
  count(&ChamberEmuStats::requests);
  if (silent()) {
    count(&ChamberEmuStats::ignored);
    return;
  }
  const int hl = modbus_get_header_length(M(ctx));
  const int fc = req[hl];
  const int address = (req[hl + 1] << 8) | req[hl + 2];
  const int n = (fc == MODBUS_FC_WRITE_SINGLE_REGISTER) ? 1 : ((req[hl + 3] << 8) | req[hl + 4]);
  if (exceptions_left_.load() > 0) {
    --exceptions_left_;
    modbus_reply_exception(M(ctx), req, static_cast<unsigned>(exception_code_.load()));
    count(&ChamberEmuStats::exceptions);
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  fw_.advance_to(emulated_now());
  fw_.master_seen();
  modbus_mapping_t* mp = MAP(mapping_);
  bool ok = false;
  const bool write = fc == MODBUS_FC_WRITE_SINGLE_REGISTER || fc == MODBUS_FC_WRITE_MULTIPLE_REGISTERS;
  if (watlow) {
    namespace w = stend::watlow_f4;
    const bool pv = address == w::kProcessValue && n == 1 && fc == MODBUS_FC_READ_HOLDING_REGISTERS;
    const bool sp = address == w::kSetpoint && n == 1 && (fc == MODBUS_FC_READ_HOLDING_REGISTERS || write);
    ok = pv || sp;
    mp->tab_registers[w::kProcessValue] = s16(fw_.reading_c() * w::kScale);
    mp->tab_registers[w::kSetpoint] = s16(fw_.setpoint_c() * w::kScale);
  } else {
    if (fc == MODBUS_FC_READ_INPUT_REGISTERS) ok = address + n <= map::kInCount;
    if (fc == MODBUS_FC_READ_HOLDING_REGISTERS || write) ok = address + n <= map::kHoldCount;
    fw_.fill_inputs(mp->tab_input_registers);
    for (int i = 0; i < map::kHoldCount; ++i) mp->tab_registers[i] = fw_.holding(i);
  }
  if (!ok) {
    modbus_reply_exception(M(ctx), req, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
    count(&ChamberEmuStats::exceptions);
    return;
  }
  const bool read = fc == MODBUS_FC_READ_HOLDING_REGISTERS || fc == MODBUS_FC_READ_INPUT_REGISTERS;
  if (rtu && read && splitmix_unit(rng_) < corrupt_p_.load()) {
    const std::uint16_t* src = fc == MODBUS_FC_READ_INPUT_REGISTERS ? mp->tab_input_registers : mp->tab_registers;
    write_corrupted_read_reply(fd, c_.slave_id, fc, src, address, n, rng_);
    count(&ChamberEmuStats::corrupted);
    return;
  }
  modbus_reply(M(ctx), req, len, mp);
  if (write) {
    if (watlow) {
      fw_.set_setpoint_c(from_s16(mp->tab_registers[stend::watlow_f4::kSetpoint]) / stend::watlow_f4::kScale);
    } else {
      for (int i = address; i < address + n; ++i) fw_.write_holding(i, mp->tab_registers[i]);
    }
  }
  count(&ChamberEmuStats::replies);
}

// ------------------------------------------------------------------------------------------------
AtmegaChamberSlave::AtmegaChamberSlave(const ChamberEmuConfig& c)
    : ChamberServerBase(c), rtu_("chamber emulator", 115200, c.slave_id) {
  thread_ = std::thread([this] { run(); });
}

AtmegaChamberSlave::~AtmegaChamberSlave() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void AtmegaChamberSlave::run() {
  std::vector<std::uint8_t> req(MODBUS_RTU_MAX_ADU_LENGTH);
  while (!stop_) {
    const int rc = rtu_.receive(req.data());  // a broken frame (−1) is flushed there
    if (rc > 0) {
      handle(rtu_.ctx(), req.data(), rc, false, rtu_.master_fd(), true);
    } else if (rc == 0) {
      std::lock_guard<std::mutex> lock(mutex_);
      fw_.advance_to(emulated_now());
    }
  }
}

// ------------------------------------------------------------------------------------------------
WatlowChamberServer::WatlowChamberServer(const ChamberEmuConfig& c, int port)
    : ChamberServerBase(c),
      tcp_("chamber emulator", LoopbackTcpOptions{.port = port, .newest_only = true, .poll_ms = 20, .down_sleep_ms = 10}) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", 0);
  if (ctx == nullptr) throw IoError("chamber emulator: libmodbus allocation failed");
  modbus_set_slave(ctx, c_.slave_id);
  modbus_set_indication_timeout(ctx, 0, 200000);
  ctx_ = ctx;
  thread_ = std::thread([this] { run(); });
}

WatlowChamberServer::~WatlowChamberServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  modbus_free(M(ctx_));
}

void WatlowChamberServer::run() {
  std::vector<std::uint8_t> req(MODBUS_TCP_MAX_ADU_LENGTH);
  while (!stop_) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      fw_.advance_to(emulated_now());
    }
    const auto ev = tcp_.wait();
    if (!ev) continue;
    if (ev->listener) {
      if (ev->accepted_fd >= 0) count(&ChamberEmuStats::connections);
      continue;
    }
    if (ev->readable.empty()) continue;
    const int fd = ev->readable.front();  // the one master
    modbus_set_socket(M(ctx_), fd);
    const int rc = modbus_receive(M(ctx_), req.data());
    if (rc > 0) {
      handle(ctx_, req.data(), rc, true, fd, false);
    } else if (rc < 0 && errno != ETIMEDOUT) {
      tcp_.drop(fd);
    }
  }
}

}  // namespace stend::emu
