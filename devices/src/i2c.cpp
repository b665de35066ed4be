// I2cDevice (register access, retries, back-off) and open_i2c_bus (see stend/devices/i2c.hpp).
#include <stend/devices/i2c.hpp>
#include <stend/devices/i2c_bench_mcu.hpp>
#include <stend/devices/i2c_hid.hpp>
#include <stend/devices/i2c_route.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>
#include <utility>
#include <vector>

namespace stend::transport {

std::string i2c_hex(unsigned v) {
  char b[8];
  std::snprintf(b, sizeof b, "0x%02X", v & 0xFFu);
  return b;
}

I2cDevice::I2cDevice(std::shared_ptr<I2cBus> bus, std::uint8_t address, I2cRetryPolicy policy)
    : bus_(std::move(bus)), address_(address), policy_(policy) {}

std::string I2cDevice::where() const { return bus_->name() + ", address " + i2c_hex(address_); }

void I2cDevice::transact(std::uint8_t reg, const std::uint8_t* w, std::size_t wlen, std::uint8_t* r, std::size_t rlen) {
  int wait_ms = policy_.backoff_initial_ms;
  for (int attempt = 0;; ++attempt) {
    try {
      bus_->write_read(address_, w, wlen, r, rlen);
      ++stats_.transactions;
      stats_.bytes_written += wlen;
      stats_.bytes_read += rlen;
      return;
    } catch (const I2cError& e) {
      switch (e.kind()) {
        case I2cError::Kind::kNack: ++stats_.nacks; break;
        case I2cError::Kind::kTimeout: ++stats_.timeouts; break;
        case I2cError::Kind::kBus: ++stats_.bus_errors; break;
        default: break;
      }
      std::string what = std::string(e.what()) + " (" + (rlen > 0 ? "reading " + std::to_string(rlen) + " bytes from" : "writing") +
                         " register " + i2c_hex(reg) + ")";
      if (e.transient() && attempt < policy_.retries) {
        stats_.last_error = what + " — retrying";
        ++stats_.retries;
        std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
        wait_ms *= 2;
        continue;
      }
      if (e.transient()) what += " after " + std::to_string(attempt + 1) + " attempts";
      stats_.last_error = what;
      ++stats_.failures;
      throw I2cError(what, e.kind());
    }
  }
}

std::uint8_t I2cDevice::read_reg(std::uint8_t reg) {
  std::uint8_t v = 0;
  transact(reg, &reg, 1, &v, 1);
  return v;
}

void I2cDevice::read_regs(std::uint8_t reg, std::uint8_t* out, std::size_t n, bool advance) {
  const std::size_t chunk = std::max<std::size_t>(1, bus_->max_read());
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(chunk, n - done);
    const auto r = static_cast<std::uint8_t>(advance ? reg + done : reg);
    transact(r, &r, 1, out + done, k);
    done += k;
  }
}

void I2cDevice::write_reg(std::uint8_t reg, std::uint8_t value) {
  const std::uint8_t w[2] = {reg, value};
  transact(reg, w, 2, nullptr, 0);
}

bool I2cRouteConfig::IsValid(std::string* error) const {
  if (bus != "i2c-dev" && bus != "mcp2221a" && bus != "cp2112" && bus != "bench_mcu")
    return invalid(error, "unknown I2C bus '" + bus + "'; use i2c-dev, mcp2221a, cp2112 or bench_mcu");
  if (bus == "i2c-dev" && device.empty()) return invalid(error, "I2C route i2c-dev needs 'device', e.g. /dev/i2c-1");
  if (bus == "bench_mcu" && device.empty())
    return invalid(error, "I2C route bench_mcu needs 'device', the serial port, e.g. /dev/ttyUSB0");
  if (!(speed_hz > 0 && baud > 0 && timeout_ms > 0)) return invalid(error, "I2C route: speed_hz, baud and timeout_ms must be > 0");
  if (retries < 0) return invalid(error, "I2C route: retries must be >= 0");
  return true;
}

std::shared_ptr<I2cBus> open_i2c_bus(const I2cRouteConfig& c) {
  std::string why;
  if (!c.IsValid(&why)) throw std::invalid_argument(why);
  if (c.bus == "i2c-dev") {
    return std::make_shared<I2cDevBus>(c.device, c.i2c_dev_file ? c.i2c_dev_file : linux_i2c_dev_file());
  }
  HidBridgeConfig h;
  h.speed_hz = c.speed_hz;
  h.timeout_ms = c.timeout_ms;
  if (c.bus == "mcp2221a") {
    auto backend = c.hid_backend ? c.hid_backend : hidapi_backend();
    return std::make_shared<Mcp2221Bus>(open_hid_bridge(*backend, kMcp2221Vid, kMcp2221Pid, c.serial, "MCP2221A"), h);
  }
  if (c.bus == "cp2112") {
    auto backend = c.hid_backend ? c.hid_backend : hidapi_backend();
    return std::make_shared<Cp2112Bus>(open_hid_bridge(*backend, kCp2112Vid, kCp2112Pid, c.serial, "CP2112"), h);
  }
  ModbusRtuConfig m;  // bench_mcu
  m.device = c.device;
  m.baud = c.baud;
  m.slave_id = c.slave_id;
  m.response_timeout_ms = c.timeout_ms;
  m.retries = c.retries;
  return std::make_shared<BenchMcuI2cBus>(m);
}

}  // namespace stend::transport
