// The results store on both backends: schema migrations (an SQLite file written by an older Stend
// is migrated with its rows), round trips that keep every number bit for bit and NULL for a number
// that does not exist, passwords never printed, and concurrent writers — 8 × 200 runs, with
// overlapping rewrites of the same runs — then `stend db check`: no row lost or duplicated.
// PostgreSQL is a real server started in a temporary folder (testing/services.hpp); the tests
// that need it skip, saying why, when it cannot start.
#include "stend/errors.hpp"
#include "stend/reporting/results_store.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"
#include "stend/testing/services.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <thread>

#include <unistd.h>

namespace rp = stend::reporting;
namespace fs = std::filesystem;
using stend::testing::run_stend;
using stend::testing::shell_quote;

namespace {

constexpr int kWriters = 8;
constexpr int kRunsPerWriter = 200;
constexpr int kRewritesPerWriter = 25;  // of the next writer's runs, written again at the same time
constexpr int kParametersPerRun = 6;

// A run as two estimators would leave it: exact-looking doubles, and one parameter that is not
// identifiable (its numbers do not exist).
rp::RunResults campaign_run(int writer, int i, int version = 0) {
  rp::RunResults r;
  r.run_name = "w" + std::to_string(writer) + "-r" + std::to_string(i);
  r.dir = "/lab/campaign/" + r.run_name;
  r.vendor = writer % 2 ? "Acme" : "Bor";
  r.model = "AX-" + std::to_string(writer % 3);
  r.serial = std::to_string(1000 * writer + i);
  r.procedure_fingerprint = "ab12cd34ef56" + std::string(52, '0');
  r.run_status = "complete";
  r.estimators = {{"batch_lsq", "1.0", "fit.json", "ok", ""}, {"allan", "1.0", "allan.json", "ok", ""}};
  r.documents = {{"gap", "gap.json", "ok", R"({"schema":"stend.gap/1","status":"ok","version":)" + std::to_string(version) + "}"}};
  for (int k = 0; k < kParametersPerRun; ++k) {
    rp::ParameterResult p;
    p.estimator = k < 4 ? "batch_lsq" : "allan";
    p.name = "p" + std::to_string(k);
    p.unit = "m/s^2";
    p.identifiable = k != 3;
    if (p.identifiable) {
      p.value = 0.1 / (1 + writer + i + k) + 1e-17 * version;
      p.std_error = std::sqrt(2.0) * 1e-5 * (k + 1);
      p.lo = p.value - 1.96 * p.std_error;
      p.hi = p.value + 1.96 * p.std_error;
      p.confidence = 0.95;
    } else {
      p.reason = "aliased with bias_z";
    }
    r.parameters.push_back(p);
  }
  return r;
}

void expect_same_run(const rp::RunResults& a, const rp::RunResults& b) {
  EXPECT_EQ(a.dir, b.dir);
  EXPECT_EQ(a.vendor, b.vendor);
  EXPECT_EQ(a.serial, b.serial);
  ASSERT_EQ(a.estimators.size(), b.estimators.size());
  for (std::size_t i = 0; i < a.estimators.size(); ++i) EXPECT_EQ(a.estimators[i].name, b.estimators[i].name);
  ASSERT_EQ(a.documents.size(), b.documents.size());
  for (std::size_t i = 0; i < a.documents.size(); ++i) {
    EXPECT_EQ(a.documents[i].kind, b.documents[i].kind);
    EXPECT_EQ(a.documents[i].status, b.documents[i].status);
    EXPECT_EQ(a.documents[i].document, b.documents[i].document);  // the text, whole
  }
  ASSERT_EQ(a.parameters.size(), b.parameters.size());
  for (std::size_t i = 0; i < a.parameters.size(); ++i) {
    const auto &p = a.parameters[i], &q = b.parameters[i];
    EXPECT_EQ(p.name, q.name);
    EXPECT_EQ(p.identifiable, q.identifiable);
    if (p.identifiable) {
      EXPECT_EQ(p.value, q.value) << p.name;  // bit for bit, not "near"
      EXPECT_EQ(p.std_error, q.std_error);
      EXPECT_EQ(p.lo, q.lo);
    } else {
      EXPECT_TRUE(std::isnan(q.value) && std::isnan(q.std_error));  // NULL, never a default
      EXPECT_EQ(p.reason, q.reason);
    }
  }
}

// 8 writers at once, each with its own connection: its own 200 runs, and (at the same time as that
// writer) a rewrite of 25 runs of the next writer.
void write_concurrently(const std::string& location) {
  std::vector<std::thread> writers;
  std::vector<std::string> errors(kWriters);
  for (int w = 0; w < kWriters; ++w)
    writers.emplace_back([&, w] {
      try {
        rp::ResultsStore store(location);
        for (int i = 0; i < kRunsPerWriter; ++i) {
          store.add(campaign_run(w, i));
          if (i < kRewritesPerWriter) store.add(campaign_run((w + 1) % kWriters, i));
        }
      } catch (const std::exception& e) {
        errors[w] = e.what();
      }
    });
  for (auto& t : writers) t.join();
  for (int w = 0; w < kWriters; ++w) EXPECT_EQ(errors[w], "") << "writer " << w;
}

void expect_store_complete(const std::string& location, const stend::testing::Environment& env) {
  const auto check = run_stend("db check --db " + shell_quote(location), env);
  EXPECT_EQ(check.code, 0) << check.text;
  const long long runs = kWriters * kRunsPerWriter;
  EXPECT_NE(check.text.find("runs:       " + std::to_string(runs) + "\n"), std::string::npos) << check.text;
  EXPECT_NE(check.text.find("estimators: " + std::to_string(2 * runs) + "\n"), std::string::npos) << check.text;
  EXPECT_NE(check.text.find("parameters: " + std::to_string(kParametersPerRun * runs) + "\n"), std::string::npos)
      << check.text;
  EXPECT_NE(check.text.find("documents:  " + std::to_string(runs) + "\n"), std::string::npos) << check.text;
  EXPECT_NE(check.text.find("verdict:    consistent"), std::string::npos) << check.text;
  // And the rows are the runs written, number for number.
  const rp::ResultsStore store(location);
  const rp::RunResults back = store.find_run("/lab/campaign/w3-r7");
  expect_same_run(campaign_run(3, 7), back);
}

class Postgres : public ::testing::Test {
 protected:
  static inline std::unique_ptr<stend::testing::TempPostgres> pg;
  static void SetUpTestSuite() {
    pg = std::make_unique<stend::testing::TempPostgres>();
    if (pg->why_not().empty()) ::setenv("PGPASSWORD", pg->password().c_str(), 1);  // as a lab's environment
  }
  static void TearDownTestSuite() {
    ::unsetenv("PGPASSWORD");
    pg.reset();
  }
  void SetUp() override { STEND_SKIP_UNLESS_RUNNING(*pg); }
  // A fresh database of the cluster for one test, migrated with `stend db migrate`.
  static std::string fresh_database(const std::string& name) {
    const auto r = stend::testing::run_command("psql -q " + shell_quote(pg->url()) + " -c " +
                                                   shell_quote("DROP DATABASE IF EXISTS " + name) + " -c " +
                                                   shell_quote("CREATE DATABASE " + name),
                                               pg->env());
    EXPECT_EQ(r.code, 0) << r.text;
    std::string url = pg->url();
    return url.replace(url.rfind('/') + 1, std::string::npos, name);
  }
};

}  // namespace

