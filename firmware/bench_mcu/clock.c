#include "clock.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "board.h"

static volatile uint32_t g_ms;

ISR(TIMER0_COMPA_vect) { ++g_ms; }

void clock_init(void) {
  TCCR0A = (1 << WGM01);              /* CTC */
  TCCR0B = (1 << CS01) | (1 << CS00); /* clk/64: 4 us per count at 16 MHz */
  OCR0A = (uint8_t)(F_CPU / 64 / 1000 - 1);
  TIMSK0 = (1 << OCIE0A);
}

uint32_t clock_ms(void) {
  uint32_t ms;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { ms = g_ms; }
  return ms;
}
