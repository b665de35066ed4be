#include "ds18b20.h"

#include <stend/devices/bench_mcu_regs.h>

#include "crc.h"
#include "onewire.h"

enum { CMD_SKIP_ROM = 0xCC, CMD_CONVERT_T = 0x44, CMD_READ_SCRATCHPAD = 0xBE, SCRATCHPAD_BYTES = 9 };

uint8_t ds18b20_start_conversion(void) {
  if (!ow_reset()) return 0;
  ow_write_byte(CMD_SKIP_ROM);
  ow_write_byte(CMD_CONVERT_T);
  return 1;
}

int16_t ds18b20_read_raw(uint8_t* crc_ok) {
  uint8_t pad[SCRATCHPAD_BYTES];
  *crc_ok = 0;
  if (!ow_reset()) return STEND_CHAMBER_RAW_DISCONNECTED;
  ow_write_byte(CMD_SKIP_ROM);
  ow_write_byte(CMD_READ_SCRATCHPAD);
  for (uint8_t i = 0; i < SCRATCHPAD_BYTES; ++i) pad[i] = ow_read_byte();
  if (crc8_dallas(pad, SCRATCHPAD_BYTES - 1) != pad[SCRATCHPAD_BYTES - 1]) return STEND_CHAMBER_RAW_DISCONNECTED;
  *crc_ok = 1;
  return (int16_t)((pad[1] << 8) | pad[0]);
}
