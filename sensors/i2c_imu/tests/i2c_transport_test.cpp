// The I2C routes (devices/src/i2c*.cpp) against emulated peers: the i2c-dev driver code
// building struct i2c_msg arrays and mapping errno, the MCP2221A / CP2112 report encoders and
// decoders, and the bench MCU's MODBUS I2C window — each talking to register models on an
// emulated I2C bus.
#include <gtest/gtest.h>

#include <stend/devices/i2c.hpp>
#include <stend/devices/i2c_bench_mcu.hpp>
#include <stend/devices/i2c_dev.hpp>
#include <stend/devices/i2c_hid.hpp>
#include <stend/devices/i2c_route.hpp>

#include <cerrno>
#include <memory>
#include <string>

#include "bench_mcu_slave.hpp"
#include "hid_bridge_models.hpp"
#include "i2c_dev_emulator.hpp"
#include "imu_chip_models.hpp"

namespace {

using namespace stend;
using transport::I2cError;

BenchTruth level() {
  BenchTruth t;
  t.specific_force_mps2 = {0.0, 0.0, 9.80665};
  t.die_temperature_c = 30.0;
  return t;
}

std::shared_ptr<emu::EmulatedI2cBus> bus_with_mpu(std::uint8_t who = 0x68) {
  auto bus = std::make_shared<emu::EmulatedI2cBus>();
  bus->attach(0x68, std::make_shared<emu::Mpu6050I2c>(emu::Mpu6050Model(sim::SimImuConfig{}, level(), who)));
  bus->attach(0x53, std::make_shared<emu::Adxl345Model>(sim::SimImuConfig{}, emu::static_truth(level())));
  return bus;
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(I2cDev, CombinedReadThroughI2cRdwr) {
  auto file = std::make_shared<emu::EmulatedI2cDevFile>();
  file->add_adapter("/dev/i2c-1", bus_with_mpu());
  transport::I2cDevice mpu(std::make_shared<transport::I2cDevBus>("/dev/i2c-1", file), 0x68);
  EXPECT_EQ(mpu.read_reg(0x75), 0x68);
  EXPECT_EQ(mpu.read_reg(0x6B), 0x40);  // power-on: asleep
  mpu.write_reg(0x1C, 0x10);            // ACCEL_CONFIG ±8 g
  std::uint8_t b[4];
  mpu.read_regs(0x19, b, 4);            // auto-increment across SMPLRT_DIV..ACCEL_CONFIG
  EXPECT_EQ(b[3], 0x10);
  transport::I2cDevice adxl(std::make_shared<transport::I2cDevBus>("/dev/i2c-1", file), 0x53);
  EXPECT_EQ(adxl.read_reg(0x00), 0xE5);
  EXPECT_EQ(file->ioctls(), 5u);        // one I2C_RDWR per register operation
}

TEST(I2cDev, NackNamesAddressBusAndRegister) {
  for (int e : {ENXIO, EREMOTEIO}) {
    auto file = std::make_shared<emu::EmulatedI2cDevFile>();
    file->add_adapter("/dev/i2c-1", bus_with_mpu());
    file->set_nack_errno(e);
    transport::I2cDevice d(std::make_shared<transport::I2cDevBus>("/dev/i2c-1", file), 0x69, {2, 1});
    try {
      d.read_reg(0x75);
      FAIL() << "no error for an absent device";
    } catch (const I2cError& err) {
      const std::string w = err.what();
      EXPECT_EQ(err.kind(), I2cError::Kind::kNack);
      EXPECT_TRUE(contains(w, "no ACK from 0x69 on /dev/i2c-1")) << w;
      EXPECT_TRUE(contains(w, "register 0x75")) << w;
      EXPECT_TRUE(contains(w, "after 3 attempts")) << w;
    }
    EXPECT_EQ(d.stats().nacks, 3u);
  }
}

TEST(I2cDev, MissingAdapterSaysHowToGetOne) {
  auto file = std::make_shared<emu::EmulatedI2cDevFile>();
  try {
    transport::I2cDevBus bus("/dev/i2c-7", file);
    FAIL();
  } catch (const I2cError& e) {
    EXPECT_EQ(e.kind(), I2cError::Kind::kOpen);
    EXPECT_TRUE(contains(e.what(), "/dev/i2c-7")) << e.what();
    EXPECT_TRUE(contains(e.what(), "modprobe i2c-dev")) << e.what();
  }
}

TEST(I2cDev, ArbitrationLossIsRetriedAndValuesStayRight) {
  auto file = std::make_shared<emu::EmulatedI2cDevFile>();
  file->add_adapter("/dev/i2c-1", bus_with_mpu());
  file->set_fault(EAGAIN, 0.3, 5);
  transport::I2cDevice d(std::make_shared<transport::I2cDevBus>("/dev/i2c-1", file), 0x68, {8, 0});
  for (int i = 0; i < 200; ++i) ASSERT_EQ(d.read_reg(0x75), 0x68);
  EXPECT_GT(d.stats().retries, 20u);
  EXPECT_EQ(d.stats().bus_errors, d.stats().retries);
  EXPECT_EQ(d.stats().failures, 0u);
  EXPECT_TRUE(contains(d.stats().last_error, "arbitration lost")) << d.stats().last_error;
}

struct Hid {
  std::shared_ptr<emu::EmulatedI2cBus> bus = bus_with_mpu();
  std::shared_ptr<emu::EmulatedHidBackend> backend = std::make_shared<emu::EmulatedHidBackend>();
  std::shared_ptr<emu::Mcp2221Model> mcp = std::make_shared<emu::Mcp2221Model>("/dev/hidraw-emu0", bus);
  std::shared_ptr<emu::Cp2112Model> cp = std::make_shared<emu::Cp2112Model>("/dev/hidraw-emu1", bus);
  Hid() {
    backend->add(transport::kMcp2221Vid, transport::kMcp2221Pid, "MCP0001", mcp);
    backend->add(transport::kCp2112Vid, transport::kCp2112Pid, "CP0001", cp);
  }
  std::shared_ptr<transport::I2cBus> open(const std::string& which) {
    transport::I2cRouteConfig r;
    r.bus = which;
    r.hid_backend = backend;
    r.timeout_ms = 20;
    return transport::open_i2c_bus(r);
  }
};

TEST(Mcp2221, SetsSpeedReadsWritesAndOpensOnlyTheEnumeratedPath) {
  Hid h;
  transport::I2cDevice d(h.open("mcp2221a"), 0x68);
  EXPECT_EQ(h.mcp->speed_divider(), 12000000 / 400000 - 3);
  EXPECT_EQ(d.read_reg(0x75), 0x68);
  d.write_reg(0x1B, 0x18);
  EXPECT_EQ(d.read_reg(0x1B), 0x18);
  std::uint8_t big[0x74];  // two 60-byte GET_DATA reports (stops before the FIFO port 0x74)
  d.read_regs(0x00, big, sizeof big);
  EXPECT_EQ(big[0x1B], 0x18);
  EXPECT_EQ(big[0x6B], 0x40);
  ASSERT_EQ(h.backend->opened().size(), 1u);
  EXPECT_EQ(h.backend->opened().front(), "/dev/hidraw-emu0");
}

TEST(Mcp2221, NackAndLostReportAreNamed) {
  Hid h;
  transport::I2cDevice d(h.open("mcp2221a"), 0x1D, {1, 0});
  try {
    d.read_reg(0x00);
    FAIL();
  } catch (const I2cError& e) {
    EXPECT_EQ(e.kind(), I2cError::Kind::kNack);
    EXPECT_TRUE(contains(e.what(), "no ACK from 0x1D on MCP2221A /dev/hidraw-emu0")) << e.what();
    EXPECT_TRUE(contains(e.what(), "register 0x00")) << e.what();
  }
  transport::I2cDevice ok(h.open("mcp2221a"), 0x68, {0, 0});  // after a cancel the bus works again
  EXPECT_EQ(ok.read_reg(0x75), 0x68);
  h.mcp->set_lose_probability(1.0);
  try {
    ok.read_reg(0x75);
    FAIL();
  } catch (const I2cError& e) {
    EXPECT_EQ(e.kind(), I2cError::Kind::kTimeout);
    EXPECT_TRUE(contains(e.what(), "did not answer")) << e.what();
  }
}

TEST(Mcp2221, BridgeSelectionBySerial) {
  Hid h;
  auto second = std::make_shared<emu::Mcp2221Model>("/dev/hidraw-emu2", h.bus);
  h.backend->add(transport::kMcp2221Vid, transport::kMcp2221Pid, "MCP0002", second);
  try {
    h.open("mcp2221a");
    FAIL() << "two bridges and no serial";
  } catch (const I2cError& e) {
    EXPECT_TRUE(contains(e.what(), "2 MCP2221A (04d8:00dd) attached")) << e.what();
    EXPECT_TRUE(contains(e.what(), "MCP0002")) << e.what();
  }
  transport::I2cRouteConfig r;
  r.bus = "mcp2221a";
  r.serial = "MCP0002";
  r.hid_backend = h.backend;
  transport::I2cDevice d(transport::open_i2c_bus(r), 0x53);
  EXPECT_EQ(d.read_reg(0x00), 0xE5);
  EXPECT_EQ(h.backend->opened().back(), "/dev/hidraw-emu2");
  r.serial = "NOPE";
  EXPECT_THROW(transport::open_i2c_bus(r), I2cError);
}

TEST(Cp2112, ConfiguresReadsWritesAndNamesNack) {
  Hid h;
  transport::I2cDevice d(h.open("cp2112"), 0x68);
  EXPECT_EQ(h.cp->clock_hz(), 400000u);
  EXPECT_EQ(d.read_reg(0x75), 0x68);
  d.write_reg(0x19, 7);
  EXPECT_EQ(d.read_reg(0x19), 7);
  transport::I2cDevice adxl(h.open("cp2112"), 0x53);
  std::uint8_t big[200];  // four 61-byte read responses
  adxl.read_regs(0x00, big, sizeof big);
  EXPECT_EQ(big[0x00], 0xE5);
  EXPECT_EQ(big[0x2C], 0x0A);
  transport::I2cDevice none(h.open("cp2112"), 0x1D, {0, 0});
  try {
    none.read_reg(0x00);
    FAIL();
  } catch (const I2cError& e) {
    EXPECT_EQ(e.kind(), I2cError::Kind::kNack);
    EXPECT_TRUE(contains(e.what(), "0x1D on CP2112 /dev/hidraw-emu1")) << e.what();
  }
}

TEST(BenchMcuWindow, ReachesTheMcusMpuAndOtherSensors) {
  auto bus = std::make_shared<emu::EmulatedI2cBus>();
  bus->attach(0x53, std::make_shared<emu::Adxl345Model>(sim::SimImuConfig{}, emu::static_truth(level())));
  emu::BenchMcuSlave mcu(emu::BenchMcuConfig{}, emu::Mpu6050Model(sim::SimImuConfig{}, level()), bus);
  transport::I2cRouteConfig r;
  r.bus = "bench_mcu";
  r.device = mcu.device_path();
  r.timeout_ms = 50;
  auto b = transport::open_i2c_bus(r);
  transport::I2cDevice mpu(b, 0x68), adxl(b, 0x53), none(b, 0x1D, {0, 0});
  EXPECT_EQ(mpu.read_reg(0x75), 0x68);
  EXPECT_EQ(adxl.read_reg(0x00), 0xE5);
  adxl.write_reg(0x31, 0x0B);
  EXPECT_EQ(adxl.read_reg(0x31), 0x0B);
  std::uint8_t regs[0x30];
  adxl.read_regs(0x00, regs, sizeof regs);
  EXPECT_EQ(regs[0x00], 0xE5);
  EXPECT_EQ(regs[0x2C], 0x0A);
  try {
    none.read_reg(0x00);
    FAIL();
  } catch (const I2cError& e) {
    EXPECT_EQ(e.kind(), I2cError::Kind::kNack);
    EXPECT_TRUE(contains(e.what(), "no ACK from 0x1D on bench MCU device " + mcu.device_path() + ", slave 1")) << e.what();
  }
  EXPECT_EQ(mpu.read_reg(0x75), 0x68);  // the window works after a NACK
}

}  // namespace
