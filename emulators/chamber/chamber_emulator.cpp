#include "chamber_emulator.hpp"

#include <arpa/inet.h>
#include <modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "chamber_map.hpp"

namespace stend::emu {
namespace {

namespace map = stend::chamber_map;

modbus_t* M(void* p) { return static_cast<modbus_t*>(p); }
modbus_mapping_t* MAP(void* p) { return static_cast<modbus_mapping_t*>(p); }

std::uint16_t crc16(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ p[i]);
    for (int b = 0; b < 8; ++b)
      crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

std::uint64_t splitmix(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::uint16_t s16(double v) {
  return static_cast<std::uint16_t>(static_cast<std::int16_t>(std::clamp(std::round(v), -32768.0, 32767.0)));
}
double from_s16(std::uint16_t v) { return static_cast<double>(static_cast<std::int16_t>(v)); }

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

// ------------------------------------------------------------------------------------------------
ChamberFirmware::ChamberFirmware(const ChamberEmuConfig& c) : c_(c) {
  const auto& p = c.plant;
  if (!(p.control_period_s > 0.0 && p.heat_capacity_j_per_c > 0.0 && p.conductance_w_per_c > 0.0))
    throw std::invalid_argument("chamber emulator: control period, heat capacity and conductance must be > 0");
  tau_air_ = p.heat_capacity_j_per_c / p.conductance_w_per_c;
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
  const auto& p = c_.plant;
  const int heater = heater_stuck_ ? 255 : heater_;
  const double e = p.ambient_c + (p.internal_load_w + p.heater_power_w * heater / 255.0 -
                                  p.peltier_cooling_w * peltier_ / 255.0) /
                                     p.conductance_w_per_c;
  const double ea = std::exp(-dt / tau_air_);
  const double air0 = air_;
  air_ = e + (air0 - e) * ea;
  const double target = e + p.self_heating_c;
  const double td = p.die_lag_s;
  if (td <= 0.0) {
    die_ = air_ + p.self_heating_c;
    return;
  }
  const double ed = std::exp(-dt / td);
  if (std::abs(tau_air_ - td) > 1e-6 * td) {
    const double k = (air0 - e) * tau_air_ / (tau_air_ - td);
    die_ = target + k * ea + (die_ - target - k) * ed;
  } else {
    die_ = target + (die_ - target) * ed + (air0 - e) * (dt / td) * ed;
  }
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
    : c_(c), fw_(c), t0_(std::chrono::steady_clock::now()), rng_(c.seed) {
  if (!(c.speed > 0.0)) throw std::invalid_argument("chamber emulator: speed must be > 0");
  mapping_ = modbus_mapping_new(0, 0, 301, map::kInCount);
  if (mapping_ == nullptr) throw std::runtime_error("chamber emulator: libmodbus allocation failed");
}

ChamberServerBase::~ChamberServerBase() { modbus_mapping_free(MAP(mapping_)); }

double ChamberServerBase::emulated_now() const {
  return c_.speed * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

void ChamberServerBase::go_silent(std::chrono::milliseconds d) {
  silent_until_ns_ = now_ns() + std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

void ChamberServerBase::reply_exception(int n, int code) {
  exception_code_ = code;
  exceptions_left_ = n;
}

bool ChamberServerBase::silent() const { return now_ns() < silent_until_ns_.load(); }

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
  if (rtu && read && static_cast<double>(splitmix(rng_) >> 11) * 0x1.0p-53 < corrupt_p_.load()) {
    const std::uint16_t* src = fc == MODBUS_FC_READ_INPUT_REGISTERS ? mp->tab_input_registers : mp->tab_registers;
    std::vector<std::uint8_t> frame{static_cast<std::uint8_t>(c_.slave_id), static_cast<std::uint8_t>(fc),
                                    static_cast<std::uint8_t>(2 * n)};
    for (int i = 0; i < n; ++i) {
      frame.push_back(static_cast<std::uint8_t>(src[address + i] >> 8));
      frame.push_back(static_cast<std::uint8_t>(src[address + i] & 0xFF));
    }
    const std::uint16_t crc = crc16(frame.data(), frame.size());
    frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    frame.push_back(static_cast<std::uint8_t>(crc >> 8));
    frame[3 + splitmix(rng_) % static_cast<std::uint64_t>(2 * n)] ^= 0x5A;  // line noise on a data byte
    const ssize_t wr = ::write(fd, frame.data(), frame.size());
    (void)wr;
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
AtmegaChamberSlave::AtmegaChamberSlave(const ChamberEmuConfig& c) : ChamberServerBase(c) {
  char name[256] = {};
  if (openpty(&master_fd_, &slave_fd_, name, nullptr, nullptr) != 0)
    throw std::runtime_error(std::string("chamber emulator: openpty failed: ") + std::strerror(errno));
  device_path_ = name;
  termios t{};
  tcgetattr(slave_fd_, &t);
  cfmakeraw(&t);
  tcsetattr(slave_fd_, TCSANOW, &t);
  modbus_t* ctx = modbus_new_rtu(device_path_.c_str(), 115200, 'N', 8, 1);
  if (ctx == nullptr) throw std::runtime_error("chamber emulator: libmodbus allocation failed");
  modbus_set_slave(ctx, c_.slave_id);
  modbus_set_socket(ctx, master_fd_);
  modbus_set_indication_timeout(ctx, 0, 20000);
  ctx_ = ctx;
  thread_ = std::thread([this] { run(); });
}

AtmegaChamberSlave::~AtmegaChamberSlave() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  modbus_free(M(ctx_));
  ::close(master_fd_);
  ::close(slave_fd_);
}

void AtmegaChamberSlave::run() {
  std::vector<std::uint8_t> req(MODBUS_RTU_MAX_ADU_LENGTH);
  while (!stop_) {
    const int rc = modbus_receive(M(ctx_), req.data());
    const int err = errno;
    if (rc > 0) {
      handle(ctx_, req.data(), rc, false, master_fd_, true);
    } else if (rc < 0 && err != ETIMEDOUT) {
      modbus_flush(M(ctx_));
    } else {
      std::lock_guard<std::mutex> lock(mutex_);
      fw_.advance_to(emulated_now());
    }
  }
}

// ------------------------------------------------------------------------------------------------
WatlowChamberServer::WatlowChamberServer(const ChamberEmuConfig& c, int port) : ChamberServerBase(c), port_(port) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", 0);
  if (ctx == nullptr) throw std::runtime_error("chamber emulator: libmodbus allocation failed");
  modbus_set_slave(ctx, c_.slave_id);
  modbus_set_indication_timeout(ctx, 0, 200000);
  ctx_ = ctx;
  if (!listen_now()) {
    modbus_free(M(ctx_));
    throw std::runtime_error("chamber emulator: cannot listen on 127.0.0.1:" + std::to_string(port) + ": " +
                             std::strerror(errno));
  }
  thread_ = std::thread([this] { run(); });
}

WatlowChamberServer::~WatlowChamberServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (client_fd_ >= 0) ::close(client_fd_);
  if (listen_fd_ >= 0) ::close(listen_fd_);
  modbus_free(M(ctx_));
}

bool WatlowChamberServer::listen_now() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port_));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 4) != 0) {
    ::close(fd);
    return false;
  }
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
  listen_fd_ = fd;
  return true;
}

