/* Bit-banged 1-Wire master on OW_BIT (board.h), standard speed, the timings of Maxim's
 * application note 126 (A 6, B 64, C 60, D 10, E 9, F 55, H 480, I 70, J 410 us). The line is
 * open drain: the pin's PORT bit stays 0 and DDR switches between driving low and released
 * (the 4.7 kOhm pull-up). Interrupts are masked only for the few microseconds of a slot's start
 * and sample, so a 921600-baud request arriving meanwhile is not overrun. */
#ifndef BENCH_MCU_ONEWIRE_H
#define BENCH_MCU_ONEWIRE_H
#include <stdint.h>
uint8_t ow_reset(void); /* 1 when a device answered with a presence pulse */
void ow_write_byte(uint8_t b);
uint8_t ow_read_byte(void);
#endif
