// I2C through the bench microcontroller's MODBUS RTU register window (docs/bench-mcu-modbus.md,
// "I2C passthrough"): the PC writes address, register, length and a command into holding
// registers; the MCU performs the I2C transaction on its own bus and leaves status and data in
// input registers. Any sensor on the MCU's bus is reachable over the paper's path.
#pragma once

#include <stend/devices/bench_mcu_regs.h>  // the numbers, shared with firmware/bench_mcu

#include <stend/devices/i2c.hpp>
#include <stend/devices/modbus_rtu.hpp>

#include <memory>
#include <string>

namespace stend::bench_mcu {

// Holding registers (FC 06 write).
inline constexpr int kHoldI2cAddr = STEND_BMCU_HOLD_I2C_ADDR;   // 7-bit address
inline constexpr int kHoldI2cReg = STEND_BMCU_HOLD_I2C_REG;    // register address (first byte written)
inline constexpr int kHoldI2cLen = STEND_BMCU_HOLD_I2C_LEN;    // bytes to read (1..kI2cMaxRead) or to write (0..kI2cMaxWrite)
inline constexpr int kHoldI2cCmd = STEND_BMCU_HOLD_I2C_CMD;    // low byte: command; high byte: tag echoed in STATUS
inline constexpr int kHoldI2cWdata = STEND_BMCU_HOLD_I2C_WDATA;  // kI2cMaxWrite registers, one byte each (low byte)
inline constexpr int kI2cMaxWrite = STEND_BMCU_I2C_MAX_WRITE;
inline constexpr int kHoldMapSize = kHoldI2cWdata + kI2cMaxWrite;  // holding registers mapped
inline constexpr std::uint16_t kI2cCmdRead = STEND_BMCU_I2C_CMD_READ;       // write REG, repeated START, read LEN bytes
inline constexpr std::uint16_t kI2cCmdWrite = STEND_BMCU_I2C_CMD_WRITE;      // write REG then LEN bytes of WDATA
inline constexpr std::uint16_t kI2cCmdReadNoReg = STEND_BMCU_I2C_CMD_READ_NO_REG;  // read LEN bytes without writing REG

// Input registers (FC 04), read together: STATUS, COUNT, DATA.
inline constexpr int kInI2cStatus = STEND_BMCU_IN_I2C_STATUS;  // low byte: result (below); high byte: tag of the command
inline constexpr int kInI2cCount = STEND_BMCU_IN_I2C_COUNT;   // bytes read
inline constexpr int kInI2cData = STEND_BMCU_IN_I2C_DATA;    // two bytes per register, first byte in the high half
inline constexpr int kI2cMaxRead = STEND_BMCU_I2C_MAX_READ;      // 2 + 120 registers ≤ 125 per FC 04
inline constexpr std::uint16_t kI2cIdle = STEND_BMCU_I2C_IDLE, kI2cOk = STEND_BMCU_I2C_OK, kI2cNackAddress = STEND_BMCU_I2C_NACK_ADDRESS, kI2cNackData = STEND_BMCU_I2C_NACK_DATA,
                               kI2cBusError = STEND_BMCU_I2C_BUS_ERROR, kI2cBadRequest = STEND_BMCU_I2C_BAD_REQUEST, kI2cBusy = STEND_BMCU_I2C_BUSY;

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
