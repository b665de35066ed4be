// `--json` of every command that prints results or status: one JSON document on stdout, valid
// against its schema in docs/schemas/ (checked by python3-jsonschema, tests/check_json_schema.py),
// and saying what the run folder shows. Also: results stay in the run folder or --out (compare
// writes nothing unasked, a failed fit is marked and its numbers excluded, fit refreshes the report).
#include <gtest/gtest.h>

#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <memory>
#include <set>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;
using stend::testing::ProgramOutput;
using stend::testing::run_command;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::TempDir;

namespace {

const std::string src = STEND_SOURCE_DIR;
const std::string kPaperModel = src + "/estimators/batch_lsq/examples/paper_z_channel.yaml";

class JsonOutput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<TempDir>("json-output");
    run_ = command("run", "run " + src + "/configs/paper_mpu6050_z.yaml --quiet --output " + (dir() / "runs").string() +
                              " --name paper");
  }
  static void TearDownTestSuite() { dir_.reset(); }

  static fs::path dir() { return dir_->path(); }
  static fs::path run_dir() { return dir() / "runs" / "paper"; }

  // Runs `stend ARGS --json`, stdout to NAME.json; the document, or a null one (with a failure).
  static json command(const std::string& name, const std::string& args, int expected_code = 0) {
    const fs::path out = dir() / (name + ".json"), err = dir() / (name + ".stderr");
    const ProgramOutput o = run_stend(args + " --json > " + shell_quote(out.string()) + " 2> " + shell_quote(err.string()));
    EXPECT_EQ(o.code, expected_code) << args << "\n" << stend::testing::read_text(err);
    last_output_ = out;
    return json::parse(stend::testing::read_text(out), nullptr, false);
  }
  // Checks the last command's output against docs/schemas/SCHEMA.schema.json.
  static void expect_valid(const std::string& schema) {
    const ProgramOutput v = run_command("python3 " + shell_quote(src + "/tests/check_json_schema.py") + " " +
                                        shell_quote(src + "/docs/schemas/" + schema + ".schema.json") + " " +
                                        shell_quote(last_output_.string()));
    if (v.code == 77) GTEST_SKIP() << v.text;
    EXPECT_EQ(v.code, 0) << v.text;
  }
  static std::set<std::string> listing(const fs::path& folder) {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(folder)) names.insert(e.path().filename().string());
    return names;
  }

  static std::unique_ptr<TempDir> dir_;
  static json run_;
  static fs::path last_output_;
};
std::unique_ptr<TempDir> JsonOutput::dir_;
json JsonOutput::run_;
fs::path JsonOutput::last_output_;

}  // namespace

TEST_F(JsonOutput, RunSummary) {
  last_output_ = dir() / "run.json";
  expect_valid("run");
  ASSERT_TRUE(run_.is_object());
  EXPECT_EQ(run_["status"], "complete");
  EXPECT_TRUE(fs::equivalent(run_["run_dir"].get<std::string>(), run_dir()));
  EXPECT_TRUE(run_["fit"]["ok"].get<bool>());
  EXPECT_TRUE(fs::exists(run_["fit"]["results_file"].get<std::string>()));
  EXPECT_TRUE(fs::exists(run_["report"].get<std::string>()));
}

TEST_F(JsonOutput, Plugins) {
  const json j = command("plugins", "plugins");
  expect_valid("plugins");
  ASSERT_FALSE(j["search_path"].empty());
  // The build tree's program searches its own tree first and loads its plugins from there.
  EXPECT_EQ(j["search_path"][0]["origin"], "build tree");
  int loaded = 0;
  for (const auto& p : j["plugins"])
    if (p["loaded"].get<bool>() && !p.contains("shadowed_by")) {
      ++loaded;
      EXPECT_EQ(fs::path(p["file"].get<std::string>()).parent_path(), fs::path(j["search_path"][0]["path"].get<std::string>()));
    }
  EXPECT_GE(loaded, 5);
}

TEST_F(JsonOutput, Validate) {
  const json j = command("validate", "validate " + src + "/configs/paper_mpu6050_z.yaml");
  expect_valid("validate");
  EXPECT_EQ(j["orientations"], 23);
  EXPECT_EQ(j["sensor"], "sim_imu");
}

