// ProcedureEta on hand-made procedures: the plan before anything ran, the time left moving with
// the steps, the chamber's approach rate learnt from a step and used for the next one of the same
// direction, a hold that restarts when the measurement leaves the band, and nothing left once done.
#include "stend/core/eta.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

stend::Step temperature(double setpoint_c, double hold_s) {
  stend::Step s;
  s.kind = stend::Step::Kind::kSetTemperature;
  s.setpoint_c = setpoint_c;
  s.tolerance_c = 0.5;
  s.hold_s = hold_s;
  return s;
}

stend::Step orientations(int n, double dwell_s, double record_s) {
  stend::Step s;
  s.kind = stend::Step::Kind::kOrientations;
  s.orientations.resize(static_cast<std::size_t>(n));
  s.dwell_s = dwell_s;
  s.record_s = record_s;
  return s;
}

}  // namespace

TEST(ProcedureEta, PlanBeforeTheRunIsHoldsAndItems) {
  const stend::EtaDefaults d;
  const stend::ProcedureEta eta({temperature(40, 600), orientations(6, 5, 20)});
  // The chamber's start temperature unknown: no approach, moves at the default.
  EXPECT_DOUBLE_EQ(eta.remaining_s(0.0, NAN), 600.0 + 6 * (d.move_s + 5 + 20));
  // Known: the approach at the default rate, to the band's edge.
  EXPECT_DOUBLE_EQ(eta.remaining_s(0.0, 20.0), (20.0 - 0.5) / d.chamber_rate_c_per_s + 600.0 + 6 * (d.move_s + 25));
}

TEST(ProcedureEta, LearnsTheApproachRateAndTheMoveTime) {
  stend::ProcedureEta eta({temperature(40, 100), orientations(2, 1, 10), temperature(60, 100), orientations(2, 1, 10)});
  eta.step_started(0, 0.0, 20.0);
  eta.band_entered(390.0);  // 19.5 °C to the band in 390 s: 0.05 °C/s
  eta.step_finished(490.0);
  EXPECT_NEAR(eta.heating_rate_c_per_s(), 0.05, 1e-12);
  EXPECT_TRUE(std::isnan(eta.cooling_rate_c_per_s()));
  eta.step_started(1, 490.0, 40.0);
  eta.item_started(490.0);
  eta.move_finished(494.0);  // a 4 s move
  EXPECT_DOUBLE_EQ(eta.move_s(), 4.0);
  // At 500 s: 5 s of the first item, one whole item, then 19.5 °C at 0.05 °C/s, the hold, two items.
  EXPECT_NEAR(eta.remaining_s(500.0, 40.0), 5.0 + 15.0 + 390.0 + 100.0 + 2 * 15.0, 1e-9);
}

TEST(ProcedureEta, HoldRestartsWhenTheBandIsLeftAndBehindPlanCountsFromHere) {
  stend::ProcedureEta eta({temperature(30, 100)});
  eta.step_started(0, 0.0, 20.0);
  eta.band_entered(200.0);
  EXPECT_DOUBLE_EQ(eta.remaining_s(250.0, 30.0), 50.0);
  eta.band_left();
  // Out of the band again, 1 °C off: what is left to the band at the rate, then the whole hold.
  EXPECT_NEAR(eta.remaining_s(260.0, 29.0), 0.5 / 0.05 + 100.0, 1e-9);
  eta.finished();
  EXPECT_EQ(eta.remaining_s(300.0, 30.0), 0.0);
}
