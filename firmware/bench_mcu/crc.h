/* Checksums of the two buses: MODBUS RTU CRC-16 (poly 0xA001 reflected, init 0xFFFF; sent low
 * byte first) and the Dallas/Maxim 1-Wire CRC-8 (x^8 + x^5 + x^4 + 1, reflected). */
#ifndef BENCH_MCU_CRC_H
#define BENCH_MCU_CRC_H
#include <stdint.h>
uint16_t crc16_modbus(const uint8_t* data, uint16_t n);
uint8_t crc8_dallas(const uint8_t* data, uint8_t n);
#endif