TEST(ResultsStore, RedactsPasswords) {
  EXPECT_EQ(rp::redact_url("postgresql://lab:s3cr%40t@db.lab:5432/stend"), "postgresql://lab:***@db.lab:5432/stend");
  EXPECT_EQ(rp::redact_url("postgresql://lab@db.lab/stend?password=hunter2&sslmode=require"),
            "postgresql://lab@db.lab/stend?password=***&sslmode=require");
  EXPECT_EQ(rp::redact_url("postgresql://db.lab/stend"), "postgresql://db.lab/stend");
  EXPECT_EQ(rp::redact_url("/data/runs/stend-results.sqlite"), "/data/runs/stend-results.sqlite");
}

// A results file an older Stend wrote (schema 1, no seq column, no unique (run, estimator) index)
// is migrated on open, its rows kept in their order, and then upserted like any other.
TEST(ResultsStore, SqliteSchema1FileIsMigratedWithItsRows) {
  const stend::testing::TempDir d("store-migrate");
  const fs::path file = d / "old.sqlite";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const char* v1 = R"sql(
CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
INSERT INTO meta VALUES('schema_version', '1');
CREATE TABLE runs(id INTEGER PRIMARY KEY, run_dir TEXT NOT NULL UNIQUE, run_name TEXT NOT NULL, experiment TEXT,
  run_status TEXT, start_time_utc TEXT, stend_version TEXT, vendor TEXT, model TEXT, serial TEXT,
  procedure_fingerprint TEXT, procedure_canonical TEXT, notes TEXT, added_utc TEXT NOT NULL);
CREATE TABLE estimators(run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, name TEXT NOT NULL,
  version TEXT, file TEXT, status TEXT, message TEXT);
CREATE TABLE parameters(run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, estimator TEXT NOT NULL,
  name TEXT NOT NULL, unit TEXT, identifiable INTEGER NOT NULL, value REAL, std_error REAL, interval_lo REAL,
  interval_hi REAL, confidence REAL, reason TEXT);
INSERT INTO runs VALUES(1, '/old/run', 'run', '', 'complete', '', '0.9', 'Acme', 'M', '7', 'ff', '', '', 'then');
INSERT INTO estimators VALUES(1, 'batch_lsq', '1.0', 'fit.json', 'ok', '');
INSERT INTO parameters VALUES(1, 'batch_lsq', 'scale_z', '', 1, 0.002, 0.0001, 0.0018, 0.0022, 0.95, '');
INSERT INTO parameters VALUES(1, 'batch_lsq', 'bias_z', 'm/s^2', 1, 0.05, 0.001, 0.048, 0.052, 0.95, '');
)sql";
  ASSERT_EQ(sqlite3_exec(db, v1, nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);

  {
    rp::ResultsStore as_is(file.string(), rp::ResultsStore::Open::kAsIs);
    EXPECT_EQ(as_is.schema_version(), 1);
    EXPECT_FALSE(as_is.check().ok());  // not this Stend's schema yet
    const rp::MigrationReport m = as_is.migrate();
    EXPECT_EQ(m.from, 1);
    EXPECT_EQ(m.to, rp::kResultsStoreSchemaVersion);
    EXPECT_NE(m.print().find("migrated to schema 2"), std::string::npos);
    EXPECT_NE(m.print().find("migrated to schema 3"), std::string::npos);
  }
  rp::ResultsStore store(file.string());
  const rp::RunResults old = store.find_run("/old/run");
  ASSERT_EQ(old.parameters.size(), 2u);
  EXPECT_EQ(old.parameters[0].name, "scale_z");  // the order they were written in
  EXPECT_EQ(old.parameters[1].value, 0.05);
  store.add(campaign_run(0, 0));
  store.add(campaign_run(0, 0, 1));  // the same run again: replaced
  const rp::StoreCheck c = store.check();
  EXPECT_TRUE(c.ok()) << c.print();
  EXPECT_EQ(c.runs, 2);
  EXPECT_EQ(c.parameters, 2 + kParametersPerRun);
  expect_same_run(campaign_run(0, 0, 1), store.find_run("w0-r0"));
}

