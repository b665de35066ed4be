// The five I2C sensor drivers against register models on an emulated I2C bus, over every route:
// emulated Linux i2c-dev (the real driver's I2C_RDWR code), in-process MCP2221A and CP2112
// models (the real report encoders), and the bench MCU's MODBUS RTU window on a pseudo-terminal.
// The models' counts come from SimImu driven by a known truth, so SI values are checked against it.
#include <gtest/gtest.h>

#include <stend/core/experiment.hpp>
#include <stend/devices/i2c_hid.hpp>

#include <dlfcn.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>
#include <thread>
#include <vector>
#include <yaml-cpp/yaml.h>

#include "bench_mcu_slave.hpp"
#include "hid_bridge_models.hpp"
#include "i2c_dev_emulator.hpp"
#include "i2c_imu.hpp"
#include "imu_chip_models.hpp"

namespace {

using namespace stend;
using i2c_imu::I2cImuConfig;
using i2c_imu::I2cImuSensor;
constexpr double kG = 9.80665;

BenchTruth bench_truth() {
  BenchTruth t;
  t.specific_force_mps2 = {0.3, -0.2, kG};
  t.angular_rate_radps = {0.01, -0.02, 0.005};
  t.die_temperature_c = 30.0;
  t.air_temperature_c = 30.0;
  return t;
}

sim::SimImuConfig physics() {
  sim::SimImuConfig p;  // default noise, bias instability and random walk
  p.seed = 42;
  return p;
}

class NoTruth final : public TruthSource {
 public:
  BenchTruth at(double t) const override {
    BenchTruth b;
    b.t_s = t;
    return b;
  }
};

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

enum class Chip { kMpu6050, kAdxl345, kLsm6dso, kBmi160, kIcm42688p };
const char* chip_name(Chip c) {
  switch (c) {
    case Chip::kMpu6050: return "mpu6050";
    case Chip::kAdxl345: return "adxl345";
    case Chip::kLsm6dso: return "lsm6dso";
    case Chip::kBmi160: return "bmi160";
    default: return "icm42688p";
  }
}
std::uint8_t chip_address(Chip c) {
  switch (c) {
    case Chip::kAdxl345: return 0x53;
    case Chip::kLsm6dso: return 0x6A;
    case Chip::kBmi160: return 0x69;  // on the bench MCU's bus the MPU-6050 holds 0x68
    default: return 0x68;
  }
}

std::shared_ptr<emu::I2cTarget> make_model(Chip c, int identity = -1) {
  const auto truth = emu::static_truth(bench_truth());
  switch (c) {
    case Chip::kMpu6050:
      return std::make_shared<emu::Mpu6050I2c>(emu::Mpu6050Model(physics(), bench_truth(), static_cast<std::uint8_t>(identity < 0 ? 0x68 : identity)));
    case Chip::kAdxl345: return std::make_shared<emu::Adxl345Model>(physics(), truth, identity < 0 ? 0xE5 : identity);
    case Chip::kLsm6dso: return std::make_shared<emu::Lsm6dsoModel>(physics(), truth, identity < 0 ? 0x6C : identity);
    case Chip::kBmi160: return std::make_shared<emu::Bmi160Model>(physics(), truth, identity < 0 ? 0xD1 : identity);
    default: return std::make_shared<emu::Icm42688Model>(physics(), truth, identity < 0 ? 0x47 : identity);
  }
}

std::unique_ptr<i2c_imu::ChipDriver> make_driver(Chip c) {
  switch (c) {
    case Chip::kMpu6050: return i2c_imu::make_mpu6050();
    case Chip::kAdxl345: return i2c_imu::make_adxl345();
    case Chip::kLsm6dso: return i2c_imu::make_lsm6dso();
    case Chip::kBmi160: return i2c_imu::make_bmi160();
    default: return i2c_imu::make_icm42688p();
  }
}

// Atomic: the bench MCU emulator's thread reads it.
std::shared_ptr<std::atomic<double>> manual_clock(emu::EmulatedI2cBus& bus) {
  auto now = std::make_shared<std::atomic<double>>(0.0);
  bus.set_clock([now] { return now->load(); });
  return now;
}

// An emulated bench: one I2C bus reachable through every route.
struct World {
  std::shared_ptr<emu::EmulatedI2cBus> bus = std::make_shared<emu::EmulatedI2cBus>();
  std::shared_ptr<emu::EmulatedI2cDevFile> dev = std::make_shared<emu::EmulatedI2cDevFile>();
  std::shared_ptr<emu::EmulatedHidBackend> hid = std::make_shared<emu::EmulatedHidBackend>();
  std::unique_ptr<emu::BenchMcuSlave> mcu;  // its MPU-6050 sits at 0x68 on its side

