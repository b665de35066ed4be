// mpu6050_modbus against the emulated bench microcontroller: a real MODBUS RTU slave (libmodbus)
// on a pseudo-terminal, reading an MPU-6050 register model backed by SimImu. The driver opens the
// pty's slave-side path exactly as it would open /dev/ttyUSB0.
#include <gtest/gtest.h>

#include <stend/core/experiment.hpp>
#include <stend/devices/modbus_rtu.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>
#include <yaml-cpp/yaml.h>

#include "bench_mcu_slave.hpp"
#include "mpu6050_modbus.hpp"

extern "C" const stend_plugin_info* stend_plugin_entry(void);

namespace {

using stend::ImuSample;
using stend::emu::BenchMcuConfig;
using stend::emu::BenchMcuSlave;
using stend::emu::Mpu6050Model;
using stend::mpu6050::Mpu6050Modbus;
using stend::mpu6050::Mpu6050ModbusConfig;
using Clock = std::chrono::steady_clock;

constexpr double kG = 9.80665;

class NoTruth final : public stend::TruthSource {
 public:
  stend::BenchTruth at(double t) const override {
    stend::BenchTruth b;
    b.t_s = t;
    return b;
  }
};

stend::BenchTruth bench_truth() {
  stend::BenchTruth t;
  t.specific_force_mps2 = {0.3, -0.2, kG};
  t.angular_rate_radps = {0.01, -0.02, 0.005};
  t.die_temperature_c = 30.0;
  t.air_temperature_c = 30.0;
  return t;
}

std::unique_ptr<BenchMcuSlave> make_mcu(std::uint8_t who = 0x68, std::size_t fifo = 1024) {
  stend::sim::SimImuConfig physics;  // MPU-6050 defaults: noise, bias instability, random walk
  physics.seed = 42;
  BenchMcuConfig c;
  c.fifo_depth = fifo;
  return std::make_unique<BenchMcuSlave>(c, Mpu6050Model(physics, bench_truth(), who));
}

Mpu6050ModbusConfig driver_cfg(const std::string& device) {
  Mpu6050ModbusConfig c;
  c.device = device;
  c.timeout_ms = 50;
  c.retries = 3;
  return c;
}

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Polls like a runner would: every poll_ms, acquire up to t = duration; tolerates thrown
// device faults (counted) and keeps going until every sample up to `duration_s` arrived or
// the wall clock ran out.
struct PollResult {
  std::vector<ImuSample> samples;
  int faults = 0;
  std::vector<std::string> fault_texts;
  double cpu_s = 0.0;
};
PollResult poll(Mpu6050Modbus& s, double duration_s, int poll_ms, const std::function<void(double)>& at_wall = {}) {
  PollResult r;
  const NoTruth truth;
  const auto t0 = Clock::now();
  const double period = 1.0 / s.info().output_rate_hz;
  while (true) {
    std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
    const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
    if (at_wall) at_wall(wall);
    const double c0 = thread_cpu_s();
    try {
      s.acquire(duration_s, truth, r.samples);
    } catch (const std::runtime_error& e) {
      ++r.faults;
      r.fault_texts.push_back(e.what());
    }
    r.cpu_s += thread_cpu_s() - c0;
    if (!r.samples.empty() && r.samples.back().t_s >= duration_s - 0.5 * period) break;
    if (wall > duration_s + 3.0) break;
  }
  return r;
}

TEST(Mpu6050Modbus, ExampleValidatesAndImpossibleRatesAreRefused) {
  // `device` has no default: the schema requires it.
  EXPECT_THROW(stend::params_from_yaml(YAML::Load("{}"), *stend_plugin_entry(), "test.yaml", "config"), std::exception);
  const YAML::Node doc = YAML::LoadFile(std::string(STEND_SOURCE_DIR) + "/sensors/mpu6050/example.yaml");
  EXPECT_EQ(doc["plugin"].as<std::string>(), "mpu6050_modbus");
  const auto pe = stend::params_from_yaml(doc["config"], *stend_plugin_entry(), "example.yaml", "config");
  const Mpu6050Modbus sensor(pe);  // validates, does not open the port
  EXPECT_DOUBLE_EQ(sensor.info().output_rate_hz, 500.0);
  // Rates the part cannot make are refused with the nearest one it can.
  auto bad = driver_cfg("/dev/null");
  bad.dlpf_hz = 44;
  bad.output_rate_hz = 3000.0;
  EXPECT_THROW(Mpu6050Modbus{bad}, std::invalid_argument);
}

TEST(Mpu6050Modbus, WhoAmIPasses) {
  auto mcu = make_mcu();
  Mpu6050Modbus s(driver_cfg(mcu->device_path()));
  s.start(0.0);
  EXPECT_EQ(s.identity().who_am_i, "0x68");
  EXPECT_EQ(s.identity().model, "MPU-6050");
}

TEST(Mpu6050Modbus, WrongIdentityNamesDeviceExpectedAndActual) {
  auto mcu = make_mcu(0x70);
  Mpu6050Modbus s(driver_cfg(mcu->device_path()));
  try {
    s.start(0.0);
    FAIL() << "start() accepted WHO_AM_I 0x70";
  } catch (const std::runtime_error& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find(mcu->device_path()), std::string::npos) << w;
    EXPECT_NE(w.find("slave 1"), std::string::npos) << w;
    EXPECT_NE(w.find("expected 0x68"), std::string::npos) << w;
    EXPECT_NE(w.find("0x70"), std::string::npos) << w;
  }
}