// SQLite's documented limit: one file on a local disk, writers take turns (one write lock, busy
// timeout); with that, concurrent writers lose or duplicate nothing either.
TEST(ResultsStore, DbCheckOfAMissingFileCreatesNothing) {
  const stend::testing::TempDir tmp("store-missing");
  const fs::path missing = tmp.path() / "nowhere.sqlite";
  const auto check = run_stend("db check --db " + shell_quote(missing.string()));
  EXPECT_EQ(check.code, 2) << check.text;
  EXPECT_NE(check.text.find("no results store at " + missing.string()), std::string::npos) << check.text;
  EXPECT_FALSE(fs::exists(missing));
}

TEST(ResultsStore, SqliteEightConcurrentWritersLoseAndDuplicateNothing) {
  // In memory-backed /dev/shm when there is one: the 1800 commits then cost no disk syncs (what is
  // tested is the locking, not the disk); else the temp folder (~50 s on this VM's disk).
  const bool shm = fs::is_directory("/dev/shm") && ::access("/dev/shm", W_OK) == 0;
  const std::string file =
      (shm ? fs::path("/dev/shm") : fs::temp_directory_path()) / ("stend-store-writers-" + std::to_string(::getpid()) + ".sqlite");
  struct Remove {
    std::string f;
    ~Remove() {
      for (const char* ext : {"", "-journal"}) fs::remove(f + ext);
    }
  } remove{file};
  write_concurrently(file);
  expect_store_complete(file, {});
}

TEST_F(Postgres, WritersRefuseAnUnmigratedStoreUntilDbMigrate) {
  const std::string url = fresh_database("unmigrated");
  try {
    rp::ResultsStore store(url);
    FAIL() << "opened a store without schema";
  } catch (const stend::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("stend db migrate"), std::string::npos) << e.what();
  }
  const auto m = run_stend("db migrate --db " + shell_quote(url), pg->env());
  ASSERT_EQ(m.code, 0) << m.text;
  EXPECT_NE(m.text.find("migrated to schema 1"), std::string::npos) << m.text;
  EXPECT_NE(m.text.find("migrated to schema 2"), std::string::npos) << m.text;
  EXPECT_NE(m.text.find("migrated to schema 3"), std::string::npos) << m.text;
  const auto again = run_stend("db migrate --db " + shell_quote(url), pg->env());
  EXPECT_NE(again.text.find("schema 3 is current"), std::string::npos) << again.text;
  rp::ResultsStore store(url);
  EXPECT_EQ(store.schema_version(), rp::kResultsStoreSchemaVersion);
}

