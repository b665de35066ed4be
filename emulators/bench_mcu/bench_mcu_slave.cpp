#include "bench_mcu_slave.hpp"

#include <stend/errors.hpp>

#include <modbus.h>

#include <algorithm>
#include <stdexcept>
#include <thread>
#include <vector>

#include <stend/devices/bench_mcu_map.hpp>
#include "stend/emulators/splitmix.hpp"
#include "stend/emulators/steady_ns.hpp"

namespace stend::emu {
namespace {

namespace map = stend::bench_mcu;

modbus_mapping_t* MAP(void* p) { return static_cast<modbus_mapping_t*>(p); }

}  // namespace

BenchMcuSlave::BenchMcuSlave(BenchMcuConfig config, Mpu6050Model mpu)
    : BenchMcuSlave(config, std::move(mpu), nullptr) {}

bool BenchMcuConfig::IsValid(std::string* error) const {
  if (!(slave_id >= 1 && slave_id <= 247)) return invalid(error, "slave_id must be 1..247");
  if (fifo_depth == 0) return invalid(error, "fifo_depth must be > 0");
  if (mpu_address > 0x7F) return invalid(error, "mpu_address must be a 7-bit I2C address");
  return true;
}

BenchMcuSlave::BenchMcuSlave(BenchMcuConfig config, Mpu6050Model mpu, std::shared_ptr<EmulatedI2cBus> i2c_bus)
    : c_(require_valid(config, "bench MCU emulator")), mpu_(std::move(mpu)), i2c_bus_(std::move(i2c_bus)), rtu_("bench MCU emulator", 921600, config.slave_id),
      boot_count_(config.boot_count), rng_(config.seed) {
  modbus_mapping_t* mapping = modbus_mapping_new(0, 0, map::kHoldMapSize,
                                                 map::kInWindowBase + static_cast<int>(map::kWindowSeqModulo) + map::kWindowMaxWords);
  if (mapping == nullptr) throw IoError("bench MCU emulator: libmodbus allocation failed");
  mapping_ = mapping;
  power_on_ = std::chrono::steady_clock::now();
  thread_ = std::thread([this] { run(); });
}

BenchMcuSlave::~BenchMcuSlave() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  modbus_mapping_free(MAP(mapping_));
}

void BenchMcuSlave::go_silent(std::chrono::milliseconds d) {
  silent_until_ns_ = steady_ns_after(d);
}

void BenchMcuSlave::stall(std::chrono::milliseconds d) {
  stalled_until_ns_ = steady_ns_after(d);
}

void BenchMcuSlave::restart() {
  restart_pending_ = true;
}

void BenchMcuSlave::reset() {
  std::uint16_t* hold = MAP(mapping_)->tab_registers;
  std::fill(hold, hold + map::kHoldMapSize, std::uint16_t{0});
  if (running_) mpu_.write(mpu6050::kPwrMgmt1, mpu6050::kSleep);
  running_ = false;
  fifo_.clear();
  front_seq_ = next_seq_ = sent_seq_ = 0;
  overflows_ = 0;
  overflow_flag_ = false;
  ++boot_count_;
}

BenchMcuStats BenchMcuSlave::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

void BenchMcuSlave::run() {
  std::vector<std::uint8_t> req(MODBUS_RTU_MAX_ADU_LENGTH);
  while (!stop_) {
    if (restart_pending_.exchange(false)) reset();
    if (steady_now_ns() < stalled_until_ns_.load()) {  // requests wait in the line's buffer
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    const int rc = rtu_.receive(req.data());  // a broken frame is flushed there
    produce();
    if (rc > 0) handle(req.data(), rc);
  }
}

void BenchMcuSlave::produce() {
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - power_on_).count();
  mpu_.advance(t, [this] {
    if (!running_) return;
    std::uint8_t b[14];
    mpu_.read_burst(mpu6050::kAccelXoutH, b, sizeof b);  // the MCU's 14-byte I2C burst
    std::array<std::int16_t, 7> s{};
    for (int i = 0; i < 7; ++i) s[i] = static_cast<std::int16_t>((b[2 * i] << 8) | b[2 * i + 1]);
    if (fifo_.size() >= c_.fifo_depth) {  // the oldest is dropped; lost only if no window returned it
      const bool lost = front_seq_ >= sent_seq_;
      fifo_.pop_front();
      ++front_seq_;
      if (lost) {
        ++overflows_;
        overflow_flag_ = true;
      }
    }
    fifo_.push_back(s);
    ++next_seq_;
  });
}