TEST(Mpu6050Modbus, OneSecondAt1kHzNoLossMeanMatchesTruth) {
  auto mcu = make_mcu();
  Mpu6050Modbus s(driver_cfg(mcu->device_path()));
  s.start(0.0);
  const PollResult r = poll(s, 1.0, 50);
  ASSERT_EQ(r.faults, 0) << (r.fault_texts.empty() ? "" : r.fault_texts.front());
  ASSERT_EQ(r.samples.size(), 1000u);
  Eigen::Vector3d fa = Eigen::Vector3d::Zero(), wg = Eigen::Vector3d::Zero();
  double temp = 0.0;
  for (std::size_t k = 0; k < r.samples.size(); ++k) {
    const ImuSample& x = r.samples[k];
    ASSERT_NEAR(x.t_s, 1e-3 * static_cast<double>(k + 1), 1e-9);
    ASSERT_EQ(x.flags, 0u);
    fa += x.accel_mps2;
    wg += x.gyro_radps;
    temp += x.temperature_c;
  }
  const double n = static_cast<double>(r.samples.size());
  fa /= n;
  wg /= n;
  temp /= n;
  const auto truth = bench_truth();
  // σ of a 1000-sample mean: accel ≈ 0.0028 m/s², gyro ≈ 6e-5 rad/s, plus bias instability
  // (5e-4 m/s², 5e-5 rad/s) and one LSB (6e-4 m/s², 1.3e-4 rad/s).
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(fa[i], truth.specific_force_mps2[i], 0.015) << "axis " << i;
    EXPECT_NEAR(wg[i], truth.angular_rate_radps[i], 5e-4) << "axis " << i;
  }
  EXPECT_NEAR(temp, 30.0, 0.01);
  const auto& rep = s.report();
  const double wire = static_cast<double>(rep.bus.request_bytes + rep.bus.reply_bytes);
  const double ratio = static_cast<double>(rep.payload_bytes) / wire;
  std::printf("[figures] 1 kHz, poll 50 ms: %llu samples in %llu window reads (%llu transactions); "
              "payload/wire bytes = %.3f; wire load at 921600 baud = %.1f%%; host CPU per sample = %.2f us\n",
              static_cast<unsigned long long>(rep.samples), static_cast<unsigned long long>(rep.window_reads),
              static_cast<unsigned long long>(rep.bus.transactions), ratio, 100.0 * wire * 10.0 / 921600.0,
              1e6 * r.cpu_s / n);
  RecordProperty("payload_over_wire", std::to_string(ratio));
  RecordProperty("cpu_us_per_sample", std::to_string(1e6 * r.cpu_s / n));
  EXPECT_GE(ratio, 0.9);
}