  World() {
    dev->add_adapter("/dev/i2c-1", bus);
    hid->add(transport::kMcp2221Vid, transport::kMcp2221Pid, "M1", std::make_shared<emu::Mcp2221Model>("/dev/hidraw-emu0", bus));
    hid->add(transport::kCp2112Vid, transport::kCp2112Pid, "C1", std::make_shared<emu::Cp2112Model>("/dev/hidraw-emu1", bus));
  }
  I2cImuConfig config(Chip c, const std::string& route) {
    I2cImuConfig k;
    k.route.bus = route;
    k.route.i2c_dev_file = dev;
    k.route.hid_backend = hid;
    k.route.timeout_ms = 50;
    k.address = chip_address(c);
    k.accel_range_g = 2;
    k.gyro_range_dps = 250;
    k.output_rate_hz = c == Chip::kLsm6dso ? 104.0 : 100.0;
    if (c == Chip::kMpu6050) k.dlpf_hz = 44;  // 1 kHz / (1 + 9)
    if (route == "i2c-dev") k.route.device = "/dev/i2c-1";
    if (route == "bench_mcu") {
      mcu = std::make_unique<emu::BenchMcuSlave>(emu::BenchMcuConfig{}, emu::Mpu6050Model(physics(), bench_truth()), bus);
      k.route.device = mcu->device_path();
      k.route.timeout_ms = 100;
    }
    return k;
  }
};

// Polls like a runner: acquire every `poll_ms` until `n` samples arrived (or 5 s passed). With
// `sim_clock` (the bus's clock, see manual_clock) the bus time advances by poll_ms per call
// instead of the test sleeping: independent of machine load.
std::vector<ImuSample> collect(I2cImuSensor& s, std::size_t n, int poll_ms, double* cpu_s = nullptr,
                               std::shared_ptr<std::atomic<double>> sim_clock = nullptr) {
  std::vector<ImuSample> out;
  const NoTruth truth;
  const auto t0 = std::chrono::steady_clock::now();
  double cpu = 0.0;
  while (out.size() < n && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(5)) {
    double run_t = 0.0;
    if (sim_clock) {
      run_t = sim_clock->load() + 1e-3 * poll_ms;
      sim_clock->store(run_t);
    } else {
      static const auto origin = std::chrono::steady_clock::now();  // run clock: wall time since the first call
      std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
      run_t = std::chrono::duration<double>(std::chrono::steady_clock::now() - origin).count();
    }
    timespec a{}, b{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
    s.acquire(run_t, truth, out);
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
    cpu += static_cast<double>(b.tv_sec - a.tv_sec) + 1e-9 * static_cast<double>(b.tv_nsec - a.tv_nsec);
  }
  if (cpu_s) *cpu_s = cpu;
  return out;
}

// Means against the truth. Tolerances: white-noise σ of the mean (defaults: 400 µg/√Hz,
// 0.005 °/s/√Hz at ≤ 100 Hz over ≥ 30 samples: ≤ 0.006 m/s², ≤ 1.2e-4 rad/s), bias instability
// (5e-4 m/s², 5e-5 rad/s), random walk over the run, and half an LSB (ADXL345: 0.019 m/s²).
void expect_matches_truth(const std::vector<ImuSample>& v, const SensorInfo& info, const std::string& what,
                          double temperature_tolerance_c = -1.0) {
  ASSERT_GE(v.size(), 30u) << what;
  Eigen::Vector3d f = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
  double temp = 0.0;
  for (const auto& s : v) {
    f += s.accel_mps2;
    w += s.gyro_radps;
    temp += s.temperature_c;
    EXPECT_EQ(s.flags & (kAccelSaturated | kGyroSaturated), 0u) << what;
  }
  const double n = static_cast<double>(v.size());
  f /= n;
  w /= n;
  temp /= n;
  const auto t = bench_truth();
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(f[i], t.specific_force_mps2[i], 0.03 + info.accel_lsb_mps2) << what << " accel axis " << i;
    if (info.has_gyro) {
      EXPECT_NEAR(w[i], t.angular_rate_radps[i], 1e-3 + info.gyro_lsb_radps) << what << " gyro axis " << i;
    }
  }
  if (info.has_temperature) {
    EXPECT_NEAR(temp, 30.0, temperature_tolerance_c > 0.0 ? temperature_tolerance_c : info.temperature_lsb_c + 1e-9) << what;
  }
}

void run_route(Chip c, const std::string& route) {
  World w;
  const std::uint8_t addr = chip_address(c);
  if (!(route == "bench_mcu" && c == Chip::kMpu6050)) w.bus->attach(addr, make_model(c));
  auto cfg = w.config(c, route);
  cfg.mode = "poll";
  I2cImuSensor s(make_driver(c), cfg);
  s.start(0.0);
  const std::string what = std::string(chip_name(c)) + " over " + route;
  EXPECT_EQ(s.identity().model, make_driver(c)->model()) << what;
  char id[8];
  std::snprintf(id, sizeof id, "0x%02X", make_driver(c)->expected_id());
  EXPECT_EQ(s.identity().who_am_i, id) << what;
  const auto v = collect(s, 40, 12);
  expect_matches_truth(v, s.info(), what);
  EXPECT_EQ(s.report().bus.failures, 0u) << what;
}

TEST(I2cImu, EveryChipOverI2cDev) {
  for (Chip c : {Chip::kMpu6050, Chip::kAdxl345, Chip::kLsm6dso, Chip::kBmi160, Chip::kIcm42688p}) run_route(c, "i2c-dev");
}
TEST(I2cImu, Mpu6050AndAdxl345OverMcp2221a) {
  run_route(Chip::kMpu6050, "mcp2221a");
  run_route(Chip::kAdxl345, "mcp2221a");
}
TEST(I2cImu, Mpu6050AndLsm6dsoOverCp2112) {
  run_route(Chip::kMpu6050, "cp2112");
  run_route(Chip::kLsm6dso, "cp2112");
}
TEST(I2cImu, Mpu6050AndBmi160OverTheBenchMcuWindow) {
  run_route(Chip::kMpu6050, "bench_mcu");
  run_route(Chip::kBmi160, "bench_mcu");
}

TEST(I2cImu, WrongIdentityNamesBusAddressExpectedAndActual) {
  struct Case {
    Chip chip;
    int actual;
    const char* expected;
    const char* hint;
  };
  for (const Case& k : {Case{Chip::kMpu6050, 0x70, "expected 0x68 (MPU-6050)", "MPU-6500"},
                        Case{Chip::kAdxl345, 0xE6, "expected 0xE5 (ADXL345)", ""},
                        Case{Chip::kLsm6dso, 0x6A, "expected 0x6C (LSM6DSO)", "LSM6DSL"},
                        Case{Chip::kBmi160, 0xD8, "expected 0xD1 (BMI160)", ""},
                        Case{Chip::kIcm42688p, 0x68, "expected 0x47 (ICM-42688-P)", "mpu6050_i2c"}}) {
    World w;
    w.bus->attach(chip_address(k.chip), make_model(k.chip, k.actual));
    I2cImuSensor s(make_driver(k.chip), w.config(k.chip, "i2c-dev"));
    try {
      s.start(0.0);
      ADD_FAILURE() << chip_name(k.chip) << " accepted a wrong identity";
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      char actual[8], addr[8];
      std::snprintf(actual, sizeof actual, "0x%02X", k.actual);
      std::snprintf(addr, sizeof addr, "0x%02X", chip_address(k.chip));
      EXPECT_TRUE(contains(m, "/dev/i2c-1")) << m;
      EXPECT_TRUE(contains(m, std::string("address ") + addr)) << m;
      EXPECT_TRUE(contains(m, std::string("reads ") + actual)) << m;
      EXPECT_TRUE(contains(m, k.expected)) << m;
      EXPECT_TRUE(contains(m, k.hint)) << m;
    }
  }
}

TEST(I2cImu, AbsentDeviceIsANackErrorNeverData) {
  for (const char* route : {"i2c-dev", "mcp2221a", "cp2112", "bench_mcu"}) {
    World w;  // nothing at 0x69
    auto cfg = w.config(Chip::kMpu6050, route);
    cfg.address = 0x69;
    cfg.retries = 1;
    I2cImuSensor s(i2c_imu::make_mpu6050(), cfg);
    try {
      s.start(0.0);
      ADD_FAILURE() << "no error over " << route;
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      EXPECT_TRUE(contains(m, "no ACK")) << m;
      EXPECT_TRUE(contains(m, "0x69")) << m;
      EXPECT_TRUE(contains(m, "expected 0x68 (MPU-6050)")) << m;
      EXPECT_TRUE(contains(m, "nothing")) << m;
      if (std::string(route) == "i2c-dev") {
        EXPECT_TRUE(contains(m, "no ACK from 0x69 on /dev/i2c-1")) << m;
      }
    }
  }
}

TEST(I2cImu, Mpu6050TemperatureFormula) {
  World w;
  w.bus->attach(0x68, make_model(Chip::kMpu6050));
  I2cImuSensor s(i2c_imu::make_mpu6050(), w.config(Chip::kMpu6050, "i2c-dev"));
  s.start(0.0);
  const auto v = collect(s, 5, 15);
  ASSERT_FALSE(v.empty());
  for (const auto& x : v) {
    EXPECT_DOUBLE_EQ(x.temperature_c, x.temperature_counts / 340.0 + 36.53);
    EXPECT_EQ(x.temperature_counts, static_cast<int>(std::floor((30.0 - 36.53) * 340.0 + 0.5)));  // −2220
  }
}

// FIFO mode at 1 kHz: every sample, contiguous on the chip's clock, values right.
TEST(I2cImu, Mpu6050FifoAt1kHzKeepsEverySample) {
  World w;
  w.bus->attach(0x68, make_model(Chip::kMpu6050));
  auto cfg = w.config(Chip::kMpu6050, "i2c-dev");
  cfg.mode = "fifo";
  cfg.dlpf_hz = 44;
  cfg.output_rate_hz = 1000.0;
  auto clock = manual_clock(*w.bus);
  I2cImuSensor s(i2c_imu::make_mpu6050(), cfg);
  s.start(0.0);
  double cpu = 0.0;
  const auto v = collect(s, 500, 20, &cpu, clock);
  ASSERT_GE(v.size(), 500u);
  for (std::size_t k = 0; k < v.size(); ++k) {
    ASSERT_NEAR(v[k].t_s, 1e-3 * static_cast<double>(k + 1), 1e-9) << k;
    ASSERT_EQ(v[k].flags, 0u) << k;
  }
  expect_matches_truth(v, s.info(), "mpu6050 fifo");
  const auto& r = s.report();
  EXPECT_EQ(r.samples_lost, 0u);
  std::printf("[figures] MPU-6050 FIFO over emulated i2c-dev, 1 kHz, poll every 20 ms of bus time: %zu samples in %llu FIFO reads "
              "(%.1f frames per read), %llu I2C transactions, host CPU %.2f us/sample\n",
              v.size(), static_cast<unsigned long long>(r.fifo_reads), static_cast<double>(r.samples) / static_cast<double>(r.fifo_reads),
              static_cast<unsigned long long>(r.bus.transactions), 1e6 * cpu / static_cast<double>(v.size()));
}

TEST(I2cImu, Mpu6050FifoOverflowMarksAGap) {
  World w;
  w.bus->attach(0x68, make_model(Chip::kMpu6050));
  auto cfg = w.config(Chip::kMpu6050, "i2c-dev");
  cfg.mode = "fifo";
  cfg.output_rate_hz = 1000.0;
  I2cImuSensor s(i2c_imu::make_mpu6050(), cfg);
  s.start(0.0);
  std::vector<ImuSample> v;
  const NoTruth truth;
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  s.acquire(10.0, truth, v);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));  // 1024-byte FIFO = 73 samples = 73 ms
  s.acquire(10.0, truth, v);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  s.acquire(10.0, truth, v);
  const auto& r = s.report();
  EXPECT_EQ(r.gaps, 1u);
  EXPECT_GT(r.samples_lost, 50u);
  int gaps = 0;
  for (const auto& x : v) gaps += (x.flags & kGapBefore) ? 1 : 0;
  EXPECT_EQ(gaps, 1);
  ASSERT_FALSE(r.events.empty());
  EXPECT_TRUE(contains(r.events.front(), "FIFO overflow")) << r.events.front();
  for (const auto& x : v) ASSERT_NEAR(x.accel_mps2.z(), kG, 0.6);  // no misaligned frames
}

