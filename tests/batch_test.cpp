// `stend batch fit` end to end on simulated runs: on the local worker pool, through a real
// single-node Slurm job array, and with the runs chosen by procedure fingerprint from a real
// PostgreSQL store — each gives the same results, number for number, as `stend fit` run by hand
// on each run; a task that fails is retried and then reported. Slurm and PostgreSQL are started
// by the test (testing/services.hpp); their tests skip, saying why, when they cannot start.
#include "stend/estimators/builtin.hpp"
#include "stend/reporting/results_store.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"
#include "stend/testing/services.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <memory>
#include <regex>

namespace fs = std::filesystem;
namespace rp = stend::reporting;
using stend::testing::run_stend;
using stend::testing::shell_quote;

namespace {

const std::string kModel = stend::testing::source_path("diagnosis/examples/bias_scale.yaml").string();
const char* kUnits[] = {"unit-a", "unit-b", "unit-c"};

class Batch : public ::testing::Test {
 protected:
  static inline std::unique_ptr<stend::testing::TempDir> tmp;
  static void SetUpTestSuite() {
    tmp = std::make_unique<stend::testing::TempDir>("batch");
    // Three units of the six-position test (seeds differ), each fitted by hand in `by-hand/`.
    const std::string cfg = stend::testing::read_text(stend::testing::source_path("configs/six_position.yaml"));
    int seed = 61;
    for (const char* u : kUnits) {
      std::string c = cfg;
      c.replace(c.find("seed: 6"), 7, "seed: " + std::to_string(seed++));
      stend::testing::write_text(*tmp / (std::string(u) + ".yaml"), c);
      const auto r = run_stend("run " + shell_quote((*tmp / (std::string(u) + ".yaml")).string()) + " -q -o " +
                               shell_quote((*tmp / "by-hand").string()) + " --name " + u + " --db " +
                               shell_quote((*tmp / "scratch.sqlite").string()));
      ASSERT_EQ(r.code, 0) << r.text;
    }
    for (const char* u : kUnits) {
      const auto f = run_stend("fit " + shell_quote((*tmp / "by-hand" / u).string()) + " -m " + shell_quote(kModel));
      ASSERT_EQ(f.code, 0) << f.text;
    }
  }
  static void TearDownTestSuite() { tmp.reset(); }

  // Copies of the recorded runs (without the hand fit's results) under `set/`.
  static std::vector<std::string> copies(const std::string& set) {
    std::vector<std::string> out;
    for (const char* u : kUnits) {
      const fs::path to = *tmp / set / u;
      fs::create_directories(to.parent_path());
      fs::copy(*tmp / "by-hand" / u, to, fs::copy_options::recursive);
      fs::remove(to / "fit.json");
      fs::remove(to / "fit.txt");
      out.push_back(to.string());
    }
    return out;
  }
  static std::string words(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += " " + shell_quote(x);
    return s;
  }
  // Every fitted number of `set`'s runs equals the hand fit's, bit for bit.
  static void expect_same_as_by_hand(const std::string& set) {
    for (const char* u : kUnits) {
      const rp::RunResults a = rp::load_run_results(*tmp / "by-hand" / u, stend::estimators::builtin());
      const rp::RunResults b = rp::load_run_results(*tmp / set / u, stend::estimators::builtin());
      ASSERT_FALSE(b.parameters.empty()) << set << "/" << u << " was not fitted";
      ASSERT_EQ(a.parameters.size(), b.parameters.size());
      for (std::size_t i = 0; i < a.parameters.size(); ++i) {
        EXPECT_EQ(a.parameters[i].name, b.parameters[i].name);
        if (a.parameters[i].identifiable) {
          EXPECT_EQ(a.parameters[i].value, b.parameters[i].value) << u << " " << a.parameters[i].name;
          EXPECT_EQ(a.parameters[i].std_error, b.parameters[i].std_error);
        }
      }
    }
  }
  // A folder that is not a run: its task fails every time.
  static std::string not_a_run(const std::string& set) {
    fs::create_directories(*tmp / set / "not-a-run");
    return (*tmp / set / "not-a-run").string();
  }
};

}  // namespace