TEST(Mpu6050Modbus, CrcErrorsAreRetriedAndReportedNoGarbage) {
  auto mcu = make_mcu();
  auto c = driver_cfg(mcu->device_path());
  c.retries = 6;
  Mpu6050Modbus s(c);
  s.start(0.0);
  mcu->set_corrupt_probability(0.15);
  const PollResult r = poll(s, 0.5, 20);
  mcu->set_corrupt_probability(0.0);
  ASSERT_EQ(r.faults, 0) << (r.fault_texts.empty() ? "" : r.fault_texts.front());
  ASSERT_EQ(r.samples.size(), 500u);
  for (std::size_t k = 0; k < r.samples.size(); ++k) {
    const ImuSample& x = r.samples[k];
    ASSERT_NEAR(x.t_s, 1e-3 * static_cast<double>(k + 1), 1e-9);
    ASSERT_EQ(x.flags, 0u);
    ASSERT_NEAR(x.accel_mps2.z(), kG, 0.6) << "sample " << k;  // ±6σ of the white noise
    ASSERT_NEAR(x.temperature_c, 30.0, 0.01) << "sample " << k;
  }
  const auto& rep = s.report();
  EXPECT_GT(mcu->stats().corrupted, 0u);
  EXPECT_EQ(rep.bus.crc_errors, mcu->stats().corrupted);
  EXPECT_GE(rep.bus.retries, rep.bus.crc_errors);
  ASSERT_FALSE(rep.events.empty());
  EXPECT_NE(rep.events.front().find("CRC"), std::string::npos) << rep.events.front();
  EXPECT_EQ(rep.samples_lost, 0u);
  std::printf("[figures] CRC test: %llu corrupted replies, all retried; %zu event lines, e.g. %s\n",
              static_cast<unsigned long long>(rep.bus.crc_errors), rep.events.size(), rep.events.front().c_str());
}

TEST(Mpu6050Modbus, TimeOutRetriesThenGapMarkedSamplesKept) {
  auto mcu = make_mcu(0x68, 128);  // 128 ms of FIFO: a 300 ms outage overflows it
  auto c = driver_cfg(mcu->device_path());
  c.retries = 2;  // 3 × 50 ms + back-off < 300 ms: the outage outlasts the retries
  Mpu6050Modbus s(c);
  s.start(0.0);
  bool silenced = false;
  const PollResult r = poll(s, 1.0, 20, [&](double wall) {
    if (!silenced && wall > 0.2) {
      mcu->go_silent(std::chrono::milliseconds(300));
      silenced = true;
    }
  });
  const auto& rep = s.report();
  EXPECT_GE(r.faults, 1);
  ASSERT_FALSE(r.fault_texts.empty());
  EXPECT_NE(r.fault_texts.front().find(mcu->device_path()), std::string::npos) << r.fault_texts.front();
  EXPECT_NE(r.fault_texts.front().find("timed out"), std::string::npos) << r.fault_texts.front();
  EXPECT_GT(rep.bus.timeouts, 0u);
  EXPECT_GT(rep.bus.retries, 0u);
  EXPECT_EQ(rep.gaps, 1u);
  EXPECT_GT(rep.samples_lost, 50u);
  // Contiguous before and after the one gap; the gap's length is the samples lost.
  ASSERT_GT(r.samples.size(), 300u);
  int gaps = 0;
  for (std::size_t k = 1; k < r.samples.size(); ++k) {
    const double dt = r.samples[k].t_s - r.samples[k - 1].t_s;
    if (r.samples[k].flags & stend::kGapBefore) {
      ++gaps;
      EXPECT_NEAR(dt, 1e-3 * static_cast<double>(rep.samples_lost + 1), 1e-9);
    } else {
      ASSERT_NEAR(dt, 1e-3, 1e-9) << "sample " << k;
    }
    ASSERT_NEAR(r.samples[k].accel_mps2.z(), kG, 0.6);
  }
  EXPECT_EQ(gaps, 1);
  EXPECT_NEAR(r.samples.front().t_s, 1e-3, 1e-9);
  EXPECT_NEAR(r.samples.back().t_s, 1.0, 1e-9);
  EXPECT_EQ(r.samples.size() + rep.samples_lost, 1000u);
  std::printf("[figures] time-out test: %d acquire() faults, %llu time-outs, %llu samples lost, 1 gap flagged\n",
              r.faults, static_cast<unsigned long long>(rep.bus.timeouts), static_cast<unsigned long long>(rep.samples_lost));
}

