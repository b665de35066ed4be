/* DS18B20 on the 1-Wire line, the only device (SKIP ROM): conversion started, then read
 * CONVERSION_MS later as a CRC-checked scratchpad. Readings that are not a temperature are the
 * values the Dallas library gives: STEND_CHAMBER_RAW_DISCONNECTED (no presence pulse or a CRC
 * error, -127 C) and the part's power-on value STEND_CHAMBER_RAW_POWER_ON (85 C). */
#ifndef BENCH_MCU_DS18B20_H
#define BENCH_MCU_DS18B20_H
#include <stdint.h>
uint8_t ds18b20_start_conversion(void);  /* 1 when the sensor answered */
int16_t ds18b20_read_raw(uint8_t* crc_ok); /* 1/16 C; *crc_ok = 0 on absence or CRC error */
#endif
