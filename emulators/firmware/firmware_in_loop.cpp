#include "firmware_in_loop.hpp"

#include <avr_ioport.h>
#include <avr_twi.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_io.h>
#include <sim_irq.h>
#include <sim_cycle_timers.h>

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "stend/emulators/splitmix.hpp"
#include "stend/emulators/steady_ns.hpp"

// LeakSanitizer (-DSTEND_SANITIZE=ON): simavr 1.6's avr_terminate() frees the I/O modules but not
// the core's IRQ pool (the irq array, the names avr_init_irq strdup()s, their notify hooks), which
// no public call releases. Those two allocation sites are simavr's own and suppressed here, in
// every program that runs the firmware; everything this file allocates is freed (~Impl).
extern "C" __attribute__((used, visibility("default"))) const char* __lsan_default_suppressions();
extern "C" const char* __lsan_default_suppressions() { return "leak:avr_init_irq\nleak:avr_irq_register_notify\n"; }

namespace stend::emu {
namespace {

// ATmega328P data-space addresses (datasheet, "Register Summary") and the board's wiring
// (firmware/bench_mcu/board.h).
constexpr std::uint16_t kPinB = 0x23, kTccr1a = 0x80, kOcr1al = 0x88, kOcr1bl = 0x8A;
constexpr std::uint8_t kCom1a1 = 1u << 7, kCom1b1 = 1u << 5;
constexpr int kOneWireBit = 3;  // PB3, Arduino pin 11
constexpr std::uint8_t kMpuAddress = 0x68;
constexpr std::uint32_t kCpuHz = 16000000;
constexpr avr_cycle_count_t kSliceCycles = kCpuHz / 1000;  // 1 ms of simulated time per step
// A paced simulation starved of CPU catches up at most this many times faster than the wall
// clock, and gives up a lag beyond kMaxLagS (wall time; Impl::pace).
constexpr double kCatchUpRate = 2.0;
constexpr double kMaxLagS = 0.5;
constexpr double kSliceS = static_cast<double>(kSliceCycles) / kCpuHz;
// Two host ports share the one UART (FirmwareLoopConfig::host_ports): a transaction ends this long
// after the MCU's last reply byte, or without a reply after kNoReplyCycles (a request the firmware
// drops: bad CRC, another slave id). Simulated time.
constexpr avr_cycle_count_t kReplyQuietCycles = 2 * (kCpuHz / 1000);
constexpr avr_cycle_count_t kNoReplyCycles = 30 * (kCpuHz / 1000);

constexpr avr_cycle_count_t us(double v) { return static_cast<avr_cycle_count_t>(v * kCpuHz / 1e6); }

std::uint8_t dallas_crc8(const std::uint8_t* d, int n) {
  std::uint8_t crc = 0;
  for (int i = 0; i < n; ++i) {
    std::uint8_t b = d[i];
    for (int k = 0; k < 8; ++k) {
      const bool mix = ((crc ^ b) & 1) != 0;
      crc = static_cast<std::uint8_t>(crc >> 1);
      if (mix) crc ^= 0x8C;
      b = static_cast<std::uint8_t>(b >> 1);
    }
  }
  return crc;
}

}  // namespace

struct FirmwareInTheLoop::Impl {
  FirmwareLoopConfig c;
  Mpu6050Model mpu;
  avr_t* avr = nullptr;
  struct HostPort {
    int master_fd = -1, slave_fd = -1;
    std::string path;
    std::deque<std::vector<std::uint8_t>> frames;  // requests waiting for the line (two ports only)
  };
  std::vector<HostPort> ports;
  std::thread thread;
  std::atomic<bool> stop{false};
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point pace_origin = t0;  // wall instant of simulated time 0 (pacing)
  std::chrono::steady_clock::time_point last_paced = t0;   // when the previous slice was let go

