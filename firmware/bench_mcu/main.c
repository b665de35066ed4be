/* The bench microcontroller (docs/firmware.md): one MODBUS RTU line serving the MPU-6050
 * stream (slave SLAVE_ID_SENSOR) and the chamber's PID loop (slave SLAVE_ID_CHAMBER).
 * The main loop: hardware watchdog, a request when one is complete, the sensor drain, the
 * control cycle. A hung loop is reset by the watchdog; every pin is an input after a reset, so
 * heater and Peltier are off until the loop runs again. */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>

#include "board.h"
#include "chamber.h"
#include "clock.h"
#include "modbus.h"
#include "sensor_stream.h"
#include "twi.h"
#include "uart_rtu.h"

static uint16_t EEMEM ee_boot_count; /* BOOT_COUNT, power-ons and resets, wraps at 0xFFFF */

/* Early in start-up: stop a watchdog left running by the reset it caused (avr-libc FAQ). */
void wdt_off_at_boot(void) __attribute__((naked, used, section(".init3")));
void wdt_off_at_boot(void) {
  MCUSR = 0;
  wdt_disable();
}

static uint16_t count_boot(void) {
  const uint16_t stored = eeprom_read_word(&ee_boot_count);
  const uint16_t n = stored == 0xFFFF ? 1 : (uint16_t)(stored + 1); /* erased EEPROM reads 0xFFFF */
  eeprom_update_word(&ee_boot_count, n);
  return n;
}

static void serve_request(void) {
  static const ModbusMap* const maps[] = {&sensor_stream_map, &chamber_map};
  const uint8_t* req;
  const uint16_t len = rtu_frame(&req);
  if (len == 0 || rtu_sending()) return;
  const uint16_t n = modbus_handle(req, len, maps, 2, rtu_tx_buffer());
  rtu_frame_done();
  if (n > 0) rtu_send(n);
}

int main(void) {
  const uint16_t boots = count_boot();
  clock_init();
  rtu_init();
  twi_init();
  sei();
  chamber_init();
  sensor_stream_init(boots);
  wdt_enable(WDTO_250MS);
  for (;;) {
    wdt_reset();
    const uint32_t now = clock_ms();
    chamber_poll(now);
    serve_request();
    sensor_stream_poll(now);
    serve_request();
  }
}