TEST(I2cImu, Adxl345StreamFifoOverCp2112) {
  World w;
  w.bus->attach(0x53, make_model(Chip::kAdxl345));
  auto cfg = w.config(Chip::kAdxl345, "cp2112");
  cfg.mode = "fifo";
  cfg.output_rate_hz = 400.0;
  auto clock = manual_clock(*w.bus);
  I2cImuSensor s(i2c_imu::make_adxl345(), cfg);
  s.start(0.0);
  const auto v = collect(s, 200, 20, nullptr, clock);
  ASSERT_GE(v.size(), 200u);
  for (std::size_t k = 0; k < v.size(); ++k) ASSERT_NEAR(v[k].t_s, 2.5e-3 * static_cast<double>(k + 1), 1e-9) << k;
  expect_matches_truth(v, s.info(), "adxl345 fifo");
  EXPECT_EQ(s.report().samples_lost, 0u);
}

TEST(I2cImu, Icm42688pFifoAt1kHz) {
  World w;
  w.bus->attach(0x68, make_model(Chip::kIcm42688p));
  auto cfg = w.config(Chip::kIcm42688p, "i2c-dev");
  cfg.mode = "fifo";
  cfg.output_rate_hz = 1000.0;
  auto clock = manual_clock(*w.bus);
  I2cImuSensor s(i2c_imu::make_icm42688p(), cfg);
  s.start(0.0);
  const auto v = collect(s, 500, 20, nullptr, clock);
  ASSERT_GE(v.size(), 500u);
  for (std::size_t k = 0; k < v.size(); ++k) ASSERT_NEAR(v[k].t_s, 1e-3 * static_cast<double>(k + 1), 1e-9) << k;
  // FIFO temperature is 8 bits, 1/2.07 °C per LSB.
  expect_matches_truth(v, s.info(), "icm42688p fifo", 0.5 / 2.07);
  EXPECT_EQ(s.report().samples_lost, 0u);
  EXPECT_EQ(s.report().payload_bytes, 16u * s.report().samples);
}

