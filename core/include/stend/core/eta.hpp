// The time left in a run: the procedure's plan with the bench's behaviour seen so far put in for
// what the plan cannot know — how fast the chamber approaches a setpoint (per direction, heating
// or cooling) and how long a table move takes. The runner reports what happens; the progress line
// and the live view read remaining_s().
#pragma once

#include <stend/core/experiment.hpp>

#include <cstddef>
#include <vector>

namespace stend {

// Assumptions used until the bench has shown its own figures, each written once here.
struct EtaDefaults {
  double chamber_rate_c_per_s = 0.05;  // 3 °C/min, a typical bench chamber's ramp
  double move_s = 2.0;                 // one table move (also estimate_run's planned move)
};

class ProcedureEta {
 public:
  // Before any step has started, remaining_s() is the plan: moves at EtaDefaults::move_s,
  // temperature steps at their hold time plus the approach at the default rate.
  explicit ProcedureEta(std::vector<Step> procedure, EtaDefaults defaults = {});

  // What the runner saw, in run time (s) and measured chamber temperature (°C, NaN without one).
  void step_started(std::size_t index, double t_s, double temperature_c);
  void item_started(double t_s);  // an orientation or rate of the current step begins (its move)
  void move_finished(double t_s);  // the table reported settled after the item's move
  void band_entered(double t_s);  // set_temperature: the measurement came into the tolerance band
  void band_left();               // … and left it again (the hold starts over)
  void step_finished(double t_s);  // learns the approach rate of a set_temperature step
  void finished();                 // the procedure is done: nothing left

  // Run time left (s) at run time t_s with the chamber at temperature_c.
  double remaining_s(double t_s, double temperature_c) const;

  // The figures learnt so far (NaN until seen): for the docs, the live view and tests.
  double heating_rate_c_per_s() const { return rate_[1].value(); }
  double cooling_rate_c_per_s() const { return rate_[0].value(); }
  double move_s() const { return moves_.count ? moves_.sum / moves_.count : defaults_.move_s; }

 private:
  struct Ratio {  // Σ numerator / Σ denominator over the observations
    double num = 0.0, den = 0.0;
    double value() const;
  };
  struct Mean {
    double sum = 0.0;
    int count = 0;
  };
  double approach_rate_c_per_s(bool heating) const;
  double approach_s(double from_c, double to_c, double tolerance_c) const;
  double item_s(const Step& s) const;
  double step_s(const Step& s, double from_c) const;
  double current_step_left_s(double t_s, double temperature_c) const;
  double setpoint_before(std::size_t index) const;  // the chamber's setpoint when step `index` starts

  std::vector<Step> procedure_;
  EtaDefaults defaults_;
  Ratio rate_[2];  // [0] cooling, [1] heating: °C approached per second
  Mean moves_;
  std::size_t step_ = 0;
  bool started_ = false, done_ = false;
  double step_t0_s_ = 0.0, step_from_c_ = 0.0;
  double item_t0_s_ = 0.0;
  int items_started_ = 0;
  double move_end_s_ = -1.0;  // run time the current item's move ended, −1 while moving
  double in_band_since_s_ = -1.0;
};

}  // namespace stend
