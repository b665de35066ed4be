/* The chamber's PID loop exactly as published (../shared/paper.md), in the AVR's float (32 bit):
 *   T = raw/16; err = T - T_set; I += (I_STEP/1000)·err, |I| <= I_LIMIT;
 *   u = KP·err + KI·I - KD·(err - err_prev); err_prev = err; |u| <= 255;
 *   u > 0: Peltier = min(u + OFFSET, 255), heater 0;  else: Peltier 0, heater = -u/DIVISOR
 *   (both truncated to integers as the Arduino's analogWrite(int) receives them). */
#ifndef BENCH_MCU_PID_H
#define BENCH_MCU_PID_H
#include <stdint.h>

typedef struct {
  uint16_t kp, ki, kd, i_step, i_limit, peltier_offset, heater_divisor;
} PidGains;

typedef struct {
  float integral, err_prev, u;
  uint8_t heater_pwm, peltier_pwm;
} PidState;

void pid_reset(PidState* s);
void pid_step(PidState* s, const PidGains* g, int16_t raw, int16_t setpoint_centi_c);
#endif
