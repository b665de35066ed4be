/* The bench microcontroller's board: ATmega328P at 16 MHz (Arduino Uno / Nano), pin map and
 * line settings. Every pin and rate of the firmware is written here once (docs/firmware.md). */
#ifndef BENCH_MCU_BOARD_H
#define BENCH_MCU_BOARD_H

#include <stend/devices/bench_mcu_regs.h> /* the slave ids, shared with the host */

#ifndef F_CPU
#define F_CPU 16000000UL /* Hz, the Uno's / Nano's crystal */
#endif

/* MODBUS RTU line (docs/bench-mcu-modbus.md: 921600 baud 8N1 by default). */
#ifndef BENCH_BAUD
#define BENCH_BAUD 921600UL
#endif
#define SLAVE_ID_SENSOR STEND_BMCU_SLAVE_SENSOR   /* the sensor stream and I2C window (docs/bench-mcu-modbus.md) */
#define SLAVE_ID_CHAMBER STEND_BMCU_SLAVE_CHAMBER /* the chamber's PID loop (docs/thermochamber-modbus.md) */

/* I2C (TWI): SDA = A4 (PC4), SCL = A5 (PC5); the MPU-6050 at 0x68 (AD0 low). */
#define TWI_SCL_HZ 400000UL
#define MPU_ADDRESS 0x68

/* Sample ring in RAM, 14 bytes per sample (the MPU-6050's 0x3B..0x48 burst). */
#define RING_SAMPLES 60
/* How often the MPU-6050's own FIFO is drained into the ring [ms]. */
#define MPU_DRAIN_PERIOD_MS 2

/* Chamber: DS18B20 data on pin 11 (PB3, 4.7 kOhm pull-up), heater PWM pin 10 (PB2, OC1B),
 * Peltier + fan PWM pin 9 (PB1, OC1A) — the paper's wiring. */
#define OW_PORT PORTB
#define OW_DDR DDRB
#define OW_PIN PINB
#define OW_BIT 3
#define CONTROL_PERIOD_MS 1000 /* one DS18B20 12-bit conversion per PID cycle */
#define CONVERSION_MS 750      /* 12-bit conversion time (datasheet maximum) */

#endif
