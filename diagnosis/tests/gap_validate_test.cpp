// `stend gap validate` with a reduced seed count: the targets, asserted over all designs
// and per design (static tumble × temperature with accel bias+scale and bias only, the rate table
// with a gyro and with an accelerometer off the axis):
//   top-1 ≥ 0.9 where the planted effect is ≥ 5× the noise floor and identifiable,
//   false positives in ≤ 5 % of null runs, ≥ 80 % of the explainable held-out gap closed,
//   out-of-vocabulary effects never named.
// The full run (20 seeds × 4 sizes) is `stend gap validate`; its figures are in docs/gap-diagnosis.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>

#include "stend/diagnosis/validate.hpp"

using namespace stend::diagnosis;

namespace {

const ValidationReport& reduced_run() {
  static const ValidationReport r = [] {
    ValidateOptions o;
    o.seeds = 2;
    o.sizes = {5, 10};
    o.null_runs = 20;
    o.oov_runs = 6;
    o.rate_null_runs = 10;
    o.rate_oov_runs = 4;
    o.seed = 2026;
    o.noise_seeds = 0;  // the noise-stage experiments have their own test
    o.noise_null_runs = 0;
    o.design_runs = 0;  // the design cases have their own test (gap_test, GapDesignCases)
    return run_validation(o);
  }();
  return r;
}

const CandidateValidation* find(const ValidationReport& r, const std::string& experiment_prefix,
                                const std::string& term) {
  for (const auto& c : r.candidates)
    if (c.term == term && c.experiment.rfind(experiment_prefix, 0) == 0) return &c;
  return nullptr;
}

bool has_alias(const CandidateValidation& c, const std::string& name) {
  return std::any_of(c.aliases.begin(), c.aliases.end(), [&](const std::string& a) { return a.rfind(name, 0) == 0; });
}

// Identifiable, and named first in every run at ≥ 5× the floor (strictly, not via an alias).
void expect_named_first(const CandidateValidation* c, const char* what) {
  ASSERT_NE(c, nullptr) << what;
  EXPECT_TRUE(c->identifiable) << what;
  for (const auto& b : c->by_size) {
    if (b.size < 5) continue;
    EXPECT_GT(b.runs, 0) << what;
    EXPECT_EQ(b.top1_strict, b.runs) << what << " at " << b.size << "x";
  }
}

}  // namespace

TEST(GapValidate, ReducedSeedRunMeetsTheTargets) {
  const ValidationReport& r = reduced_run();
  EXPECT_GE(r.top1_at5, 0.9);
  EXPECT_GE(r.closed_at5, 0.8);
  EXPECT_EQ(r.null_runs, 30);
  EXPECT_LE(r.false_positive_rate, 0.05);
  EXPECT_EQ(r.oov_wrong_name, 0);
  EXPECT_GE(r.oov_unexplained, r.oov_runs - 1);
  EXPECT_GE(r.coverage, 0.75);  // 95 % intervals; few seeds
  const auto j = nlohmann::json::parse(validation_json(r));
  EXPECT_EQ(j["schema"], "stend.gap_validate/1");
  EXPECT_EQ(j["experiments"].size(), r.experiments.size());
}

TEST(GapValidate, EveryDesignMeetsTheTargets) {
  const ValidationReport& r = reduced_run();
  ASSERT_EQ(r.experiments.size(), 4u);
  for (const auto& e : r.experiments) {
    SCOPED_TRACE(e.experiment);
    ASSERT_GT(e.planted_at5, 0);
    EXPECT_GE(e.top1_at5, 0.9);
    EXPECT_GE(e.closed_at5, 0.8);
    EXPECT_LE(e.null_false_positives, e.null_runs / 20);  // ≤ 5 %
    EXPECT_EQ(e.oov_wrong_name, 0);
  }
  // Null and out-of-vocabulary runs on the rate table too (gyro).
  const auto& gyro = r.experiments[2];
  EXPECT_EQ(gyro.experiment, "rate table, gyro bias+scale");
  EXPECT_EQ(gyro.null_runs, 10);
  EXPECT_EQ(gyro.oov_runs, 4);
  EXPECT_EQ(gyro.unit, "rad/s");
}

