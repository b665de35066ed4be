#include "sensor_stream.h"

#include <string.h>

#include <stend/devices/bench_mcu_regs.h>

#include "board.h"
#include "mpu6050.h"
#include "twi.h"

#define WINDOW_MAX_WORDS (STEND_BMCU_WINDOW_HEADER_WORDS + STEND_BMCU_WORDS_PER_SAMPLE * STEND_BMCU_WINDOW_MAX_SAMPLES)
#define I2C_DATA_REGS (STEND_BMCU_I2C_MAX_READ / 2)
#define PART_FIFO_HIGH 52 /* of the part's 73 samples: above this the ring makes room (21 ms of margin at 1 kHz, twice the ~10 ms 1-Wire cycle) */
#define CAPACITY (RING_SAMPLES + PART_FIFO_HIGH)
#define PART_FIFO_SAMPLES 73 /* 1024 bytes / 14 */
#define MAX_DRAIN_PER_POLL 4 /* samples per poll (0.4 ms of I2C each), so a request waits at most ~2 ms */

static uint16_t hold[STEND_BMCU_HOLD_MAP_SIZE];
static uint8_t ring[RING_SAMPLES][MPU_SAMPLE_BYTES];
static uint8_t ring_head; /* index of the oldest sample */
static uint8_t ring_size;
static uint16_t part_pending; /* samples in the part's FIFO at the last drain */
static uint32_t front_seq, next_seq; /* sequence numbers of the oldest and the next sample */
static uint32_t sent_seq; /* one past the last sample a window has returned (delivered, maybe not yet acknowledged) */
static uint16_t overflows;
static uint8_t overflow_flag, running;
static uint16_t boot_count;
static uint32_t last_drain_ms;
static uint16_t i2c_status, i2c_count;
static uint8_t i2c_data[STEND_BMCU_I2C_MAX_READ];

static void put16(uint8_t* out, uint16_t v) {
  out[0] = (uint8_t)(v >> 8);
  out[1] = (uint8_t)(v & 0xFF);
}

static void ring_clear(void) {
  ring_head = 0;
  ring_size = 0;
  part_pending = 0;
}

static void ring_pop(void) {
  ring_head = (uint8_t)((ring_head + 1) % RING_SAMPLES);
  --ring_size;
  ++front_seq;
}

static uint8_t* ring_at(uint8_t i) { return ring[(ring_head + i) % RING_SAMPLES]; }

static void count_lost(uint16_t n) {
  if (n == 0) return;
  overflows = (uint16_t)(overflows > 0xFFFF - n ? 0xFFFF : overflows + n);
  overflow_flag = 1;
}

/* Samples in the ring no window has returned yet: the ones the host could still lose. */
static uint8_t ring_unsent(void) { return (uint8_t)(sent_seq > front_seq ? next_seq - sent_seq : ring_size); }

/* The slot for the next sample; the oldest is dropped when the ring is full. Only a dropped sample
 * no window had returned is lost (OVERFLOWS): one returned but not yet acknowledged reached the host. */
static uint8_t* ring_push_slot(void) {
  if (ring_size == RING_SAMPLES) {
    const uint8_t lost = front_seq >= sent_seq;
    ring_pop();
    count_lost(lost);
  }
  ++ring_size;
  ++next_seq;
  return ring_at((uint8_t)(ring_size - 1));
}

void sensor_stream_init(uint16_t boots) {
  boot_count = boots;
  mpu_sleep(); /* the part powers up asleep; a reset of the MCU alone leaves it as it was */
}

static void drain_mpu(void) {
  uint8_t part_overflowed = 0;
  uint16_t n = mpu_fifo_samples(&part_overflowed);
  if (part_overflowed) { /* frame alignment lost: start the part's FIFO afresh */
    mpu_reset_fifo();
    /* At least a FIFO's worth was dropped there. The ring's numbering is contiguous, so the ring
     * is dropped too and the sequence numbers skip both: the master sees one gap (its length
     * is this estimate, not an exact count). Needs a firmware stall of > 33 ms to happen. */
    const uint16_t dropped = (uint16_t)(ring_unsent() + PART_FIFO_SAMPLES);
    next_seq += PART_FIFO_SAMPLES;
    ring_clear();
    front_seq = next_seq;
    count_lost(dropped);
    return;
  }
  part_pending = n;
  /* Backpressure: while the ring is full, samples wait in the part's own FIFO; only when that
   * nears its end are the ring's oldest overwritten (counted), so sequence numbers stay exact. */
  if (ring_size == RING_SAMPLES && n < PART_FIFO_HIGH) return;
  if (n > MAX_DRAIN_PER_POLL) n = MAX_DRAIN_PER_POLL;
  for (uint16_t i = 0; i < n; ++i) {
    uint8_t sample[MPU_SAMPLE_BYTES];
    if (mpu_read_sample(sample) != STEND_BMCU_I2C_OK) return;
    memcpy(ring_push_slot(), sample, MPU_SAMPLE_BYTES);
    --part_pending;
  }
}

