// Motion of one simulated fixture axis (a table axis): trapezoidal position moves and rate ramps
// under a speed and an acceleration limit, stored as an analytic plan so the state is exact at ANY
// time (the runner advances fixtures every ~10 ms, the sensor asks for the pose at each 1 ms
// sample). Shared by the simulated one- and three-axis tables.
//
// Units are the axis's own (deg, deg/s, deg/s² for tables); time in seconds on the run clock.
#pragma once

#include <stend/model/noise.hpp>
#include <stend/sdk.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace stend::sim {

struct AxisState {
  double position = 0.0;
  double velocity = 0.0;
  double acceleration = 0.0;
};

// A plan: up to 4 segments of constant acceleration starting at start_time(), then a final
// segment of constant velocity (0 = holding a position) that lasts forever.
class MotionPlan {
 public:
  MotionPlan() { push(0.0, 0.0, 0.0, 0.0); }

  static MotionPlan hold(double t0, double position) {
    MotionPlan m;
    m.n_ = 0;
    m.push(t0, position, 0.0, 0.0);
    return m;
  }

  // Time-optimal move from `from` (position, velocity) to rest at `target`, |v| ≤ vmax,
  // |a| ≤ amax. A start velocity above vmax is first brought down to vmax; moving away from the
  // target (or too fast to stop before it) first brakes to rest, then moves back.
  static MotionPlan to_position(double t0, const AxisState& from, double target, double vmax, double amax) {
    check_limits(vmax, amax);
    MotionPlan m;
    m.n_ = 0;
    double t = t0, p = from.position, v = from.velocity;
    const double d = target - p;
    const double stop = v * std::abs(v) / (2.0 * amax);  // signed distance to brake to rest
    if (v != 0.0 && (std::signbit(v) != std::signbit(d) || d == 0.0 || std::abs(stop) > std::abs(d))) {
      m.push(t, p, v, v > 0.0 ? -amax : amax);
      t += std::abs(v) / amax;
      p += stop;
      v = 0.0;
    }
    const double dist = target - p;
    const double D = std::abs(dist);
    if (D > 0.0) {
      const double s = dist > 0.0 ? 1.0 : -1.0;
      const double w0 = std::abs(v);  // speed toward the target
      double vp;                      // peak (cruise) speed
      if (w0 > vmax) {
        vp = vmax;
        m.push(t, p, v, -s * amax);  // slow down to vmax
        const double t1 = (w0 - vmax) / amax;
        p += s * (w0 * w0 - vmax * vmax) / (2.0 * amax);
        t += t1;
      } else {
        vp = std::min(vmax, std::sqrt(amax * D + 0.5 * w0 * w0));
        if (vp > w0) {
          m.push(t, p, v, s * amax);
          p += s * (vp * vp - w0 * w0) / (2.0 * amax);
          t += (vp - w0) / amax;
        }
      }
      const double cruise = std::max(0.0, std::abs(target - p) - vp * vp / (2.0 * amax));
      if (cruise > 0.0 && vp > 0.0) {
        m.push(t, p, s * vp, 0.0);
        p += s * cruise;
        t += cruise / vp;
      }
      if (vp > 0.0) {
        m.push(t, p, s * vp, -s * amax);
        t += vp / amax;
      }
    }
    m.push(t, target, 0.0, 0.0);  // exact end point
    return m;
  }

  // Ramp from `from` to the constant velocity `rate` at amax, then turn at that rate forever.
  static MotionPlan to_rate(double t0, const AxisState& from, double rate, double amax) {
    check_limits(std::abs(rate) > 0.0 ? std::abs(rate) : 1.0, amax);
    MotionPlan m;
    m.n_ = 0;
    double t = t0, p = from.position;
    const double dv = rate - from.velocity;
    if (dv != 0.0) {
      m.push(t, p, from.velocity, dv > 0.0 ? amax : -amax);
      const double ta = std::abs(dv) / amax;
      p += (from.velocity + rate) * 0.5 * ta;
      t += ta;
    }
    m.push(t, p, rate, 0.0);
    return m;
  }

  AxisState at(double t) const {
    int i = n_ - 1;
    while (i > 0 && t < seg_[static_cast<std::size_t>(i)].t0) --i;
    const Segment& s = seg_[static_cast<std::size_t>(i)];
    const double dt = std::max(0.0, t - s.t0);
    return {s.p0 + dt * (s.v0 + 0.5 * s.a * dt), s.v0 + s.a * dt, t >= s.t0 ? s.a : 0.0};
  }

  double start_time() const { return seg_[0].t0; }
  // From this time on the axis holds a position or turns at a constant rate.
  double end_time() const { return seg_[static_cast<std::size_t>(n_ - 1)].t0; }
  double final_velocity() const { return seg_[static_cast<std::size_t>(n_ - 1)].v0; }
  int segments() const { return n_; }