TEST_F(JsonOutput, Info) {
  const json j = command("info", "info " + run_dir().string());
  expect_valid("info");
  EXPECT_EQ(j["samples"], run_["samples"]);
  EXPECT_EQ(j["segments"].size(), run_["segments"].get<std::size_t>());
}

TEST_F(JsonOutput, FitRefreshesTheReport) {
  const fs::path report = run_dir() / "report.html";
  stend::testing::write_text(report, "stale");
  const json j = command("fit", "fit " + run_dir().string() + " -m " + kPaperModel);
  expect_valid("fit");
  EXPECT_TRUE(j["ok"].get<bool>());
  EXPECT_TRUE(fs::equivalent(j["results_file"].get<std::string>(), run_dir() / "fit.json"));
  EXPECT_EQ(j["document"]["status"], "ok");
  ASSERT_TRUE(j["report"].is_string());
  EXPECT_NE(stend::testing::read_text(report), "stale") << "stend fit did not refresh report.html";
}

TEST_F(JsonOutput, FitOfADatasetFileWritesNothingWithoutOut) {
  const fs::path csv = dir() / "cwd";
  fs::create_directories(csv);
  const std::string table2 = src + "/datasets/paper_table2/table2.csv";
  const ProgramOutput o = run_command("cd " + shell_quote(csv.string()) + " && " + shell_quote(stend::testing::stend_program().string()) +
                                      " fit " + shell_quote(table2) + " -m " + shell_quote(kPaperModel) + " --json");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(listing(csv).empty()) << "stend fit wrote into the current directory";
}

TEST_F(JsonOutput, Gap) {
  const json j = command("gap", "gap " + run_dir().string() + " -m " + kPaperModel);
  expect_valid("gap");
  EXPECT_TRUE(fs::equivalent(j["results_file"].get<std::string>(), run_dir() / "gap.json"));
}

TEST_F(JsonOutput, CompareWritesNothingUnasked) {
  const std::set<std::string> before = listing(dir() / "runs"), run_before = listing(run_dir());
  const json j = command("compare", "compare " + run_dir().string());
  expect_valid("compare");
  EXPECT_TRUE(j["report"].is_null());
  EXPECT_FALSE(j["parameters"].empty());
  EXPECT_EQ(listing(dir() / "runs"), before) << "stend compare wrote beside the runs without being asked";
  EXPECT_EQ(listing(run_dir()), run_before);
  // Asked: the HTML report goes where -o says.
  const fs::path html = dir() / "compare.html";
  command("compare_out", "compare " + run_dir().string() + " -o " + html.string());
  EXPECT_TRUE(fs::exists(html));
}

TEST_F(JsonOutput, FailedFitIsMarkedAndItsNumbersExcluded) {
  // A temperature model on a run at one temperature fails: its results file says so, the report
  // and the comparison (the results database's reading) carry no number of it.
  const json j = command("fit_failed", "fit " + run_dir().string() + " -m " + src + "/estimators/temp_poly/examples/temp_poly.yaml",
                         3);
  expect_valid("fit");
  EXPECT_FALSE(j["ok"].get<bool>());
  EXPECT_EQ(j["document"]["status"], "failed");
  const json c = command("compare_after_failure", "compare " + run_dir().string());
  for (const auto& p : c["parameters"]) EXPECT_NE(p["estimator"], "temp_poly") << p.dump();
  EXPECT_NE(stend::testing::read_text(run_dir() / "report.html").find("no numbers are reported"), std::string::npos);
}

TEST_F(JsonOutput, VersionSaysWherePluginsAreFound) {
  const ProgramOutput o = run_stend("--version");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_NE(o.text.find(std::string(STEND_BUILD_PLUGIN_DIR) + " (build tree"), std::string::npos) << o.text;
}

TEST_F(JsonOutput, Report) {
  const json j = command("report", "report " + run_dir().string() + " --db " + (dir() / "report.sqlite").string());
  expect_valid("report");
  EXPECT_TRUE(fs::equivalent(j["report"].get<std::string>(), run_dir() / "report.html"));
  EXPECT_TRUE(fs::exists(dir() / "report.sqlite"));
}

