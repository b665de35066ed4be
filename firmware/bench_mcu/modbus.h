/* MODBUS RTU slave: checks a request frame (length, CRC, slave id), decodes FC 03/04/06/16,
 * answers with the register map of the addressed slave or with an exception:
 *   01 illegal function (any other function code), 02 illegal data address (the map's answer),
 *   03 illegal data value (register count 0 or above the MODBUS limit, byte count mismatch),
 *   04 slave device failure (the map could not reach its device, e.g. the MPU-6050 on I2C).
 * A frame with a bad CRC, too short, or for another slave gets no reply (MODBUS RTU). */
#ifndef BENCH_MCU_MODBUS_H
#define BENCH_MCU_MODBUS_H
#include <stdint.h>

enum {
  MB_OK = 0,
  MB_EX_ILLEGAL_FUNCTION = 1,
  MB_EX_ILLEGAL_ADDRESS = 2,
  MB_EX_ILLEGAL_VALUE = 3,
  MB_EX_DEVICE_FAILURE = 4
};

/* One slave's register map. Reads fill `out` with n big-endian words; writes take n words. */
typedef struct {
  uint8_t slave_id;
  uint8_t (*read_holding)(uint16_t address, uint8_t n, uint8_t* out);
  uint8_t (*read_input)(uint16_t address, uint8_t n, uint8_t* out);
  uint8_t (*write_holding)(uint16_t address, uint8_t n, const uint8_t* values);
  void (*seen)(void); /* any valid request for this slave (the master is alive) */
} ModbusMap;

/* Handles one received frame; returns the reply length written to `reply` (0: no reply). */
uint16_t modbus_handle(const uint8_t* req, uint16_t len, const ModbusMap* const* maps, uint8_t n_maps,
                       uint8_t* reply);

#endif