  // Same motion, dt later / shifted by dp (a whole turn on a continuous axis changes nothing
  // physical).
  void shift_time(double dt) {
    for (int i = 0; i < n_; ++i) seg_[static_cast<std::size_t>(i)].t0 += dt;
  }
  void shift_position(double dp) {
    for (int i = 0; i < n_; ++i) seg_[static_cast<std::size_t>(i)].p0 += dp;
  }

  // Shortest time for a rest-to-rest move of `distance` (the trapezoid's or triangle's length).
  static double min_move_time(double distance, double vmax, double amax) {
    const double D = std::abs(distance);
    if (D * amax <= vmax * vmax) return 2.0 * std::sqrt(D / amax);  // triangle
    return D / vmax + vmax / amax;
  }

 private:
  struct Segment {
    double t0 = 0.0, p0 = 0.0, v0 = 0.0, a = 0.0;
  };
  static void check_limits(double vmax, double amax) {
    if (!(vmax > 0.0 && std::isfinite(vmax) && amax > 0.0 && std::isfinite(amax)))
      throw std::invalid_argument("motion plan: speed and acceleration limits must be finite and > 0");
  }
  void push(double t0, double p0, double v0, double a) { seg_[static_cast<std::size_t>(n_++)] = {t0, p0, v0, a}; }

  std::array<Segment, 6> seg_{};
  int n_ = 0;
};

// ---------------------------------------------------------------------------------------------
// One simulated axis: limits, the current (and previous) plan, an encoder, settling.
struct AxisConfig {
  std::string name = "angle";
  std::string unit = "deg";
  double min = -360.0, max = 360.0;  // position-command limits
  double max_rate = 500.0;           // unit/s
  double max_accel = 200.0;          // unit/s²
  double initial = 0.0;
  double settle_tolerance = 0.01;       // |measured − commanded| for position mode
  double settle_rate_tolerance = 0.01;  // |rate − commanded rate| (unit/s)
  double settle_time_s = 0.5;           // the condition must hold this long
  double encoder_resolution = 1e-4;     // reading quantum (0 = none)
  double encoder_noise = 0.0;           // standard deviation of the reading noise
  double full_turn = 360.0;             // an axis whose range spans a full turn is continuous

  // Travel, initial position within it, limits, settling and encoder.
  bool IsValid(std::string* error = nullptr) const {
    if (!(min < max)) return invalid(error, "min must be < max");
    if (!(initial >= min && initial <= max)) return invalid(error, "initial position outside [min, max]");
    if (!(max_rate > 0.0 && max_accel > 0.0)) return invalid(error, "max rate and acceleration must be > 0");
    if (!(settle_tolerance > 0.0 && settle_rate_tolerance > 0.0 && settle_time_s >= 0.0))
      return invalid(error, "settle tolerances must be > 0 and the settle time >= 0");
    if (!(encoder_resolution >= 0.0 && encoder_noise >= 0.0))
      return invalid(error, "encoder resolution/noise must be >= 0");
    return true;
  }
};

class SimAxis {
 public:
  SimAxis() = default;
  SimAxis(const AxisConfig& c, std::uint64_t seed) : c_(require_valid(c, "axis '" + c.name + "'")), rng_(seed) {
    continuous_ = c.max - c.min >= c.full_turn;
    plan_ = prev_ = MotionPlan::hold(0.0, c.initial);
    commanded_ = c.initial;
    measured_ = read(c.initial);
  }

  const AxisConfig& config() const { return c_; }
  bool continuous() const { return continuous_; }
  AxisSpec spec() const {
    AxisSpec s;
    s.name = c_.name;
    s.unit = c_.unit;
    s.min = c_.min;
    s.max = c_.max;
    s.max_rate = c_.max_rate;
    s.supports_rate = true;
    return s;
  }