void BenchMcuSlave::apply_ctrl() {
  std::uint16_t* hold = MAP(mapping_)->tab_registers;
  const bool run = (hold[map::kHoldCtrl] & map::kCtrlRun) != 0;
  if (hold[map::kHoldCtrl] & map::kCtrlFifoReset) {
    fifo_.clear();
    front_seq_ = next_seq_;
    hold[map::kHoldCtrl] = static_cast<std::uint16_t>(hold[map::kHoldCtrl] & ~map::kCtrlFifoReset);
  }
  if (run && !running_) {
    mpu_.write(mpu6050::kSmplrtDiv, static_cast<std::uint8_t>(hold[map::kHoldSmplrtDiv] & 0xFF));
    mpu_.write(mpu6050::kConfig, static_cast<std::uint8_t>(hold[map::kHoldDlpfCfg] & 0x07));
    mpu_.write(mpu6050::kGyroConfig, static_cast<std::uint8_t>((hold[map::kHoldGyroFsSel] & 3) << 3));
    mpu_.write(mpu6050::kAccelConfig, static_cast<std::uint8_t>((hold[map::kHoldAccelFsSel] & 3) << 3));
    mpu_.write(mpu6050::kPwrMgmt1, 0x01);  // wake, PLL with X gyro
    fifo_.clear();
    front_seq_ = next_seq_ = sent_seq_ = 0;
    overflows_ = 0;
    overflow_flag_ = false;
  } else if (!run && running_) {
    mpu_.write(mpu6050::kPwrMgmt1, mpu6050::kSleep);
  }
  running_ = run;
}

// The I2C window: one transaction on the MCU's bus per write of I2C_CMD.
void BenchMcuSlave::run_i2c_command() {
  const std::uint16_t* hold = MAP(mapping_)->tab_registers;
  std::uint16_t* in = MAP(mapping_)->tab_input_registers;
  const std::uint16_t cmd = hold[map::kHoldI2cCmd];
  const auto tag = static_cast<std::uint16_t>(cmd & 0xFF00);
  const auto addr = static_cast<std::uint8_t>(hold[map::kHoldI2cAddr] & 0x7F);
  auto reg = static_cast<std::uint8_t>(hold[map::kHoldI2cReg] & 0xFF);
  const int len = hold[map::kHoldI2cLen];
  std::fill(in + map::kInI2cStatus, in + map::kInI2cData + map::kI2cMaxRead / 2, 0);
  auto done = [&](std::uint16_t result, const std::uint8_t* data, int n) {
    in[map::kInI2cStatus] = static_cast<std::uint16_t>(tag | result);
    in[map::kInI2cCount] = static_cast<std::uint16_t>(n);
    for (int i = 0; i < n; ++i) {
      std::uint16_t& w = in[map::kInI2cData + i / 2];
      w = static_cast<std::uint16_t>(i % 2 == 0 ? (w & 0x00FF) | (data[i] << 8) : (w & 0xFF00) | data[i]);
    }
  };
  const int op = cmd & 0xFF;
  const bool read = op == map::kI2cCmdRead || op == map::kI2cCmdReadNoReg;
  if ((read && (len < 1 || len > map::kI2cMaxRead)) || (op == map::kI2cCmdWrite && len > map::kI2cMaxWrite) ||
      (!read && op != map::kI2cCmdWrite)) {
    done(map::kI2cBadRequest, nullptr, 0);
    return;
  }
  std::vector<std::uint8_t> w{reg};
  if (op == map::kI2cCmdWrite) {
    for (int i = 0; i < len; ++i) w.push_back(static_cast<std::uint8_t>(hold[map::kHoldI2cWdata + i] & 0xFF));
  }
  std::vector<std::uint8_t> r(read ? static_cast<std::size_t>(len) : 0);
  if (addr == c_.mpu_address) {  // the MCU's own MPU-6050
    if (op == map::kI2cCmdWrite) {
      for (std::size_t i = 1; i < w.size(); ++i) mpu_.write(static_cast<std::uint8_t>(reg + i - 1), w[i]);
    } else {
      mpu_.i2c_read(reg, r.data(), r.size());
    }
    done(map::kI2cOk, r.data(), static_cast<int>(r.size()));
    return;
  }
  I2cSegment segs[2];
  std::size_t n = 0;
  if (op != map::kI2cCmdReadNoReg) segs[n++] = {addr, false, w.data(), w.size()};
  if (read) segs[n++] = {addr, true, r.data(), r.size()};
  if (!i2c_bus_ || !i2c_bus_->transfer(segs, n)) {
    done(map::kI2cNackAddress, nullptr, 0);
    return;
  }
  done(map::kI2cOk, r.data(), static_cast<int>(r.size()));
}

