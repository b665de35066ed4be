#include "stend/core/eta.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace stend {

double ProcedureEta::Ratio::value() const { return den > 0.0 ? num / den : std::numeric_limits<double>::quiet_NaN(); }

ProcedureEta::ProcedureEta(std::vector<Step> procedure, EtaDefaults defaults)
    : procedure_(std::move(procedure)), defaults_(defaults) {}

void ProcedureEta::step_started(std::size_t index, double t_s, double temperature_c) {
  started_ = true;
  step_ = index;
  step_t0_s_ = t_s;
  step_from_c_ = std::isfinite(temperature_c) ? temperature_c : setpoint_before(index);
  items_started_ = 0;
  move_end_s_ = -1.0;
  in_band_since_s_ = -1.0;
}

void ProcedureEta::item_started(double t_s) {
  ++items_started_;
  item_t0_s_ = t_s;
  move_end_s_ = -1.0;
}

void ProcedureEta::move_finished(double t_s) {
  moves_.sum += t_s - item_t0_s_;
  ++moves_.count;
  move_end_s_ = t_s;
}

void ProcedureEta::band_entered(double t_s) { in_band_since_s_ = t_s; }
void ProcedureEta::band_left() { in_band_since_s_ = -1.0; }

// The approach of a set_temperature step: from its start to its last entry into the band (the
// whole step when it timed out), over the distance to the band's edge.
void ProcedureEta::step_finished(double t_s) {
  if (step_ >= procedure_.size() || procedure_[step_].kind != Step::Kind::kSetTemperature) return;
  const Step& s = procedure_[step_];
  if (!std::isfinite(step_from_c_)) return;
  const double distance_c = std::abs(s.setpoint_c - step_from_c_) - s.tolerance_c;
  const double approach = (in_band_since_s_ >= 0.0 ? in_band_since_s_ : t_s) - step_t0_s_;
  if (distance_c <= 0.0 || approach <= 0.0) return;
  Ratio& r = rate_[s.setpoint_c > step_from_c_ ? 1 : 0];
  r.num += distance_c;
  r.den += approach;
}

void ProcedureEta::finished() { done_ = true; }

// The direction's own rate once seen, else the other direction's, else the default.
double ProcedureEta::approach_rate_c_per_s(bool heating) const {
  const Ratio& own = rate_[heating ? 1 : 0];
  const Ratio& other = rate_[heating ? 0 : 1];
  if (own.den > 0.0) return own.value();
  if (other.den > 0.0) return other.value();
  return defaults_.chamber_rate_c_per_s;
}

// Time to bring the chamber from from_c into the band of ±tolerance_c around to_c.
double ProcedureEta::approach_s(double from_c, double to_c, double tolerance_c) const {
  if (!std::isfinite(from_c) || !std::isfinite(to_c)) return 0.0;
  return std::max(std::abs(to_c - from_c) - tolerance_c, 0.0) / approach_rate_c_per_s(to_c > from_c);
}

double ProcedureEta::item_s(const Step& s) const { return move_s() + s.dwell_s + s.record_s; }

double ProcedureEta::step_s(const Step& s, double from_c) const {
  switch (s.kind) {
    case Step::Kind::kSetTemperature:
      return approach_s(from_c, s.setpoint_c, s.tolerance_c) + s.hold_s;
    case Step::Kind::kOrientations: return static_cast<double>(s.orientations.size()) * item_s(s);
    case Step::Kind::kRates: return static_cast<double>(s.rates.size()) * item_s(s);
    case Step::Kind::kRecord: return s.record_s;
    case Step::Kind::kWait: return s.dwell_s;
    case Step::Kind::kSetVibration:
    case Step::Kind::kFaces:  // observed steps never run (require_runnable)
    case Step::Kind::kTurns:
    case Step::Kind::kRateLegs:
    case Step::Kind::kStill: return 0.0;
  }
  return 0.0;
}

double ProcedureEta::current_step_left_s(double t_s, double temperature_c) const {
  const Step& s = procedure_[step_];
  const double elapsed = t_s - step_t0_s_;
  switch (s.kind) {
    case Step::Kind::kSetTemperature: {
      if (in_band_since_s_ >= 0.0) return std::max(s.hold_s - (t_s - in_band_since_s_), 0.0);
      const double planned = step_s(s, step_from_c_) - s.hold_s - elapsed;
      const double from_here = step_s(s, temperature_c) - s.hold_s;  // behind the plan: what is left
      return std::max(planned, from_here) + s.hold_s;
    }
    case Step::Kind::kOrientations:
    case Step::Kind::kRates: {
      const int n = static_cast<int>(s.kind == Step::Kind::kRates ? s.rates.size() : s.orientations.size());
      if (items_started_ == 0) return step_s(s, NAN);
      double current = 0.0;
      if (move_end_s_ < 0.0) current = std::max(move_s() - (t_s - item_t0_s_), 0.0) + s.dwell_s + s.record_s;
      else current = std::max(s.dwell_s + s.record_s - (t_s - move_end_s_), 0.0);
      return current + static_cast<double>(std::max(n - items_started_, 0)) * item_s(s);
    }
    case Step::Kind::kRecord:
    case Step::Kind::kWait:
    case Step::Kind::kSetVibration:
    case Step::Kind::kFaces:
    case Step::Kind::kTurns:
    case Step::Kind::kRateLegs:
    case Step::Kind::kStill: return std::max(step_s(s, NAN) - elapsed, 0.0);
  }
  return 0.0;
}

double ProcedureEta::setpoint_before(std::size_t index) const {
  for (std::size_t j = std::min(index, procedure_.size()); j-- > 0;)
    if (procedure_[j].kind == Step::Kind::kSetTemperature) return procedure_[j].setpoint_c;
  return NAN;
}

double ProcedureEta::remaining_s(double t_s, double temperature_c) const {
  if (done_) return 0.0;
  double left = 0.0;
  std::size_t next = 0;
  if (started_ && step_ < procedure_.size()) {
    left += current_step_left_s(t_s, temperature_c);
    next = step_ + 1;
  }
  for (std::size_t j = next; j < procedure_.size(); ++j) {
    const double before = setpoint_before(j);
    left += step_s(procedure_[j], std::isfinite(before) ? before : temperature_c);
  }
  return left;
}

}  // namespace stend
