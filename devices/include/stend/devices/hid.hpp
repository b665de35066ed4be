// USB-HID access for I2C bridges, with a seam between the bridge drivers and hidapi.
//
// Real: hidapi_backend() — hid_enumerate / hid_open_path / hid_write / hid_read_timeout /
// hid_send_feature_report (hidapi-hidraw). Emulated (tests): emulators/hid provides a backend
// whose devices are in-process models of the MCP2221A and CP2112 that parse the same reports.
// The byte layout is hidapi's: the first byte written is the report ID (0 for a device without
// numbered reports, such as the MCP2221A); reads return the report as the device sends it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace stend::transport {

struct HidDeviceInfo {
  std::string path;  // as hid_enumerate returned it, e.g. "/dev/hidraw3"
  std::uint16_t vendor_id = 0, product_id = 0;
  std::string serial, manufacturer, product;
};

class HidDevice {
 public:
  virtual ~HidDevice() = default;
  virtual const std::string& path() const = 0;
  // hid_write; throws I2cError (kBus) when the device refuses.
  virtual void write(const std::uint8_t* data, std::size_t n) = 0;
  // hid_read_timeout: bytes read, 0 when nothing arrived within timeout_ms; throws I2cError (kBus).
  virtual std::size_t read(std::uint8_t* data, std::size_t n, int timeout_ms) = 0;
  // hid_send_feature_report (data[0] = report ID); throws I2cError (kBus).
  virtual void send_feature_report(const std::uint8_t* data, std::size_t n) = 0;
};

class HidBackend {
 public:
  virtual ~HidBackend() = default;
  virtual std::vector<HidDeviceInfo> enumerate(std::uint16_t vendor_id, std::uint16_t product_id) = 0;
  // Opens a path enumerate() returned; throws I2cError (kOpen).
  virtual std::unique_ptr<HidDevice> open_path(const std::string& path) = 0;
};

// hidapi (hidraw). hid_init() is called once on first use.
std::shared_ptr<HidBackend> hidapi_backend();

// Enumerates vendor_id:product_id, picks the device with USB serial `serial` (or the only one
// when `serial` is empty) and opens that enumerated path — never a path from elsewhere. Errors
// name the bridge (`what`, e.g. "MCP2221A"), the VID:PID and what was found.
std::unique_ptr<HidDevice> open_hid_bridge(HidBackend& backend, std::uint16_t vendor_id, std::uint16_t product_id,
                                           const std::string& serial, const std::string& what);

}  // namespace stend::transport
