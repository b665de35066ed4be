#include "bench_mcu_slave.hpp"

#include <modbus.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "bench_mcu_map.hpp"

namespace stend::emu {
namespace {

namespace map = stend::bench_mcu;

modbus_t* M(void* p) { return static_cast<modbus_t*>(p); }
modbus_mapping_t* MAP(void* p) { return static_cast<modbus_mapping_t*>(p); }

std::uint16_t crc16(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ p[i]);
    for (int b = 0; b < 8; ++b) crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

std::uint64_t splitmix(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace

BenchMcuSlave::BenchMcuSlave(BenchMcuConfig config, Mpu6050Model mpu)
    : BenchMcuSlave(config, std::move(mpu), nullptr) {}

BenchMcuSlave::BenchMcuSlave(BenchMcuConfig config, Mpu6050Model mpu, std::shared_ptr<EmulatedI2cBus> i2c_bus)
    : c_(config), mpu_(std::move(mpu)), i2c_bus_(std::move(i2c_bus)), rng_(config.seed) {
  char name[256] = {};
  if (openpty(&master_fd_, &slave_fd_, name, nullptr, nullptr) != 0) {
    throw std::runtime_error(std::string("bench MCU emulator: openpty failed: ") + std::strerror(errno));
  }
  device_path_ = name;
  termios t{};
  tcgetattr(slave_fd_, &t);
  cfmakeraw(&t);
  tcsetattr(slave_fd_, TCSANOW, &t);

  // The context's device name is never opened: the slave talks on the pty's master end.
  modbus_t* ctx = modbus_new_rtu(device_path_.c_str(), 921600, 'N', 8, 1);
  modbus_mapping_t* mapping = modbus_mapping_new(0, 0, map::kHoldMapSize,
                                                 map::kInWindowBase + static_cast<int>(map::kWindowSeqModulo) + map::kWindowMaxWords);
  if (ctx == nullptr || mapping == nullptr) throw std::runtime_error("bench MCU emulator: libmodbus allocation failed");
  modbus_set_slave(ctx, c_.slave_id);
  modbus_set_socket(ctx, master_fd_);
  modbus_set_indication_timeout(ctx, 0, 20000);
  ctx_ = ctx;
  mapping_ = mapping;
  power_on_ = std::chrono::steady_clock::now();
  thread_ = std::thread([this] { run(); });
}

BenchMcuSlave::~BenchMcuSlave() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  modbus_mapping_free(MAP(mapping_));
  modbus_free(M(ctx_));
  ::close(master_fd_);
  ::close(slave_fd_);
}

void BenchMcuSlave::go_silent(std::chrono::milliseconds d) {
  const auto until = std::chrono::steady_clock::now() + d;
  silent_until_ns_ = std::chrono::duration_cast<std::chrono::nanoseconds>(until.time_since_epoch()).count();
}

BenchMcuStats BenchMcuSlave::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

void BenchMcuSlave::run() {
  std::vector<std::uint8_t> req(MODBUS_RTU_MAX_ADU_LENGTH);
  while (!stop_) {
    const int rc = modbus_receive(M(ctx_), req.data());
    const int err = errno;
    produce();
    if (rc > 0) {
      handle(req.data(), rc);
    } else if (rc < 0 && err != ETIMEDOUT) {
      modbus_flush(M(ctx_));  // broken frame: drop what is left of it
    }
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
    if (fifo_.size() >= c_.fifo_depth) {
      fifo_.pop_front();
      ++front_seq_;
      ++overflows_;
      overflow_flag_ = true;
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
    front_seq_ = next_seq_ = 0;
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
  const auto now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
  if (now_ns < silent_until_ns_.load()) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.ignored;
    return;
  }
  const int hl = modbus_get_header_length(M(ctx_));
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
      if (address <= map::kInStatus) overflow_flag_ = false;
      ok = true;
    } else if (address >= map::kInI2cStatus && address + count <= map::kInI2cData + map::kI2cMaxRead / 2) {
      ok = true;  // I2C window: STATUS, COUNT, DATA as left by the last command
    } else if (address >= map::kInWindowBase && address < map::kInWindowBase + static_cast<int>(map::kWindowSeqModulo) &&
               count >= map::kWindowHeaderWords && count <= map::kWindowMaxWords) {
      ok = window(address, count);
    }
    if (!ok) {
      modbus_reply_exception(M(ctx_), req, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.exceptions;
      return;
    }
  }
  const bool read = fc == MODBUS_FC_READ_INPUT_REGISTERS ||
                    (fc == MODBUS_FC_READ_HOLDING_REGISTERS && address + count <= map::kHoldMapSize);
  if (read && static_cast<double>(splitmix(rng_) >> 11) * 0x1.0p-53 < corrupt_p_.load()) {
    const std::uint16_t* src = fc == MODBUS_FC_READ_INPUT_REGISTERS ? MAP(mapping_)->tab_input_registers
                                                                    : MAP(mapping_)->tab_registers;
    std::vector<std::uint8_t> frame{static_cast<std::uint8_t>(c_.slave_id), static_cast<std::uint8_t>(fc),
                                    static_cast<std::uint8_t>(2 * count)};
    for (int i = 0; i < count; ++i) {
      frame.push_back(static_cast<std::uint8_t>(src[address + i] >> 8));
      frame.push_back(static_cast<std::uint8_t>(src[address + i] & 0xFF));
    }
    const std::uint16_t crc = crc16(frame.data(), frame.size());
    frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    frame.push_back(static_cast<std::uint8_t>(crc >> 8));
    frame[3 + splitmix(rng_) % static_cast<std::uint64_t>(2 * count)] ^= 0x5A;  // line noise on a data byte
    const ssize_t w = ::write(master_fd_, frame.data(), frame.size());
    (void)w;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.corrupted;
    return;
  }
  modbus_reply(M(ctx_), req, len, MAP(mapping_));
  if (fc == MODBUS_FC_WRITE_SINGLE_REGISTER || fc == MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
    apply_ctrl();
    if (address <= map::kHoldI2cCmd && address + (fc == MODBUS_FC_WRITE_SINGLE_REGISTER ? 1 : count) > map::kHoldI2cCmd) run_i2c_command();
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++stats_.replies;
}

}  // namespace stend::emu