bool BenchMcuSlave::window(int address, int count) {
  std::uint16_t* in = MAP(mapping_)->tab_input_registers + address;
  std::fill(in, in + count, 0);
  const std::uint32_t s_mod = static_cast<std::uint32_t>(address - map::kInWindowBase);
  const std::uint32_t back = (next_seq_ - s_mod) & (map::kWindowSeqModulo - 1);
  // Acknowledge everything before the requested sequence number (if it is still buffered).
  if (back <= next_seq_ - front_seq_) {
    const std::uint32_t s = next_seq_ - back;
    while (front_seq_ < s && !fifo_.empty()) {
      fifo_.pop_front();
      ++front_seq_;
    }
  }
  const std::size_t n = std::min<std::size_t>({fifo_.size(), static_cast<std::size_t>((count - map::kWindowHeaderWords) / map::kWordsPerSample),
                                               static_cast<std::size_t>(map::kWindowMaxSamples)});
  in[0] = static_cast<std::uint16_t>(n);
  in[1] = static_cast<std::uint16_t>(std::min<std::size_t>(fifo_.size() - n, 0xFFFF));
  in[2] = static_cast<std::uint16_t>(front_seq_ >> 16);
  in[3] = static_cast<std::uint16_t>(front_seq_ & 0xFFFF);
  sent_seq_ = std::max(sent_seq_, front_seq_ + static_cast<std::uint32_t>(n));
  for (std::size_t i = 0; i < n; ++i) {
    for (int w = 0; w < map::kWordsPerSample; ++w) {
      in[map::kWindowHeaderWords + static_cast<int>(i) * map::kWordsPerSample + w] = static_cast<std::uint16_t>(fifo_[i][static_cast<std::size_t>(w)]);
    }
  }
  return true;
}

void BenchMcuSlave::handle(const std::uint8_t* req, int len) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.requests;
  }
  if (steady_now_ns() < silent_until_ns_.load()) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.ignored;
    return;
  }
  const int hl = modbus_get_header_length(rtu_.ctx());
  const int fc = req[hl];
  const int address = (req[hl + 1] << 8) | req[hl + 2];
  const int count = (req[hl + 3] << 8) | req[hl + 4];
  if (fc == MODBUS_FC_READ_INPUT_REGISTERS) {
    bool ok = false;
    if (address + count <= map::kInCount) {
      std::uint16_t* in = MAP(mapping_)->tab_input_registers;
      in[map::kInStatus] = static_cast<std::uint16_t>((running_ ? map::kStatusRunning : 0) |
                                                      (overflow_flag_ ? map::kStatusOverflow : 0) |
                                                      (mpu_.asleep() ? map::kStatusAsleep : 0));
      in[map::kInWhoAmI] = mpu_.read(mpu6050::kWhoAmI);
      in[map::kInFifoCount] = static_cast<std::uint16_t>(std::min<std::size_t>(fifo_.size(), 0xFFFF));
      in[map::kInFifoCapacity] = static_cast<std::uint16_t>(std::min<std::size_t>(c_.fifo_depth, 0xFFFF));
      in[map::kInOverflows] = static_cast<std::uint16_t>(std::min<std::uint32_t>(overflows_, 0xFFFF));
      in[map::kInFirmware] = map::kFirmwareVersion;
      in[map::kInBootCount] = boot_count_;
      if (address <= map::kInStatus) overflow_flag_ = false;
      ok = true;
    } else if (address >= map::kInI2cStatus && address + count <= map::kInI2cData + map::kI2cMaxRead / 2) {
      ok = true;  // I2C window: STATUS, COUNT, DATA as left by the last command
    } else if (address >= map::kInWindowBase && address < map::kInWindowBase + static_cast<int>(map::kWindowSeqModulo) &&
               count >= map::kWindowHeaderWords && count <= map::kWindowMaxWords) {
      ok = window(address, count);
    }
    if (!ok) {
      modbus_reply_exception(rtu_.ctx(), req, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.exceptions;
      return;
    }
  }
  const bool read = fc == MODBUS_FC_READ_INPUT_REGISTERS ||
                    (fc == MODBUS_FC_READ_HOLDING_REGISTERS && address + count <= map::kHoldMapSize);
  if (read && splitmix_unit(rng_) < corrupt_p_.load()) {
    const std::uint16_t* src = fc == MODBUS_FC_READ_INPUT_REGISTERS ? MAP(mapping_)->tab_input_registers
                                                                    : MAP(mapping_)->tab_registers;
    write_corrupted_read_reply(rtu_.master_fd(), c_.slave_id, fc, src, address, count, rng_);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.corrupted;
    return;
  }
  modbus_reply(rtu_.ctx(), req, len, MAP(mapping_));
  if (fc == MODBUS_FC_WRITE_SINGLE_REGISTER || fc == MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
    apply_ctrl();
    if (address <= map::kHoldI2cCmd && address + (fc == MODBUS_FC_WRITE_SINGLE_REGISTER ? 1 : count) > map::kHoldI2cCmd) run_i2c_command();
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++stats_.replies;
}

}  // namespace stend::emu
