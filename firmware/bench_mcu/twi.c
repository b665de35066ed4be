#include "twi.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/twi.h>

#include <stend/devices/bench_mcu_regs.h>

#include "board.h"

#define TWI_WAIT_LOOPS 20000u /* ~5 ms at 16 MHz: a stuck bus is reported, not waited on */

void twi_init(void) {
  TWSR = 0; /* prescaler 1 */
  TWBR = (uint8_t)((F_CPU / TWI_SCL_HZ - 16) / 2);
  TWCR = (1 << TWEN);
}

/* Each step waits for the TWI interrupt, whose handler only notes it: the same code runs on the
 * part and under simavr 1.6, whose TWINT stays set after software writes 1 to it (so polling
 * TWINT would return at once there). */
static volatile uint8_t twi_step_done;

ISR(TWI_vect) {
  TWCR &= (uint8_t)~((1 << TWIE) | (1 << TWINT)); /* TWINT written 0: left set for the status read */
  twi_step_done = 1;
}

static uint8_t twi_cmd(uint8_t flags) {
  twi_step_done = 0;
  TWCR = (uint8_t)((1 << TWINT) | (1 << TWEN) | (1 << TWIE) | flags);
  for (uint16_t i = 0; i < TWI_WAIT_LOOPS; ++i)
    if (twi_step_done) return 1;
  TWCR = (1 << TWEN); /* give up: no interrupt left armed */
  return 0;
}

static void twi_stop(void) {
  TWCR = (1 << TWINT) | (1 << TWEN) | (1 << TWSTO);
  for (uint16_t i = 0; i < TWI_WAIT_LOOPS && (TWCR & (1 << TWSTO)); ++i) {
  }
}

static uint8_t twi_start(uint8_t sla_rw) {
  if (!twi_cmd(1 << TWSTA)) return STEND_BMCU_I2C_BUS_ERROR;
  if (TW_STATUS != TW_START && TW_STATUS != TW_REP_START) return STEND_BMCU_I2C_BUS_ERROR;
  TWDR = sla_rw;
  if (!twi_cmd(0)) return STEND_BMCU_I2C_BUS_ERROR;
  /* After SLA+W the part reports 0x18/0x20; simavr 1.6 reports the data-phase codes 0x28/0x30
   * instead, which a real TWI never gives here, so both are read as the address's ACK/NACK. */
  const uint8_t s = TW_STATUS;
  if (s == TW_MT_SLA_ACK || s == TW_MR_SLA_ACK || s == TW_MT_DATA_ACK) return STEND_BMCU_I2C_OK;
  const uint8_t nack = s == TW_MT_SLA_NACK || s == TW_MR_SLA_NACK || s == TW_MT_DATA_NACK;
  return nack ? STEND_BMCU_I2C_NACK_ADDRESS : STEND_BMCU_I2C_BUS_ERROR;
}

static uint8_t twi_send(const uint8_t* w, uint8_t wn) {
  for (uint8_t i = 0; i < wn; ++i) {
    TWDR = w[i];
    if (!twi_cmd(0)) return STEND_BMCU_I2C_BUS_ERROR;
    if (TW_STATUS != TW_MT_DATA_ACK) return STEND_BMCU_I2C_NACK_DATA;
  }
  return STEND_BMCU_I2C_OK;
}

static uint8_t twi_receive(uint8_t* r, uint8_t rn) {
  for (uint8_t i = 0; i < rn; ++i) {
    const uint8_t last = (uint8_t)(i + 1 == rn);
    if (!twi_cmd(last ? 0 : (1 << TWEA))) return STEND_BMCU_I2C_BUS_ERROR;
    r[i] = TWDR;
  }
  return STEND_BMCU_I2C_OK;
}

uint8_t twi_transfer(uint8_t address, const uint8_t* w, uint8_t wn, uint8_t* r, uint8_t rn) {
  uint8_t s = STEND_BMCU_I2C_OK;
  if (wn > 0) {
    s = twi_start((uint8_t)(address << 1) | TW_WRITE);
    if (s == STEND_BMCU_I2C_OK) s = twi_send(w, wn);
  }
  if (s == STEND_BMCU_I2C_OK && rn > 0) {
    s = twi_start((uint8_t)(address << 1) | TW_READ);
    if (s == STEND_BMCU_I2C_OK) s = twi_receive(r, rn);
  }
  twi_stop();
  return s;
}

uint8_t twi_write_reg(uint8_t address, uint8_t reg, uint8_t value) {
  const uint8_t w[2] = {reg, value};
  return twi_transfer(address, w, 2, 0, 0);
}

uint8_t twi_read_regs(uint8_t address, uint8_t reg, uint8_t* r, uint8_t rn) {
  return twi_transfer(address, &reg, 1, r, rn);
}