TEST(I2cImu, Bmi160FifoAt800HzOverTheBenchMcuWindow) {
  World w;
  w.bus->attach(0x69, make_model(Chip::kBmi160));
  auto cfg = w.config(Chip::kBmi160, "bench_mcu");
  cfg.mode = "fifo";
  cfg.output_rate_hz = 800.0;
  auto clock = manual_clock(*w.bus);
  I2cImuSensor s(i2c_imu::make_bmi160(), cfg);
  s.start(0.0);
  const auto v = collect(s, 400, 20, nullptr, clock);
  ASSERT_GE(v.size(), 400u);
  for (std::size_t k = 0; k < v.size(); ++k) ASSERT_NEAR(v[k].t_s, 1.25e-3 * static_cast<double>(k + 1), 1e-9) << k;
  expect_matches_truth(v, s.info(), "bmi160 fifo over bench_mcu");
  EXPECT_EQ(s.report().samples_lost, 0u);
}

TEST(I2cImu, Lsm6dsoFifoAt833HzOverMcp2221a) {
  World w;
  w.bus->attach(0x6A, make_model(Chip::kLsm6dso));
  auto cfg = w.config(Chip::kLsm6dso, "mcp2221a");
  cfg.mode = "fifo";
  cfg.output_rate_hz = 833.0;
  auto clock = manual_clock(*w.bus);
  I2cImuSensor s(i2c_imu::make_lsm6dso(), cfg);
  s.start(0.0);
  const auto v = collect(s, 400, 20, nullptr, clock);
  ASSERT_GE(v.size(), 400u);
  for (std::size_t k = 0; k < v.size(); ++k) ASSERT_NEAR(v[k].t_s, static_cast<double>(k + 1) / 833.0, 1e-9) << k;
  expect_matches_truth(v, s.info(), "lsm6dso fifo");
  EXPECT_EQ(s.report().samples_lost, 0u);
}

