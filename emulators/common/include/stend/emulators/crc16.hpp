// The MODBUS RTU frame check (CRC-16/MODBUS: polynomial 0xA001 reflected, initial 0xFFFF), for the
// emulators that hand-build a frame (a reply with injected line noise). libmodbus computes it for
// every ordinary frame, on both sides of the link; core has no copy of its own.
#pragma once

#include <cstddef>
#include <cstdint>

namespace stend::emu {

// CRC of bytes p[0..n); on the wire low byte first, then high byte.
inline std::uint16_t modbus_crc16(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ p[i]);
    for (int b = 0; b < 8; ++b)
      crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

}  // namespace stend::emu
