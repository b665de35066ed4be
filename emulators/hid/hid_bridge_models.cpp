#include "hid_bridge_models.hpp"

#include <stend/devices/i2c.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <thread>

namespace stend::emu {

using transport::I2cError;

void HidBridgeModel::check_plugged() const {
  if (unplugged_) throw I2cError("HID " + path_ + ": device disconnected (emulated unplug)", I2cError::Kind::kBus);
}

void HidBridgeModel::write(const std::uint8_t* data, std::size_t n) {
  check_plugged();
  ++reports_in_;
  // hidapi: byte 0 is the report ID; for a device without numbered reports it is 0 and not sent.
  std::array<std::uint8_t, 64> r{};
  if (numbered()) {
    std::memcpy(r.data(), data, std::min<std::size_t>(n, 64));
  } else {
    if (n < 2 || data[0] != 0) throw I2cError("HID " + path_ + ": report ID must be 0 for this device", I2cError::Kind::kBus);
    std::memcpy(r.data(), data + 1, std::min<std::size_t>(n - 1, 64));
  }
  handle(r.data());
}

void HidBridgeModel::reply(const std::array<std::uint8_t, 64>& r) {
  std::lock_guard<std::mutex> lock(m_);
  if (lose_p_.load() > 0.0) {
    rng_ = rng_ * 6364136223846793005ULL + 1442695040888963407ULL;
    if (static_cast<double>(rng_ >> 11) * 0x1.0p-53 < lose_p_.load()) {
      ++lost_;
      return;
    }
  }
  replies_.push_back(r);
}

std::size_t HidBridgeModel::read(std::uint8_t* data, std::size_t n, int timeout_ms) {
  check_plugged();
  {
    std::lock_guard<std::mutex> lock(m_);
    if (!replies_.empty()) {
      const std::size_t k = std::min<std::size_t>(n, 64);
      std::memcpy(data, replies_.front().data(), k);
      replies_.pop_front();
      return k;
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(std::min(timeout_ms, 1)));
  return 0;
}

void HidBridgeModel::feature(const std::uint8_t* /*data*/, std::size_t /*n*/) {
  check_plugged();
  throw I2cError("HID " + path_ + ": feature report not supported by this device", I2cError::Kind::kBus);
}

// ---------------------------------------------------------------------------------------------
// MCP2221A
void Mcp2221Model::handle(const std::uint8_t* r) {
  std::array<std::uint8_t, 64> out{};
  out[0] = r[0];
  const std::size_t len = static_cast<std::size_t>(r[1] | (r[2] << 8));
  const auto addr = static_cast<std::uint8_t>(r[3] >> 1);
  switch (r[0]) {
    case 0x10: {
      if (r[2] == 0x10) {  // cancel: free the bus, forget the transfer
        nack_ = false;
        state_ = 0;
        have_pending_ = false;
        data_.clear();
        reading_ = false;
        out[2] = 0x10;
      }
      if (r[3] == 0x20) {
        if (nack_ || reading_) {
          out[3] = 0x21;  // busy: speed not set
        } else {
          divider_ = r[4];
          out[3] = 0x20;
        }
      }
      out[4] = static_cast<std::uint8_t>(divider_);
      out[8] = state_;
      out[9] = r[1];
      out[20] = nack_ ? 0x40 : 0x00;
      break;
    }
    case 0x90:
    case 0x94: {
      std::vector<std::uint8_t> w(r + 4, r + 4 + std::min<std::size_t>(len, 60));
      if (r[0] == 0x94) {
        have_pending_ = true;
        pending_addr_ = addr;
        pending_ = w;
      } else {
        I2cSegment s{addr, false, w.data(), w.size()};
        nack_ = !run(&s, 1);
        state_ = nack_ ? 0x25 : 0x00;
      }
      break;
    }
    case 0x91:
    case 0x93: {
      std::vector<std::uint8_t> buf(len);
      I2cSegment segs[2];
      std::size_t n = 0;
      if (r[0] == 0x93 && have_pending_) segs[n++] = {pending_addr_, false, pending_.data(), pending_.size()};
      segs[n++] = {addr, true, buf.data(), buf.size()};
      have_pending_ = false;
      nack_ = !run(segs, n);
      state_ = nack_ ? 0x25 : 0x55;
      data_.clear();
      if (!nack_) data_.assign(buf.begin(), buf.end());
      reading_ = !nack_;
      break;
    }
    case 0x40: {
      if (nack_) {
        out[2] = 0x25;
        out[3] = 0;
      } else if (!reading_) {
        out[1] = 0x41;  // error reading the I2C engine: nothing requested
        out[3] = 127;
      } else {
        const std::size_t k = std::min<std::size_t>(60, data_.size());
        for (std::size_t i = 0; i < k; ++i) {
          out[4 + i] = data_.front();
          data_.pop_front();
        }
        out[3] = static_cast<std::uint8_t>(k);
        out[2] = data_.empty() ? 0x55 : 0x54;
        if (data_.empty()) {
          reading_ = false;
          state_ = 0;
        }
      }
      break;
    }
    default:
      out[1] = 0x01;  // unknown command
      break;
  }
  reply(out);
}

// ---------------------------------------------------------------------------------------------
// CP2112
void Cp2112Model::feature(const std::uint8_t* data, std::size_t n) {
  check_plugged();
  if (n < 14 || data[0] != 0x06) throw I2cError("HID " + path() + ": unsupported feature report", I2cError::Kind::kBus);
  clock_hz_ = (static_cast<std::uint32_t>(data[1]) << 24) | (static_cast<std::uint32_t>(data[2]) << 16) |
              (static_cast<std::uint32_t>(data[3]) << 8) | data[4];
}

void Cp2112Model::finish(bool ok, std::size_t read_len) {
  status0_ = ok ? 2 : 3;
  status1_ = ok ? 5 : 0;  // error 0: address NACKed
  length_ = static_cast<std::uint16_t>(ok ? read_len : 0);
}

void Cp2112Model::handle(const std::uint8_t* r) {
  std::array<std::uint8_t, 64> out{};
  const auto addr = static_cast<std::uint8_t>(r[1] >> 1);
  switch (r[0]) {
    case 0x10:
    case 0x11: {
      const std::size_t len = static_cast<std::size_t>((r[2] << 8) | r[3]);
      std::vector<std::uint8_t> buf(std::min<std::size_t>(len, 512));
      std::vector<std::uint8_t> w;
      I2cSegment segs[2];
      std::size_t n = 0;
      if (r[0] == 0x11) {
        w.assign(r + 5, r + 5 + std::min<int>(r[4], 16));
        segs[n++] = {addr, false, w.data(), w.size()};
      }
      segs[n++] = {addr, true, buf.data(), buf.size()};
      const bool ok = run(segs, n);
      data_.assign(buf.begin(), ok ? buf.end() : buf.begin());
      finish(ok, buf.size());
      return;  // no immediate reply: the host polls with 0x15
    }
    case 0x14: {
      std::vector<std::uint8_t> w(r + 3, r + 3 + std::min<int>(r[2], 61));
      I2cSegment s{addr, false, w.data(), w.size()};
      finish(run(&s, 1), 0);
      return;
    }
    case 0x15:
      out[0] = 0x16;
      out[1] = status0_;
      out[2] = status1_;
      out[5] = static_cast<std::uint8_t>(length_ >> 8);
      out[6] = static_cast<std::uint8_t>(length_ & 0xFF);
      break;
    case 0x12: {
      const std::size_t want = static_cast<std::size_t>((r[1] << 8) | r[2]);
      const std::size_t k = std::min<std::size_t>({want, 61, data_.size()});
      out[0] = 0x13;
      out[1] = status0_;
      out[2] = static_cast<std::uint8_t>(k);
      for (std::size_t i = 0; i < k; ++i) {
        out[3 + i] = data_.front();
        data_.pop_front();
      }
      break;
    }
    case 0x17:
      status0_ = status1_ = 0;
      length_ = 0;
      data_.clear();
      return;
    default:
      return;  // unknown output report: the device ignores it
  }
  reply(out);
}

// ---------------------------------------------------------------------------------------------
namespace {
class ModelHandle final : public transport::HidDevice {
 public:
  explicit ModelHandle(std::shared_ptr<HidBridgeModel> m) : m_(std::move(m)) {}
  const std::string& path() const override { return m_->path(); }
  void write(const std::uint8_t* data, std::size_t n) override { m_->write(data, n); }
  std::size_t read(std::uint8_t* data, std::size_t n, int timeout_ms) override { return m_->read(data, n, timeout_ms); }
  void send_feature_report(const std::uint8_t* data, std::size_t n) override { m_->feature(data, n); }

 private:
  std::shared_ptr<HidBridgeModel> m_;
};
}  // namespace

void EmulatedHidBackend::add(std::uint16_t vid, std::uint16_t pid, const std::string& serial, std::shared_ptr<HidBridgeModel> model) {
  std::lock_guard<std::mutex> lock(m_);
  transport::HidDeviceInfo i;
  i.path = model->path();
  i.vendor_id = vid;
  i.product_id = pid;
  i.serial = serial;
  entries_.push_back({i, std::move(model)});
}

std::vector<transport::HidDeviceInfo> EmulatedHidBackend::enumerate(std::uint16_t vendor_id, std::uint16_t product_id) {
  std::lock_guard<std::mutex> lock(m_);
  std::vector<transport::HidDeviceInfo> out;
  for (const auto& e : entries_) {
    if (e.info.vendor_id == vendor_id && e.info.product_id == product_id) out.push_back(e.info);
  }
  return out;
}

std::unique_ptr<transport::HidDevice> EmulatedHidBackend::open_path(const std::string& path) {
  std::lock_guard<std::mutex> lock(m_);
  for (const auto& e : entries_) {
    if (e.info.path == path) {
      opened_.push_back(path);
      return std::make_unique<ModelHandle>(e.model);
    }
  }
  throw I2cError("HID: cannot open " + path + " (no such device)", I2cError::Kind::kOpen);
}

std::vector<std::string> EmulatedHidBackend::opened() const {
  std::lock_guard<std::mutex> lock(m_);
  return opened_;
}

}  // namespace stend::emu
