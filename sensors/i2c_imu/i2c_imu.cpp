// Generic I2C inertial sensor (see i2c_imu.hpp).
#include "i2c_imu.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace stend::i2c_imu {

using transport::I2cError;
using transport::i2c_hex;

std::string ChipDriver::id_hint(std::uint8_t /*actual*/) const { return ""; }

bool I2cImuConfig::IsValid(std::string* error) const {
  if (address != -1 && !(address >= 0x03 && address <= 0x77))
    return invalid(error, "address must be a 7-bit I2C address 0x03..0x77 (got " + std::to_string(address) + ")");
  const std::string& b = route.bus;
  if (b != "i2c-dev" && b != "mcp2221a" && b != "cp2112" && b != "bench_mcu")
    return invalid(error, "bus must be i2c-dev, mcp2221a, cp2112 or bench_mcu (got '" + b + "')");
  if ((b == "i2c-dev" || b == "bench_mcu") && route.device.empty())
    return invalid(error, "bus " + b + " needs 'device' (" +
                              (b == "i2c-dev" ? "/dev/i2c-N" : "the serial port, e.g. /dev/ttyUSB0") + ")");
  if (mode != "poll" && mode != "fifo") return invalid(error, "mode must be fifo or poll (got '" + mode + "')");
  if (!(retries >= 0 && route.timeout_ms >= 1)) return invalid(error, "retries must be >= 0 and timeout_ms >= 1");
  if (!(output_rate_hz > 0.0)) return invalid(error, "output_rate_hz must be > 0");
  return true;
}

I2cImuSensor::I2cImuSensor(std::unique_ptr<ChipDriver> chip, I2cImuConfig c)
    : chip_(std::move(chip)), c_(require_valid(c, chip_->plugin())) {
  if (c_.address < 0) c_.address = chip_->default_address();
  if (c_.mode == "fifo" && !chip_->supports_fifo())
    throw std::invalid_argument(std::string(chip_->plugin()) + ": mode fifo is not implemented for the " + chip_->model() +
                                "; use mode: poll");
  chip_->validate(c_);
  period_s_ = 1.0 / chip_->info().output_rate_hz;
}

I2cImuSensor::~I2cImuSensor() {
  try {
    stop();
  } catch (...) {
  }
}

std::string I2cImuSensor::where() const {
  const std::string bus = dev_ ? dev_->bus().name()
                               : (c_.route.bus == "i2c-dev" || c_.route.bus == "bench_mcu" ? c_.route.device : c_.route.bus);
  return std::string(chip_->plugin()) + ": " + bus + ", address " + i2c_hex(static_cast<unsigned>(c_.address));
}

SensorIdentity I2cImuSensor::identity() const { return {chip_->vendor(), chip_->model(), "", who_am_i_}; }

const I2cLinkReport& I2cImuSensor::report() const {
  if (dev_) report_.bus = dev_->stats();
  return report_;
}

void I2cImuSensor::start(double t0_s) {
  if (!dev_) {
    try {
      dev_ = std::make_unique<transport::I2cDevice>(transport::open_i2c_bus(c_.route), static_cast<std::uint8_t>(c_.address),
                                                    transport::I2cRetryPolicy{c_.retries, 1});
    } catch (const std::exception& e) {
      throw IoError(std::string(chip_->plugin()) + ": cannot open the I2C route: " + e.what());
    }
  }
  const std::string expected = i2c_hex(chip_->expected_id()) + " (" + chip_->model() + ")";
  const std::string reg = std::string(chip_->id_register_name()) + " (" + i2c_hex(chip_->id_register()) + ")";
  std::uint8_t id = 0;
  try {
    id = dev_->read_reg(chip_->id_register());
  } catch (const I2cError& e) {
    if (e.kind() == I2cError::Kind::kNack) {
      throw IoError(where() + ": no device answers: no ACK reading " + reg + ", expected " + expected +
                    ", actual: nothing (address NACKed); check wiring, power and the address pin. " + e.what());
    }
    throw IoError(where() + ": reading " + reg + " failed: " + e.what());
  }
  who_am_i_ = i2c_hex(id);
  if (id != chip_->expected_id()) {
    const std::string hint = chip_->id_hint(id);
    throw IoError(where() + ": wrong device: " + reg + " reads " + who_am_i_ + ", expected " + expected +
                  (hint.empty() ? "" : "; " + hint));
  }
  try {
    chip_->configure(*dev_);
    if (c_.mode == "fifo") chip_->fifo_start(*dev_);
  } catch (const I2cError& e) {
    throw IoError(where() + ": configuration failed: " + e.what());
  }
  t0_ = t0_s;
  last_poll_t_ = t0_s;
  next_seq_ = 0;
  gap_pending_ = false;
  pending_.clear();
  report_ = {};
  dev_->reset_stats();
  faults_seen_ = 0;
  started_ = std::chrono::steady_clock::now();
}

