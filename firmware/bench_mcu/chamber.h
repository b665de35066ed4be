/* Slave SLAVE_ID_CHAMBER: the paper's PID loop on the DS18B20 reading, driving the heater
 * (pin 10) and the Peltier cooler (pin 9), with the guards of docs/thermochamber-modbus.md
 * (sensor fault, trips, master watchdog: outputs off, latched). */
#ifndef BENCH_MCU_CHAMBER_H
#define BENCH_MCU_CHAMBER_H
#include "modbus.h"
void chamber_init(void);
void chamber_poll(uint32_t now_ms);
void chamber_outputs_off(void);
extern const ModbusMap chamber_map;
#endif
