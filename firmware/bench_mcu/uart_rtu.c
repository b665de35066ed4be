#include "uart_rtu.h"

#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"

/* 3.5 characters of 10 bits (8N1) in Timer2 counts; the prescaler is chosen so it fits 8 bits. */
#define T35_CYCLES (35UL * F_CPU / BENCH_BAUD)
#if T35_CYCLES / 8 < 256
#define T2_PRESCALE_BITS (1 << CS21)
#define T2_DIV 8UL
#elif T35_CYCLES / 32 < 256
#define T2_PRESCALE_BITS ((1 << CS21) | (1 << CS20))
#define T2_DIV 32UL
#elif T35_CYCLES / 128 < 256
#define T2_PRESCALE_BITS ((1 << CS22) | (1 << CS20))
#define T2_DIV 128UL
#else
#define T2_PRESCALE_BITS ((1 << CS22) | (1 << CS21) | (1 << CS20))
#define T2_DIV 1024UL
#endif

static uint8_t rx_buf[RTU_RX_MAX];
static volatile uint16_t rx_len;
static volatile uint8_t rx_ready;  /* a frame is complete and not yet handled */
static uint8_t tx_buf[RTU_TX_MAX];
static volatile uint16_t tx_len, tx_pos;

void rtu_init(void) {
  /* U2X (8 samples a bit) first: simavr derives its line rate when UBRR is written. */
  const uint16_t ubrr = (uint16_t)((F_CPU + 4UL * BENCH_BAUD) / (8UL * BENCH_BAUD) - 1);
  UCSR0A = (1 << U2X0);
  UBRR0H = (uint8_t)(ubrr >> 8);
  UBRR0L = (uint8_t)ubrr;
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00); /* 8N1 */
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
  TCCR2A = (1 << WGM21); /* CTC, OCR2A = the 3.5-character silence */
  TCCR2B = 0;
  OCR2A = (uint8_t)(T35_CYCLES / T2_DIV);
}

ISR(USART_RX_vect) {
  const uint8_t status = UCSR0A;
  const uint8_t byte = UDR0;
  if (rx_ready) return; /* the previous request is still being handled: the master is early */
  if (status & ((1 << FE0) | (1 << DOR0))) rx_len = 0xFFFF; /* framing error / overrun: drop the frame */
  if (rx_len < RTU_RX_MAX) rx_buf[rx_len] = byte;
  if (rx_len != 0xFFFF) ++rx_len;
  if (rx_len > RTU_RX_MAX && rx_len != 0xFFFF) rx_len = 0xFFFF;
  TCNT2 = 0;
  TIFR2 = (1 << OCF2A);
  TIMSK2 = (1 << OCIE2A);
  TCCR2B = T2_PRESCALE_BITS;
}

ISR(TIMER2_COMPA_vect) { /* 3.5 characters of silence: the frame is complete */
  TCCR2B = 0;
  TIMSK2 = 0;
  if (rx_len > 0) rx_ready = 1;
}

uint16_t rtu_frame(const uint8_t** data) {
  if (!rx_ready) return 0;
  *data = rx_buf;
  return rx_len;
}

void rtu_frame_done(void) {
  rx_len = 0;
  rx_ready = 0;
}

uint8_t* rtu_tx_buffer(void) { return tx_buf; }

ISR(USART_UDRE_vect) {
  UDR0 = tx_buf[tx_pos++];
  if (tx_pos >= tx_len) UCSR0B &= (uint8_t)~(1 << UDRIE0);
}

void rtu_send(uint16_t n) {
  tx_len = n;
  tx_pos = 0;
  UCSR0B |= (1 << UDRIE0);
}

uint8_t rtu_sending(void) { return (UCSR0B & (1 << UDRIE0)) != 0; }
