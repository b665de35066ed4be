/* The MPU-6050 as the firmware drives it over TWI: configuration at a RUN edge, its own FIFO
 * (accel, temperature, gyro: the 0x3B..0x48 burst order, 14 bytes per sample) drained into the
 * MCU's sample ring, sleep. Register numbers: the InvenSense register map, rev. 4.2. */
#ifndef BENCH_MCU_MPU6050_H
#define BENCH_MCU_MPU6050_H
#include <stdint.h>

#define MPU_SAMPLE_BYTES 14

typedef struct {
  uint8_t smplrt_div, dlpf_cfg, gyro_fs_sel, accel_fs_sel;
} MpuConfig;

uint8_t mpu_start(const MpuConfig* c); /* configure, wake, empty and enable the FIFO; I2C status */
uint8_t mpu_sleep(void);
uint8_t mpu_reset_fifo(void);
/* Samples waiting in the part's FIFO (0 on an I2C error); sets *overflowed when the part's FIFO
 * overflowed (its frame alignment is then lost: the firmware resets it). */
uint16_t mpu_fifo_samples(uint8_t* overflowed);
uint8_t mpu_read_sample(uint8_t* out14);
uint8_t mpu_who_am_i(void);  /* 0 when the part does not answer */
uint8_t mpu_asleep(void);    /* 1 when PWR_MGMT_1.SLEEP is set or the part does not answer */
#endif