TEST_F(Postgres, RoundTripIsExactAndLikeSqlite) {
  const std::string url = fresh_database("roundtrip");
  ASSERT_EQ(run_stend("db migrate --db " + shell_quote(url), pg->env()).code, 0);
  const stend::testing::TempDir d("store-roundtrip");
  rp::ResultsStore pg_store(url), lite((d / "r.sqlite").string());
  for (auto* s : {&pg_store, &lite})
    for (int i = 0; i < 5; ++i) s->add(campaign_run(i % 2, i));
  const auto a = pg_store.all(), b = lite.all();
  ASSERT_EQ(a.size(), 5u);
  ASSERT_EQ(b.size(), 5u);
  for (std::size_t i = 0; i < a.size(); ++i) expect_same_run(a[i], b[i]);  // same rows, same order
  EXPECT_EQ(pg_store.with_fingerprint("ab12cd34").size(), 5u);  // a prefix of 8 hex digits
  EXPECT_EQ(pg_store.with_fingerprint("ab12").size(), 0u);      // shorter: exact only
  EXPECT_TRUE(pg_store.check().equals(lite.check()));
}

// The gap diagnosis is one document per (run, kind) on both stores: recorded again it is replaced,
// never duplicated; recorded without it (gap.json removed) it is gone.
void expect_documents_upserted(const std::string& location) {
  rp::ResultsStore store(location);
  store.add(campaign_run(0, 0, 0));
  store.add(campaign_run(0, 0, 1));  // the same run, a newer diagnosis
  rp::RunResults back = store.find_run("/lab/campaign/w0-r0");
  ASSERT_EQ(back.documents.size(), 1u);
  EXPECT_EQ(back.documents[0].document, campaign_run(0, 0, 1).documents[0].document);
  EXPECT_EQ(store.check().documents, 1);
  rp::RunResults without = campaign_run(0, 0, 2);
  without.documents.clear();
  store.add(without);
  EXPECT_TRUE(store.find_run("/lab/campaign/w0-r0").documents.empty());
  EXPECT_EQ(store.check().documents, 0);
  EXPECT_TRUE(store.check().ok());
}

TEST(ResultsStore, SqliteGapDocumentIsUpsertedByRunAndKind) {
  const stend::testing::TempDir d("store-documents");
  expect_documents_upserted((d / "r.sqlite").string());
}

TEST_F(Postgres, GapDocumentIsUpsertedByRunAndKind) {
  const std::string url = fresh_database("documents");
  ASSERT_EQ(run_stend("db migrate --db " + shell_quote(url), pg->env()).code, 0);
  expect_documents_upserted(url);
}

TEST_F(Postgres, PasswordIsNeverPrinted) {
  std::string url = fresh_database("secret");
  ASSERT_EQ(run_stend("db migrate --db " + shell_quote(url), pg->env()).code, 0);
  url.replace(url.find("stend@"), 6, "stend:" + pg->password() + "@");
  const auto r = run_stend("db check --db " + shell_quote(url));  // the password only in the URL
  EXPECT_EQ(r.code, 0) << r.text;
  EXPECT_EQ(r.text.find(pg->password()), std::string::npos) << r.text;
  EXPECT_NE(r.text.find("stend:***@127.0.0.1"), std::string::npos) << r.text;
  std::string wrong = fresh_database("secret");
  wrong.replace(wrong.find("stend@"), 6, "stend:not-the-password@");
  const auto refused = run_stend("db check --db " + shell_quote(wrong), {{"PGPASSWORD", ""}});
  EXPECT_EQ(refused.code, 4) << refused.text;  // the server refused: an I/O failure, said with the URL redacted
  EXPECT_EQ(refused.text.find("not-the-password"), std::string::npos) << refused.text;
}

TEST_F(Postgres, EightConcurrentWritersLoseAndDuplicateNothing) {
  const std::string url = fresh_database("campaign");
  ASSERT_EQ(run_stend("db migrate --db " + shell_quote(url), pg->env()).code, 0);
  write_concurrently(url);
  expect_store_complete(url, pg->env());
}