TEST_F(Batch, LocalWorkersMatchHandFitsAndAFailedTaskIsRetriedAndReported) {
  auto runs = copies("local");
  const std::string bad = not_a_run("local");
  const std::string db = (*tmp / "local.sqlite").string();
  const auto r = run_stend("batch fit" + words(runs) + " " + shell_quote(bad) + " -m " + shell_quote(kModel) +
                           " --db " + shell_quote(db) + " -j 2 --retries 2");
  EXPECT_EQ(r.code, 3) << r.text;  // a task failed
  EXPECT_NE(r.text.find("failed:     " + bad + " (exit 2 after 3 attempt(s))"), std::string::npos) << r.text;
  EXPECT_NE(r.text.find("3 ok, 1 failed, 1 retried"), std::string::npos) << r.text;
  expect_same_as_by_hand("local");
  const rp::ResultsStore store(db);
  EXPECT_EQ(store.check().runs, 3);  // each fitted run recorded, once
  EXPECT_TRUE(store.check().ok());
}

TEST_F(Batch, RunsChosenByProcedureFromAPostgresStore) {
  stend::testing::TempPostgres pg;
  STEND_SKIP_UNLESS_RUNNING(pg);
  const auto runs = copies("pg");
  const std::string url = pg.url();
  ASSERT_EQ(run_stend("db migrate --db " + shell_quote(url), pg.env()).code, 0);
  const auto push = run_stend("db push" + words(runs) + " --db " + shell_quote(url), pg.env());  // recorded offline
  ASSERT_EQ(push.code, 0) << push.text;
  EXPECT_NE(push.text.find("pushed:     3 run(s)"), std::string::npos) << push.text;
  const std::string fp = rp::load_run_results(runs[0], stend::estimators::builtin()).procedure_fingerprint;
  const auto r = run_stend("batch fit --procedure " + fp.substr(0, 12) + " -m " + shell_quote(kModel) + " --db " +
                               shell_quote(url) + " -j 2",
                           pg.env());
  EXPECT_EQ(r.code, 0) << r.text;
  EXPECT_NE(r.text.find("3 ok, 0 failed"), std::string::npos) << r.text;
  expect_same_as_by_hand("pg");
  ::setenv("PGPASSWORD", pg.password().c_str(), 1);
  const rp::ResultsStore store(url);
  ::unsetenv("PGPASSWORD");
  const auto stored = store.with_fingerprint(fp);
  ASSERT_EQ(stored.size(), 3u);
  for (const auto& s : stored) EXPECT_FALSE(s.parameters.empty()) << s.run_name << ": the fit is in the store";
  EXPECT_TRUE(store.check().ok());
}

// Two runs per array task: the bad run shares its first array task with unit-c; only the bad run
// is submitted again.
TEST_F(Batch, SlurmJobArrayMatchesHandFitsAndRetriesAFailedTask) {
  stend::testing::TempSlurm slurm;
  STEND_SKIP_UNLESS_RUNNING(slurm);
  const auto runs = copies("slurm");
  const std::string bad = not_a_run("slurm");
  const std::string db = (*tmp / "slurm.sqlite").string();
  const auto r = run_stend("batch fit" + words(runs) + " " + shell_quote(bad) + " -m " + shell_quote(kModel) +
                               " --db " + shell_quote(db) + " --slurm --out " +
                               shell_quote((*tmp / "slurm-job").string()) + " --partition " + slurm.partition() +
                               " --retries 1 --runs-per-task 2",
                           slurm.env());
  EXPECT_EQ(r.code, 3) << r.text;
  EXPECT_NE(r.text.find("(attempt 1): 4 task(s) in 2 array task(s) of up to 2 run(s)"), std::string::npos) << r.text;
  EXPECT_NE(r.text.find("(attempt 2): 1 task(s) in 1 array task(s)"), std::string::npos) << r.text;
  // The retry's array runs task 3 (the bad run) alone, not its neighbour (task 2, unit-c).
  EXPECT_EQ(stend::testing::read_text(*tmp / "slurm-job" / "chunks-1.txt"), "0 1\n2 3\n");
  EXPECT_EQ(stend::testing::read_text(*tmp / "slurm-job" / "chunks-2.txt"), "3\n");
  EXPECT_NE(r.text.find("failed:     " + bad + " (exit 2 after 2 attempt(s))"), std::string::npos) << r.text;
  EXPECT_NE(r.text.find("3 ok, 1 failed"), std::string::npos) << r.text;
  expect_same_as_by_hand("slurm");
  EXPECT_EQ(rp::ResultsStore(db).check().runs, 3);
}