void WatlowChamberServer::disconnect_for(std::chrono::milliseconds d) {
  down_until_ns_ = now_ns() + std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

void WatlowChamberServer::run() {
  std::vector<std::uint8_t> req(MODBUS_TCP_MAX_ADU_LENGTH);
  while (!stop_) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      fw_.advance_to(emulated_now());
    }
    if (now_ns() < down_until_ns_.load()) {  // the peer is gone: nothing listens, nothing answers
      if (client_fd_ >= 0) ::close(client_fd_);
      if (listen_fd_ >= 0) ::close(listen_fd_);
      client_fd_ = listen_fd_ = -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      continue;
    }
    if (listen_fd_ < 0 && !listen_now()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    pollfd p[2] = {{listen_fd_, POLLIN, 0}, {client_fd_, POLLIN, 0}};
    const int r = ::poll(p, client_fd_ >= 0 ? 2 : 1, 20);
    if (r <= 0) continue;
    if (p[0].revents & POLLIN) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd >= 0) {
        if (client_fd_ >= 0) ::close(client_fd_);  // one master at a time: the newest wins
        client_fd_ = fd;
        count(&ChamberEmuStats::connections);
      }
      continue;
    }
    if (client_fd_ >= 0 && (p[1].revents & (POLLIN | POLLHUP | POLLERR))) {
      modbus_set_socket(M(ctx_), client_fd_);
      const int rc = modbus_receive(M(ctx_), req.data());
      if (rc > 0) {
        handle(ctx_, req.data(), rc, true, client_fd_, false);
      } else if (rc < 0 && errno != ETIMEDOUT) {
        ::close(client_fd_);
        client_fd_ = -1;
      }
    }
  }
}

}  // namespace stend::emu