  // Line (simulation thread only, except the atomics).
  std::deque<std::uint8_t> to_mcu;
  std::vector<std::uint8_t> from_mcu;
  // The line's transaction with two host ports: whose request the MCU is answering.
  std::size_t owner = 0;
  bool line_busy = false, replied = false;
  avr_cycle_count_t busy_since = 0, last_reply = 0;
  bool uart_full = false;
  std::uint64_t rng;
  std::atomic<double> reply_corrupt_p{0.0}, request_corrupt_p{0.0};
  std::atomic<std::int64_t> silent_until_ns{0};
  std::atomic<bool> reset_pending{false}, hang_pending{false};
  void (*core_reset)(avr_t*) = nullptr;  // the core's own reset hook, chained by on_avr_reset

  // TWI slave state (MPU-6050).
  std::atomic<bool> mpu_present{true};
  bool twi_selected = false, twi_expect_reg = false;
  std::uint8_t twi_addr = 0, mpu_reg = 0;

  // 1-Wire slave state (DS18B20).
  enum class OwState { kIdle, kRom, kFunction, kSend };
  std::atomic<Ds18b20Fault> ow_fault{Ds18b20Fault::kNone};
  bool master_low = false, device_low = false;
  avr_cycle_count_t fall_cycle = 0;
  OwState ow_state = OwState::kIdle;
  std::uint8_t ow_byte = 0;
  int ow_bits = 0;
  std::array<std::uint8_t, 9> scratchpad{};
  int send_bit = 0;
  bool converted = false;

  // Plant.
  double air = 0.0, die = 0.0;
  std::atomic<int> heater{0}, peltier{0};
  std::atomic<double> air_out{0.0}, die_out{0.0}, sim_s{0.0}, busy_s{0.0};
  mutable std::mutex stats_mutex;
  FirmwareLoopStats st;

  Impl(FirmwareLoopConfig cfg, Mpu6050Model m) : c(std::move(cfg)), mpu(std::move(m)), rng(c.seed) {
    air = c.plant.initial_c;
    die = c.plant.initial_c + c.plant.self_heating_c;
    air_out = air;
    die_out = die;
    load();
    for (int i = 0; i < c.host_ports; ++i) open_pty();
    connect_peripherals();
  }

  ~Impl() {
    if (avr != nullptr) {
      avr_terminate(avr);
      std::free(avr);  // avr_make_mcu_by_name's allocation; avr_terminate frees only what it holds
    }
    free_elf();
    for (const HostPort& hp : ports) {
      if (hp.master_fd >= 0) ::close(hp.master_fd);
      if (hp.slave_fd >= 0) ::close(hp.slave_fd);
    }
  }

  // Cycles since power-on: simavr 1.6's avr_reset() sets avr->cycle back to 0, so the cycles
  // before each reset are kept in cycle_base (simulated time never runs backwards).
  avr_cycle_count_t cycle_base = 0, cycle_at_reset = 0;
  bool reset_seen = false;
  avr_cycle_count_t cycles() const { return cycle_base + avr->cycle; }
  double now_s() const { return static_cast<double>(cycles()) / kCpuHz; }
  void account_reset() {
    if (!reset_seen) return;
    reset_seen = false;
    if (avr->cycle < cycle_at_reset) cycle_base += cycle_at_reset;
  }

  // simavr's loader and core report through one process-wide logger: errors to
  // stderr, its chatter ("Loaded 8884 .text …", timer-mode notes) dropped.
  __attribute__((format(printf, 3, 0))) static void quiet_logger(avr_t*, const int level, const char* format, va_list ap) {
    if (level <= LOG_ERROR) std::vfprintf(stderr, format, ap);
  }

  // What elf_read_firmware allocated; kept until avr_terminate (a tracing simavr keeps the symbols).
  elf_firmware_t elf{};
  void free_elf() {
    for (std::uint8_t* p : {elf.flash, elf.eeprom, elf.fuse, elf.lockbits}) std::free(p);
    for (std::uint32_t i = 0; elf.symbol != nullptr && i < elf.symbolcount; ++i) std::free(elf.symbol[i]);
    std::free(elf.symbol);
    elf = elf_firmware_t{};
  }

