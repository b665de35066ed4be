// I2C through the bench microcontroller's MODBUS RTU window (see stend/devices/i2c_bench_mcu.hpp
// and docs/bench-mcu-modbus.md).
#include <stend/devices/i2c_bench_mcu.hpp>

#include <chrono>
#include <thread>

namespace stend::transport {

namespace map = stend::bench_mcu;

BenchMcuI2cBus::BenchMcuI2cBus(ModbusRtuConfig modbus) try : modbus_(std::move(modbus)) {
} catch (const ModbusError& e) {
  throw I2cError(std::string("I2C via bench MCU: ") + e.what(), I2cError::Kind::kOpen);
}

std::string BenchMcuI2cBus::name() const { return "bench MCU " + modbus_.where(); }

void BenchMcuI2cBus::set(int reg, std::uint16_t value, int& cache) {
  if (cache == value) return;
  cache = -1;  // unknown until the write is confirmed
  modbus_.write_register(reg, value);
  cache = value;
}

void BenchMcuI2cBus::write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r, std::size_t rlen) {
  if (wlen > max_write() || rlen > max_read() || (wlen > 1 && rlen > 0) || (wlen == 0 && rlen == 0)) {
    throw I2cError("I2C: " + name() + ": the MCU window moves a register address then up to " +
                       std::to_string(map::kI2cMaxRead) + " bytes read, or up to " + std::to_string(map::kI2cMaxWrite) +
                       " bytes written; asked " + std::to_string(wlen) + " + " + std::to_string(rlen),
                   I2cError::Kind::kProtocol);
  }
  try {
    set(map::kHoldI2cAddr, address, addr_);
    if (wlen > 0) set(map::kHoldI2cReg, w[0], reg_);
    std::uint16_t cmd = map::kI2cCmdRead;
    if (rlen > 0) {
      set(map::kHoldI2cLen, static_cast<std::uint16_t>(rlen), len_);
      if (wlen == 0) cmd = map::kI2cCmdReadNoReg;
    } else {
      set(map::kHoldI2cLen, static_cast<std::uint16_t>(wlen - 1), len_);
      for (std::size_t i = 1; i < wlen; ++i) modbus_.write_register(map::kHoldI2cWdata + static_cast<int>(i - 1), w[i]);
      cmd = map::kI2cCmdWrite;
    }
    tag_ = static_cast<std::uint8_t>(tag_ + 1);
    modbus_.write_register(map::kHoldI2cCmd, static_cast<std::uint16_t>((tag_ << 8) | cmd));
    const int words = 2 + static_cast<int>((rlen + 1) / 2);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(modbus_.config().response_timeout_ms);
    while (true) {
      const auto in = modbus_.read_input_registers(map::kInI2cStatus, words);
      const unsigned result = in[0] & 0xFF, tag = in[0] >> 8;
      if (tag == tag_ && result != map::kI2cBusy) {
        const std::string who = i2c_hex(address) + " on " + name();
        switch (result) {
          case map::kI2cOk: break;
          case map::kI2cNackAddress: throw I2cError("I2C: no ACK from " + who + " (the MCU saw an address NACK)", I2cError::Kind::kNack);
          case map::kI2cNackData: throw I2cError("I2C: data byte NACKed by " + who, I2cError::Kind::kNack);
          case map::kI2cBusError: throw I2cError("I2C: bus error or time-out on the MCU's bus talking to " + who, I2cError::Kind::kBus);
          default: throw I2cError("I2C: the MCU refused the request for " + who + " (status " + std::to_string(result) + ")", I2cError::Kind::kProtocol);
        }
        if (in[1] < rlen) {
          throw I2cError("I2C: the MCU returned " + std::to_string(in[1]) + " of " + std::to_string(rlen) + " bytes from " + who,
                         I2cError::Kind::kBus);
        }
        for (std::size_t i = 0; i < rlen; ++i) {
          const std::uint16_t v = in[2 + i / 2];
          r[i] = static_cast<std::uint8_t>(i % 2 == 0 ? v >> 8 : v & 0xFF);
        }
        return;
      }
      if (std::chrono::steady_clock::now() > deadline) {
        throw I2cError("I2C: the MCU did not finish command tag " + std::to_string(tag_) + " for " + i2c_hex(address) + " on " +
                           name() + " (status tag " + std::to_string(tag) + ", result " + std::to_string(result) + ")",
                       I2cError::Kind::kTimeout);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  } catch (const ModbusError& e) {
    addr_ = reg_ = len_ = -1;  // the MCU's registers are unknown after a failed exchange
    // MODBUS retried already; a second layer of retries would multiply the waits.
    throw I2cError("I2C: " + i2c_hex(address) + " via " + name() + ": " + e.what(), I2cError::Kind::kProtocol);
  }
}

}  // namespace stend::transport
