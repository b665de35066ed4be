/* The MODBUS RTU line on USART0 (pins 0/1): bytes are received by interrupt; a silence of 3.5
 * character times (Timer2) ends a frame. Replies are sent by interrupt from tx_buf, so the
 * main loop keeps draining the sensor while a 251-byte reply goes out. */
#ifndef BENCH_MCU_UART_RTU_H
#define BENCH_MCU_UART_RTU_H
#include <stdint.h>

#define RTU_RX_MAX 160 /* longest request the maps accept: FC 16 of 64 registers = 137 bytes */
#define RTU_TX_MAX 256 /* longest reply: FC 04 of 125 registers = 255 bytes */

void rtu_init(void);
/* The frame that ended with the last silence, or 0 when none is waiting. A frame longer than
 * RTU_RX_MAX is reported with length 0xFFFF (dropped, no reply). */
uint16_t rtu_frame(const uint8_t** data);
void rtu_frame_done(void);  /* frees the receive buffer for the next request */
uint8_t* rtu_tx_buffer(void);
void rtu_send(uint16_t n);  /* sends tx_buf[0..n) (CRC already appended) */
uint8_t rtu_sending(void);

#endif
