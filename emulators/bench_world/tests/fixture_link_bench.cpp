// Cost of one fixture poll through the real transports against the emulators (loopback / pty):
// what bounds a fixture's poll_period_s. Run: build-*/bin/fixture_link_bench
#include <benchmark/benchmark.h>

#include <stend/devices/modbus_rtu.hpp>
#include <stend/devices/modbus_tcp.hpp>
#include <stend/devices/text_command.hpp>

#include "chamber_emulator.hpp"
#include "table_text_server.hpp"

namespace {

void BM_ModbusTcpWatlowPv(benchmark::State& state) {
  stend::emu::WatlowChamberServer emu(stend::emu::ChamberEmuConfig{});
  stend::transport::ModbusTcpConfig c;
  c.port = emu.port();
  stend::transport::ModbusTcpClient bus(c);
  for (auto _ : state) benchmark::DoNotOptimize(bus.read_holding_registers(100, 1));
  state.counters["failures"] = static_cast<double>(bus.stats().failures);
}
BENCHMARK(BM_ModbusTcpWatlowPv)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_ModbusRtuAtmegaStatusBlock(benchmark::State& state) {
  stend::emu::AtmegaChamberSlave emu(stend::emu::ChamberEmuConfig{});
  stend::transport::ModbusRtuConfig c;
  c.device = emu.device_path();
  c.baud = 115200;
  stend::transport::ModbusRtuClient bus(c);
  for (auto _ : state) benchmark::DoNotOptimize(bus.read_input_registers(0, 10));
  state.counters["failures"] = static_cast<double>(bus.stats().failures);
}
BENCHMARK(BM_ModbusRtuAtmegaStatusBlock)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_TextCommandPositionQuery(benchmark::State& state) {
  stend::emu::TableTextConfig tc;
  tc.axes = {stend::sim::AxisConfig{}};
  stend::emu::TableTextServer emu(tc);
  stend::transport::TextCommandConfig c;
  c.host = "127.0.0.1";
  c.port = emu.port();
  stend::transport::TextCommandClient link(c);
  for (auto _ : state) benchmark::DoNotOptimize(link.query(":POS? 1"));
}
BENCHMARK(BM_TextCommandPositionQuery)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
