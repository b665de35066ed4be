// I2C through the bench microcontroller's MODBUS RTU register window (docs/bench-mcu-modbus.md,
// "I2C passthrough"): the PC writes address, register, length and a command into holding
// registers; the MCU performs the I2C transaction on its own bus and leaves status and data in
// input registers. Any sensor on the MCU's bus is reachable over the paper's path.
#pragma once

#include <stend/devices/i2c.hpp>
#include <stend/devices/modbus_rtu.hpp>

#include <memory>
#include <string>

namespace stend::bench_mcu {

// Holding registers (FC 06 write).
inline constexpr int kHoldI2cAddr = 0x0010;   // 7-bit address
inline constexpr int kHoldI2cReg = 0x0011;    // register address (first byte written)
inline constexpr int kHoldI2cLen = 0x0012;    // bytes to read (1..kI2cMaxRead) or to write (0..kI2cMaxWrite)
inline constexpr int kHoldI2cCmd = 0x0013;    // low byte: command; high byte: tag echoed in STATUS
inline constexpr int kHoldI2cWdata = 0x0020;  // kI2cMaxWrite registers, one byte each (low byte)
inline constexpr int kI2cMaxWrite = 32;
inline constexpr int kHoldMapSize = kHoldI2cWdata + kI2cMaxWrite;  // holding registers mapped
inline constexpr std::uint16_t kI2cCmdRead = 1;       // write REG, repeated START, read LEN bytes
inline constexpr std::uint16_t kI2cCmdWrite = 2;      // write REG then LEN bytes of WDATA
inline constexpr std::uint16_t kI2cCmdReadNoReg = 3;  // read LEN bytes without writing REG

// Input registers (FC 04), read together: STATUS, COUNT, DATA.
inline constexpr int kInI2cStatus = 0x0100;  // low byte: result (below); high byte: tag of the command
inline constexpr int kInI2cCount = 0x0101;   // bytes read
inline constexpr int kInI2cData = 0x0102;    // two bytes per register, first byte in the high half
inline constexpr int kI2cMaxRead = 240;      // 2 + 120 registers ≤ 125 per FC 04
inline constexpr std::uint16_t kI2cIdle = 0, kI2cOk = 1, kI2cNackAddress = 2, kI2cNackData = 3,
                               kI2cBusError = 4, kI2cBadRequest = 5, kI2cBusy = 0xFF;

}  // namespace stend::bench_mcu

namespace stend::transport {

class BenchMcuI2cBus final : public I2cBus {
 public:
  explicit BenchMcuI2cBus(ModbusRtuConfig modbus);  // opens the serial port
  std::string name() const override;
  void write_read(std::uint8_t address, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r,
                  std::size_t rlen) override;
  std::size_t max_read() const override { return bench_mcu::kI2cMaxRead; }
  std::size_t max_write() const override { return bench_mcu::kI2cMaxWrite + 1; }
  const ModbusStats& modbus_stats() const { return modbus_.stats(); }

 private:
  void set(int reg, std::uint16_t value, int& cache);

  ModbusRtuClient modbus_;
  int addr_ = -1, reg_ = -1, len_ = -1;  // last values written (-1: unknown)
  std::uint8_t tag_ = 0;
};

}  // namespace stend::transport
