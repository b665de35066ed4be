// In-process models of USB-HID I2C bridges (this kernel has no /dev/uhid, so no virtual hidraw
// node can be made): each model is a stend::transport::HidDevice that parses the same reports
// the real chip does (byte layout of hidapi: first byte written = report ID) and drives an
// emulated I2C bus (emulators/i2c). EmulatedHidBackend plays hid_enumerate / hid_open_path and
// opens only the paths it enumerated.
//
//   Mcp2221Model: commands 0x10 (status, cancel, set speed), 0x90, 0x94, 0x91, 0x93, 0x40.
//   Cp2112Model:  feature report 0x06; reports 0x10, 0x11, 0x12, 0x14, 0x15, 0x17; answers 0x13
//                 and 0x16.
// Fault injection: lose a reply with a probability; unplug (every call fails like hidapi does).
#pragma once

#include <stend/devices/hid.hpp>

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "i2c_bus_model.hpp"

namespace stend::emu {

class HidBridgeModel {
 public:
  HidBridgeModel(std::string path, std::shared_ptr<EmulatedI2cBus> bus) : path_(std::move(path)), bus_(std::move(bus)) {}
  virtual ~HidBridgeModel() = default;
  const std::string& path() const { return path_; }
  void write(const std::uint8_t* data, std::size_t n);
  std::size_t read(std::uint8_t* data, std::size_t n, int timeout_ms);
  virtual void feature(const std::uint8_t* data, std::size_t n);
  void set_lose_probability(double p) { lose_p_ = p; }
  void set_unplugged(bool u) { unplugged_ = u; }
  std::uint64_t reports_in() const { return reports_in_; }
  std::uint64_t reports_lost() const { return lost_; }

 protected:
  virtual void handle(const std::uint8_t* report) = 0;  // 64 bytes, report ID first where numbered
  virtual bool numbered() const = 0;
  void reply(const std::array<std::uint8_t, 64>& r);
  bool run(I2cSegment* segs, std::size_t n) { return bus_->transfer(segs, n); }
  void check_plugged() const;

 private:
  std::string path_;
  std::shared_ptr<EmulatedI2cBus> bus_;
  std::mutex m_;
  std::deque<std::array<std::uint8_t, 64>> replies_;
  std::atomic<double> lose_p_{0.0};
  std::atomic<bool> unplugged_{false};
  std::uint64_t rng_ = 7;
  std::atomic<std::uint64_t> reports_in_{0}, lost_{0};
};

class Mcp2221Model final : public HidBridgeModel {
 public:
  using HidBridgeModel::HidBridgeModel;
  int speed_divider() const { return divider_; }

 private:
  void handle(const std::uint8_t* r) override;
  bool numbered() const override { return false; }

  int divider_ = 0x1D;  // 100 kHz at power-on
  bool nack_ = false;
  std::uint8_t state_ = 0;
  bool have_pending_ = false;
  std::uint8_t pending_addr_ = 0;
  std::vector<std::uint8_t> pending_;  // 0x94 write waiting for its repeated-start read
  std::deque<std::uint8_t> data_;      // read data not yet fetched with 0x40
  bool reading_ = false;
};

class Cp2112Model final : public HidBridgeModel {
 public:
  using HidBridgeModel::HidBridgeModel;
  void feature(const std::uint8_t* data, std::size_t n) override;
  std::uint32_t clock_hz() const { return clock_hz_; }

 private:
  void handle(const std::uint8_t* r) override;
  bool numbered() const override { return true; }
  void finish(bool ok, std::size_t read_len);

  std::uint32_t clock_hz_ = 100000;
  std::uint8_t status0_ = 0, status1_ = 0;
  std::uint16_t length_ = 0;
  std::deque<std::uint8_t> data_;
};

// hid_enumerate / hid_open_path over registered models.
class EmulatedHidBackend final : public transport::HidBackend {
 public:
  void add(std::uint16_t vid, std::uint16_t pid, const std::string& serial, std::shared_ptr<HidBridgeModel> model);
  std::vector<transport::HidDeviceInfo> enumerate(std::uint16_t vendor_id, std::uint16_t product_id) override;
  std::unique_ptr<transport::HidDevice> open_path(const std::string& path) override;
  std::vector<std::string> opened() const;

 private:
  struct Entry {
    transport::HidDeviceInfo info;
    std::shared_ptr<HidBridgeModel> model;
  };
  mutable std::mutex m_;
  std::vector<Entry> entries_;
  std::vector<std::string> opened_;
};

}  // namespace stend::emu