void sensor_stream_poll(uint32_t now_ms) {
  if (!running || now_ms - last_drain_ms < MPU_DRAIN_PERIOD_MS) return;
  last_drain_ms = now_ms;
  drain_mpu();
}

/* ---- CTRL: RUN edges and FIFO reset ---- */
static uint8_t start_stream(void) {
  const MpuConfig c = {(uint8_t)(hold[STEND_BMCU_HOLD_SMPLRT_DIV] & 0xFF), (uint8_t)hold[STEND_BMCU_HOLD_DLPF_CFG],
                       (uint8_t)hold[STEND_BMCU_HOLD_GYRO_FS_SEL], (uint8_t)hold[STEND_BMCU_HOLD_ACCEL_FS_SEL]};
  ring_clear();
  front_seq = next_seq = sent_seq = 0;
  overflows = 0;
  overflow_flag = 0;
  return mpu_start(&c) == STEND_BMCU_I2C_OK;
}

static uint8_t apply_ctrl(void) {
  uint16_t* ctrl = &hold[STEND_BMCU_HOLD_CTRL];
  if (*ctrl & STEND_BMCU_CTRL_FIFO_RESET) {
    ring_clear();
    if (running) mpu_reset_fifo(); /* what waits in the part is older than the reset too */
    front_seq = next_seq;
    *ctrl &= (uint16_t)~STEND_BMCU_CTRL_FIFO_RESET;
  }
  const uint8_t run = (*ctrl & STEND_BMCU_CTRL_RUN) != 0;
  if (run && !running && !start_stream()) {
    *ctrl &= (uint16_t)~STEND_BMCU_CTRL_RUN;
    return MB_EX_DEVICE_FAILURE; /* the MPU-6050 did not answer on I2C */
  }
  if (!run && running) mpu_sleep();
  running = run;
  return MB_OK;
}

/* ---- I2C passthrough: one transaction per write of I2C_CMD ---- */
static void i2c_done(uint16_t tag, uint8_t result, uint8_t n) {
  i2c_status = (uint16_t)(tag | result);
  i2c_count = n;
}

static void run_i2c_command(void) {
  const uint16_t cmd = hold[STEND_BMCU_HOLD_I2C_CMD];
  const uint16_t tag = (uint16_t)(cmd & 0xFF00);
  const uint8_t op = (uint8_t)(cmd & 0xFF);
  const uint8_t addr = (uint8_t)(hold[STEND_BMCU_HOLD_I2C_ADDR] & 0x7F);
  const uint16_t len = hold[STEND_BMCU_HOLD_I2C_LEN];
  const uint8_t read = op == STEND_BMCU_I2C_CMD_READ || op == STEND_BMCU_I2C_CMD_READ_NO_REG;
  memset(i2c_data, 0, sizeof i2c_data);
  if ((read && (len < 1 || len > STEND_BMCU_I2C_MAX_READ)) || (op == STEND_BMCU_I2C_CMD_WRITE && len > STEND_BMCU_I2C_MAX_WRITE) ||
      (!read && op != STEND_BMCU_I2C_CMD_WRITE)) {
    i2c_done(tag, STEND_BMCU_I2C_BAD_REQUEST, 0);
    return;
  }
  uint8_t w[1 + STEND_BMCU_I2C_MAX_WRITE];
  uint8_t wn = 0;
  if (op != STEND_BMCU_I2C_CMD_READ_NO_REG) w[wn++] = (uint8_t)hold[STEND_BMCU_HOLD_I2C_REG];
  if (op == STEND_BMCU_I2C_CMD_WRITE)
    for (uint8_t i = 0; i < len; ++i) w[wn++] = (uint8_t)hold[STEND_BMCU_HOLD_I2C_WDATA + i];
  const uint8_t rn = read ? (uint8_t)len : 0;
  const uint8_t s = twi_transfer(addr, w, wn, i2c_data, rn);
  i2c_done(tag, s, s == STEND_BMCU_I2C_OK ? rn : 0);
}