TEST(Mpu6050Modbus, SlaveExceptionNamesTheRegister) {
  auto mcu = make_mcu();
  stend::transport::ModbusRtuConfig c;
  c.device = mcu->device_path();
  c.response_timeout_ms = 50;
  stend::transport::ModbusRtuClient bus(c);
  EXPECT_EQ(bus.read_input_registers(0x0001, 1).at(0), 0x68);
  try {
    bus.read_input_registers(0x0300, 2);
    FAIL() << "no exception for an unmapped register";
  } catch (const stend::transport::ModbusError& e) {
    const std::string w = e.what();
    EXPECT_EQ(e.kind(), stend::transport::ModbusError::Kind::kException);
    EXPECT_EQ(e.exception_code(), 2);
    EXPECT_NE(w.find("0x0300"), std::string::npos) << w;
    EXPECT_NE(w.find("Illegal data address"), std::string::npos) << w;
    EXPECT_NE(w.find(mcu->device_path()), std::string::npos) << w;
    EXPECT_NE(w.find("FC 04"), std::string::npos) << w;
  }
  EXPECT_EQ(bus.stats().retries, 0u);  // a definitive answer is not retried
}

}  // namespace

// Checks the stream's invariants: one sample per period except after a flagged gap, whose length
// is the samples lost; nothing duplicated.
void expect_contiguous_but_for_gaps(const std::vector<ImuSample>& samples, std::uint64_t lost) {
  std::uint64_t skipped = 0;
  for (std::size_t k = 1; k < samples.size(); ++k) {
    const double dt = samples[k].t_s - samples[k - 1].t_s;
    ASSERT_GT(dt, 0.5e-3) << "sample " << k << " repeats or goes back in time";
    if (samples[k].flags & stend::kGapBefore) skipped += static_cast<std::uint64_t>(std::llround(dt / 1e-3)) - 1;
    else ASSERT_NEAR(dt, 1e-3, 1e-9) << "sample " << k;
  }
  EXPECT_EQ(skipped, lost);
}

// A 2 s stall of the MCU: the requests sent meanwhile are answered late, in order, so replies to
// requests the driver gave up on arrive after it moved on. The driver drops the overlap (the
// BOOT_COUNT is unchanged), marks the samples the overflowing FIFO lost as a gap and never
// declares a restart.
TEST(Mpu6050Modbus, StallIsRiddenOutWithoutDeclaringARestart) {
  for (int trial = 0; trial < 3; ++trial) {
    auto mcu = make_mcu(0x68, 1024);
    auto c = driver_cfg(mcu->device_path());
    Mpu6050Modbus s(c);
    s.start(0.0);
    bool stalled = false;
    const PollResult r = poll(s, 3.0, 20, [&](double wall) {
      if (!stalled && wall > 0.3) {
        mcu->stall(std::chrono::milliseconds(2000));
        stalled = true;
      }
    });
    for (const auto& t : r.fault_texts) EXPECT_EQ(t.find("restarted"), std::string::npos) << t;
    const auto& rep = s.report();
    ASSERT_GT(r.samples.size(), 1000u);
    expect_contiguous_but_for_gaps(r.samples, rep.samples_lost);
    EXPECT_NEAR(r.samples.back().t_s, 3.0, 1e-9);
    EXPECT_EQ(r.samples.size() + rep.samples_lost, 3000u);
    EXPECT_GT(rep.samples_lost, 500u);  // 2 s at 1 kHz into a 1024-sample FIFO
    std::printf("[figures] stall trial %d: %d acquire() faults, %llu samples lost, %llu resynchronisations\n", trial,
                r.faults, static_cast<unsigned long long>(rep.samples_lost),
                static_cast<unsigned long long>(rep.resyncs));
  }
}

// A real restart of the MCU (BOOT_COUNT moves): the stream cannot continue, and the error says
// why with both counter values.
TEST(Mpu6050Modbus, RestartIsDeclaredFromTheBootCounter) {
  auto mcu = make_mcu();
  Mpu6050Modbus s(driver_cfg(mcu->device_path()));
  s.start(0.0);
  bool restarted = false;
  const PollResult r = poll(s, 1.0, 20, [&](double wall) {
    if (!restarted && wall > 0.3) {
      mcu->restart();
      restarted = true;
    }
  });
  ASSERT_FALSE(r.fault_texts.empty());
  EXPECT_NE(r.fault_texts.front().find("bench MCU restarted (BOOT_COUNT 1 -> 2)"), std::string::npos)
      << r.fault_texts.front();
  expect_contiguous_but_for_gaps(r.samples, 0);
}
