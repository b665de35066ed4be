// The estimator registry and the typed estimator summary.
#include <gtest/gtest.h>

#include <stend/estimation/registry.hpp>
#include <stend/estimation/summary.hpp>
#include <stend/recording/recording.hpp>
#include <stend/testing/files.hpp>

#include <nlohmann/json.hpp>

#include <sstream>

namespace se = stend::estimation;

namespace {

class Constant final : public stend::Estimator {
 public:
  stend::EstimatorResult fit(const stend::EstimatorRequest&) override { return {true, {}, "{}", "", ""}; }
};

se::EstimatorEntry entry(const std::string& name, const char* key, bool fallback = false) {
  se::EstimatorEntry e;
  e.name = name;
  e.version = "1.0";
  e.results_file = name + ".json";
  e.fallback = fallback;
  if (key != nullptr) e.claims = [key](const YAML::Node& root) { return root.IsMap() && root[key]; };
  e.create = [] { return stend::PluginPtr<stend::Estimator>(new Constant(), [](stend::Estimator* p) { delete p; }); };
  return e;
}

se::Registry three() {
  se::Registry r;
  r.add(entry("plain", nullptr, true));
  r.add(entry("noise", "noise"));
  r.add(entry("nonlinear", "nonlinear"));
  return r;
}

}  // namespace

TEST(Registry, ModelFileGoesToTheEstimatorThatClaimsIt) {
  const se::Registry r = three();
  EXPECT_EQ(r.for_model(YAML::Load("noise: {tau: 1}"), "m.yaml").name, "noise");
  EXPECT_EQ(r.for_model(YAML::Load("nonlinear: {}"), "m.yaml").name, "nonlinear");
  EXPECT_EQ(r.for_model(YAML::Load("terms: [bias]"), "m.yaml").name, "plain");  // the fallback
}

TEST(Registry, AmbiguousOrUnclaimedModelFileIsRefusedWithTheFileName) {
  const se::Registry r = three();
  try {
    r.for_model(YAML::Load("noise: {}\nnonlinear: {}"), "both.yaml");
    FAIL() << "two claims accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("both.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--estimator"), std::string::npos) << e.what();
  }
  se::Registry no_fallback;
  no_fallback.add(entry("noise", "noise"));
  EXPECT_THROW(no_fallback.for_model(YAML::Load("terms: [bias]"), "m.yaml"), std::runtime_error);
}

TEST(Registry, NamesAreUnique) {
  se::Registry r = three();
  EXPECT_THROW(r.add(entry("noise", "other")), std::logic_error);
  EXPECT_EQ(r.names(), "plain, noise, nonlinear");
  EXPECT_EQ(r.find("absent"), nullptr);
}

TEST(Registry, ResultsAreReadByTheEstimatorThatWroteThem) {
  se::Registry r = three();
  se::EstimatorEntry custom = entry("custom", "custom");
  custom.read = [](const nlohmann::json& doc) {
    se::FitResult res;
    res.summary.status = se::FitStatus::kOk;
    res.summary.parameters.push_back({"k", "1", true, "", doc.at("k").get<double>(), 0.1, 0.8, 1.2});
    return res;
  };
  r.add(custom);
  // By the document's estimator name, else by the results file's name.
  const auto by_name = r.summarize(nlohmann::json::parse(R"({"estimator": "custom", "k": 1.0})"), "other.json");
  ASSERT_EQ(by_name.parameters.size(), 1u);
  EXPECT_EQ(by_name.estimator, "custom");
  EXPECT_EQ(by_name.version, "1.0");
  const auto by_file = r.summarize(nlohmann::json::parse(R"({"k": 2.0})"), "custom.json");
  EXPECT_DOUBLE_EQ(by_file.parameters.at(0).value, 2.0);
}

