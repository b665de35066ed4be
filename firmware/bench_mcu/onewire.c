#include "onewire.h"

#include <avr/io.h>
#include <util/atomic.h>

#include "board.h"
#include <util/delay.h>

static void line_low(void) { OW_DDR |= (uint8_t)(1 << OW_BIT); }
static void line_release(void) { OW_DDR &= (uint8_t)~(1 << OW_BIT); }
static uint8_t line_level(void) { return (OW_PIN >> OW_BIT) & 1; }

uint8_t ow_reset(void) {
  OW_PORT &= (uint8_t)~(1 << OW_BIT);
  line_release();
  line_low();
  _delay_us(480); /* H */
  uint8_t present;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    line_release();
    _delay_us(70); /* I */
    present = !line_level();
  }
  _delay_us(410); /* J */
  return present;
}

static void write_bit(uint8_t bit) {
  if (bit) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      line_low();
      _delay_us(6); /* A */
      line_release();
    }
    _delay_us(64); /* B */
  } else {
    line_low(); /* an interrupt here only lengthens the slot (60..120 us is a 0) */
    _delay_us(60); /* C */
    line_release();
    _delay_us(10); /* D */
  }
}

static uint8_t read_bit(void) {
  uint8_t bit;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    line_low();
    _delay_us(6); /* A */
    line_release();
    _delay_us(9); /* E */
    bit = line_level();
  }
  _delay_us(55); /* F */
  return bit;
}

void ow_write_byte(uint8_t b) {
  for (uint8_t i = 0; i < 8; ++i, b >>= 1) write_bit(b & 1);
}

uint8_t ow_read_byte(void) {
  uint8_t b = 0;
  for (uint8_t i = 0; i < 8; ++i) b |= (uint8_t)(read_bit() << i);
  return b;
}
