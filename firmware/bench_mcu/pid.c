#include "pid.h"

static float clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

void pid_reset(PidState* s) {
  s->integral = 0.0f;
  s->err_prev = 0.0f;
  s->u = 0.0f;
  s->heater_pwm = 0;
  s->peltier_pwm = 0;
}

void pid_step(PidState* s, const PidGains* g, int16_t raw, int16_t setpoint_centi_c) {
  const float err = (float)raw / 16.0f - (float)setpoint_centi_c / 100.0f;
  const float ilim = (float)g->i_limit;
  s->integral = clampf(s->integral + (float)g->i_step / 1000.0f * err, -ilim, ilim);
  float u = (float)g->kp * err + (float)g->ki * s->integral - (float)g->kd * (err - s->err_prev);
  s->err_prev = err;
  u = clampf(u, -255.0f, 255.0f);
  s->u = u;
  if (u > 0.0f) {
    const float p = u + (float)g->peltier_offset;
    s->peltier_pwm = (uint8_t)(p > 255.0f ? 255.0f : p);
    s->heater_pwm = 0;
  } else {
    const float d = g->heater_divisor < 1 ? 1.0f : (float)g->heater_divisor;
    s->peltier_pwm = 0;
    s->heater_pwm = (uint8_t)(-u / d);
  }
}