TEST(I2cImu, BusFaultsAreRetriedReportedAndSamplesKept) {
  World w;
  w.bus->attach(0x68, make_model(Chip::kMpu6050));
  w.dev->set_fault(EAGAIN, 0.05, 3);
  auto cfg = w.config(Chip::kMpu6050, "i2c-dev");
  cfg.mode = "fifo";
  cfg.output_rate_hz = 1000.0;
  cfg.retries = 6;
  auto clock = manual_clock(*w.bus);
  I2cImuSensor s(i2c_imu::make_mpu6050(), cfg);
  s.start(0.0);
  const auto v = collect(s, 300, 20, nullptr, clock);
  ASSERT_GE(v.size(), 300u);
  for (std::size_t k = 0; k < v.size(); ++k) ASSERT_NEAR(v[k].t_s, 1e-3 * static_cast<double>(k + 1), 1e-9) << k;
  const auto& r = s.report();
  EXPECT_GT(r.bus.retries, 0u);
  EXPECT_EQ(r.bus.bus_errors, r.bus.retries);
  ASSERT_FALSE(r.events.empty());
  EXPECT_TRUE(contains(r.events.front(), "arbitration lost")) << r.events.front();
}

TEST(I2cImu, DeviceThatDisappearsThrowsKeepsSamplesAndResumes) {
  World w;
  auto model = make_model(Chip::kMpu6050);
  w.bus->attach(0x68, model);
  auto cfg = w.config(Chip::kMpu6050, "i2c-dev");
  cfg.retries = 1;
  I2cImuSensor s(i2c_imu::make_mpu6050(), cfg);
  s.start(0.0);
  std::vector<ImuSample> v = collect(s, 5, 12);
  const std::size_t before = v.size();
  w.bus->detach(0x68);
  const NoTruth truth;
  try {
    s.acquire(100.0, truth, v);
    FAIL() << "no error while the device is gone";
  } catch (const std::runtime_error& e) {
    EXPECT_TRUE(contains(e.what(), "no ACK from 0x68 on /dev/i2c-1")) << e.what();
    EXPECT_TRUE(contains(e.what(), "samples up to here were kept")) << e.what();
  }
  EXPECT_EQ(v.size(), before);
  w.bus->attach(0x68, model);
  std::this_thread::sleep_for(std::chrono::milliseconds(15));
  s.acquire(100.0, truth, v);
  EXPECT_EQ(v.size(), before + 1);
}

