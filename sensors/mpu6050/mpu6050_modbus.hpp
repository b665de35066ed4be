// mpu6050_modbus: an InvenSense MPU-6050 read by the bench microcontroller and polled by the PC
// over MODBUS RTU (register map: docs/bench-mcu-modbus.md). See README.md.
#pragma once

#include <stend/fields.hpp>
#include <stend/sdk.hpp>
#include <stend/devices/modbus_rtu.hpp>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

namespace stend::mpu6050 {

struct Mpu6050ModbusConfig {
  std::string device;
  int baud = 921600;
  int slave_id = 1;
  int accel_range_g = 2;      // 2, 4, 8, 16
  int gyro_range_dps = 250;   // 250, 500, 1000, 2000
  int dlpf_hz = 0;            // 0 (off: 260 Hz, 8 kHz gyro rate), 184, 94, 44, 21, 10, 5
  double output_rate_hz = 1000.0;
  int timeout_ms = 100;
  int retries = 3;

  // Every parameter of the mpu6050_modbus plugin: its schema and the reader of its Params.
  static const stend::fields::Table<Mpu6050ModbusConfig>& fields();
  static Mpu6050ModbusConfig from(const Params& p) { return fields().read(p); }  // throws std::invalid_argument
  // CONFIG.DLPF_CFG of dlpf_hz (0..6), −1 when the chip has no such filter.
  int dlpf_cfg() const;
  // The sample-rate base [Hz] (8000 with the filter off, else 1000) and SMPLRT_DIV for
  // output_rate_hz: base / (1 + SMPLRT_DIV), rounded (IsValid checks it is exact and 0..255).
  double rate_base_hz() const { return dlpf_cfg() == 0 ? 8000.0 : 1000.0; }
  double smplrt_div() const { return std::round(rate_base_hz() / output_rate_hz - 1.0); }
  // A device, a slave address 1..247, ranges, filter and rate the MPU-6050 has, a positive
  // time-out and no negative retries.
  bool IsValid(std::string* error = nullptr) const;
};

// Link health since start(), for reports and tests.
struct LinkReport {
  std::uint64_t samples = 0;        // delivered
  std::uint64_t samples_lost = 0;   // sequence numbers skipped
  std::uint64_t gaps = 0;           // samples flagged kGapBefore
  std::uint64_t resyncs = 0;        // windows behind next_seq_ whose overlap was dropped (late replies)
  std::uint64_t window_reads = 0;
  std::uint64_t payload_bytes = 0;  // 14 per sample delivered
  transport::ModbusStats bus;       // retries, CRC errors, time-outs, wire bytes
  std::vector<std::string> events;  // one line per retried fault, gap or failure
};

class Mpu6050Modbus final : public Sensor {
 public:
  static constexpr std::uint16_t kExpectedWhoAmI = 0x68;

  explicit Mpu6050Modbus(const Params& p);
  explicit Mpu6050Modbus(Mpu6050ModbusConfig c);
  ~Mpu6050Modbus() override;

  SensorIdentity identity() const override;
  SensorInfo info() const override;
  void start(double t0_s) override;
  void acquire(double t_s, const TruthSource& truth, std::vector<ImuSample>& out) override;
  void stop() override;

  const LinkReport& report() const;
  const Mpu6050ModbusConfig& config() const { return c_; }

 private:
  void open();
  bool read_window(int max_samples);  // appends to pending_; false when the FIFO is drained
  // A window starting `overlap` samples before next_seq_: a restart when the boot counter moved
  // (throws), else a late reply to an earlier request whose overlap is dropped.
  void resynchronise(std::uint32_t first, std::uint32_t overlap);
  std::string where() const;

  Mpu6050ModbusConfig c_;
  int smplrt_div_ = 0, dlpf_cfg_ = 0;
  double period_s_ = 1e-3;
  std::unique_ptr<transport::ModbusRtuClient> bus_;
  std::string who_am_i_;
  double t0_ = 0.0;
  std::uint32_t next_seq_ = 0;  // sequence number of the next sample expected
  std::uint16_t boot_count_ = 0;  // the MCU's BOOT_COUNT when the stream started
  bool gap_pending_ = false;
  int estimate_ = 0;            // samples known to wait (0: estimate from the clock)
  std::chrono::steady_clock::time_point last_poll_{};
  std::deque<ImuSample> pending_;  // read but later than the last acquire's t_s
  std::uint64_t faults_seen_ = 0;
  mutable LinkReport report_;
};

}  // namespace stend::mpu6050
