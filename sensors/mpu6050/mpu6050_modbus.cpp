#include "mpu6050_modbus.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <stend/devices/bench_mcu_map.hpp>
#include <stend/physics/units.hpp>

namespace stend::mpu6050 {
namespace {

namespace map = stend::bench_mcu;

std::string hex2(unsigned v) {
  char b[8];
  std::snprintf(b, sizeof b, "0x%02X", v & 0xFFu);
  return b;
}

}  // namespace

const stend::fields::Table<Mpu6050ModbusConfig>& Mpu6050ModbusConfig::fields() {
  using F = stend::fields::Field<Mpu6050ModbusConfig>;
  static const stend::fields::Table<Mpu6050ModbusConfig> table("mpu6050_modbus", {
      F("device", &Mpu6050ModbusConfig::device, "",
        "serial port of the USB–RS-485 converter the bench microcontroller hangs on, e.g. /dev/ttyUSB0")
          .required(),
      F("baud", &Mpu6050ModbusConfig::baud, "1/s", "line rate, 8N1").range(1200, 4000000),
      F("slave_id", &Mpu6050ModbusConfig::slave_id, "", "MODBUS address of the bench microcontroller").range(1, 247),
      F("accel_range_g", &Mpu6050ModbusConfig::accel_range_g, "g", "accelerometer full scale: 2, 4, 8 or 16 (±g)").range(2, 16),
      F("gyro_range_dps", &Mpu6050ModbusConfig::gyro_range_dps, "deg/s", "gyroscope full scale: 250, 500, 1000 or 2000 (±°/s)")
          .range(250, 2000),
      F("dlpf_hz", &Mpu6050ModbusConfig::dlpf_hz, "Hz",
        "MPU-6050 digital low-pass (CONFIG.DLPF_CFG): 0 = off (260 Hz, 8 kHz gyro rate), 184, 94, 44, 21, 10, 5")
          .range(0, 260),
      F("output_rate_hz", &Mpu6050ModbusConfig::output_rate_hz, "Hz",
        "sample rate; must be 8000/(1+n) with dlpf_hz 0, else 1000/(1+n), n = SMPLRT_DIV 0..255")
          .range(3.9, 8000),
      F("timeout_ms", &Mpu6050ModbusConfig::timeout_ms, "ms", "MODBUS response time-out per attempt").range(1, 10000),
      F("retries", &Mpu6050ModbusConfig::retries, "", "extra attempts after a CRC error or time-out (back-off 5 ms, doubling)")
          .range(0, 20),
  });
  return table;
}

Mpu6050Modbus::Mpu6050Modbus(const Params& p) : Mpu6050Modbus(Mpu6050ModbusConfig::from(p)) {}

int Mpu6050ModbusConfig::dlpf_cfg() const {
  static constexpr int kDlpf[7] = {0, 184, 94, 44, 21, 10, 5};
  for (int i = 0; i < 7; ++i)
    if (kDlpf[i] == dlpf_hz) return i;
  return -1;
}

bool Mpu6050ModbusConfig::IsValid(std::string* error) const {
  if (device.empty()) return invalid(error, "'device' is empty; give the serial port of the USB converter, e.g. /dev/ttyUSB0");
  if (!(slave_id >= 1 && slave_id <= 247)) return invalid(error, "slave_id must be 1..247");
  if (accel_range_g != 2 && accel_range_g != 4 && accel_range_g != 8 && accel_range_g != 16)
    return invalid(error, "accel_range_g must be 2, 4, 8 or 16 (got " + std::to_string(accel_range_g) + ")");
  if (gyro_range_dps != 250 && gyro_range_dps != 500 && gyro_range_dps != 1000 && gyro_range_dps != 2000)
    return invalid(error, "gyro_range_dps must be 250, 500, 1000 or 2000 (got " + std::to_string(gyro_range_dps) + ")");
  if (dlpf_cfg() < 0)
    return invalid(error, "dlpf_hz must be one of 0 (off), 184, 94, 44, 21, 10, 5 (got " + std::to_string(dlpf_hz) + ")");
  const double base = rate_base_hz(), div = smplrt_div();
  if (!(div >= 0.0 && div <= 255.0 && std::abs(base / (1.0 + div) - output_rate_hz) <= 1e-6 * output_rate_hz))
    return invalid(error, "output_rate_hz " + std::to_string(output_rate_hz) + " is not " +
                              std::to_string(static_cast<int>(base)) +
                              "/(1 + SMPLRT_DIV) for an integer SMPLRT_DIV 0..255 with dlpf_hz " +
                              std::to_string(dlpf_hz) + "; e.g. " +
                              std::to_string(base / (1.0 + std::clamp(div, 0.0, 255.0))) + " Hz");
  if (!(timeout_ms >= 1 && retries >= 0)) return invalid(error, "timeout_ms must be >= 1 and retries >= 0");
  return true;
}

Mpu6050Modbus::Mpu6050Modbus(Mpu6050ModbusConfig c) : c_(require_valid(c, "mpu6050_modbus")) {
  dlpf_cfg_ = c_.dlpf_cfg();
  smplrt_div_ = static_cast<int>(c_.smplrt_div());
  period_s_ = (1.0 + c_.smplrt_div()) / c_.rate_base_hz();
}

Mpu6050Modbus::~Mpu6050Modbus() {
  try {
    stop();
  } catch (...) {
  }
}

std::string Mpu6050Modbus::where() const {
  return "device " + c_.device + ", slave " + std::to_string(c_.slave_id);
}

SensorIdentity Mpu6050Modbus::identity() const { return {"InvenSense", "MPU-6050", "", who_am_i_}; }

SensorInfo Mpu6050Modbus::info() const {
  SensorInfo i;
  i.output_rate_hz = 1.0 / period_s_;
  i.accel_range_mps2 = c_.accel_range_g * physics::kStandardGravity;
  i.gyro_range_radps = c_.gyro_range_dps * physics::kDegPerSecond;
  i.accel_lsb_mps2 = i.accel_range_mps2 / 32768.0;
  i.gyro_lsb_radps = i.gyro_range_radps / 32768.0;
  i.temperature_lsb_c = 1.0 / 340.0;
  return i;
}

void Mpu6050Modbus::open() {
  if (bus_) return;
  transport::ModbusRtuConfig b;
  b.device = c_.device;
  b.baud = c_.baud;
  b.slave_id = c_.slave_id;
  b.response_timeout_ms = c_.timeout_ms;
  b.retries = c_.retries;
  bus_ = std::make_unique<transport::ModbusRtuClient>(b);
}

void Mpu6050Modbus::start(double t0_s) {
  open();
  const auto in = bus_->read_input_registers(map::kInStatus, map::kInCount);
  const unsigned who = in[map::kInWhoAmI];
  boot_count_ = in[map::kInBootCount];
  who_am_i_ = hex2(who);
  if (who != kExpectedWhoAmI) {
    throw IoError("mpu6050_modbus: " + where() + ": WHO_AM_I (0x75) reads " + who_am_i_ +
                  ", expected " + hex2(kExpectedWhoAmI) +
                  " (MPU-6050); check which sensor the bench microcontroller carries "
                  "(0x70/0x71 is an MPU-6500/9250) and the slave id");
  }
  bus_->write_register(map::kHoldCtrl, 0);  // stop before reconfiguring
  bus_->write_register(map::kHoldSmplrtDiv, static_cast<std::uint16_t>(smplrt_div_));
  bus_->write_register(map::kHoldDlpfCfg, static_cast<std::uint16_t>(dlpf_cfg_));
  bus_->write_register(map::kHoldGyroFsSel, static_cast<std::uint16_t>(std::countr_zero(static_cast<unsigned>(c_.gyro_range_dps / 250))));
  bus_->write_register(map::kHoldAccelFsSel, static_cast<std::uint16_t>(std::countr_zero(static_cast<unsigned>(c_.accel_range_g / 2))));
  bus_->write_register(map::kHoldCtrl, map::kCtrlRun | map::kCtrlFifoReset);
  t0_ = t0_s;
  next_seq_ = 0;
  gap_pending_ = false;
  estimate_ = 0;
  last_poll_ = std::chrono::steady_clock::now();
  pending_.clear();
  report_ = {};
  bus_->reset_stats();
  faults_seen_ = 0;
}

void Mpu6050Modbus::stop() {
  if (bus_) bus_->write_register(map::kHoldCtrl, 0);
}

const LinkReport& Mpu6050Modbus::report() const {
  if (bus_) report_.bus = bus_->stats();
  return report_;
}

bool Mpu6050Modbus::read_window(int max_samples) {
  const int k = std::clamp(max_samples, 1, map::kWindowMaxSamples);
  const int address = map::kInWindowBase + static_cast<int>(next_seq_ & (map::kWindowSeqModulo - 1));
  const auto w = bus_->read_input_registers(address, map::kWindowHeaderWords + map::kWordsPerSample * k);
  ++report_.window_reads;
  const int n = w[0];
  const int remaining = w[1];
  const std::uint32_t first = (static_cast<std::uint32_t>(w[2]) << 16) | w[3];
  if (n > k) {
    throw IoError("mpu6050_modbus: " + where() + ": FIFO window at input register " + std::to_string(address) + " claims " + std::to_string(n) +
                  " samples, asked for " + std::to_string(k) + " (firmware mismatch?)");
  }
  const auto ahead = static_cast<std::int32_t>(first - next_seq_);
  int skip = 0;  // samples at the window's start that were already received
  if (ahead < 0) {
    const auto overlap = static_cast<std::uint32_t>(-ahead);
    resynchronise(first, overlap);
    skip = static_cast<int>(std::min<std::uint32_t>(overlap, static_cast<std::uint32_t>(n)));
    if (skip == n) {  // nothing new in this window: ask again from next_seq_
      estimate_ = remaining;
      return n > 0;
    }
  }
  if (ahead > 0 && n > 0) {
    report_.samples_lost += static_cast<std::uint64_t>(ahead);
    report_.events.push_back("gap: " + std::to_string(ahead) + " samples lost before sequence " + std::to_string(first) +
                             " (bench MCU FIFO overflowed while the link was down)");
    gap_pending_ = true;
    next_seq_ = first;
  }
  const SensorInfo si = info();
  for (int i = skip; i < n; ++i) {
    const std::uint16_t* p = &w[static_cast<std::size_t>(map::kWindowHeaderWords + map::kWordsPerSample * i)];
    auto v = [&](int j) { return static_cast<std::int32_t>(static_cast<std::int16_t>(p[j])); };
    ImuSample s;
    s.t_s = t0_ + static_cast<double>(next_seq_ + 1) * period_s_;
    for (int a = 0; a < 3; ++a) {
      s.accel_counts[a] = v(a);
      s.gyro_counts[a] = v(4 + a);
      s.accel_mps2[a] = v(a) * si.accel_lsb_mps2;
      s.gyro_radps[a] = v(4 + a) * si.gyro_lsb_radps;
      if (v(a) == 32767 || v(a) == -32768) s.flags |= kAccelSaturated;
      if (v(4 + a) == 32767 || v(4 + a) == -32768) s.flags |= kGyroSaturated;
    }
    s.temperature_counts = v(3);
    s.temperature_c = v(3) / 340.0 + 36.53;
    if (gap_pending_) {
      s.flags |= kGapBefore;
      ++report_.gaps;
      gap_pending_ = false;
    }
    pending_.push_back(s);
    ++next_seq_;
    ++report_.samples;
    report_.payload_bytes += 14;
  }
  estimate_ = remaining;
  return remaining > 0;
}

void Mpu6050Modbus::resynchronise(std::uint32_t first, std::uint32_t overlap) {
  const std::uint16_t boot = bus_->read_input_registers(map::kInBootCount, 1)[0];
  if (boot != boot_count_) {
    throw IoError("mpu6050_modbus: " + where() + ": bench MCU restarted (BOOT_COUNT " +
                  std::to_string(boot_count_) + " -> " + std::to_string(boot) +
                  "): its FIFO window starts at sequence " + std::to_string(first) + ", before the expected " +
                  std::to_string(next_seq_) + "; samples from sequence " + std::to_string(next_seq_) +
                  " on are lost");
  }
  report_.events.push_back("resynchronised: FIFO window started at sequence " + std::to_string(first) + ", " +
                           std::to_string(overlap) + " sample(s) before the expected " + std::to_string(next_seq_) +
                           " (a late reply to an earlier request; BOOT_COUNT unchanged); the overlap was dropped");
  ++report_.resyncs;
}

void Mpu6050Modbus::acquire(double t_s, const TruthSource& /*truth*/, std::vector<ImuSample>& out) {
  if (!bus_) throw std::logic_error("mpu6050_modbus: " + where() + ": acquire() before start()");
  auto flush = [&] {
    while (!pending_.empty() && pending_.front().t_s <= t_s) {
      out.push_back(pending_.front());
      pending_.pop_front();
    }
  };
  auto note_faults = [&] {
    const auto& st = bus_->stats();
    const std::uint64_t faults = st.crc_errors + st.timeouts;
    if (faults != faults_seen_) {
      const std::string line = "mpu6050_modbus: " + where() + ": " + std::to_string(faults - faults_seen_) +
                               " transient fault(s) (CRC errors total " + std::to_string(st.crc_errors) +
                               ", time-outs total " + std::to_string(st.timeouts) + "), last: " + st.last_error;
      report_.events.push_back(line);
      faults_seen_ = faults;
    }
  };
  flush();
  try {
    // Poll the FIFO until it is drained or holds samples later than t_s.
    for (bool first = true; pending_.empty(); first = false) {
      int want = estimate_;
      if (first && want == 0) {
        const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - last_poll_).count();
        want = static_cast<int>(std::ceil(dt / period_s_));
      }
      last_poll_ = std::chrono::steady_clock::now();
      const bool more = read_window(want);
      flush();
      if (!more) break;
    }
  } catch (const std::exception& e) {
    note_faults();
    report_.events.push_back(e.what());
    throw IoError(std::string(e.what()) + "; samples up to here were kept, the next acquire() resumes");
  }
  note_faults();
}

}  // namespace stend::mpu6050