// A stimulus changed while the emulator runs (TruthCell) reaches the samples read afterwards.
TEST(I2cImu, TruthChangedWhileRunningReachesTheSamples) {
  World w;
  auto cell = std::make_shared<emu::TruthCell>(bench_truth());
  w.bus->attach(0x68, std::make_shared<emu::Mpu6050I2c>(emu::Mpu6050Model(physics(), [cell](double t) { return cell->at(t); })));
  I2cImuSensor s(i2c_imu::make_mpu6050(), w.config(Chip::kMpu6050, "i2c-dev"));
  s.start(0.0);
  auto mean_z = [](const std::vector<ImuSample>& v) {
    double z = 0.0;
    for (const auto& x : v) z += x.accel_mps2.z();
    return z / static_cast<double>(v.size());
  };
  const auto up = collect(s, 20, 12);
  BenchTruth flipped = bench_truth();
  flipped.specific_force_mps2 = {0.0, 0.0, -kG};  // turned upside down
  cell->set(flipped);
  // The 44 Hz DLPF at 100 Hz output rings for ~10 samples after the step: wait it out.
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  const auto down = collect(s, 20, 12);
  ASSERT_EQ(up.size(), 20u);
  ASSERT_EQ(down.size(), 20u);
  EXPECT_NEAR(mean_z(up), kG, 0.05);
  EXPECT_NEAR(mean_z(down), -kG, 0.05);
}