  // A command at run time `now` (the fixture's current time). Position (or setpoint) mode moves to
  // `value`; rate mode ramps to `value` unit/s. On a continuous axis rate mode turns without end;
  // otherwise it stops at the travel limit. Throws std::invalid_argument beyond the limits.
  void command(CommandMode mode, double value, double now) {
    if (!std::isfinite(value))
      throw std::invalid_argument("axis '" + c_.name + "': command is not a finite number");
    AxisState s = plan_.at(now);
    if (mode == CommandMode::kRate) {
      if (std::abs(value) > c_.max_rate)
        throw std::invalid_argument("axis '" + c_.name + "': rate " + num(value) + " " + c_.unit +
                                    "/s beyond the limit ±" + num(c_.max_rate) + " " + c_.unit + "/s");
      MotionPlan p;
      if (continuous_ || value == 0.0) {
        p = MotionPlan::to_rate(now, s, value, c_.max_accel);
      } else {
        p = MotionPlan::to_position(now, s, value > 0.0 ? c_.max : c_.min, std::abs(value), c_.max_accel);
      }
      install(p);
      rate_mode_ = true;
    } else {
      if (value < c_.min || value > c_.max)
        throw std::invalid_argument("axis '" + c_.name + "': position " + num(value) + " " + c_.unit +
                                    " outside the travel [" + num(c_.min) + ", " + num(c_.max) + "] " + c_.unit);
      // After turning in rate mode the angle may be many turns away: drop whole turns first.
      if (continuous_) {
        const double shift = wrap(s.position) - s.position;
        s.position += shift;
        plan_.shift_position(shift);
        prev_.shift_position(shift);
      }
      install(MotionPlan::to_position(now, s, value, c_.max_rate, c_.max_accel));
      rate_mode_ = false;
    }
    commanded_ = value;
    settled_since_ = kNever;
  }

  // Plans made before the first advance start at the first advance time.
  void start_at(double t) {
    const double dt = t - plan_.start_time();
    plan_.shift_time(dt);
    prev_.shift_time(dt);
  }

  void advance(double t) {
    now_ = t;
    const AxisState s = plan_.at(t);
    const double reading = read(s.position);  // in plan coordinates (whole turns not removed)
    measured_ = continuous_ ? wrap(reading) : reading;
    bool ok;
    if (rate_mode_) {
      const double target = continuous_ ? commanded_ : plan_.final_velocity();
      ok = std::abs(s.velocity - target) <= c_.settle_rate_tolerance && s.acceleration == 0.0;
    } else {
      ok = std::abs(reading - commanded_) <= c_.settle_tolerance &&
           std::abs(s.velocity) <= c_.settle_rate_tolerance;
    }
    if (!ok) settled_since_ = kNever;
    else if (settled_since_ == kNever) settled_since_ = t;
  }

  // State in axis units at any time since the previous command (exact).
  AxisState at(double t) const { return t < plan_.start_time() ? prev_.at(t) : plan_.at(t); }

  double measured() const { return measured_; }
  double commanded() const { return commanded_; }
  bool rate_mode() const { return rate_mode_; }
  bool settled() const { return settled_since_ != kNever && now_ - settled_since_ >= c_.settle_time_s - 1e-9; }
  const MotionPlan& plan() const { return plan_; }

  // On a continuous axis: x with whole turns removed so that it lies in [min, max] (x itself when
  // it already does; otherwise the sign-keeping remainder when that fits).
  double wrap(double x) const {
    if (x >= c_.min && x <= c_.max) return x;
    double r = std::fmod(x, c_.full_turn);
    if (r < c_.min) r += c_.full_turn;
    if (r > c_.max) r -= c_.full_turn;
    if (r < c_.min || r > c_.max) {
      r = std::fmod(x - c_.min, c_.full_turn);
      if (r < 0.0) r += c_.full_turn;
      r += c_.min;
    }
    return r;
  }

  // Decelerate at the acceleration limit and hold where the axis comes to rest.
  void safe_state(double now) noexcept {
    const AxisState s = plan_.at(now);
    install(MotionPlan::to_rate(now, s, 0.0, c_.max_accel));
    rate_mode_ = false;
    double rest = s.position + s.velocity * std::abs(s.velocity) / (2.0 * c_.max_accel);
    if (continuous_) {  // hold inside the travel: drop whole turns (nothing physical changes)
      const double shift = wrap(rest) - rest;
      plan_.shift_position(shift);
      prev_.shift_position(shift);
      rest += shift;
    }
    commanded_ = rest;
    settled_since_ = kNever;
  }

 private:
  static constexpr double kNever = -std::numeric_limits<double>::infinity();
  static std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
  }
  // A reading of the encoder: noise and quantization.
  double read(double p) {
    double r = p;
    if (c_.encoder_noise > 0.0) r += c_.encoder_noise * rng_.normal();
    if (c_.encoder_resolution > 0.0) r = std::round(r / c_.encoder_resolution) * c_.encoder_resolution;
    return r;
  }

 private:
  // Keep the running plan for times before the new one starts (the sensor may still ask about
  // them); a second command at the same instant replaces the first without losing that history.
  void install(const MotionPlan& p) {
    if (plan_.start_time() < p.start_time()) prev_ = plan_;
    plan_ = p;
  }

  AxisConfig c_;
  model::Rng rng_;
  MotionPlan plan_, prev_;
  bool continuous_ = true;
  bool rate_mode_ = false;
  double commanded_ = 0.0, measured_ = 0.0, now_ = 0.0;
  double settled_since_ = kNever;
};

}  // namespace stend::sim
