// Host cost of FIFO reads: MPU-6050 at 1 kHz drained every 20 ms (20 frames) through the real
// route code against the emulators, on a simulated bus clock (bus time itself is not modelled).
//   build/bin/i2c_imu_bench
#include <benchmark/benchmark.h>

#include <stend/devices/i2c_hid.hpp>
#include <stend/physics/units.hpp>

#include <memory>
#include <string>
#include <vector>

#include "hid_bridge_models.hpp"
#include "i2c_dev_emulator.hpp"
#include "i2c_imu.hpp"
#include "imu_chip_models.hpp"

namespace {

using namespace stend;

class NoTruth final : public TruthSource {
 public:
  BenchTruth at(double t) const override {
    BenchTruth b;
    b.t_s = t;
    return b;
  }
};

void fifo_drain(benchmark::State& state, const std::string& route) {
  auto bus = std::make_shared<emu::EmulatedI2cBus>();
  auto now = std::make_shared<double>(0.0);
  bus->set_clock([now] { return *now; });
  BenchTruth truth;
  truth.specific_force_mps2 = {0.0, 0.0, stend::physics::kStandardGravity};
  sim::SimImuConfig physics;
  physics.seed = 1;
  bus->attach(0x68, std::make_shared<emu::Mpu6050I2c>(emu::Mpu6050Model(physics, truth)));
  auto dev = std::make_shared<emu::EmulatedI2cDevFile>();
  dev->add_adapter("/dev/i2c-1", bus);
  auto hid = std::make_shared<emu::EmulatedHidBackend>();
  hid->add(transport::kMcp2221Vid, transport::kMcp2221Pid, "M", std::make_shared<emu::Mcp2221Model>("/dev/hidraw-emu0", bus));
  hid->add(transport::kCp2112Vid, transport::kCp2112Pid, "C", std::make_shared<emu::Cp2112Model>("/dev/hidraw-emu1", bus));
  i2c_imu::I2cImuConfig c;
  c.route.bus = route;
  c.route.device = "/dev/i2c-1";
  c.route.i2c_dev_file = dev;
  c.route.hid_backend = hid;
  c.mode = "fifo";
  c.dlpf_hz = 44;
  c.output_rate_hz = 1000.0;
  i2c_imu::I2cImuSensor s(i2c_imu::make_mpu6050(), c);
  s.start(0.0);
  const NoTruth nt;
  std::vector<ImuSample> out;
  std::size_t samples = 0;
  for (auto _ : state) {
    *now += 0.020;
    out.clear();
    s.acquire(1e9, nt, out);
    samples += out.size();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(samples));
  const auto& r = s.report();
  state.counters["frames_per_read"] = static_cast<double>(r.samples) / static_cast<double>(r.fifo_reads);
  state.counters["transactions_per_sample"] = static_cast<double>(r.bus.transactions) / static_cast<double>(r.samples);
}

void BM_Mpu6050Fifo_I2cDev(benchmark::State& s) { fifo_drain(s, "i2c-dev"); }
void BM_Mpu6050Fifo_Mcp2221a(benchmark::State& s) { fifo_drain(s, "mcp2221a"); }
void BM_Mpu6050Fifo_Cp2112(benchmark::State& s) { fifo_drain(s, "cp2112"); }
BENCHMARK(BM_Mpu6050Fifo_I2cDev);
BENCHMARK(BM_Mpu6050Fifo_Mcp2221a);
BENCHMARK(BM_Mpu6050Fifo_Cp2112);

}  // namespace

BENCHMARK_MAIN();