// Each chip's plugin fills in the chip's own address and the plugin's rate, in FIFO mode (the
// defaults of its field table; I2cImuConfig{} itself says "the chip's address" and polls).
TEST(I2cImu, PluginDefaultsAreTheChipsOwn) {
  struct Case {
    const char* plugin;
    std::unique_ptr<i2c_imu::ChipDriver> (*make)();
    double rate_hz;
  };
  for (const Case& k : {Case{"mpu6050_i2c", i2c_imu::make_mpu6050, 1000.0}, Case{"adxl345", i2c_imu::make_adxl345, 100.0},
                        Case{"lsm6dso", i2c_imu::make_lsm6dso, 104.0}, Case{"bmi160", i2c_imu::make_bmi160, 100.0},
                        Case{"icm42688p", i2c_imu::make_icm42688p, 100.0}}) {
    const std::string so = std::string(STEND_BUILD_PLUGIN_DIR) + "/stend_" + k.plugin + ".so";
    void* h = dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
    ASSERT_NE(h, nullptr) << dlerror();
    using Entry = const stend_plugin_info* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(h, "stend_plugin_entry"));
    ASSERT_NE(entry, nullptr) << so;
    const Params p = params_from_yaml(YAML::Load("{}"), *entry(), "defaults.yaml", "config");
    EXPECT_EQ(p.integer("address"), k.make()->default_address()) << k.plugin;
    EXPECT_EQ(p.number("output_rate_hz"), k.rate_hz) << k.plugin;
    EXPECT_EQ(p.string("mode"), "fifo") << k.plugin;
    EXPECT_EQ(p.string("bus"), "i2c-dev") << k.plugin;
    dlclose(h);
  }
}

// Example YAML files validate through each plugin's schema (the plugins are loaded as built).
TEST(I2cImu, ExamplesValidateThroughThePluginSchemas) {
  const std::string dir = std::string(STEND_SOURCE_DIR) + "/sensors/i2c_imu/examples/";
  for (const char* file : {"mpu6050_i2c.yaml", "adxl345_mcp2221a.yaml", "lsm6dso_cp2112.yaml", "bmi160_bench_mcu.yaml", "icm42688p.yaml"}) {
    const YAML::Node doc = YAML::LoadFile(dir + file);
    const std::string plugin = doc["plugin"].as<std::string>();
    const std::string so = std::string(STEND_BUILD_PLUGIN_DIR) + "/stend_" + plugin + ".so";
    void* h = dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
    ASSERT_NE(h, nullptr) << dlerror();
    using Entry = const stend_plugin_info* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(h, "stend_plugin_entry"));
    ASSERT_NE(entry, nullptr) << so;
    const Params p = params_from_yaml(doc["config"], *entry(), file, "config");
    EXPECT_GE(p.integer("address"), 0x03) << file;
    // The plugin's own factory validates (no bus access before start()).
    char err[512] = {};
    void* obj = entry()->create(&p, err, sizeof err);
    EXPECT_NE(obj, nullptr) << file << ": " << err;
    if (obj) entry()->destroy(obj);
    dlclose(h);
  }
}

}  // namespace
