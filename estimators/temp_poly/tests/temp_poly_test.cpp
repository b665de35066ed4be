// temp_poly on synthetic static points built with ErrorModel::measure + Gaussian noise: order
// selection (BIC, CV), interval coverage, refusals, heating/cooling legs and hysteresis.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <iostream>
#include <random>
#include <sstream>

#include "stend/core/experiment.hpp"
#include "stend/temp_poly/temp_poly.hpp"

using namespace stend;
using stend::processing::StaticPoint;

namespace {

constexpr double kG = 9.80665;

// Truth: bias, scale, bias_temperature (order 2), scale_temperature (order 1), T0 = 25 degC.
struct Truth {
  model::ErrorModel model;
  Eigen::VectorXd theta;
};

Truth make_truth(bool quadratic_y = true) {
  Truth t;
  t.model.instrument = model::Instrument::kAccelerometer;
  t.model.terms = {{model::TermKind::kBias, 1, 25.0},
                   {model::TermKind::kScale, 1, 25.0},
                   {model::TermKind::kBiasTemperature, 2, 25.0},
                   {model::TermKind::kScaleTemperature, 1, 25.0}};
  t.theta.resize(t.model.size());
  // bias xyz, scale xyz, bias_tc (x: c1 c2, y: c1 c2, z: c1 c2), scale_tc1 xyz
  t.theta << 0.05, -0.03, 0.027, 0.002, -0.001, 0.0007, 8e-4, 1e-5, -5e-4, quadratic_y ? -1.5e-5 : 0.0,
      1.1e-3, -2e-5, 2e-5, -1e-5, 3e-5;
  return t;
}

// Visits: temperature setpoints in time order; six orientations (±g on each axis) per visit.
std::vector<StaticPoint> make_points(const Truth& truth, const std::vector<double>& visits,
                                     double sigma, unsigned seed,
                                     const std::vector<double>& offset_per_visit = {}) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::normal_distribution<double> jitter(0.0, 0.05);
  std::vector<StaticPoint> pts;
  double t = 0.0;
  for (std::size_t v = 0; v < visits.size(); ++v) {
    for (int k = 0; k < 6; ++k) {
      StaticPoint p;
      p.segment.label = "visit " + std::to_string(v) + " orientation " + std::to_string(k);
      p.stimulus.input = Eigen::Vector3d::Zero();
      p.stimulus.input[k / 2] = (k % 2 == 0 ? 1.0 : -1.0) * kG;
      p.stimulus.specific_force = p.stimulus.input;
      p.stimulus.temperature_c = visits[v] + jitter(rng);
      p.t_start_s = t;
      p.t_end_s = t + 10.0;
      p.stimulus.time_s = t + 5.0;
      t += 20.0;
      const Eigen::Vector3d y = truth.model.measure<double>(truth.theta.data(), p.stimulus);
      for (int a = 0; a < 3; ++a)
        p.axes(truth.model.instrument).mean[a] = y[a] + noise(rng) + (offset_per_visit.empty() ? 0.0 : offset_per_visit[v]);
      pts.push_back(p);
    }
  }
  return pts;
}

const std::vector<double> kSweep = {-20, 0, 20, 40, 60, 40, 20, 0};

}  // namespace

TEST(TempPoly, BicChoosesQuadraticOverLinearAndCubic) {
  const Truth truth = make_truth(/*quadratic_y=*/false);
  int chosen2[3] = {0, 0, 0}, chosen1_y = 0;
  const int seeds = 200;  // BIC over-selects order 3 in ~5 % of seeds at n = 48 (small-sample F)
  for (int s = 0; s < seeds; ++s) {
    const auto pts = make_points(truth, kSweep, 0.002, 1000u + static_cast<unsigned>(s));
    temp_poly::TempPolyOptions o;
    o.selection = "bic";
    o.max_order = 3;
    const auto r = temp_poly::fit_temperature_points(pts, o);
    ASSERT_TRUE(r.ok()) << r.message;
    ASSERT_EQ(r.axes.size(), 3u);
    for (const auto& ax : r.axes) {
      ASSERT_EQ(ax.scores.size(), 4u);  // orders 0..3
      if (ax.axis != 1 && ax.chosen_order == 2) ++chosen2[ax.axis];
      if (ax.axis == 1 && ax.chosen_order == 1) ++chosen1_y;
    }
  }
  // x and z carry a quadratic bias; y is linear in temperature.
  EXPECT_GE(chosen2[0], seeds * 9 / 10);
  EXPECT_GE(chosen2[2], seeds * 9 / 10);
  EXPECT_GE(chosen1_y, seeds * 8 / 10);
  std::cout << "BIC chose order 2 on x " << chosen2[0] << "/" << seeds << ", on z " << chosen2[2] << "/" << seeds
            << "; order 1 on y (linear truth) " << chosen1_y << "/" << seeds << "\n";
}

