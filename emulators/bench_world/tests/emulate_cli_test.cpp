// `stend emulate`: each emulator started from the command line says where it listens, and the
// real transports find there the device the register maps describe.
#include <gtest/gtest.h>

#include <stend/devices/modbus_rtu.hpp>
#include <stend/devices/modbus_tcp.hpp>
#include <stend/devices/text_command.hpp>

#include <stend/testing/program.hpp>

#include <string>

namespace {

using stend::testing::start_stend;

TEST(EmulateCli, WatlowChamberAnswersPvAndSetpointRegistersOnlyOnItsPort) {
  auto e = start_stend("emulate chamber --protocol watlow_f4 --port 0 --initial-c 23.4 --duration-s 2");
  const std::string port = e.wait_for("tcp 127\\.0\\.0\\.1:([0-9]+)");
  ASSERT_FALSE(port.empty());
  stend::transport::ModbusTcpConfig c;
  c.port = std::stoi(port);
  c.retries = 1;
  stend::transport::ModbusTcpClient bus(c);
  EXPECT_EQ(static_cast<std::int16_t>(bus.read_holding_registers(100, 1)[0]), 234);  // PV, tenths of °C
  bus.write_register(300, 305);
  EXPECT_EQ(bus.read_holding_registers(300, 1)[0], 305);
  try {
    (void)bus.read_holding_registers(101, 1);
    FAIL() << "register 101 is not in the F4 map";
  } catch (const stend::transport::ModbusError& err) {
    EXPECT_EQ(err.exception_code(), 2) << err.what();
    EXPECT_NE(std::string(err.what()).find("register 0x0065"), std::string::npos) << err.what();
  }
}

TEST(EmulateCli, AtmegaChamberOnAPtyReportsFirmwareAndReading) {
  auto e = start_stend("emulate chamber --protocol atmega328 --initial-c 30 --duration-s 2");
  const std::string dev = e.wait_for("(/dev/pts/[0-9]+)");
  ASSERT_FALSE(dev.empty());
  stend::transport::ModbusRtuConfig c;
  c.device = dev;
  c.baud = 115200;
  stend::transport::ModbusRtuClient bus(c);
  const auto in = bus.read_input_registers(0, 10);
  EXPECT_EQ(in[8], 0x0100);                                // FIRMWARE
  EXPECT_EQ(static_cast<std::int16_t>(in[1]), 30 * 16);    // TEMP_RAW, 1/16 °C
  EXPECT_EQ(in[0] & 1u, 0u) << "the loop must be off until RUN";
}

TEST(EmulateCli, TableAnswersTheAcutrolDialect) {
  auto e = start_stend("emulate table --axes 3 --port 0 --duration-s 2");
  const std::string port = e.wait_for("tcp 127\\.0\\.0\\.1:([0-9]+)");
  ASSERT_FALSE(port.empty());
  stend::transport::TextCommandConfig c;
  c.host = "127.0.0.1";
  c.port = std::stoi(port);
  stend::transport::TextCommandClient link(c);
  EXPECT_EQ(link.query(":POS? 3"), "0.000000");
  link.send(":POS 2,120");  // tilt travel is ±90°
  EXPECT_EQ(link.query(":SYST:ERR?").rfind("-222,", 0), 0u);
  EXPECT_EQ(link.query(":SYST:ERR?"), "0,\"No error\"");
}

}  // namespace