/* ---- Register reads ---- */
static void read_status_block(uint16_t address, uint8_t n, uint8_t* out) {
  for (uint16_t a = address; a < address + n; ++a, out += 2) {
    uint16_t v = 0;
    switch (a) {
      case STEND_BMCU_IN_STATUS:
        v = (uint16_t)((running ? STEND_BMCU_STATUS_RUNNING : 0) | (overflow_flag ? STEND_BMCU_STATUS_OVERFLOW : 0) |
                       (mpu_asleep() ? STEND_BMCU_STATUS_ASLEEP : 0));
        overflow_flag = 0; /* cleared by reading */
        break;
      case STEND_BMCU_IN_WHO_AM_I: v = mpu_who_am_i(); break;
      case STEND_BMCU_IN_FIFO_COUNT: v = (uint16_t)(ring_size + part_pending); break;
      case STEND_BMCU_IN_FIFO_CAPACITY: v = CAPACITY; break;
      case STEND_BMCU_IN_OVERFLOWS: v = overflows; break;
      case STEND_BMCU_IN_FIRMWARE: v = STEND_BMCU_FIRMWARE_VERSION; break;
      case STEND_BMCU_IN_BOOT_COUNT: v = boot_count; break;
      default: break;
    }
    put16(out, v);
  }
}

static void read_i2c_window(uint16_t address, uint8_t n, uint8_t* out) {
  for (uint16_t a = address; a < address + n; ++a, out += 2) {
    uint16_t v;
    if (a == STEND_BMCU_IN_I2C_STATUS) v = i2c_status;
    else if (a == STEND_BMCU_IN_I2C_COUNT) v = i2c_count;
    else {
      const uint16_t i = (uint16_t)(2 * (a - STEND_BMCU_IN_I2C_DATA));
      v = (uint16_t)((i2c_data[i] << 8) | i2c_data[i + 1]);
    }
    put16(out, v);
  }
}

/* Acknowledges every sample before s (when still buffered), returns up to 17 from there. */
static void read_fifo_window(uint16_t address, uint8_t n, uint8_t* out) {
  const uint32_t s_mod = (uint32_t)(address - STEND_BMCU_IN_WINDOW_BASE);
  const uint32_t back = (next_seq - s_mod) & (STEND_BMCU_WINDOW_SEQ_MODULO - 1);
  if (back <= next_seq - front_seq) {
    const uint32_t s = next_seq - back;
    while (front_seq < s && ring_size > 0) ring_pop();
  }
  uint8_t k = (uint8_t)((n - STEND_BMCU_WINDOW_HEADER_WORDS) / STEND_BMCU_WORDS_PER_SAMPLE);
  if (k > STEND_BMCU_WINDOW_MAX_SAMPLES) k = STEND_BMCU_WINDOW_MAX_SAMPLES;
  if (k > ring_size) k = ring_size;
  memset(out, 0, (size_t)(2 * n));
  put16(out, k);
  put16(out + 2, (uint16_t)(ring_size - k + part_pending));
  put16(out + 4, (uint16_t)(front_seq >> 16));
  put16(out + 6, (uint16_t)(front_seq & 0xFFFF));
  if (front_seq + k > sent_seq) sent_seq = front_seq + k;
  for (uint8_t i = 0; i < k; ++i) memcpy(out + 8 + i * MPU_SAMPLE_BYTES, ring_at(i), MPU_SAMPLE_BYTES);
}

static uint8_t read_input(uint16_t address, uint8_t n, uint8_t* out) {
  const uint32_t end = (uint32_t)address + n;
  if (end <= STEND_BMCU_IN_COUNT) {
    read_status_block(address, n, out);
  } else if (address >= STEND_BMCU_IN_I2C_STATUS && end <= STEND_BMCU_IN_I2C_DATA + I2C_DATA_REGS) {
    read_i2c_window(address, n, out);
  } else if (address >= STEND_BMCU_IN_WINDOW_BASE && address < (uint32_t)STEND_BMCU_IN_WINDOW_BASE + STEND_BMCU_WINDOW_SEQ_MODULO &&
             n >= STEND_BMCU_WINDOW_HEADER_WORDS && n <= WINDOW_MAX_WORDS) {
    read_fifo_window(address, n, out);
  } else {
    return MB_EX_ILLEGAL_ADDRESS;
  }
  return MB_OK;
}

static uint8_t read_holding(uint16_t address, uint8_t n, uint8_t* out) {
  if ((uint32_t)address + n > STEND_BMCU_HOLD_MAP_SIZE) return MB_EX_ILLEGAL_ADDRESS;
  for (uint8_t i = 0; i < n; ++i) put16(out + 2 * i, hold[address + i]);
  return MB_OK;
}

static uint8_t write_holding(uint16_t address, uint8_t n, const uint8_t* values) {
  if ((uint32_t)address + n > STEND_BMCU_HOLD_MAP_SIZE) return MB_EX_ILLEGAL_ADDRESS;
  for (uint8_t i = 0; i < n; ++i) hold[address + i] = (uint16_t)((values[2 * i] << 8) | values[2 * i + 1]);
  const uint8_t code = apply_ctrl();
  if (address <= STEND_BMCU_HOLD_I2C_CMD && address + n > STEND_BMCU_HOLD_I2C_CMD) run_i2c_command();
  return code;
}

const ModbusMap sensor_stream_map = {SLAVE_ID_SENSOR, read_holding, read_input, write_holding, 0};
