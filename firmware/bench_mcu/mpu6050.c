#include "mpu6050.h"

#include <stend/devices/bench_mcu_regs.h>

#include "board.h"
#include "twi.h"

enum {
  REG_SMPLRT_DIV = 0x19, REG_CONFIG = 0x1A, REG_GYRO_CONFIG = 0x1B, REG_ACCEL_CONFIG = 0x1C,
  REG_FIFO_EN = 0x23, REG_INT_STATUS = 0x3A, REG_USER_CTRL = 0x6A, REG_PWR_MGMT_1 = 0x6B,
  REG_FIFO_COUNT_H = 0x72, REG_FIFO_R_W = 0x74, REG_WHO_AM_I = 0x75
};
enum {
  FIFO_EN_TEMP_GYRO_ACCEL = 0xF8, /* TEMP, XG, YG, ZG, ACCEL */
  USER_FIFO_EN = 0x40, USER_FIFO_RESET = 0x04, PWR_CLK_PLL_XGYRO = 0x01, PWR_SLEEP = 0x40,
  INT_FIFO_OFLOW = 0x10
};

static uint8_t write_all(const uint8_t (*pairs)[2], uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) {
    const uint8_t s = twi_write_reg(MPU_ADDRESS, pairs[i][0], pairs[i][1]);
    if (s != STEND_BMCU_I2C_OK) return s;
  }
  return STEND_BMCU_I2C_OK;
}

uint8_t mpu_start(const MpuConfig* c) {
  const uint8_t seq[][2] = {
      {REG_SMPLRT_DIV, c->smplrt_div},
      {REG_CONFIG, (uint8_t)(c->dlpf_cfg & 0x07)},
      {REG_GYRO_CONFIG, (uint8_t)((c->gyro_fs_sel & 3) << 3)},
      {REG_ACCEL_CONFIG, (uint8_t)((c->accel_fs_sel & 3) << 3)},
      {REG_PWR_MGMT_1, PWR_CLK_PLL_XGYRO},
      {REG_FIFO_EN, FIFO_EN_TEMP_GYRO_ACCEL},
      {REG_USER_CTRL, USER_FIFO_RESET},
      {REG_USER_CTRL, USER_FIFO_EN},
  };
  return write_all(seq, (uint8_t)(sizeof seq / sizeof seq[0]));
}

uint8_t mpu_sleep(void) { return twi_write_reg(MPU_ADDRESS, REG_PWR_MGMT_1, PWR_SLEEP); }

uint8_t mpu_reset_fifo(void) {
  const uint8_t seq[][2] = {{REG_USER_CTRL, USER_FIFO_RESET}, {REG_USER_CTRL, USER_FIFO_EN}};
  return write_all(seq, 2);
}

uint16_t mpu_fifo_samples(uint8_t* overflowed) {
  uint8_t st = 0, cnt[2] = {0, 0};
  if (twi_read_regs(MPU_ADDRESS, REG_INT_STATUS, &st, 1) != STEND_BMCU_I2C_OK) return 0;
  *overflowed = (st & INT_FIFO_OFLOW) != 0;
  if (twi_read_regs(MPU_ADDRESS, REG_FIFO_COUNT_H, cnt, 2) != STEND_BMCU_I2C_OK) return 0;
  return (uint16_t)(((cnt[0] << 8) | cnt[1]) / MPU_SAMPLE_BYTES);
}

uint8_t mpu_read_sample(uint8_t* out14) { return twi_read_regs(MPU_ADDRESS, REG_FIFO_R_W, out14, MPU_SAMPLE_BYTES); }

uint8_t mpu_who_am_i(void) {
  uint8_t v = 0;
  return twi_read_regs(MPU_ADDRESS, REG_WHO_AM_I, &v, 1) == STEND_BMCU_I2C_OK ? v : 0;
}

uint8_t mpu_asleep(void) {
  uint8_t v = PWR_SLEEP;
  twi_read_regs(MPU_ADDRESS, REG_PWR_MGMT_1, &v, 1);
  return (v & PWR_SLEEP) != 0;
}
