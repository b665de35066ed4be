/* Slave SLAVE_ID_SENSOR: the MPU-6050 stream and the I2C passthrough window
 * (docs/bench-mcu-modbus.md). */
#ifndef BENCH_MCU_SENSOR_STREAM_H
#define BENCH_MCU_SENSOR_STREAM_H
#include "modbus.h"
void sensor_stream_init(uint16_t boot_count);
void sensor_stream_poll(uint32_t now_ms); /* drains the MPU-6050's FIFO into the ring */
extern const ModbusMap sensor_stream_map;
#endif