TEST(Summary, JsonRoundTripKeepsEveryField) {
  se::FitSummary s;
  s.estimator = "batch_lsq";
  s.version = "0.1.0";
  s.status = se::FitStatus::kOk;
  s.confidence = 0.95;
  s.parameters.push_back({"bias_z", "m/s^2", true, "", 0.01, 0.001, 0.008, 0.012});
  s.parameters.push_back({"scale_z", "1", false, "aliased with bias_z", NAN, NAN, NAN, NAN});
  s.notes.push_back("segment 3 skipped");
  const se::FitSummary back = se::summary_from_json(nlohmann::json::parse(se::to_json(s).dump()));
  EXPECT_TRUE(back.equals(s)) << back.FullReport() << "\n" << s.FullReport();
  EXPECT_EQ(back.BriefReport(), "batch_lsq 0.1.0: ok — 2 parameters, 1 identified");
  // equals sees a changed number.
  se::FitSummary moved = s;
  moved.parameters[0].value = 0.0100001;
  EXPECT_FALSE(moved.equals(s));
  EXPECT_TRUE(moved.equals(s, 1e-4));
}

TEST(Summary, FailedFitHasNoNumbersAndSaysWhy) {
  const auto doc = nlohmann::json::parse(
      R"({"estimator": {"name": "x", "version": "2"}, "status": "failed", "message": "k < p",
          "parameters": [{"name": "a", "identifiable": true, "value": 1.0}]})");
  const se::FitSummary s = se::summary_from_json(doc);
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(s.parameters.empty());
  EXPECT_EQ(s.BriefReport(), "x 2: FAILED — k < p");
  EXPECT_EQ(s.FullReport(), "x 2: FAILED — k < p\n");
}

TEST(Summary, NotIdentifiedParameterNeverCarriesANumber) {
  const auto doc = nlohmann::json::parse(
      R"({"status": "ok", "parameters": [{"name": "a", "identifiable": false, "value": 0.0, "std_error": 0.0}]})");
  const se::FitSummary s = se::summary_from_json(doc);
  ASSERT_EQ(s.parameters.size(), 1u);
  EXPECT_TRUE(std::isnan(s.parameters[0].value));
  EXPECT_EQ(s.parameters[0].reason, "not identifiable");
  std::ostringstream row;
  row << s.parameters[0];
  EXPECT_NE(row.str().find("not estimated"), std::string::npos) << row.str();
}

TEST(ResultsFiles, OnePerInstrumentAndEstimator) {
  using stend::estimation::model_instrument;
  using stend::estimation::results_file_for;
  using stend::estimation::results_files_of;
  // The accelerometer's (and an instrument-less model's) name is the estimator's own; a gyroscope
  // model's differs, so that fitting one never overwrites the other.
  EXPECT_EQ(results_file_for("temp_poly.json", "accelerometer"), "temp_poly.json");
  EXPECT_EQ(results_file_for("allan.json", ""), "allan.json");
  EXPECT_EQ(results_file_for("temp_poly.json", "gyroscope"), "temp_poly-gyroscope.json");
  EXPECT_NE(results_file_for("fit.json", "gyroscope"), results_file_for("fit.json", "accelerometer"));
  const auto all = results_files_of("fit.json");
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0], "fit.json");
  EXPECT_EQ(all[1], "fit-gyroscope.json");
  EXPECT_EQ(model_instrument(YAML::Load("instrument: gyroscope\naxes: [z]")), "gyroscope");
  EXPECT_EQ(model_instrument(YAML::Load("allan: {max_m: 8}")), "");
  // Reading results back: the gyroscope file is the same estimator's.
  stend::estimation::Registry r;
  stend::estimation::EstimatorEntry e;
  e.name = "temp_poly";
  e.results_file = "temp_poly.json";
  r.add(e);
  ASSERT_NE(r.for_results(nlohmann::json::object(), "temp_poly-gyroscope.json"), nullptr);
  EXPECT_EQ(r.for_results(nlohmann::json::object(), "temp_poly-gyroscope.json")->name, "temp_poly");
}

