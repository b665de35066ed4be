/* Millisecond clock (Timer0, CTC, 1 kHz interrupt). */
#ifndef BENCH_MCU_CLOCK_H
#define BENCH_MCU_CLOCK_H
#include <stdint.h>
void clock_init(void);
uint32_t clock_ms(void); /* ms since power-on (wraps after 49 days) */
#endif
