// The bench microcontroller's real firmware (firmware/bench_mcu) under simavr, driven by the real
// libmodbus client (stend::transport::ModbusRtuClient) over the pty, as a board on /dev/ttyUSB0:
// every register read/write, each exception code, CRC errors and time-outs injected on the
// line, the FIFO window sequence across a stall, the I2C window, the DS18B20's CRC error and open
// sensor, the master watchdog forcing the outputs off, restart detection (BOOT_COUNT), and a
// conformance set shared with the C++ emulation (emulators/bench_mcu, emulators/chamber).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <modbus.h>
#include <termios.h>
#include <unistd.h>

#include <stend/devices/bench_mcu_map.hpp>
#include <stend/devices/chamber_map.hpp>
#include <stend/devices/modbus_rtu.hpp>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bench_mcu_slave.hpp"
#include "chamber_emulator.hpp"
#include "firmware_in_loop.hpp"

namespace {

namespace bm = stend::bench_mcu;
namespace cm = stend::chamber_map;
using stend::emu::Ds18b20Fault;
using stend::emu::FirmwareInTheLoop;
using stend::emu::FirmwareLoopConfig;
using stend::emu::Mpu6050Model;
using stend::transport::ModbusError;
using stend::transport::ModbusRtuClient;
using stend::transport::ModbusRtuConfig;
using namespace std::chrono_literals;

constexpr int kChamberSlave = bm::kFirmwareChamberSlave;

stend::BenchTruth level_truth() {
  stend::BenchTruth t;
  t.specific_force_mps2 = {0.0, 0.0, 9.80665};
  t.angular_rate_radps = {0.01, -0.02, 0.005};
  return t;
}

Mpu6050Model make_mpu() {
  stend::sim::SimImuConfig physics;
  physics.seed = 7;
  return Mpu6050Model(physics, level_truth());
}

std::unique_ptr<FirmwareInTheLoop> make_fw(double speed = 1.0, double initial_c = 22.0) {
  FirmwareLoopConfig c;
  c.elf_path = STEND_BENCH_MCU_ELF;
  c.speed = speed;
  c.plant.initial_c = initial_c;  // ambient: the plant's default 22 °C
  auto fw = std::make_unique<FirmwareInTheLoop>(c, make_mpu());
  EXPECT_TRUE(fw->wait_until_simulated(0.02, 10s));  // past the firmware's start-up
  return fw;
}

// Waits `seconds` of simulated time: the firmware's clock, whatever the load on the host.
void sim_sleep(const FirmwareInTheLoop& fw, double seconds) {
  ASSERT_TRUE(fw.wait_until_simulated(fw.stats().simulated_s + seconds, 60s));
}

ModbusRtuClient client(const std::string& path, int slave = 1, int retries = 3, int timeout_ms = 300) {
  ModbusRtuConfig c;
  c.device = path;
  c.slave_id = slave;
  c.retries = retries;
  c.response_timeout_ms = timeout_ms;
  return ModbusRtuClient(c);
}

// A hand-built request (CRC appended here) written to the line: the reply's function code and,
// for an exception reply, its code (0 for a normal reply; {-1, -1} when nothing came in 300 ms).
std::pair<int, int> raw_request(const std::string& path, std::vector<std::uint8_t> frame) {
  std::uint16_t crc = 0xFFFF;
  for (const std::uint8_t b : frame) {
    crc ^= b;
    for (int k = 0; k < 8; ++k) crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : static_cast<std::uint16_t>(crc >> 1);
  }
  frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  frame.push_back(static_cast<std::uint8_t>(crc >> 8));
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  EXPECT_GE(fd, 0) << path;
  termios t{};
  tcgetattr(fd, &t);
  cfmakeraw(&t);
  tcsetattr(fd, TCSANOW, &t);
  EXPECT_EQ(::write(fd, frame.data(), frame.size()), static_cast<ssize_t>(frame.size()));
  std::uint8_t rsp[MODBUS_RTU_MAX_ADU_LENGTH];
  std::size_t n = 0;
  const auto until = std::chrono::steady_clock::now() + 300ms;
  while (std::chrono::steady_clock::now() < until && n < 5) {
    const ssize_t r = ::read(fd, rsp + n, sizeof rsp - n);
    if (r > 0) n += static_cast<std::size_t>(r);
    else std::this_thread::sleep_for(1ms);
  }
  ::close(fd);
  if (n < 5) return {-1, -1};
  return {rsp[1], (rsp[1] & 0x80) ? rsp[2] : 0};
}

int exception_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ModbusError& e) {
    return e.kind() == ModbusError::Kind::kException ? e.exception_code() : -1;
  }
  return 0;
}

