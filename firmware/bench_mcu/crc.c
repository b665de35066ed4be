#include "crc.h"

uint16_t crc16_modbus(const uint8_t* data, uint16_t n) {
  uint16_t crc = 0xFFFF;
  for (uint16_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (uint8_t b = 0; b < 8; ++b) crc = (crc & 1) ? (uint16_t)((crc >> 1) ^ 0xA001) : (uint16_t)(crc >> 1);
  }
  return crc;
}

uint8_t crc8_dallas(const uint8_t* data, uint8_t n) {
  uint8_t crc = 0;
  for (uint8_t i = 0; i < n; ++i) {
    uint8_t byte = data[i];
    for (uint8_t b = 0; b < 8; ++b) {
      const uint8_t mix = (uint8_t)((crc ^ byte) & 1);
      crc >>= 1;
      if (mix) crc ^= 0x8C;
      byte >>= 1;
    }
  }
  return crc;
}