// `stend gap RUN --db` records gap.json as a stored result kind, once per run however often it is
// recorded (by hand or by `stend batch gap`); `stend export --db --procedure --to json` gives back
// every run of the procedure from the store, the diagnosis whole. SQLite, then PostgreSQL.
namespace {

void expect_gap_stored_and_exported(const std::vector<std::string>& runs, const std::string& db,
                                    const std::string& out, const stend::testing::Environment& env) {
  for (const auto& run : runs) {
    const auto g = run_stend("gap " + shell_quote(run) + " -m " + shell_quote(kModel) + " --db " + shell_quote(db), env);
    ASSERT_NE(g.code, 4) << g.text;  // ran (a diagnosis may say "failed"; it is recorded all the same)
  }
  const auto b = run_stend("batch gap" + std::string([&] {
                             std::string s;
                             for (const auto& r : runs) s += " " + shell_quote(r);
                             return s;
                           }()) + " -m " + shell_quote(kModel) + " --db " + shell_quote(db) + " -j 2",
                           env);  // the same runs again: replaced, not duplicated
  EXPECT_NE(b.text.find("3 task(s)"), std::string::npos) << b.text;
  const std::string fp = rp::load_run_results(runs[0], stend::estimators::builtin()).procedure_fingerprint;
  const auto e = run_stend("export --db " + shell_quote(db) + " --procedure " + fp.substr(0, 10) + " --to json -o " +
                               shell_quote(out),
                           env);
  ASSERT_EQ(e.code, 0) << e.text;
  EXPECT_NE(e.text.find("3 run(s) read from the results store"), std::string::npos) << e.text;
  const auto doc = nlohmann::json::parse(stend::testing::read_text(out));
  EXPECT_EQ(doc.at("schema"), "stend.results_set/1");
  ASSERT_EQ(doc.at("runs").size(), 3u);
  for (const auto& r : doc.at("runs")) {
    const fs::path dir = r.at("run").at("dir").get<std::string>();
    ASSERT_EQ(r.at("documents").size(), 1u) << dir;
    EXPECT_EQ(r["documents"][0].at("kind"), "gap");
    // The stored diagnosis is the folder's gap.json, whole.
    EXPECT_EQ(r["documents"][0].at("document"), nlohmann::json::parse(stend::testing::read_text(dir / "gap.json")));
  }
  const auto one = run_stend("export " + shell_quote(runs[1]) + " --db " + shell_quote(db) + " --to json -o " +
                                 shell_quote(out + ".one.json"),
                             env);
  ASSERT_EQ(one.code, 0) << one.text;
  EXPECT_EQ(nlohmann::json::parse(stend::testing::read_text(out + ".one.json")).at("run").at("dir"), runs[1]);
  EXPECT_EQ(run_stend("export --db " + shell_quote(db) + " --procedure " + fp.substr(0, 10) + " --to kalibr -o " +
                          shell_quote(out + ".yaml"),
                      env)
                .code,
            2);  // Kalibr needs allan.json: the folder, not the store
  const auto check = run_stend("db check --db " + shell_quote(db), env);
  EXPECT_EQ(check.code, 0) << check.text;
  EXPECT_NE(check.text.find("documents:  3\n"), std::string::npos) << check.text;
  EXPECT_NE(check.text.find("verdict:    consistent"), std::string::npos) << check.text;
}

}  // namespace

TEST_F(Batch, GapAndExportWithDbOnSqlite) {
  expect_gap_stored_and_exported(copies("gap-lite"), (*tmp / "gap.sqlite").string(), (*tmp / "gap-lite.json").string(),
                                 {});
}

TEST_F(Batch, GapAndExportWithDbOnPostgres) {
  stend::testing::TempPostgres pg;
  STEND_SKIP_UNLESS_RUNNING(pg);
  ASSERT_EQ(run_stend("db migrate --db " + shell_quote(pg.url()), pg.env()).code, 0);
  expect_gap_stored_and_exported(copies("gap-pg"), pg.url(), (*tmp / "gap-pg.json").string(), pg.env());
}