TEST(TempPoly, CrossValidationChoosesQuadratic) {
  const Truth truth = make_truth();
  const auto pts = make_points(truth, kSweep, 0.002, 7u);
  temp_poly::TempPolyOptions o;
  o.selection = "cv";
  o.max_order = 3;
  const auto r = temp_poly::fit_temperature_points(pts, o);
  ASSERT_TRUE(r.ok()) << r.message;
  for (const auto& ax : r.axes) {
    EXPECT_EQ(ax.chosen_order, 2) << "axis " << ax.axis << "\n" << r;
    for (const auto& s : ax.scores) EXPECT_TRUE(s.cv_ok) << s.note;
  }
}

TEST(TempPoly, IntervalCoverageOverSeeds) {
  const Truth truth = make_truth();
  const auto all = truth.model.params();
  int inside = 0, total = 0;
  for (int s = 0; s < 150; ++s) {
    const auto pts = make_points(truth, kSweep, 0.003, 50000u + static_cast<unsigned>(s));
    temp_poly::TempPolyOptions o;
    o.selection = "fixed";
    o.order = 2;
    const auto r = temp_poly::fit_temperature_points(pts, o);
    ASSERT_TRUE(r.ok()) << r.message;
    for (const auto& ax : r.axes) {
      for (const auto& p : ax.fit.lsq.parameters) {
        ASSERT_TRUE(p.identifiable) << p.name;
        double true_value = 0.0;  // scale_tc2 is zero in the truth
        for (std::size_t j = 0; j < all.size(); ++j)
          if (all[j].name == p.name) true_value = truth.theta[static_cast<Eigen::Index>(j)];
        inside += (p.lower <= true_value && true_value <= p.upper);
        ++total;
      }
    }
  }
  const double coverage = static_cast<double>(inside) / total;
  std::cout << "95 % interval coverage: " << inside << "/" << total << " = " << coverage << "\n";
  EXPECT_GE(coverage, 0.90) << inside << "/" << total;
  EXPECT_LE(coverage, 0.98) << inside << "/" << total;
}

TEST(TempPoly, RefusesTooSmallSpan) {
  const Truth truth = make_truth();
  const auto pts = make_points(truth, {24, 25, 26}, 0.002, 3u);
  temp_poly::TempPolyOptions o;
  o.min_span_c = 20.0;
  const auto r = temp_poly::fit_temperature_points(pts, o);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.message.find("span"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("min_span_c"), std::string::npos) << r.message;
  EXPECT_TRUE(r.axes.empty()) << "a refused fit reports no numbers";
  std::ostringstream os;
  os << r;
  EXPECT_NE(os.str().find("REFUSED"), std::string::npos) << os.str();
}

TEST(TempPoly, RefusesTooFewLevelsForOrder) {
  const Truth truth = make_truth();
  const auto pts = make_points(truth, {0, 20, 40}, 0.002, 4u);
  temp_poly::TempPolyOptions o;
  o.selection = "fixed";
  o.order = 3;
  const auto r = temp_poly::fit_temperature_points(pts, o);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.message.find("at least 4 distinct temperature levels"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("3 distinct"), std::string::npos) << r.message;
  EXPECT_TRUE(r.axes.empty());
  // Selection caps the candidate orders instead, and says so.
  o.selection = "bic";
  const auto b = temp_poly::fit_temperature_points(pts, o);
  ASSERT_TRUE(b.ok()) << b.message;
  EXPECT_EQ(b.axes[0].scores.back().order, 2);
  bool noted = false;
  for (const auto& n : b.notes) noted = noted || n.find("not tried") != std::string::npos;
  EXPECT_TRUE(noted);
  // One level: even order 1 is refused.
  const auto one = temp_poly::fit_temperature_points(make_points(truth, {25, 25}, 0.002, 5u), o);
  EXPECT_FALSE(one.ok());
}