  void load() {
    avr_global_logger_set(&Impl::quiet_logger);
    elf_firmware_t& f = elf;
    if (elf_read_firmware(c.elf_path.c_str(), &f) != 0)
      throw InputError("firmware in the loop: cannot read " + c.elf_path +
                       " (build the target bench_mcu_firmware, or install gcc-avr: scripts/install-deps.sh)");
    std::strcpy(f.mmcu, "atmega328p");
    f.frequency = kCpuHz;
    avr = avr_make_mcu_by_name(f.mmcu);
    if (avr == nullptr) throw IoError("firmware in the loop: simavr has no atmega328p core");
    avr_init(avr);
    avr->log = LOG_ERROR;
    avr_load_firmware(avr, &f);
    core_reset = avr->reset;
    avr->custom.data = this;  // read back by on_avr_reset (custom.init/deinit stay unset)
    avr->reset = &Impl::on_avr_reset;
  }

  // Every reset of the part — the RESET pin (reset_mcu), the AVR's own watchdog, a crash: the
  // pins are inputs again, so the harness's view of the 1-Wire line, the TWI transfer and the
  // UART's flow control starts afresh too.
  static void on_avr_reset(avr_t* a) {
    auto* self = static_cast<Impl*>(a->custom.data);
    if (self->core_reset != nullptr) self->core_reset(a);
    self->after_reset();
  }

  void after_reset() {
    cycle_at_reset = avr->cycle;
    reset_seen = true;
    master_low = device_low = false;
    ow_state = OwState::kIdle;
    twi_selected = false;
    uart_full = false;
    set_line();
    std::lock_guard<std::mutex> lock(stats_mutex);
    ++st.resets;
  }

  // A firmware hang as a bug would cause one: the CPU jumps into avr-libc's _exit (cli; rjmp .),
  // a tight loop with interrupts off that never calls wdt_reset(). Timers and PWM keep running.
  void hang_now() {
    static constexpr std::uint8_t kCliRjmpSelf[] = {0xF8, 0x94, 0xFF, 0xCF};
    for (avr_flashaddr_t a = 0; a + sizeof kCliRjmpSelf <= avr->flashend; a += 2) {
      if (std::memcmp(avr->flash + a, kCliRjmpSelf, sizeof kCliRjmpSelf) == 0) {
        avr->pc = a;
        return;
      }
    }
    std::fprintf(stderr, "firmware in the loop: %s has no _exit loop (cli; rjmp .) to hang in\n", c.elf_path.c_str());
  }

  void open_pty() {
    char name[256] = {};
    HostPort& hp = ports.emplace_back();
    if (openpty(&hp.master_fd, &hp.slave_fd, name, nullptr, nullptr) != 0)
      throw IoError(std::string("firmware in the loop: openpty failed: ") + std::strerror(errno));
    termios t{};
    tcgetattr(hp.slave_fd, &t);
    cfmakeraw(&t);
    tcsetattr(hp.slave_fd, TCSANOW, &t);
    fcntl(hp.master_fd, F_SETFL, fcntl(hp.master_fd, F_GETFL) | O_NONBLOCK);
    hp.path = name;
  }