// An estimator plugin's results file is a name in the run folder: a path that would leave it is
// refused before anything is fitted.
TEST(ResultsFiles, PluginResultsFileStaysInTheRunFolder) {
  const auto valid = [](const std::string& name) {
    std::string why;
    const bool ok = stend::estimation::EstimatorConfig{name}.IsValid(&why);
    EXPECT_EQ(ok, why.empty()) << name;
    return ok;
  };
  EXPECT_TRUE(valid("allan.json"));
  EXPECT_FALSE(valid(""));
  EXPECT_FALSE(valid("../allan.json"));
  EXPECT_FALSE(valid("/tmp/allan.json"));
  EXPECT_FALSE(valid("results/allan.json"));
  EXPECT_FALSE(valid(".."));
}

// Through its entry, a read-back result carries the document and the entry's defaults.
TEST(Registry, ReadFillsInTheEntrysNameVersionAndResultsFile) {
  const se::Registry r = three();
  const se::FitResult res = r.read(nlohmann::json::parse(R"({"status": "ok", "parameters": []})"), "noise.json");
  EXPECT_EQ(res.summary.estimator, "noise");
  EXPECT_EQ(res.summary.version, "1.0");
  EXPECT_EQ(res.results_file, "noise.json");
  EXPECT_TRUE(res.ok());
  EXPECT_EQ(res.document.value("status", ""), "ok");
  // A document no entry claims: the generic reader, the file's own name.
  const se::FitResult other = r.read(nlohmann::json::parse(R"({"status": "failed", "message": "why"})"), "x.json");
  EXPECT_FALSE(other.ok());
  EXPECT_EQ(other.results_file, "x.json");
  EXPECT_EQ(r.summarize(nlohmann::json::parse(R"({"status": "failed", "message": "why"})"), "x.json").message, "why");
}

namespace {

// A plugin-style estimator: its JSON document, ok and message as it states them.
class Document final : public stend::Estimator {
 public:
  Document(bool ok, std::string json) : ok_(ok), json_(std::move(json)) {}
  stend::EstimatorResult fit(const stend::EstimatorRequest&) override {
    return {ok_, ok_ ? "" : "too few points", json_, "table\n", ""};
  }

 private:
  bool ok_;
  std::string json_;
};

se::EstimatorEntry plugin(bool ok, const std::string& json) {
  se::EstimatorEntry e;
  e.name = "plug";
  e.version = "2.0";
  e.results_file = "plug.json";
  e.create = [ok, json] { return stend::PluginPtr<stend::Estimator>(new Document(ok, json), [](stend::Estimator* p) { delete p; }); };
  return e;
}

}  // namespace

// A plugin's JSON is read back by the generic reader: its summary fields and a stend.fit/1-shaped
// model section; its own word on success stands; the document is written as it gave it.
TEST(Registry, PluginResultsAreReadByTheGenericReader) {
  const std::string doc =
      R"({"status": "ok", "parameters": [{"name": "bias_z", "unit": "m/s^2", "identifiable": true, "value": 0.1,)"
      R"( "std_error": 0.01, "interval": [0.08, 0.12]}],)"
      R"( "model": {"instrument": "accelerometer", "axes": ["z"], "terms": [{"kind": "bias"}]}})";
  const se::FitResult r = se::fit(plugin(true, doc), {});
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.summary.estimator, "plug");
  EXPECT_EQ(r.results_file, "plug.json");
  EXPECT_EQ(r.text, "table\n");
  EXPECT_EQ(r.written_document(), doc);
  ASSERT_TRUE(r.accelerometer.has_value());
  EXPECT_FALSE(r.gyroscope.has_value());
  const se::InstrumentModel& m = *r.accelerometer;
  EXPECT_EQ(m.coverage, se::Coverage::kAxes);
  EXPECT_EQ(m.axes, std::vector<int>{2});
  ASSERT_EQ(m.theta.size(), 3u);
  EXPECT_EQ(m.theta[2], 0.1);
  EXPECT_EQ(m.theta[0], 0.0);  // bias_x: not in this fit, held at 0
  EXPECT_TRUE(m.parameters[0].held);
  EXPECT_FALSE(m.parameters[2].held);
  EXPECT_DOUBLE_EQ(m.covariance(2, 2), 1e-4);
  // A plugin's failure without a document: the summary fields, the plugin's message.
  const se::FitResult failed = se::fit(plugin(false, ""), {});
  EXPECT_FALSE(failed.ok());
  EXPECT_EQ(failed.summary.message, "too few points");
  EXPECT_EQ(failed.document.value("status", ""), "failed");
  // A document without "status" from a plugin that says ok is ok.
  EXPECT_TRUE(se::fit(plugin(true, R"({"samples": 3})"), {}).ok());
}