TEST(TempPoly, UsesHeatingAndCoolingLegsAndReportsHysteresis) {
  const Truth truth = make_truth();
  // 20 (first), 40 heating, 20 cooling, 0 cooling, 20 heating, -20 cooling, 60 heating
  const std::vector<double> visits = {20, 40, 20, 0, 20, -20, 60};
  const double planted = 0.01;  // cooling-leg offset at 20 degC
  const auto pts = make_points(truth, visits, 0.002, 11u, {0, 0, planted, 0, 0, 0, 0});
  temp_poly::TempPolyOptions o;
  o.selection = "fixed";
  o.order = 2;
  const auto r = temp_poly::fit_temperature_points(pts, o);
  ASSERT_TRUE(r.ok()) << r.message;
  int heating = 0, cooling = 0, unknown = 0;
  for (auto l : r.legs) {
    heating += l == temp_poly::Leg::kHeating;
    cooling += l == temp_poly::Leg::kCooling;
    unknown += l == temp_poly::Leg::kUnknown;
  }
  EXPECT_EQ(unknown, 6);
  EXPECT_EQ(heating, 18);  // 40, 20 (second), 60
  EXPECT_EQ(cooling, 18);  // 20, 0, -20
  for (const auto& ax : r.axes) {
    EXPECT_EQ(ax.fit.lsq.observations, static_cast<int>(pts.size())) << "every leg enters the fit";
    ASSERT_EQ(ax.hysteresis.size(), 1u);
    const auto& h = ax.hysteresis[0];
    EXPECT_NEAR(h.temperature_c, 20.0, 0.5);
    EXPECT_EQ(h.heating_points, 6);
    EXPECT_EQ(h.cooling_points, 6);
    // Same orientations at (nearly) the same temperature get the same fitted value on both legs,
    // so the residual difference is the observed difference: the planted offset up to noise.
    EXPECT_TRUE(h.significant) << h.value << " ± " << h.std_error;
    EXPECT_NEAR(h.value, planted, 5 * h.std_error);
  }
  const auto j = nlohmann::json::parse(temp_poly::to_json(r));
  EXPECT_EQ(j["schema"], "stend.temp_poly/1");
  EXPECT_EQ(j["axes"][0]["hysteresis"].size(), 1u);
  EXPECT_EQ(j["axes"][0]["fit"]["schema"], "stend.fit/1");
  EXPECT_DOUBLE_EQ(j["reference_c"].get<double>(), 25.0);
  EXPECT_EQ(j["valid_range_c"].size(), 2u);

  // Without a planted offset the hysteresis is consistent with zero.
  const auto clean = temp_poly::fit_temperature_points(make_points(truth, visits, 0.002, 12u), o);
  ASSERT_TRUE(clean.ok());
  for (const auto& ax : clean.axes) EXPECT_LT(std::abs(ax.hysteresis[0].value), 4 * ax.hysteresis[0].std_error);
}

TEST(TempPoly, RecordsReferenceAndValidRange) {
  const Truth truth = make_truth();
  const auto pts = make_points(truth, kSweep, 0.002, 21u);
  temp_poly::TempPolyOptions o;
  o.reference_c = 25.0;
  const auto r = temp_poly::fit_temperature_points(pts, o);
  ASSERT_TRUE(r.ok());
  EXPECT_DOUBLE_EQ(r.reference_c, 25.0);
  EXPECT_NEAR(r.valid_min_c, -20.0, 0.3);
  EXPECT_NEAR(r.valid_max_c, 60.0, 0.3);
  EXPECT_EQ(r.levels.size(), 5u);
  o.reference_c = 80.0;
  const auto out = temp_poly::fit_temperature_points(pts, o);
  bool noted = false;
  for (const auto& n : out.notes) noted = noted || n.find("outside the measured range") != std::string::npos;
  EXPECT_TRUE(noted);
}

TEST(TempPoly, ParsesOptionsAndRejectsBadKeys) {
  const auto o = temp_poly::parse_options(
      "instrument: accelerometer\naxes: [x, z]\nselection: cv\nmax_order: 2\nreference_c: 20\n"
      "min_span_c: 30\nextraction: {settle_s: 1.0, cutoff_hz: 0.5}\n");
  EXPECT_EQ(o.selection, "cv");
  EXPECT_EQ(o.max_order, 2);
  EXPECT_EQ(o.axes, (std::vector<int>{0, 2}));
  EXPECT_DOUBLE_EQ(o.reference_c, 20.0);
  EXPECT_DOUBLE_EQ(o.processing.extraction.settle_s, 1.0);
  EXPECT_THROW(temp_poly::parse_options("selection: aic\n"), ExperimentError);
  EXPECT_THROW(temp_poly::parse_options("max_ordr: 2\n"), ExperimentError);
  const auto ex = temp_poly::load_options(std::string(STEND_SOURCE_DIR) +
                                          "/estimators/temp_poly/examples/temp_poly.yaml");
  EXPECT_EQ(ex.selection, "bic");
}