  // ---- peripherals ------------------------------------------------------------------------
  void connect_peripherals() {
    std::uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~static_cast<std::uint32_t>(AVR_UART_FLAG_STDIO);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), &Impl::on_uart_out, this);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), &Impl::on_uart_xon, this);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), &Impl::on_uart_xoff, this);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), &Impl::on_twi, this);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_DIRECTION_ALL), &Impl::on_ddrb, this);
    set_line();
  }

  static void on_uart_out(avr_irq_t*, std::uint32_t value, void* p) {
    auto* self = static_cast<Impl*>(p);
    self->from_mcu.push_back(static_cast<std::uint8_t>(value));
    self->replied = true;
    self->last_reply = self->cycles();
  }
  static void on_uart_xon(avr_irq_t*, std::uint32_t, void* p) {
    auto* self = static_cast<Impl*>(p);
    self->uart_full = false;
    self->feed_uart();
  }
  static void on_uart_xoff(avr_irq_t*, std::uint32_t, void* p) { static_cast<Impl*>(p)->uart_full = true; }

  void feed_uart() {
    avr_irq_t* in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    while (!to_mcu.empty() && !uart_full) {
      const std::uint8_t b = to_mcu.front();
      to_mcu.pop_front();
      avr_raise_irq(in, b);
    }
  }

  // MPU-6050 as a TWI slave: START (address byte with R/W), WRITE bytes (register pointer, then
  // data), READ bytes (the model's I2C read), STOP. An ACK is an input message with data bit 1.
  static void on_twi(avr_irq_t*, std::uint32_t value, void* p) { static_cast<Impl*>(p)->twi(value); }

  void twi_reply(std::uint8_t msg, std::uint8_t data) {
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT), avr_twi_irq_msg(msg, twi_addr, data));
  }

  void twi(std::uint32_t value) {
    avr_twi_msg_irq_t v;
    v.u.v = value;
    const std::uint8_t msg = v.u.twi.msg;
    if (msg & TWI_COND_STOP) twi_selected = false;
    if (msg & TWI_COND_START) {
      twi_addr = v.u.twi.addr;
      twi_selected = (twi_addr >> 1) == kMpuAddress && mpu_present.load();
      if (!twi_selected) return;
      mpu.advance(now_s(), [] {});
      twi_expect_reg = (twi_addr & 1) == 0;
      twi_reply(TWI_COND_ACK, 1);
      return;
    }
    if (!twi_selected) return;
    if (msg & TWI_COND_WRITE) {
      twi_reply(TWI_COND_ACK, 1);
      if (twi_expect_reg) {
        mpu_reg = v.u.twi.data;
        twi_expect_reg = false;
      } else {
        mpu.write(mpu_reg, v.u.twi.data);
        mpu_reg = static_cast<std::uint8_t>(mpu_reg + 1);
      }
    } else if (msg & TWI_COND_READ) {
      std::uint8_t b = 0;
      mpu.i2c_read(mpu_reg, &b, 1);
      twi_reply(TWI_COND_READ, b);
    }
  }

  // DS18B20 on PB3: the line is low while the firmware drives it (DDRB bit set, PORTB bit 0)
  // or the device pulls it; otherwise the pull-up holds it high. The level is written into PINB.
  void set_line() {
    const bool high = !(master_low || device_low);
    std::uint8_t& pin = avr->data[kPinB];
    pin = static_cast<std::uint8_t>(high ? (pin | (1u << kOneWireBit)) : (pin & ~(1u << kOneWireBit)));
  }

  static void on_ddrb(avr_irq_t*, std::uint32_t ddr, void* p) {
    auto* self = static_cast<Impl*>(p);
    const bool low = (ddr >> kOneWireBit) & 1;
    if (low == self->master_low) return;
    self->master_low = low;
    if (low) self->ow_fall(); else self->ow_rise();
    self->set_line();
  }

  static avr_cycle_count_t on_device_release(avr_t*, avr_cycle_count_t, void* p) {
    auto* self = static_cast<Impl*>(p);
    self->device_low = false;
    self->set_line();
    return 0;
  }
  static avr_cycle_count_t on_presence_start(avr_t* a, avr_cycle_count_t, void* p) {
    auto* self = static_cast<Impl*>(p);
    self->device_low = true;
    self->set_line();
    avr_cycle_timer_register(a, us(120), &Impl::on_device_release, p);
    return 0;
  }

  void ow_fall() {
    fall_cycle = avr->cycle;
    if (ow_state == OwState::kSend && send_bit < 72) {
      const int bit = (scratchpad[static_cast<std::size_t>(send_bit / 8)] >> (send_bit % 8)) & 1;
      if (bit == 0) {  // hold the line low through the master's sample point
        device_low = true;
        avr_cycle_timer_register(avr, us(30), &Impl::on_device_release, this);
      }
    }
  }

  void ow_rise() {
    const double low_us = static_cast<double>(avr->cycle - fall_cycle) * 1e6 / kCpuHz;
    if (low_us >= 380.0) {  // reset pulse
      ow_state = OwState::kIdle;
      if (ow_fault.load() == Ds18b20Fault::kOpen) return;
      ow_state = OwState::kRom;
      ow_bits = 0;
      ow_byte = 0;
      avr_cycle_timer_register(avr, us(30), &Impl::on_presence_start, this);
      return;
    }
    if (ow_state == OwState::kSend) {
      ++send_bit;
      return;
    }
    if (ow_state != OwState::kRom && ow_state != OwState::kFunction) return;
    const int bit = low_us < 15.0 ? 1 : 0;
    ow_byte = static_cast<std::uint8_t>(ow_byte | (bit << ow_bits));
    if (++ow_bits < 8) return;
    ow_command(ow_byte);
    ow_bits = 0;
    ow_byte = 0;
  }

  void ow_command(std::uint8_t cmd) {
    if (ow_state == OwState::kRom) {
      ow_state = cmd == 0xCC ? OwState::kFunction : OwState::kIdle;  // SKIP ROM (the only device)
      return;
    }
    if (cmd == 0x44) {  // CONVERT T: the reading is latched now, ready before the firmware asks
      converted = true;
      fill_scratchpad();
      ow_state = OwState::kIdle;
    } else if (cmd == 0xBE) {  // READ SCRATCHPAD
      if (!converted || ow_fault.load() == Ds18b20Fault::kPowerOnValue) fill_scratchpad(85.0);
      if (ow_fault.load() == Ds18b20Fault::kCrcError) scratchpad[0] ^= 0x01;  // a bit flipped on the line
      ow_state = OwState::kSend;
      send_bit = 0;
    } else {
      ow_state = OwState::kIdle;
    }
  }

  void fill_scratchpad(double forced_c = std::nan("")) {
    const double t = std::isnan(forced_c) ? air : forced_c;
    const auto raw = static_cast<std::int16_t>(std::clamp(std::round(t * 16.0), -880.0, 2000.0));
    scratchpad = {static_cast<std::uint8_t>(raw & 0xFF), static_cast<std::uint8_t>((raw >> 8) & 0xFF), 0x4B, 0x46, 0x7F,
                  0xFF, 0x0C, 0x10, 0};
    scratchpad[8] = dallas_crc8(scratchpad.data(), 8);
  }

  // ---- the loop -----------------------------------------------------------------------------
  void read_pwm() {
    const std::uint8_t tccr1a = avr->data[kTccr1a];
    heater = (tccr1a & kCom1b1) ? avr->data[kOcr1bl] : 0;
    peltier = (tccr1a & kCom1a1) ? avr->data[kOcr1al] : 0;
  }

  // Bytes the host wrote (one read = one request: libmodbus writes a frame at once), after the
  // line faults: lost while silent, one byte flipped with the request-corruption probability.
  bool read_request(HostPort& hp, std::vector<std::uint8_t>& out) {
    std::uint8_t buf[512];
    const ssize_t n = ::read(hp.master_fd, buf, sizeof buf);
    if (n <= 0) return false;
    std::lock_guard<std::mutex> lock(stats_mutex);
    if (steady_now_ns() < silent_until_ns.load()) {
      ++st.dropped_requests;
      return true;
    }
    if (splitmix_unit(rng) < request_corrupt_p.load()) {
      buf[static_cast<std::size_t>(n) - 1] ^= 0x5A;  // the CRC no longer matches: the MCU must stay silent
      ++st.corrupted_requests;
    }
    st.bytes_to_mcu += static_cast<std::uint64_t>(n);
    out.assign(buf, buf + n);
    return true;
  }

  void pump_host_to_mcu() {
    std::vector<std::uint8_t> frame;
    if (ports.size() == 1) {  // one host: its bytes go straight onto the line
      while (read_request(ports[0], frame)) {
        to_mcu.insert(to_mcu.end(), frame.begin(), frame.end());
        frame.clear();
      }
    } else {
      for (HostPort& hp : ports) {
        while (read_request(hp, frame)) {
          if (!frame.empty()) hp.frames.push_back(frame);
          frame.clear();
        }
      }
      arbitrate();
    }
    feed_uart();
  }

  // Two host ports in front of the one UART, as a two-port RS-485 hub: one transaction on the
  // line at a time (a request, then the MCU's reply or its silence), the ports taking turns.
  void arbitrate() {
    if (line_busy) {
      const bool done = replied ? cycles() - last_reply >= kReplyQuietCycles : cycles() - busy_since >= kNoReplyCycles;
      if (!done || !from_mcu.empty()) return;
      line_busy = false;
    }
    for (std::size_t k = 1; k <= ports.size(); ++k) {
      const std::size_t p = (owner + k) % ports.size();
      if (ports[p].frames.empty()) continue;
      const std::vector<std::uint8_t>& f = ports[p].frames.front();
      to_mcu.insert(to_mcu.end(), f.begin(), f.end());
      ports[p].frames.pop_front();
      owner = p;
      line_busy = true;
      replied = false;
      busy_since = cycles();
      return;
    }
  }

  void pump_mcu_to_host() {
    if (from_mcu.empty()) return;
    {
      std::lock_guard<std::mutex> lock(stats_mutex);
      st.bytes_from_mcu += from_mcu.size();
      if (splitmix_unit(rng) < reply_corrupt_p.load()) {
        from_mcu[from_mcu.size() / 2] ^= 0x5A;
        ++st.corrupted_replies;
      }
    }
    std::size_t off = 0;
    const int fd = ports[owner].master_fd;  // the reply goes to the port whose request is on the line
    while (off < from_mcu.size()) {
      const ssize_t n = ::write(fd, from_mcu.data() + off, from_mcu.size() - off);
      if (n <= 0) break;  // nobody reads the line: the bytes are lost, as on a real line
      off += static_cast<std::size_t>(n);
    }
    from_mcu.clear();
  }

  void step_plant(double dt) {
    sim::plant_step(c.plant, heater.load(), peltier.load(), dt, air, die);
    air_out = air;
    die_out = die;
  }

  void reset_now() {  // on_avr_reset does the rest
    avr_reset(avr);
    account_reset();
  }

  // Waits until the wall clock catches up with simulated time (or a request arrives). A simulation
  // starved of CPU falls behind the wall clock; it catches up, but at most kCatchUpRate times
  // faster than real time: the firmware's clock keeps the wall clock's (the drivers time-stamp
  // samples by it) without a burst of samples faster than any host polls them. A lag beyond
  // kMaxLagS is given up (lag_given_up_s: the MCU's clock then runs behind the host's).
  void pace() {
    if (!(c.speed > 0.0)) return;
    using Clock = std::chrono::steady_clock;
    const auto wall = [](double s) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s)); };
    const double behind = std::chrono::duration<double>(Clock::now() - pace_origin).count() - now_s() / c.speed;
    if (behind > kMaxLagS) give_up_lag(behind - kMaxLagS);
    const Clock::time_point until =
        std::max(pace_origin + wall(now_s() / c.speed), last_paced + wall(kSliceS / (c.speed * kCatchUpRate)));
    const double wait_s = std::chrono::duration<double>(until - Clock::now()).count();
    if (wait_s > 0.0) {
      pollfd pfd[2] = {{ports[0].master_fd, POLLIN, 0}, {ports.back().master_fd, POLLIN, 0}};
      const timespec ts{static_cast<time_t>(wait_s), static_cast<long>(std::fmod(wait_s, 1.0) * 1e9)};
      ppoll(pfd, ports.size(), &ts, nullptr);
    }
    last_paced = Clock::now();
  }

  void give_up_lag(double wall_s) {
    pace_origin += std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(wall_s));
    std::lock_guard<std::mutex> lock(stats_mutex);
    st.lag_given_up_s += wall_s;
  }

  void run() {
    while (!stop.load()) {
      if (reset_pending.exchange(false)) reset_now();
      if (hang_pending.exchange(false)) hang_now();
      const auto busy0 = std::chrono::steady_clock::now();
      const avr_cycle_count_t end = cycles() + kSliceCycles;
      const double t_before = now_s();
      while (cycles() < end) {
        const int state = avr_run(avr);
        account_reset();  // the AVR's watchdog resets the part from inside avr_run
        if (state == cpu_Done || state == cpu_Crashed) {
          reset_now();
          break;
        }
      }
      read_pwm();
      step_plant(now_s() - t_before);
      mpu.advance(now_s(), [] {});
      pump_mcu_to_host();
      pump_host_to_mcu();
      sim_s = now_s();
      busy_s = busy_s.load() + std::chrono::duration<double>(std::chrono::steady_clock::now() - busy0).count();
      pace();
    }
  }
};