// A typed entry's fit is called as it is; the entry fills in what the result leaves out.
TEST(Registry, TypedFitGoesThroughTheEntry) {
  se::EstimatorEntry e = entry("typed", nullptr);
  e.fit = [](const stend::EstimatorRequest&) {
    se::FitResult r;
    r.summary.status = se::FitStatus::kOk;
    r.text = "typed\n";
    return r;
  };
  const se::FitResult r = se::fit(e, {});
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.text, "typed\n");
  EXPECT_EQ(r.summary.estimator, "typed");
  EXPECT_EQ(r.results_file, "typed.json");
}

// "not_applicable" is a status of its own: named, read back, neither ok nor failed, and it never
// makes a fit of several parts fail.
TEST(Summary, NotApplicableIsAStatusOfItsOwn) {
  for (const auto s : {se::FitStatus::kOk, se::FitStatus::kFailed, se::FitStatus::kNotApplicable})
    EXPECT_EQ(se::fit_status_from_string(se::to_string(s)), s);
  EXPECT_STREQ(se::to_string(se::FitStatus::kNotApplicable), "not_applicable");
  EXPECT_EQ(se::fit_status_from_string("anything else"), se::FitStatus::kFailed);
  const se::FitSummary s = se::summary_from_json(nlohmann::json::parse(
      R"({"estimator": {"name": "x", "version": "2"}, "status": "not_applicable", "message": "no gyroscope"})"));
  EXPECT_EQ(s.status, se::FitStatus::kNotApplicable);
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.BriefReport(), "x 2: not applicable — no gyroscope");
  using S = se::FitStatus;
  EXPECT_EQ(se::combined_status({S::kOk, S::kNotApplicable}), S::kOk);
  EXPECT_EQ(se::combined_status({S::kFailed, S::kNotApplicable}), S::kFailed);
  EXPECT_EQ(se::combined_status({S::kOk, S::kFailed}), S::kFailed);
  EXPECT_EQ(se::combined_status({S::kNotApplicable, S::kNotApplicable}), S::kNotApplicable);
}

// A model file of an instrument the recording lacks is not fitted: the estimator is not called and
// the result is not applicable, with the instrument's model saying why.
TEST(Registry, ModelOfAnAbsentInstrumentIsNotApplicable) {
  const stend::testing::TempDir dir("registry-absent");
  stend::testing::write_text(dir / "gyro.yaml", "instrument: gyroscope\nterms: [bias]\n");
  stend::testing::write_text(dir / "accel.yaml", "instrument: accelerometer\nterms: [bias]\n");
  stend::Recording accel_only;
  accel_only.header.info.has_gyro = false;
  bool called = false;
  se::EstimatorEntry e = entry("typed", nullptr);
  e.fit = [&called](const stend::EstimatorRequest&) {
    called = true;
    se::FitResult r;
    r.summary.status = se::FitStatus::kOk;
    return r;
  };
  stend::EstimatorRequest req;
  req.recording = &accel_only;
  req.model_file = (dir / "gyro.yaml").string();
  const se::FitResult r = se::fit(e, req);
  EXPECT_FALSE(called);
  EXPECT_EQ(r.status(), se::FitStatus::kNotApplicable);
  EXPECT_NE(r.summary.message.find("no gyroscope"), std::string::npos) << r.summary.message;
  ASSERT_TRUE(r.gyroscope.has_value());
  EXPECT_EQ(r.gyroscope->status, se::FitStatus::kNotApplicable);
  EXPECT_TRUE(r.gyroscope->parameters.empty());
  EXPECT_EQ(se::status_of(r.document), se::FitStatus::kNotApplicable);
  req.model_file = (dir / "accel.yaml").string();
  EXPECT_TRUE(se::fit(e, req).ok());
  EXPECT_TRUE(called);
}
