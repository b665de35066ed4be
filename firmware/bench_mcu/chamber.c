#include "chamber.h"

#include <avr/io.h>

#include <stend/devices/bench_mcu_regs.h>

#include "board.h"
#include "ds18b20.h"
#include "pid.h"

static uint16_t hold[STEND_CHAMBER_HOLD_COUNT];
static PidState pid;
static int16_t raw;
static uint8_t running;
static uint16_t faults; /* latched STATUS fault bits */
static uint16_t sensor_errors;
static uint16_t cycles;
static uint32_t next_cycle_ms, last_master_ms, now_cache_ms;
static uint8_t converting;

static int16_t round_to_i16(float v) { return (int16_t)(v >= 0.0f ? v + 0.5f : v - 0.5f); }

/* Timer1, 8-bit fast PWM, clk/64 (976 Hz): OC1A pin 9 Peltier, OC1B pin 10 heater. A duty of
 * 0 disconnects the compare output so the pin is fully low. */
static void pwm_init(void) {
  PORTB &= (uint8_t)~((1 << PB1) | (1 << PB2));
  DDRB |= (1 << PB1) | (1 << PB2);
  TCCR1A = (1 << WGM10);
  TCCR1B = (1 << WGM12) | (1 << CS11) | (1 << CS10);
}

static void pwm_set(uint8_t heater, uint8_t peltier) {
  OCR1B = heater;
  OCR1A = peltier;
  uint8_t a = (uint8_t)(TCCR1A & ~((1 << COM1A1) | (1 << COM1B1)));
  if (peltier) a |= (1 << COM1A1);
  if (heater) a |= (1 << COM1B1);
  TCCR1A = a;
}

void chamber_outputs_off(void) {
  pid.heater_pwm = pid.peltier_pwm = 0;
  pid.u = 0.0f;
  pwm_set(0, 0);
}

void chamber_init(void) {
  hold[STEND_CHAMBER_HOLD_SETPOINT] = 2500;
  hold[STEND_CHAMBER_HOLD_KP] = STEND_CHAMBER_DEFAULT_KP;
  hold[STEND_CHAMBER_HOLD_KI] = STEND_CHAMBER_DEFAULT_KI;
  hold[STEND_CHAMBER_HOLD_KD] = STEND_CHAMBER_DEFAULT_KD;
  hold[STEND_CHAMBER_HOLD_I_STEP] = STEND_CHAMBER_DEFAULT_I_STEP;
  hold[STEND_CHAMBER_HOLD_I_LIMIT] = STEND_CHAMBER_DEFAULT_I_LIMIT;
  hold[STEND_CHAMBER_HOLD_PELTIER_OFFSET] = STEND_CHAMBER_DEFAULT_PELTIER_OFFSET;
  hold[STEND_CHAMBER_HOLD_HEATER_DIVISOR] = STEND_CHAMBER_DEFAULT_HEATER_DIVISOR;
  hold[STEND_CHAMBER_HOLD_TRIP_HIGH] = 8500;
  hold[STEND_CHAMBER_HOLD_TRIP_LOW] = (uint16_t)-4500;
  pid_reset(&pid);
  pwm_init();
  chamber_outputs_off();
  converting = ds18b20_start_conversion();
  next_cycle_ms = CONTROL_PERIOD_MS;
}

static void read_sensor(void) {
  uint8_t ok = 0;
  raw = converting ? ds18b20_read_raw(&ok) : STEND_CHAMBER_RAW_DISCONNECTED;
  if (!ok || raw == STEND_CHAMBER_RAW_POWER_ON) {
    faults |= STEND_CHAMBER_STATUS_SENSOR_FAULT;
    if (sensor_errors < 0xFFFF) ++sensor_errors;
  }
}

static void check_guards(uint32_t now_ms) {
  const int32_t centi = (int32_t)raw * 100 / 16;
  if (!(faults & STEND_CHAMBER_STATUS_SENSOR_FAULT)) {
    if (centi > (int16_t)hold[STEND_CHAMBER_HOLD_TRIP_HIGH]) faults |= STEND_CHAMBER_STATUS_TRIP_HIGH;
    if (centi < (int16_t)hold[STEND_CHAMBER_HOLD_TRIP_LOW]) faults |= STEND_CHAMBER_STATUS_TRIP_LOW;
  }
  const uint32_t wd_ms = (uint32_t)hold[STEND_CHAMBER_HOLD_WATCHDOG] * 1000u;
  if (wd_ms > 0 && running && now_ms - last_master_ms > wd_ms) faults |= STEND_CHAMBER_STATUS_WATCHDOG;
}

