// The typed result: instrument models read from a stend.fit/1-shaped document, evaluated through
// the vocabulary; print and equals of the result types.
#include <gtest/gtest.h>

#include <stend/estimation/result.hpp>
#include <stend/estimation/result_io.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>

namespace se = stend::estimation;
using nlohmann::json;

namespace {

// bias and scale of the z axis, correlated, and bias_y not identified.
json fit_document() {
  return json::parse(R"({
    "schema": "stend.fit/1", "status": "ok", "message": "",
    "estimator": {"name": "batch_lsq", "version": "0.1.0"},
    "solution": {"confidence": 0.95, "quantile": 2.0},
    "model": {"instrument": "accelerometer", "axes": ["y", "z"],
              "terms": [{"kind": "bias"}, {"kind": "scale"}]},
    "parameters": [
      {"name": "bias_y", "unit": "m/s^2", "identifiable": false, "value": null, "reason": "aliased"},
      {"name": "bias_z", "unit": "m/s^2", "identifiable": true, "value": 0.2, "std_error": 0.01, "interval": [0.18, 0.22]},
      {"name": "scale_z", "unit": "1", "identifiable": true, "value": 0.01, "std_error": 0.001, "interval": [0.008, 0.012]}],
    "correlation": [[1, null, null], [null, 1, -0.5], [null, -0.5, 1]]})");
}

}  // namespace

TEST(InstrumentModel, ReadFromAFitDocumentWithHeldAndUnidentifiedParameters) {
  const auto m = se::read_fit_model(fit_document());
  ASSERT_TRUE(m.has_value());
  EXPECT_TRUE(m->ok());
  EXPECT_EQ(m->instrument(), stend::model::Instrument::kAccelerometer);
  EXPECT_EQ(m->coverage, se::Coverage::kAxes);
  EXPECT_EQ(m->axes, (std::vector<int>{1, 2}));
  EXPECT_TRUE(m->covers(2));
  EXPECT_FALSE(m->covers(0));
  EXPECT_EQ(m->confidence, 0.95);
  ASSERT_EQ(m->theta.size(), 6u);  // bias x y z, scale x y z
  EXPECT_EQ(m->theta[0], 0.0);     // bias_x: not in this fit
  EXPECT_TRUE(m->parameters[0].held);
  EXPECT_TRUE(std::isnan(m->theta[1]));  // bias_y: not identified
  EXPECT_FALSE(m->parameters[1].held);
  EXPECT_EQ(m->theta[2], 0.2);
  EXPECT_EQ(m->not_identified(), std::vector<std::string>{"bias_y"});
  EXPECT_EQ(m->applied_theta()[1], 0.0);
  EXPECT_DOUBLE_EQ(m->std_error("bias_z"), 0.01);
  EXPECT_EQ(m->std_error("bias_x"), 0.0);
  EXPECT_DOUBLE_EQ(m->covariance(2, 5), -0.5 * 0.01 * 0.001);
  EXPECT_EQ(m->covariance(1, 1), 0.0);
  EXPECT_TRUE(std::isnan(m->reference_c));
}

TEST(InstrumentModel, ContributionThroughTheVocabularyWithItsStandardError) {
  const auto m = se::read_fit_model(fit_document());
  ASSERT_TRUE(m.has_value());
  const stend::model::Vec3<double> u(0.0, 0.0, 9.8), zero = stend::model::Vec3<double>::Zero();
  // y_z − u_z = bias_z + scale_z·u_z; its variance through the regressor row (1, u_z).
  const auto [y, se] = m->contribution(2, u, 25.0);
  EXPECT_NEAR(y, 0.2 + 0.01 * 9.8, 1e-12);
  EXPECT_NEAR(se * se, 1e-4 + 9.8 * 9.8 * 1e-6 - 2 * 9.8 * 0.5 * 1e-5, 1e-15);
  // The input part alone: the bias cancels.
  EXPECT_NEAR(m->contribution(2, u, 25.0, &zero).first, 0.01 * 9.8, 1e-12);
}

TEST(InstrumentModel, AFailedFitHasNoNumbersAndAnUnknownTermIsNamed) {
  json doc = fit_document();
  doc["status"] = "failed";
  doc["message"] = "k < p";
  const auto failed = se::read_fit_model(doc);
  ASSERT_TRUE(failed.has_value());
  EXPECT_FALSE(failed->ok());
  EXPECT_EQ(failed->message, "k < p");
  for (double t : failed->theta) EXPECT_TRUE(std::isnan(t));
  json odd = fit_document();
  odd["model"]["terms"].push_back({{"kind", "warp_drive"}});
  const auto unknown = se::read_fit_model(odd);
  ASSERT_TRUE(unknown.has_value());
  EXPECT_FALSE(unknown->ok());
  EXPECT_NE(unknown->message.find("warp_drive"), std::string::npos) << unknown->message;
  EXPECT_FALSE(se::read_fit_model(json{{"status", "ok"}}).has_value());
  EXPECT_FALSE(se::read_fit_model(json{{"model", {{"instrument", "magnetometer"}}}}).has_value());
}