TEST_F(JsonOutput, Export) {
  const fs::path out = dir() / "exported.json";  // not export.json: the command's own output
  const json j = command("export", "export " + run_dir().string() + " --to json -o " + out.string());
  expect_valid("export");
  ASSERT_EQ(j["files"].size(), 1u);
  EXPECT_TRUE(fs::equivalent(j["files"][0].get<std::string>(), out));
}

TEST_F(JsonOutput, Import) {
  const fs::path out = dir() / "imported";
  const json j = command("import", "import " + src + "/datasets/paper_table2/table2.csv -o " + out.string());
  expect_valid("import");
  EXPECT_TRUE(fs::equivalent(j["run_dir"].get<std::string>(), out));
  EXPECT_GT(j["samples"].get<int>() + j["segments"].get<int>(), 0);
}

TEST_F(JsonOutput, DbMigratePushCheck) {
  const std::string db = (dir() / "db.sqlite").string();
  const json m = command("db_migrate", "db migrate --db " + db);
  expect_valid("db");
  EXPECT_EQ(m["command"], "migrate");
  EXPECT_GE(m["schema_to"].get<int>(), 1);
  const json p = command("db_push", "db push " + run_dir().string() + " --db " + db);
  expect_valid("db");
  EXPECT_EQ(p["pushed"], 1);
  EXPECT_TRUE(p["refused"].empty());
  const json c = command("db_check", "db check --db " + db);
  expect_valid("db");
  EXPECT_TRUE(c["ok"].get<bool>());
  EXPECT_EQ(c["runs"], 1);
  EXPECT_EQ(c["parameters"].get<long long>(), p["parameters"].get<long long>());
}

TEST_F(JsonOutput, BatchReport) {
  const json j = command("batch", "batch report " + run_dir().string() + " -j 1 --db " + (dir() / "batch.sqlite").string());
  expect_valid("batch");
  EXPECT_TRUE(j["ok"].get<bool>());
  ASSERT_EQ(j["tasks"].size(), 1u);
  EXPECT_EQ(j["tasks"][0]["exit_code"], 0);
  EXPECT_TRUE(j["tasks"][0]["output_tail"].is_null());
  // A task that fails (no such run folder) is reported with its exit code and output, exit 3.
  const json f = command("batch_failed", "batch report " + (dir() / "no-such-run").string() + " -j 1 --retries 0", 3);
  expect_valid("batch");
  EXPECT_FALSE(f["ok"].get<bool>());
  EXPECT_EQ(f["failed"], 1);
  EXPECT_NE(f["tasks"][0]["exit_code"], 0);
}

TEST_F(JsonOutput, ApplyAndValidate) {
  const fs::path out = dir() / "calibrated";
  // The table tilts about one axis, so cross_zy is not excited: applied only with a stated value.
  // The paper's model calibrates the z axis only: |a| - g cannot be checked, so nothing is (exit 3).
  const json j = command("apply", "apply " + (run_dir() / "fit.json").string() + " " + run_dir().string() + " -o " +
                                      out.string() + " --validate --assume cross_zy=0", 3);
  expect_valid("apply");
  EXPECT_TRUE(fs::equivalent(j["calibrated"].get<std::string>(), out));
  ASSERT_TRUE(j["validation"].is_object());
  EXPECT_EQ(j["validation"]["verdict"], "NOT CHECKED");
  ASSERT_EQ(j["assumed"].size(), 1u);
}

TEST_F(JsonOutput, GapValidate) {
  // A small validation (one candidate, one seed, no noise stage; seconds): its targets are met.
  const json j = command("gap_validate", "gap validate --only nonlinear_k2 --seeds 1 --sizes 10 --null 2 --oov 1 "
                                         "--noise-seeds 0 --noise-null 0 --seed 7");
  expect_valid("gap-validate");
  EXPECT_TRUE(j["targets_met"].get<bool>());
  EXPECT_TRUE(j["results_file"].is_null());
  EXPECT_TRUE(j["document"].is_object());
}