void I2cImuSensor::stop() {
  if (dev_) chip_->stop(*dev_);
}

ImuSample I2cImuSensor::convert(const RawSample& r, double t_s) const {
  const SensorInfo si = chip_->info();
  ImuSample s;
  s.t_s = t_s;
  for (int a = 0; a < 3; ++a) {
    s.accel_counts[a] = r.accel[a];
    s.accel_mps2[a] = r.accel[a] * si.accel_lsb_mps2;
    if (std::abs(s.accel_mps2[a]) >= si.accel_range_mps2 - si.accel_lsb_mps2) s.flags |= kAccelSaturated;
    if (si.has_gyro) {
      s.gyro_counts[a] = r.gyro[a];
      s.gyro_radps[a] = r.gyro[a] * si.gyro_lsb_radps;
      if (std::abs(s.gyro_radps[a]) >= si.gyro_range_radps - si.gyro_lsb_radps) s.flags |= kGyroSaturated;
    }
  }
  if (si.has_temperature) {
    s.temperature_counts = r.temperature;
    s.temperature_c = chip_->temperature_offset_c() + r.temperature * si.temperature_lsb_c;
  } else {
    s.temperature_c = std::nan("");
  }
  return s;
}

void I2cImuSensor::read_fifo(double t_s) {
  const std::size_t fb = chip_->frame_bytes();
  const std::size_t max_frames = std::max<std::size_t>(1, dev_->bus().max_read() / fb);
  std::vector<std::uint8_t> buf;
  while (pending_.empty() || pending_.back().t_s <= t_s) {
    bool overflow = false;
    const std::size_t frames = chip_->fifo_frames(*dev_, overflow);
    if (overflow) {
      // The chip dropped samples: restart its FIFO and re-anchor the sample count on the host
      // clock (the chip's own count of what it dropped is not available).
      chip_->fifo_reset(*dev_);
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
      const auto expected = static_cast<std::uint64_t>(std::floor(elapsed / period_s_));
      const std::uint64_t lost = expected > next_seq_ ? expected - next_seq_ : 1;
      report_.samples_lost += lost;
      report_.events.push_back(where() + ": FIFO overflow; about " + std::to_string(lost) +
                               " samples lost before sample " + std::to_string(next_seq_ + lost) + " (poll faster or lower the rate)");
      next_seq_ += lost;
      gap_pending_ = true;
      continue;
    }
    if (frames == 0) break;
    const std::size_t n = std::min(frames, max_frames);
    buf.resize(n * fb);
    chip_->fifo_read(*dev_, buf.data(), n);
    ++report_.fifo_reads;
    for (std::size_t i = 0; i < n; ++i) {
      RawSample r;
      chip_->decode_frame(&buf[i * fb], r);
      ImuSample s = convert(r, t0_ + static_cast<double>(next_seq_ + 1) * period_s_);
      if (gap_pending_) {
        s.flags |= kGapBefore;
        ++report_.gaps;
        gap_pending_ = false;
      }
      pending_.push_back(s);
      ++next_seq_;
      ++report_.samples;
      report_.payload_bytes += fb;
    }
    if (n == frames) break;  // drained
  }
}

void I2cImuSensor::acquire(double t_s, const TruthSource& /*truth*/, std::vector<ImuSample>& out) {
  if (!dev_) throw std::logic_error(where() + ": acquire() before start()");
  auto flush = [&] {
    while (!pending_.empty() && pending_.front().t_s <= t_s) {
      out.push_back(pending_.front());
      pending_.pop_front();
    }
  };
  auto note_faults = [&] {
    const auto& st = dev_->stats();
    const std::uint64_t faults = st.nacks + st.timeouts + st.bus_errors;
    if (faults != faults_seen_) {
      report_.events.push_back(where() + ": " + std::to_string(faults - faults_seen_) + " transient fault(s) (NACKs " +
                               std::to_string(st.nacks) + ", time-outs " + std::to_string(st.timeouts) + ", bus errors " +
                               std::to_string(st.bus_errors) + " in total), last: " + st.last_error);
      faults_seen_ = faults;
    }
  };
  flush();
  try {
    if (c_.mode == "fifo") {
      read_fifo(t_s);
      flush();
    } else {
      RawSample r;
      if (t_s > last_poll_t_ && chip_->poll(*dev_, r)) {  // one sample per (previous t, t]
        // Polled: the sample is the latest the chip latched; it is stamped with this call's time.
        out.push_back(convert(r, t_s));
        last_poll_t_ = t_s;
        ++report_.samples;
        ++next_seq_;
      }
    }
  } catch (const std::exception& e) {
    note_faults();
    report_.events.push_back(e.what());
    throw IoError(where() + ": " + e.what() + "; samples up to here were kept, the next acquire() resumes");
  }
  note_faults();
}

}  // namespace stend::i2c_imu
