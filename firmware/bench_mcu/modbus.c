#include "modbus.h"

#include "crc.h"

enum { FC_READ_HOLDING = 3, FC_READ_INPUT = 4, FC_WRITE_SINGLE = 6, FC_WRITE_MULTIPLE = 16 };
enum { MAX_READ = 125, MAX_WRITE = 123 };

static uint16_t be16(const uint8_t* p) { return (uint16_t)((p[0] << 8) | p[1]); }

static uint16_t append_crc(uint8_t* frame, uint16_t n) {
  const uint16_t crc = crc16_modbus(frame, n);
  frame[n] = (uint8_t)(crc & 0xFF);
  frame[n + 1] = (uint8_t)(crc >> 8);
  return (uint16_t)(n + 2);
}

static uint16_t exception_reply(const uint8_t* req, uint8_t code, uint8_t* reply) {
  reply[0] = req[0];
  reply[1] = (uint8_t)(req[1] | 0x80);
  reply[2] = code;
  return append_crc(reply, 3);
}

static const ModbusMap* find_map(uint8_t id, const ModbusMap* const* maps, uint8_t n_maps) {
  for (uint8_t i = 0; i < n_maps; ++i)
    if (maps[i]->slave_id == id) return maps[i];
  return 0;
}

/* The expected request length of each function (0: unknown function), from its header. */
static uint16_t expected_length(const uint8_t* req, uint16_t len) {
  switch (req[1]) {
    case FC_READ_HOLDING:
    case FC_READ_INPUT:
    case FC_WRITE_SINGLE: return 8;
    case FC_WRITE_MULTIPLE: return len >= 7 ? (uint16_t)(9 + req[6]) : 9;
    default: return len;
  }
}

static uint8_t read_registers(const ModbusMap* m, const uint8_t* req, uint8_t* reply, uint16_t* n_reply) {
  const uint16_t address = be16(req + 2), count = be16(req + 4);
  if (count == 0 || count > MAX_READ) return MB_EX_ILLEGAL_VALUE;
  const uint8_t code = req[1] == FC_READ_HOLDING ? m->read_holding(address, (uint8_t)count, reply + 3)
                                                 : m->read_input(address, (uint8_t)count, reply + 3);
  if (code != MB_OK) return code;
  reply[2] = (uint8_t)(2 * count);
  *n_reply = (uint16_t)(3 + 2 * count);
  return MB_OK;
}

static uint8_t write_registers(const ModbusMap* m, const uint8_t* req, uint8_t* reply, uint16_t* n_reply) {
  const uint16_t address = be16(req + 2);
  uint8_t code;
  if (req[1] == FC_WRITE_SINGLE) {
    code = m->write_holding(address, 1, req + 4);
  } else {
    const uint16_t count = be16(req + 4);
    if (count == 0 || count > MAX_WRITE || req[6] != 2 * count) return MB_EX_ILLEGAL_VALUE;
    code = m->write_holding(address, (uint8_t)count, req + 7);
  }
  if (code != MB_OK) return code;
  for (uint8_t i = 2; i < 6; ++i) reply[i] = req[i]; /* echo address and value / count */
  *n_reply = 6;
  return MB_OK;
}

uint16_t modbus_handle(const uint8_t* req, uint16_t len, const ModbusMap* const* maps, uint8_t n_maps,
                       uint8_t* reply) {
  if (len < 4 || len == 0xFFFF) return 0;
  if (crc16_modbus(req, len) != 0) return 0; /* CRC over frame + CRC is 0 when intact */
  const ModbusMap* m = find_map(req[0], maps, n_maps);
  if (m == 0) return 0;
  if (m->seen) m->seen();
  const uint8_t fc = req[1];
  const int known = fc == FC_READ_HOLDING || fc == FC_READ_INPUT || fc == FC_WRITE_SINGLE || fc == FC_WRITE_MULTIPLE;
  if (!known) return exception_reply(req, MB_EX_ILLEGAL_FUNCTION, reply);
  if (len != expected_length(req, len)) return exception_reply(req, MB_EX_ILLEGAL_VALUE, reply);
  reply[0] = req[0];
  reply[1] = fc;
  uint16_t n = 0;
  const uint8_t code = (fc == FC_READ_HOLDING || fc == FC_READ_INPUT) ? read_registers(m, req, reply, &n)
                                                                       : write_registers(m, req, reply, &n);
  if (code != MB_OK) return exception_reply(req, code, reply);
  return append_crc(reply, n);
}
