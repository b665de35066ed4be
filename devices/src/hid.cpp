// hidapi backend and bridge selection (see stend/devices/hid.hpp).
#include <stend/devices/hid.hpp>
#include <stend/devices/i2c.hpp>

#include <hidapi/hidapi.h>

#include <cstdio>
#include <mutex>

namespace stend::transport {
namespace {

std::string narrow(const wchar_t* w) {
  std::string s;
  if (w == nullptr) return s;
  for (; *w != 0; ++w) s.push_back(*w < 128 ? static_cast<char>(*w) : '?');
  return s;
}

std::string vidpid(std::uint16_t v, std::uint16_t p) {
  char b[16];
  std::snprintf(b, sizeof b, "%04x:%04x", v, p);
  return b;
}

class HidapiDevice final : public HidDevice {
 public:
  HidapiDevice(hid_device* d, std::string path) : d_(d), path_(std::move(path)) {}
  ~HidapiDevice() override { hid_close(d_); }
  HidapiDevice(const HidapiDevice&) = delete;
  HidapiDevice& operator=(const HidapiDevice&) = delete;
  const std::string& path() const override { return path_; }
  void write(const std::uint8_t* data, std::size_t n) override {
    if (hid_write(d_, data, n) < 0) fail("hid_write");
  }
  std::size_t read(std::uint8_t* data, std::size_t n, int timeout_ms) override {
    const int r = hid_read_timeout(d_, data, n, timeout_ms);
    if (r < 0) fail("hid_read_timeout");
    return static_cast<std::size_t>(r);
  }
  void send_feature_report(const std::uint8_t* data, std::size_t n) override {
    if (hid_send_feature_report(d_, data, n) < 0) fail("hid_send_feature_report");
  }

 private:
  [[noreturn]] void fail(const char* call) {
    throw I2cError(std::string("HID ") + path_ + ": " + call + " failed: " + narrow(hid_error(d_)) +
                       " (bridge unplugged?)",
                   I2cError::Kind::kBus);
  }
  hid_device* d_;
  std::string path_;
};

class HidapiBackend final : public HidBackend {
 public:
  HidapiBackend() {
    static std::once_flag once;
    std::call_once(once, [] { hid_init(); });
  }
  std::vector<HidDeviceInfo> enumerate(std::uint16_t vendor_id, std::uint16_t product_id) override {
    std::vector<HidDeviceInfo> out;
    hid_device_info* list = hid_enumerate(vendor_id, product_id);
    for (hid_device_info* i = list; i != nullptr; i = i->next) {
      HidDeviceInfo d;
      d.path = i->path != nullptr ? i->path : "";
      d.vendor_id = i->vendor_id;
      d.product_id = i->product_id;
      d.serial = narrow(i->serial_number);
      d.manufacturer = narrow(i->manufacturer_string);
      d.product = narrow(i->product_string);
      out.push_back(d);
    }
    hid_free_enumeration(list);
    return out;
  }
  std::unique_ptr<HidDevice> open_path(const std::string& path) override {
    hid_device* d = hid_open_path(path.c_str());
    if (d == nullptr) {
      throw I2cError("HID: cannot open " + path + " (permissions? add a udev rule granting the hidraw node to your user)",
                     I2cError::Kind::kOpen);
    }
    return std::make_unique<HidapiDevice>(d, path);
  }
};

}  // namespace

std::shared_ptr<HidBackend> hidapi_backend() { return std::make_shared<HidapiBackend>(); }

std::unique_ptr<HidDevice> open_hid_bridge(HidBackend& backend, std::uint16_t vendor_id, std::uint16_t product_id,
                                           const std::string& serial, const std::string& what) {
  const auto found = backend.enumerate(vendor_id, product_id);
  const std::string id = what + " (" + vidpid(vendor_id, product_id) + ")";
  if (found.empty()) {
    throw I2cError("HID: no " + id + " attached (hid_enumerate found none); check the USB cable and that the "
                   "hidraw node is readable",
                   I2cError::Kind::kOpen);
  }
  std::string list;
  for (const auto& d : found) list += (list.empty() ? "" : ", ") + d.path + " serial '" + d.serial + "'";
  if (serial.empty()) {
    if (found.size() > 1) {
      throw I2cError("HID: " + std::to_string(found.size()) + " " + id + " attached (" + list +
                         "); give 'serial' to pick one",
                     I2cError::Kind::kOpen);
    }
    return backend.open_path(found.front().path);
  }
  for (const auto& d : found) {
    if (d.serial == serial) return backend.open_path(d.path);
  }
  throw I2cError("HID: no " + id + " with serial '" + serial + "' (found: " + list + ")", I2cError::Kind::kOpen);
}

}  // namespace stend::transport
