/* TWI (I2C) master, blocking, every wait bounded. Results use the I2C window's status codes
 * (STEND_BMCU_I2C_OK, _NACK_ADDRESS, _NACK_DATA, _BUS_ERROR). */
#ifndef BENCH_MCU_TWI_H
#define BENCH_MCU_TWI_H
#include <stdint.h>
void twi_init(void);
/* Writes w[0..wn) to `address`, then (rn > 0) a repeated START and reads rn bytes; STOP.
 * wn == 0 reads without writing first. */
uint8_t twi_transfer(uint8_t address, const uint8_t* w, uint8_t wn, uint8_t* r, uint8_t rn);
uint8_t twi_write_reg(uint8_t address, uint8_t reg, uint8_t value);
uint8_t twi_read_regs(uint8_t address, uint8_t reg, uint8_t* r, uint8_t rn);
#endif
