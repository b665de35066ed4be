// A MODBUS RTU slave's end of the line, as the emulators open it: a fresh pseudo-terminal pair
// (openpty, raw mode) and a libmodbus RTU context that reads and answers on the master end. The
// driver under test opens device_path() — the slave end, e.g. /dev/pts/7 — like /dev/ttyUSB0.
// Used by emulators/bench_mcu (the bench microcontroller) and emulators/chamber (ATmega328 firmware).
//
// Ownership: PtyModbusRtu owns both pty fds and the modbus_t context; the destructor frees the
// context and closes both fds. Keep the pty open (and the object alive) until the thread that
// serves it has been joined. Threading: construct anywhere; after that only the one server
// thread calls ctx(), receive() or writes to master_fd().
#pragma once

#include <modbus.h>

#include <cstdint>
#include <string>

namespace stend::emu {

class PtyModbusRtu {
 public:
  // `who` starts every error message ("bench MCU emulator: openpty failed: …"). `baud` [bit/s]
  // only sets libmodbus' frame timing (the pty has no line rate); `indication_timeout_us` [µs] is
  // how long receive() waits for a request before it returns 0. Throws IoError.
  PtyModbusRtu(const char* who, int baud, int slave_id, int indication_timeout_us = 20000);
  ~PtyModbusRtu();
  PtyModbusRtu(const PtyModbusRtu&) = delete;
  PtyModbusRtu& operator=(const PtyModbusRtu&) = delete;

  const std::string& device_path() const { return device_path_; }
  modbus_t* ctx() const { return ctx_; }
  int master_fd() const { return master_fd_; }  // raw writes (a hand-built, corrupted reply)

  // Waits for one request into req[MODBUS_RTU_MAX_ADU_LENGTH]: its length (> 0); 0 when none came
  // within the indication timeout (or it was for another slave); −1 after a broken frame, whose
  // remaining bytes are then flushed.
  int receive(std::uint8_t* req);

 private:
  std::string device_path_;
  int master_fd_ = -1, slave_fd_ = -1;
  modbus_t* ctx_ = nullptr;
};

// Line noise on a read reply: builds the reply to a read request (function code `fc` 03/04,
// `count` registers from `address` of `registers`) with its correct CRC, then flips one data byte
// (^0x5A) drawn from the splitmix64 stream `rng`, and writes it to `fd` — the master sees a CRC error.
void write_corrupted_read_reply(int fd, int slave_id, int fc, const std::uint16_t* registers, int address,
                                int count, std::uint64_t& rng);

}  // namespace stend::emu