TEST(FitResult, PrintsAndComparesItsTypedParts) {
  se::FitResult a = se::read_fit_document(fit_document());
  ASSERT_TRUE(a.accelerometer.has_value());
  se::NoiseResult n;
  n.rate_hz = 100.0;
  n.samples = 1000;
  se::ChannelNoise c;
  c.channel = "az";
  c.axis = 2;
  c.white_noise = {"N_az", "m/s^2/sqrt(Hz)", true, "", 1e-3, 1e-5, 0.98e-3, 1.02e-3};
  n.channels.push_back(c);
  n.sensor(stend::model::Instrument::kGyroscope).random_walk = {2e-5, true};
  a.noise = n;
  se::FitResult b = se::read_fit_document(fit_document());
  b.noise = n;
  EXPECT_TRUE(a.equals(b));
  EXPECT_EQ(a.noise->find(stend::model::Instrument::kAccelerometer, 2)->channel, "az");
  EXPECT_EQ(a.noise->find(stend::model::Instrument::kGyroscope, 2), nullptr);
  EXPECT_TRUE(a.noise->any_identified());
  b.accelerometer->theta[2] = 0.2000001;
  EXPECT_FALSE(a.equals(b));
  EXPECT_TRUE(a.equals(b, 1e-5));
  b.noise->sensor(stend::model::Instrument::kGyroscope).random_walk.upper_bound = false;
  EXPECT_FALSE(a.equals(b, 1e-5));
  const std::string text = a.FullReport();
  EXPECT_EQ(a.BriefReport(), "batch_lsq 0.1.0: ok — 3 parameters, 2 identified");
  EXPECT_NE(text.find("accelerometer: bias, scale (axes y z each on its own; ok)"), std::string::npos) << text;
  EXPECT_NE(text.find("noise: 1 channels"), std::string::npos) << text;
  EXPECT_NE(text.find("gyroscope K of the sensor when no axis identifies it: 2e-05 (upper bound)"), std::string::npos) << text;
}

TEST(FitResult, AFitThatFailedBeforeWritingHasTheSummaryFields) {
  const se::FitResult r = se::failed_fit("x", "2", "no samples");
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.BriefReport(), "x 2: FAILED — no samples");
  EXPECT_EQ(se::summary_from_json(json::parse(r.written_document())).message, "no samples");
}

// The fit's degrees of freedom are read from a results document ("dof", or stend.fit/1's
// "solution") and written back; few of them are a note, stated once; BriefReport says them.
TEST(FitSummary, StatesItsDegreesOfFreedomAndNotesWhenTheyAreFew) {
  json doc = {{"status", "ok"},
              {"confidence", 0.95},
              {"solution", {{"dof", 1}}},
              {"parameters", json::array({{{"name", "bias_z"}, {"unit", "m/s^2"}, {"identifiable", true},
                                           {"value", 0.1}, {"std_error", 0.001}, {"interval", {0.08, 0.12}}}})}};
  const se::FitSummary s = se::summary_from_json(doc);
  ASSERT_TRUE(s.dof.has_value());
  EXPECT_EQ(*s.dof, 1);
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_EQ(s.notes[0], se::degrees_of_freedom_note(1));
  EXPECT_NE(s.notes[0].find("few degrees of freedom: 1"), std::string::npos) << s.notes[0];
  EXPECT_NE(s.BriefReport().find(", 1 dof"), std::string::npos) << s.BriefReport();
  EXPECT_NE(s.FullReport().find("note: few degrees of freedom"), std::string::npos);
  // Written and read back: the same summary, the note not doubled.
  const json written = se::to_json(s);
  EXPECT_EQ(written["dof"], 1);
  EXPECT_TRUE(se::summary_from_json(written).equals(s));
  // Enough degrees of freedom: no note; none at all (a noise fit): null, no note.
  doc["solution"]["dof"] = se::kFewDegreesOfFreedom;
  EXPECT_TRUE(se::summary_from_json(doc).notes.empty());
  doc.erase("solution");
  const se::FitSummary none = se::summary_from_json(doc);
  EXPECT_FALSE(none.dof.has_value());
  EXPECT_TRUE(se::to_json(none)["dof"].is_null());
  EXPECT_NE(se::degrees_of_freedom_note(0).find("zero by construction"), std::string::npos);
}