TEST(GapValidate, StaticDesignDeclaresWhatItCannotSee) {
  const ValidationReport& r = reduced_run();
  // A wrong local g is a common scale error for a model with scale; the lever arm needs rate
  // segments — both not identifiable in the static design, declared before any planting.
  const auto* g = find(r, "static tumble x temperature, accel bias+scale", "gravity_error");
  ASSERT_NE(g, nullptr);
  EXPECT_FALSE(g->identifiable);
  EXPECT_TRUE(has_alias(*g, "scale"));
  const auto* lever = find(r, "static tumble x temperature, accel bias+scale", "lever_arm");
  ASSERT_NE(lever, nullptr);
  EXPECT_FALSE(lever->identifiable);
  const auto* cross = find(r, "static tumble x temperature, accel bias+scale", "cross_axis");
  ASSERT_NE(cross, nullptr);
  EXPECT_TRUE(cross->identifiable);
}

TEST(GapValidate, ScaleAndGravityErrorWithABiasOnlyModel) {
  const ValidationReport& r = reduced_run();
  expect_named_first(find(r, "static tumble x temperature, accel bias only", "scale"), "scale (static, bias only)");
  // Static: a wrong g is a common scale — declared as an alias of scale both ways.
  const auto* g = find(r, "static tumble x temperature, accel bias only", "gravity_error");
  ASSERT_NE(g, nullptr);
  EXPECT_TRUE(has_alias(*g, "scale"));
  const auto* s = find(r, "static tumble x temperature, accel bias only", "scale");
  ASSERT_NE(s, nullptr);
  EXPECT_TRUE(has_alias(*s, "gravity_error"));
}

TEST(GapValidate, RateTableIdentifiesGyroAndLeverArmTerms) {
  const ValidationReport& r = reduced_run();
  expect_named_first(find(r, "rate table, gyro", "g_sensitivity"), "g_sensitivity (rate table)");
  expect_named_first(find(r, "rate table, gyro", "cross_axis"), "cross_axis (rate table, gyro)");
  expect_named_first(find(r, "rate table, accel", "lever_arm"), "lever_arm (rate table, accel)");
  // The centripetal input of known radius separates a wrong local g from the scale.
  const auto* g = find(r, "rate table, accel", "gravity_error");
  ASSERT_NE(g, nullptr);
  EXPECT_TRUE(g->identifiable);
  EXPECT_FALSE(has_alias(*g, "scale"));
  EXPECT_FALSE(has_alias(*g, "lever_arm"));  // two mounts: separated from the radius too
  expect_named_first(g, "gravity_error (rate table, two mounts)");
}

TEST(GapValidate, OneMountCannotTellGravityFromScaleAndRadius) {
  // One mount: a common scale c is g and the radius both off by c — declared beforehand as an
  // alias pair (gravity_error, lever_arm) given the model's scale; top-1 counts either.
  ValidateOptions o;
  o.seeds = 1;
  o.sizes = {10};
  o.null_runs = 0;
  o.oov_runs = 0;
  o.rate_null_runs = 0;
  o.rate_oov_runs = 0;
  o.noise_seeds = 0;
  o.noise_null_runs = 0;
  o.design_runs = 0;
  o.only = {"gravity_error"};
  o.rate_accel_design = default_rate_design();
  o.seed = 7;
  const ValidationReport r = run_validation(o);
  const auto* g = find(r, "rate table, accel bias+scale (off axis)", "gravity_error");
  ASSERT_NE(g, nullptr);
  EXPECT_EQ(g->experiment, "rate table, accel bias+scale (off axis)");
  EXPECT_TRUE(g->identifiable);
  EXPECT_TRUE(has_alias(*g, "lever_arm"));
  EXPECT_FALSE(has_alias(*g, "scale"));
  ASSERT_EQ(g->by_size.size(), 1u);
  EXPECT_EQ(g->by_size[0].top1, g->by_size[0].runs);
}