bool FirmwareLoopConfig::IsValid(std::string* error) const {
  if (elf_path.empty()) return invalid(error, "no .elf given (elf_path)");
  if (!(speed >= 0.0)) return invalid(error, "speed must be >= 0 (0: unpaced)");
  if (host_ports != 1 && host_ports != 2) return invalid(error, "host_ports must be 1 or 2");
  return true;
}

FirmwareInTheLoop::FirmwareInTheLoop(FirmwareLoopConfig config, Mpu6050Model mpu)
    : impl_(std::make_unique<Impl>(require_valid(config, "firmware in the loop"), std::move(mpu))) {
  impl_->thread = std::thread([this] { impl_->run(); });
}

FirmwareInTheLoop::~FirmwareInTheLoop() {
  impl_->stop = true;
  if (impl_->thread.joinable()) impl_->thread.join();
}

const std::string& FirmwareInTheLoop::device_path(int port) const {
  return impl_->ports.at(static_cast<std::size_t>(port)).path;
}
double FirmwareInTheLoop::die_c() const { return impl_->die_out.load(); }
void FirmwareInTheLoop::set_reply_corrupt_probability(double p) { impl_->reply_corrupt_p = p; }
void FirmwareInTheLoop::set_request_corrupt_probability(double p) { impl_->request_corrupt_p = p; }
void FirmwareInTheLoop::go_silent(std::chrono::milliseconds d) { impl_->silent_until_ns = steady_ns_after(d); }
void FirmwareInTheLoop::set_ds18b20_fault(Ds18b20Fault f) { impl_->ow_fault = f; }
void FirmwareInTheLoop::set_mpu_present(bool present) { impl_->mpu_present = present; }
void FirmwareInTheLoop::reset_mcu() { impl_->reset_pending = true; }
void FirmwareInTheLoop::hang_mcu() { impl_->hang_pending = true; }
int FirmwareInTheLoop::heater_pwm() const { return impl_->heater.load(); }
int FirmwareInTheLoop::peltier_pwm() const { return impl_->peltier.load(); }
double FirmwareInTheLoop::air_c() const { return impl_->air_out.load(); }

bool FirmwareInTheLoop::wait_until_simulated(double t_s, std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (impl_->sim_s.load() < t_s) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

FirmwareLoopStats FirmwareInTheLoop::stats() const {
  std::lock_guard<std::mutex> lock(impl_->stats_mutex);
  FirmwareLoopStats s = impl_->st;
  s.simulated_s = impl_->sim_s.load();
  s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - impl_->t0).count();
  s.busy_s = impl_->busy_s.load();
  return s;
}

}  // namespace stend::emu