static void control_cycle(uint32_t now_ms) {
  ++cycles;
  read_sensor();
  check_guards(now_ms);
  if (!running || (faults & STEND_CHAMBER_STATUS_FAULT_MASK)) {
    chamber_outputs_off();
  } else {
    const PidGains g = {hold[STEND_CHAMBER_HOLD_KP], hold[STEND_CHAMBER_HOLD_KI], hold[STEND_CHAMBER_HOLD_KD],
                        hold[STEND_CHAMBER_HOLD_I_STEP], hold[STEND_CHAMBER_HOLD_I_LIMIT],
                        hold[STEND_CHAMBER_HOLD_PELTIER_OFFSET], hold[STEND_CHAMBER_HOLD_HEATER_DIVISOR]};
    pid_step(&pid, &g, raw, (int16_t)hold[STEND_CHAMBER_HOLD_SETPOINT]);
    pwm_set(pid.heater_pwm, pid.peltier_pwm);
  }
  converting = ds18b20_start_conversion(); /* read at the next cycle, CONVERSION_MS < the period */
}

void chamber_poll(uint32_t now_ms) {
  now_cache_ms = now_ms;
  if ((int32_t)(now_ms - next_cycle_ms) < 0) return;
  next_cycle_ms += CONTROL_PERIOD_MS;
  control_cycle(now_ms);
}

/* ---- Registers ---- */
static void write_ctrl(uint16_t value) {
  if (value & STEND_CHAMBER_CTRL_CLEAR_FAULT) faults = 0;
  const uint8_t run = (value & STEND_CHAMBER_CTRL_RUN) != 0;
  if (run && !running) pid_reset(&pid); /* the loop starts from I = 0, err_prev = 0 */
  if (!run) chamber_outputs_off();
  running = run;
  hold[STEND_CHAMBER_HOLD_CTRL] = (uint16_t)(value & STEND_CHAMBER_CTRL_RUN);
}

static uint8_t write_holding(uint16_t address, uint8_t n, const uint8_t* values) {
  if ((uint32_t)address + n > STEND_CHAMBER_HOLD_COUNT) return MB_EX_ILLEGAL_ADDRESS;
  for (uint8_t i = 0; i < n; ++i) {
    const uint16_t v = (uint16_t)((values[2 * i] << 8) | values[2 * i + 1]);
    if (address + i == STEND_CHAMBER_HOLD_CTRL) write_ctrl(v);
    else hold[address + i] = v;
  }
  return MB_OK;
}

static uint8_t read_holding(uint16_t address, uint8_t n, uint8_t* out) {
  if ((uint32_t)address + n > STEND_CHAMBER_HOLD_COUNT) return MB_EX_ILLEGAL_ADDRESS;
  for (uint8_t i = 0; i < n; ++i) {
    out[2 * i] = (uint8_t)(hold[address + i] >> 8);
    out[2 * i + 1] = (uint8_t)hold[address + i];
  }
  return MB_OK;
}

static uint16_t input_register(uint16_t a) {
  switch (a) {
    case STEND_CHAMBER_IN_STATUS: return (uint16_t)((running ? STEND_CHAMBER_STATUS_RUNNING : 0) | faults);
    case STEND_CHAMBER_IN_TEMP_RAW: return (uint16_t)raw;
    case STEND_CHAMBER_IN_HEATER_PWM: return pid.heater_pwm;
    case STEND_CHAMBER_IN_PELTIER_PWM: return pid.peltier_pwm;
    case STEND_CHAMBER_IN_INTEGRAL: return (uint16_t)round_to_i16(pid.integral * 100.0f);
    case STEND_CHAMBER_IN_OUTPUT: return (uint16_t)round_to_i16(pid.u);
    case STEND_CHAMBER_IN_SENSOR_ERRORS: return sensor_errors;
    case STEND_CHAMBER_IN_CYCLES: return cycles;
    case STEND_CHAMBER_IN_FIRMWARE: return STEND_CHAMBER_FIRMWARE_VERSION;
    case STEND_CHAMBER_IN_SETPOINT_ACTIVE: return hold[STEND_CHAMBER_HOLD_SETPOINT];
    default: return 0;
  }
}

static uint8_t read_input(uint16_t address, uint8_t n, uint8_t* out) {
  if ((uint32_t)address + n > STEND_CHAMBER_IN_COUNT) return MB_EX_ILLEGAL_ADDRESS;
  for (uint8_t i = 0; i < n; ++i) {
    const uint16_t v = input_register((uint16_t)(address + i));
    out[2 * i] = (uint8_t)(v >> 8);
    out[2 * i + 1] = (uint8_t)v;
  }
  return MB_OK;
}

static void master_seen(void) { last_master_ms = now_cache_ms; }

const ModbusMap chamber_map = {SLAVE_ID_CHAMBER, read_holding, read_input, write_holding, master_seen};