// ---- The conformance set: the same expectations against the firmware and the C++ emulation ----
void check_register_map(const std::string& path) {
  auto m = client(path);
  const auto in = m.read_input_registers(0, bm::kInCount);
  EXPECT_EQ(in[bm::kInWhoAmI], 0x68);
  EXPECT_EQ(in[bm::kInFirmware], bm::kFirmwareVersion);
  EXPECT_EQ(in[bm::kInFifoCount], 0);
  EXPECT_GT(in[bm::kInFifoCapacity], 0);
  EXPECT_EQ(in[bm::kInStatus] & bm::kStatusRunning, 0);
  // Every holding register of the map writes and reads back (FC 06 and FC 16), CTRL aside.
  for (int a = 1; a < bm::kHoldMapSize; ++a) m.write_register(a, static_cast<std::uint16_t>(a == bm::kHoldI2cCmd ? 0 : 0x100 + a));
  std::vector<std::uint16_t> block(bm::kI2cMaxWrite);
  for (int i = 0; i < bm::kI2cMaxWrite; ++i) block[static_cast<std::size_t>(i)] = static_cast<std::uint16_t>(0xA0 + i);
  m.write_registers(bm::kHoldI2cWdata, block);
  const auto hold = m.read_holding_registers(0, bm::kHoldMapSize);
  for (int a = 1; a < bm::kHoldI2cWdata; ++a) {
    if (a == bm::kHoldI2cCmd) continue;
    EXPECT_EQ(hold[static_cast<std::size_t>(a)], 0x100 + a) << "holding " << a;
  }
  for (int i = 0; i < bm::kI2cMaxWrite; ++i) EXPECT_EQ(hold[static_cast<std::size_t>(bm::kHoldI2cWdata + i)], 0xA0 + i);
  // Unmapped addresses answer exception 02.
  EXPECT_EQ(exception_of([&] { m.read_input_registers(bm::kInCount, 1); }), MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
  EXPECT_EQ(exception_of([&] { m.read_holding_registers(bm::kHoldMapSize, 1); }), MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
  EXPECT_EQ(exception_of([&] { m.read_input_registers(bm::kInWindowBase, 3); }), MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
  // The I2C window: WHO_AM_I of the MPU-6050 through the MCU's bus.
  m.write_register(bm::kHoldI2cAddr, 0x68);
  m.write_register(bm::kHoldI2cReg, 0x75);
  m.write_register(bm::kHoldI2cLen, 1);
  m.write_register(bm::kHoldI2cCmd, static_cast<std::uint16_t>(0x2A00 | bm::kI2cCmdRead));
  const auto st = m.read_input_registers(bm::kInI2cStatus, 3);
  EXPECT_EQ(st[0], 0x2A00 | bm::kI2cOk);
  EXPECT_EQ(st[1], 1);
  EXPECT_EQ(st[2] >> 8, 0x68);
}

// RUN at 1 kHz, then read windows: consecutive sequence numbers except where samples were
// overwritten, and every such gap is counted in OVERFLOWS (a loaded host may fall behind); a
// repeated read returns the same samples (later ones only when an overflow came in between); the
// level sensor's Z reads about +1 g (16384 counts at ±2 g).
void check_window_sequence(const std::string& path, const std::function<void(double)>& pause) {
  auto m = client(path);
  m.write_register(bm::kHoldSmplrtDiv, 0);
  m.write_register(bm::kHoldDlpfCfg, 1);
  m.write_register(bm::kHoldGyroFsSel, 0);
  m.write_register(bm::kHoldAccelFsSel, 0);
  m.write_register(bm::kHoldCtrl, bm::kCtrlRun);
  auto first_of = [](const std::vector<std::uint16_t>& w) { return (static_cast<std::uint32_t>(w[2]) << 16) | w[3]; };
  std::uint32_t s = 0, gaps = 0;
  int got = 0, reads = 0;
  for (int poll = 0; poll < 40; ++poll) {  // 400 ms of the device's time
    pause(0.010);
    for (;;) {
      const int addr = bm::kInWindowBase + static_cast<int>(s % bm::kWindowSeqModulo);
      const auto w = m.read_input_registers(addr, bm::kWindowMaxWords);
      const std::uint32_t first = first_of(w);
      EXPECT_GE(first, s);
      gaps += first - s;
      for (int i = 0; i < w[0]; ++i) {
        const auto az = static_cast<std::int16_t>(w[static_cast<std::size_t>(bm::kWindowHeaderWords + 7 * i + 2)]);
        EXPECT_NEAR(az, 16384, 400);
      }
      std::uint32_t next = first + w[0];
      if (++reads % 4 == 0) {  // a repeated read every 4th window (each costs a window's time)
        const auto again = m.read_input_registers(addr, bm::kWindowMaxWords);
        const std::uint32_t shift = first_of(again) - first;  // > 0 only after an overflow
        EXPECT_LE(shift, static_cast<std::uint32_t>(w[0] + w[1])) << "a repeated read starts at the same sample";
        for (std::uint32_t i = shift; i < std::min<std::uint32_t>(w[0], again[0] + shift); ++i) {
          for (int k = 0; k < bm::kWordsPerSample; ++k) {
            const auto at = [&](std::uint32_t j) { return static_cast<std::size_t>(bm::kWindowHeaderWords + bm::kWordsPerSample * static_cast<int>(j) + k); };
            EXPECT_EQ(again[at(i - shift)], w[at(i)]) << "the same counts again";
          }
        }
        // The host has what either read returned: samples the MCU returned are not lost to it,
        // even when they are dropped before it acknowledges them (OVERFLOWS does not count them).
        if (first_of(again) > next) gaps += first_of(again) - next;
        next = std::max(next, first_of(again) + again[0]);
      }
      s = next;
      got += w[0];
      if (w[1] == 0 || w[0] == 0) break;
    }
  }
  EXPECT_GT(got, 200);  // most of 400 samples
  EXPECT_LE(gaps, m.read_input_registers(bm::kInOverflows, 1)[0]) << "every gap is counted as overflow";
  m.write_register(bm::kHoldCtrl, 0);
}

// OVERFLOWS counts only samples the host could never have read. At 100 Hz: a window returns the
// first 17 samples (delivered, not acknowledged), then the master stalls. (a) The buffer fills and
// overwrites some of those 17 — the window at 0 now starts after 0 — but nothing the host never
// saw was dropped: OVERFLOWS stays 0 and STATUS shows no overflow. (b) It stalls on, undelivered
// samples are overwritten: OVERFLOWS equals the gap the master sees from 17 on.
void check_overflow_counting(const std::string& path, const std::function<void(double)>& pause) {
  constexpr double kRateHz = 100.0;
  constexpr std::uint32_t kSent = bm::kWindowMaxSamples;
  auto m = client(path);
  m.write_register(bm::kHoldSmplrtDiv, 9);  // 1 kHz / (1 + 9)
  m.write_register(bm::kHoldDlpfCfg, 3);    // 44 Hz, below the 50 Hz Nyquist limit
  m.write_register(bm::kHoldCtrl, bm::kCtrlRun);
  const auto front = [&m] {  // the oldest sample still buffered (a window at 0 acknowledges nothing)
    const auto w = m.read_input_registers(bm::kInWindowBase, bm::kWindowHeaderWords);
    return (static_cast<std::uint32_t>(w[2]) << 16) | w[3];
  };
  const auto overflows = [&m] { return static_cast<std::uint32_t>(m.read_input_registers(bm::kInOverflows, 1)[0]); };
  const double first_read_s = 0.25;
  pause(first_read_s);
  const auto w = m.read_input_registers(bm::kInWindowBase, bm::kWindowMaxWords);
  ASSERT_EQ(w[0], kSent);
  ASSERT_EQ((static_cast<std::uint32_t>(w[2]) << 16) | w[3], 0u);
  const int capacity = m.read_input_registers(bm::kInFifoCapacity, 1)[0];
  // (a) about capacity + 8 samples since RUN: 8 of the 17 delivered ones overwritten
  pause((capacity + kSent / 2.0) / kRateHz - first_read_s);
  const std::uint32_t f0 = front();
  const std::uint32_t o1 = overflows();
  const std::uint32_t f1 = front();
  ASSERT_GT(f0, 0u) << "delivered samples were overwritten during the stall";
  ASSERT_LE(f1, kSent) << "no sample the host had not received was dropped yet (a host this slow misses the window)";
  EXPECT_EQ(o1, 0u) << "a delivered but unacknowledged sample is not lost";
  EXPECT_EQ(m.read_input_registers(bm::kInStatus, 1)[0] & bm::kStatusOverflow, 0);
  // (b) 30 more samples: real loss, exactly what OVERFLOWS counts
  pause(0.3);
  const std::uint32_t o2 = overflows();
  const std::uint32_t f2 = front();
  const std::uint32_t o3 = overflows();
  ASSERT_GT(f2, kSent);
  EXPECT_LE(o2, f2 - kSent);
  EXPECT_GE(o3, f2 - kSent);
  EXPECT_NE(m.read_input_registers(bm::kInStatus, 1)[0] & bm::kStatusOverflow, 0);
  const auto next = m.read_input_registers(bm::kInWindowBase + static_cast<int>(kSent), bm::kWindowMaxWords);
  const std::uint32_t gap = ((static_cast<std::uint32_t>(next[2]) << 16) | next[3]) - kSent;
  EXPECT_GE(gap, f2 - kSent);
  EXPECT_LE(gap, overflows()) << "the gap the master marks is what OVERFLOWS counts";
  m.write_register(bm::kHoldCtrl, 0);
}

// The bench MCU a conformance test talks to: the firmware under simavr, or the C++ emulation
// (configured by `emulation`), with its serial device and a pause on its own clock.
struct McuUnderTest {
  std::unique_ptr<FirmwareInTheLoop> fw;
  std::unique_ptr<stend::emu::BenchMcuSlave> emu;
  std::string path;
  std::function<void(double)> pause = [](double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); };

  McuUnderTest(bool firmware, const stend::emu::BenchMcuConfig& emulation) {
    if (firmware) {
      fw = make_fw();
      path = fw->device_path();
      pause = [this](double s) { sim_sleep(*fw, s); };
    } else {
      emu = std::make_unique<stend::emu::BenchMcuSlave>(emulation, make_mpu());
      path = emu->device_path();
    }
  }
  McuUnderTest(const McuUnderTest&) = delete;  // `pause` holds `this`
  McuUnderTest& operator=(const McuUnderTest&) = delete;
};

class Conformance : public ::testing::TestWithParam<bool> {};

TEST_P(Conformance, RegisterMapAndWindowSequence) {
  McuUnderTest mcu(GetParam(), stend::emu::BenchMcuConfig{});
  check_register_map(mcu.path);
  check_window_sequence(mcu.path, mcu.pause);
}

TEST_P(Conformance, OverflowsCountOnlySamplesTheHostNeverReceived) {
  stend::emu::BenchMcuConfig c;
  c.fifo_depth = 48;  // small, so a stall of half a second fills it
  McuUnderTest mcu(GetParam(), c);
  check_overflow_counting(mcu.path, mcu.pause);
}

INSTANTIATE_TEST_SUITE_P(FirmwareAndEmulation, Conformance, ::testing::Values(true, false),
                         [](const ::testing::TestParamInfo<bool>& p) { return p.param ? "firmware" : "cpp_emulation"; });

// ---- Firmware only ----------------------------------------------------------------------------
TEST(FirmwareInLoop, EachExceptionCode) {
  auto fw = make_fw();
  const std::string p = fw->device_path();
  EXPECT_EQ(raw_request(p, {1, 0x05, 0x00, 0x00, 0xFF, 0x00}), std::make_pair(0x85, 1));  // FC 05: illegal function
  EXPECT_EQ(raw_request(p, {1, 0x04, 0x00, 0x07, 0x00, 0x01}), std::make_pair(0x84, 2));  // unmapped input register
  EXPECT_EQ(raw_request(p, {1, 0x04, 0x00, 0x00, 0x00, 0x00}), std::make_pair(0x84, 3));  // count 0
  EXPECT_EQ(raw_request(p, {1, 0x03, 0x00, 0x00, 0x00, 0x7E}), std::make_pair(0x83, 3));  // count 126 > 125
  EXPECT_EQ(raw_request(p, {kChamberSlave, 0x04, 0x00, 0x0A, 0x00, 0x01}), std::make_pair(0x84, 2));
  fw->set_mpu_present(false);  // RUN cannot configure a sensor that does not answer: 04
  auto m = client(p);
  EXPECT_EQ(exception_of([&] { m.write_register(bm::kHoldCtrl, bm::kCtrlRun); }), MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE);
  EXPECT_EQ(m.read_input_registers(bm::kInStatus, 1)[0] & bm::kStatusRunning, 0);
  EXPECT_EQ(m.read_input_registers(bm::kInWhoAmI, 1)[0], 0);
  fw->set_mpu_present(true);
  m.write_register(bm::kHoldCtrl, bm::kCtrlRun);
  EXPECT_EQ(m.read_input_registers(bm::kInStatus, 1)[0] & bm::kStatusRunning, bm::kStatusRunning);
}

TEST(FirmwareInLoop, CrcErrorsAndTimeoutsOnTheLineAreRetried) {
  auto fw = make_fw();
  auto m = client(fw->device_path(), 1, 6, 50);
  fw->set_reply_corrupt_probability(0.3);
  fw->set_request_corrupt_probability(0.2);
  for (int i = 0; i < 40; ++i) EXPECT_EQ(m.read_input_registers(bm::kInFirmware, 1)[0], bm::kFirmwareVersion);
  EXPECT_GT(m.stats().crc_errors, 0u) << "corrupted replies are CRC errors at the master";
  EXPECT_GT(m.stats().timeouts, 0u) << "a corrupted request gets no reply from the firmware";
  const auto st = fw->stats();
  EXPECT_GT(st.corrupted_replies, 0u);
  EXPECT_GT(st.corrupted_requests, 0u);
  fw->set_reply_corrupt_probability(0.0);
  fw->set_request_corrupt_probability(0.0);
  fw->go_silent(300ms);
  auto once = client(fw->device_path(), 1, 0, 50);
  try {
    once.read_input_registers(bm::kInFirmware, 1);
    FAIL() << "a silent line must time out";
  } catch (const ModbusError& e) {
    EXPECT_EQ(e.kind(), ModbusError::Kind::kTimeout) << e.what();
  }
  std::this_thread::sleep_for(350ms);  // go_silent counts wall time
  EXPECT_EQ(once.read_input_registers(bm::kInFirmware, 1)[0], bm::kFirmwareVersion);
}

TEST(FirmwareInLoop, WindowAcrossAStallMarksTheGapAndCountsOverflows) {
  auto fw = make_fw();
  auto m = client(fw->device_path());
  m.write_register(bm::kHoldSmplrtDiv, 0);
  m.write_register(bm::kHoldDlpfCfg, 1);
  m.write_register(bm::kHoldCtrl, bm::kCtrlRun);
  sim_sleep(*fw, 0.02);
  auto w = m.read_input_registers(bm::kInWindowBase, bm::kWindowMaxWords);
  std::uint32_t s = w[0];
  EXPECT_EQ((static_cast<std::uint32_t>(w[2]) << 16) | w[3], 0u);
  const int capacity = m.read_input_registers(bm::kInFifoCapacity, 1)[0];
  sim_sleep(*fw, 0.4);  // the master stalls: ~400 samples > ring + the part's FIFO
  w = m.read_input_registers(bm::kInWindowBase + static_cast<int>(s), bm::kWindowMaxWords);
  const std::uint32_t first = (static_cast<std::uint32_t>(w[2]) << 16) | w[3];
  EXPECT_GT(first, s) << "samples overwritten during the stall: the window starts after a gap";
  EXPECT_NEAR(w[0] + w[1], capacity, 4) << "the buffers are full after the stall";
  const auto in = m.read_input_registers(0, bm::kInCount);
  EXPECT_NE(in[bm::kInStatus] & bm::kStatusOverflow, 0);
  EXPECT_GT(in[bm::kInOverflows], 0);
  // The master catches up (the buffers drain faster than 1 kHz fills them; a window is ≈ 4 ms of
  // the line, longer for a host slowed by load or sanitizers) …
  s = first + w[0];
  for (int k = 0; k < 200 && w[1] > 0; ++k) {
    w = m.read_input_registers(bm::kInWindowBase + static_cast<int>(s % bm::kWindowSeqModulo), bm::kWindowMaxWords);
    s = ((static_cast<std::uint32_t>(w[2]) << 16) | w[3]) + w[0];
  }
  EXPECT_EQ(w[1], 0) << "drained";
  m.read_input_registers(bm::kInStatus, 1);
  const auto overflows = m.read_input_registers(bm::kInOverflows, 1)[0];
  // … and from then on the sequence continues; a gap only where OVERFLOWS counts one (a host
  // starved of CPU may fall behind again).
  std::uint32_t gaps = 0;
  for (int k = 0; k < 10; ++k) {
    sim_sleep(*fw, 0.01);
    w = m.read_input_registers(bm::kInWindowBase + static_cast<int>(s % bm::kWindowSeqModulo), bm::kWindowMaxWords);
    const std::uint32_t f = (static_cast<std::uint32_t>(w[2]) << 16) | w[3];
    gaps += f - s;
    s = f + w[0];
  }
  const auto overflows_after = m.read_input_registers(bm::kInOverflows, 1)[0];
  EXPECT_LE(gaps, static_cast<std::uint32_t>(overflows_after - overflows));
  if (overflows_after == overflows) {
    EXPECT_EQ(m.read_input_registers(bm::kInStatus, 1)[0] & bm::kStatusOverflow, 0) << "cleared by reading";
  }
}

TEST(FirmwareInLoop, BootCountTellsARestart) {
  auto fw = make_fw();
  auto m = client(fw->device_path());
  const auto boots = m.read_input_registers(bm::kInBootCount, 1)[0];
  EXPECT_EQ(boots, 1);
  fw->reset_mcu();
  sim_sleep(*fw, 0.05);
  EXPECT_EQ(m.read_input_registers(bm::kInBootCount, 1)[0], boots + 1) << "BOOT_COUNT lives in EEPROM";
}

// The firmware hangs (a tight loop with interrupts off, as a bug leaves it): the outputs stay as
// they were until the AVR's own watchdog (250 ms) resets the part — every pin an input, heater and
// Peltier off, BOOT_COUNT up by one, RUN cleared: the host sees the restart.
TEST(FirmwareInLoop, HardwareWatchdogResetsAHungFirmware) {
  auto fw = make_fw(1.0, 35.0);
  auto chamber = client(fw->device_path(), kChamberSlave);
  auto sensor = client(fw->device_path());
  chamber.write_register(cm::kHoldSetpoint, 2500);  // 10 °C below the air: the Peltier runs
  chamber.write_register(cm::kHoldCtrl, cm::kCtrlRun);
  sensor.write_register(bm::kHoldCtrl, bm::kCtrlRun);
  sim_sleep(*fw, 1.5);
  ASSERT_EQ(fw->peltier_pwm(), 255);
  const auto boots = sensor.read_input_registers(bm::kInBootCount, 1)[0];
  const auto resets = fw->stats().resets;
  fw->hang_mcu();
  sim_sleep(*fw, 0.1);
  EXPECT_EQ(fw->peltier_pwm(), 255) << "hung, not yet reset: Timer1 keeps the duty";
  EXPECT_EQ(fw->stats().resets, resets);
  sim_sleep(*fw, 0.3);  // past the 250 ms watchdog
  EXPECT_EQ(fw->stats().resets, resets + 1) << "the AVR's watchdog reset the part";
  EXPECT_EQ(fw->peltier_pwm(), 0);
  EXPECT_EQ(fw->heater_pwm(), 0);
  const auto in = sensor.read_input_registers(0, bm::kInCount);
  EXPECT_EQ(in[bm::kInBootCount], boots + 1) << "BOOT_COUNT tells the host the MCU restarted";
  EXPECT_EQ(in[bm::kInStatus] & bm::kStatusRunning, 0) << "the stream stopped with the reset";
  const auto ch = chamber.read_input_registers(0, cm::kInCount);
  EXPECT_EQ(ch[cm::kInPeltierPwm], 0);
  EXPECT_EQ(ch[cm::kInHeaterPwm], 0);
  EXPECT_EQ(chamber.read_holding_registers(cm::kHoldCtrl, 1)[0] & cm::kCtrlRun, 0) << "the loop waits to be told to RUN again";
  const double t = fw->stats().simulated_s;
  sim_sleep(*fw, 0.5);
  EXPECT_GT(fw->stats().simulated_s, t + 0.49) << "simulated time runs on across the reset";
  EXPECT_EQ(fw->stats().resets, resets + 1) << "the restarted firmware feeds its watchdog again";
}

TEST(FirmwareInLoop, Ds18b20ReadingCrcErrorAndOpenSensor) {
  auto fw = make_fw(1.0, 22.0);
  auto m = client(fw->device_path(), kChamberSlave);
  ASSERT_TRUE(fw->wait_until_simulated(2.2, 5s));
  auto in = m.read_input_registers(0, cm::kInCount);
  EXPECT_EQ(in[cm::kInFirmware], cm::kFirmwareVersion);
  EXPECT_NEAR(static_cast<std::int16_t>(in[cm::kInTempRaw]), std::lround(fw->air_c() * 16), 2)
      << "the DS18B20 read over bit-banged 1-Wire: the plant's air temperature";
  EXPECT_EQ(in[cm::kInStatus] & cm::kStatusSensorFault, 0);
  EXPECT_GE(in[cm::kInCycles], 2);
  fw->set_ds18b20_fault(Ds18b20Fault::kCrcError);
  sim_sleep(*fw, 1.1);
  in = m.read_input_registers(0, cm::kInCount);
  EXPECT_NE(in[cm::kInStatus] & cm::kStatusSensorFault, 0) << "a CRC error is a sensor fault";
  EXPECT_GE(in[cm::kInSensorErrors], 1);
  fw->set_ds18b20_fault(Ds18b20Fault::kOpen);
  m.write_register(cm::kHoldCtrl, cm::kCtrlClearFault);
  sim_sleep(*fw, 1.1);
  in = m.read_input_registers(0, cm::kInCount);
  EXPECT_EQ(static_cast<std::int16_t>(in[cm::kInTempRaw]), cm::kRawDisconnected);
  EXPECT_NE(in[cm::kInStatus] & cm::kStatusSensorFault, 0);
  EXPECT_EQ(fw->heater_pwm(), 0);
  EXPECT_EQ(fw->peltier_pwm(), 0);
}

TEST(FirmwareInLoop, MasterWatchdogForcesOutputsOff) {
  auto fw = make_fw(1.0, 35.0);
  auto m = client(fw->device_path(), kChamberSlave);
  m.write_register(cm::kHoldSetpoint, 2500);  // 10 °C below the air: the Peltier runs
  m.write_register(cm::kHoldWatchdog, 1);
  m.write_register(cm::kHoldCtrl, cm::kCtrlRun);
  sim_sleep(*fw, 0.8);
  m.read_input_registers(0, cm::kInCount);  // the master is alive
  sim_sleep(*fw, 0.7);
  auto in = m.read_input_registers(0, cm::kInCount);
  EXPECT_EQ(in[cm::kInStatus] & cm::kStatusWatchdog, 0);
  EXPECT_EQ(in[cm::kInPeltierPwm], 255) << "u = 100·10 + … saturates: Peltier full";
  EXPECT_EQ(fw->peltier_pwm(), 255) << "the duty on pin 9 (OCR1A) is what the register says";
  sim_sleep(*fw, 2.2);  // silent for > 1 s
  in = m.read_input_registers(0, cm::kInCount);
  EXPECT_NE(in[cm::kInStatus] & cm::kStatusWatchdog, 0);
  EXPECT_EQ(in[cm::kInPeltierPwm], 0);
  EXPECT_EQ(fw->peltier_pwm(), 0);
  EXPECT_EQ(fw->heater_pwm(), 0);
}

// The published PID on the plant, a short window of the step response (the full ~900 s run is
// firmware_loop_bench pid): the firmware's air temperature and integral follow the C++ emulation of
// the same loop (emulators/chamber) on the same plant. The firmware reads the conversion started
// one cycle before, so the two differ by up to one cycle of lag.
TEST(FirmwareInLoop, PidStepFollowsTheCppEmulationOfThePublishedLoop) {
  constexpr double kInitial = 35.0, kSetpoint = 25.0, kWindow = 30.0;  // the paper's 10 °C cooling step
  auto fw = make_fw(0.0, kInitial);  // unpaced
  auto m = client(fw->device_path(), kChamberSlave, 3, 500);
  m.write_register(cm::kHoldSetpoint, static_cast<std::uint16_t>(kSetpoint * 100));
  m.write_register(cm::kHoldCtrl, cm::kCtrlRun);
  const double t_run = fw->stats().simulated_s;
  stend::emu::ChamberEmuConfig ec;
  ec.plant.initial_c = kInitial;
  stend::emu::ChamberFirmware cpp(ec);
  cpp.write_holding(cm::kHoldSetpoint, static_cast<std::uint16_t>(kSetpoint * 100));
  cpp.write_holding(cm::kHoldCtrl, cm::kCtrlRun);
  double worst = 0.0;
  for (double t = 5.0; t <= kWindow; t += 5.0) {
    ASSERT_TRUE(fw->wait_until_simulated(t_run + t, 20s));
    cpp.advance_to(t);
    worst = std::max(worst, std::fabs(fw->air_c() - cpp.air_c()));
  }
  EXPECT_LT(worst, 0.3) << "air temperature, firmware vs C++ emulation of the same loop";
  EXPECT_LT(fw->air_c(), kInitial - 1.0) << "the Peltier (and the room) cool toward the setpoint";
  const auto in = m.read_input_registers(0, cm::kInCount);
  EXPECT_NEAR(in[cm::kInPeltierPwm], cpp.peltier_pwm(), 30);
  EXPECT_EQ(in[cm::kInHeaterPwm], 0);
  EXPECT_NEAR(static_cast<std::int16_t>(in[cm::kInIntegral]) / 100.0, cpp.integral(), 1.1);  // one cycle of I_STEP·err apart
}

}  // namespace
