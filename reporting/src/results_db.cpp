// SQLite results database (see results_db.hpp).
#include "stend/reporting/results_db.hpp"

#include "stend/errors.hpp"

#include <sqlite3.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <stdexcept>

namespace stend::reporting {

namespace fs = std::filesystem;

namespace {

const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs(
  id INTEGER PRIMARY KEY,
  run_dir TEXT NOT NULL UNIQUE,
  run_name TEXT NOT NULL,
  experiment TEXT, run_status TEXT, start_time_utc TEXT, stend_version TEXT,
  vendor TEXT, model TEXT, serial TEXT,
  procedure_fingerprint TEXT, procedure_canonical TEXT,
  notes TEXT,
  added_utc TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS runs_fp ON runs(procedure_fingerprint);
CREATE TABLE IF NOT EXISTS estimators(
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  name TEXT NOT NULL, version TEXT, file TEXT, status TEXT, message TEXT);
CREATE TABLE IF NOT EXISTS parameters(
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  estimator TEXT NOT NULL, name TEXT NOT NULL, unit TEXT,
  identifiable INTEGER NOT NULL,
  value REAL, std_error REAL, interval_lo REAL, interval_hi REAL, confidence REAL,
  reason TEXT);
CREATE INDEX IF NOT EXISTS parameters_run ON parameters(run_id);
)sql";

struct Stmt {
  sqlite3_stmt* s = nullptr;
  Stmt(sqlite3* db, const char* sql) {
    if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) != SQLITE_OK)
      throw std::runtime_error(std::string("results database: ") + sqlite3_errmsg(db));
  }
  ~Stmt() { sqlite3_finalize(s); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  void text(int i, const std::string& v) { sqlite3_bind_text(s, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT); }
  void real(int i, double v) {
    if (std::isfinite(v)) sqlite3_bind_double(s, i, v);
    else sqlite3_bind_null(s, i);  // NaN: not a number, never a default
  }
  void integer(int i, long long v) { sqlite3_bind_int64(s, i, v); }
  std::string col_text(int i) const {
    const unsigned char* t = sqlite3_column_text(s, i);
    return t ? reinterpret_cast<const char*>(t) : "";
  }
  double col_real(int i) const { return sqlite3_column_type(s, i) == SQLITE_NULL ? std::numeric_limits<double>::quiet_NaN() : sqlite3_column_double(s, i); }
};

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

fs::path default_db_path(const fs::path& run_dir) {
  if (const char* env = std::getenv("STEND_RESULTS_DB"); env && *env) return env;
  fs::path d = fs::absolute(run_dir).lexically_normal();
  if (!d.has_filename()) d = d.parent_path();
  return d.parent_path() / "stend-results.sqlite";
}

ResultsDb::ResultsDb(const fs::path& file) : file_(file) {
  if (sqlite3_open(file.c_str(), &db_) != SQLITE_OK) {
    const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw IoError(file.string() + ": cannot open the results database: " + msg);
  }
  sqlite3_busy_timeout(db_, 5000);
  char* err = nullptr;
  if (sqlite3_exec(db_, kSchema, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "?";
    sqlite3_free(err);
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(file.string() + ": not a Stend results database: " + msg);
  }
  sqlite3_exec(db_, "PRAGMA foreign_keys = ON;", nullptr, nullptr, nullptr);
  Stmt v(db_, "SELECT value FROM meta WHERE key = 'schema_version'");
  if (sqlite3_step(v.s) == SQLITE_ROW) {
    const int version = std::atoi(v.col_text(0).c_str());
    if (version > kResultsDbSchemaVersion) {
      sqlite3_close(db_);
      db_ = nullptr;
      throw std::runtime_error(file.string() + ": results database schema " + std::to_string(version) +
                               " is newer than this Stend's (" + std::to_string(kResultsDbSchemaVersion) +
                               "): upgrade Stend");
    }
  } else {
    Stmt ins(db_, "INSERT INTO meta(key, value) VALUES('schema_version', ?)");
    ins.text(1, std::to_string(kResultsDbSchemaVersion));
    sqlite3_step(ins.s);
  }
}

ResultsDb::~ResultsDb() { sqlite3_close(db_); }

long long ResultsDb::add(const RunResults& r) {
  auto exec = [&](const char* sql) {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string msg = err ? err : "?";
      sqlite3_free(err);
      throw IoError(file_.string() + ": " + msg);
    }
  };
  exec("BEGIN IMMEDIATE");
  try {
    {
      Stmt del(db_, "DELETE FROM runs WHERE run_dir = ?");
      del.text(1, r.dir.string());
      sqlite3_step(del.s);
    }
    std::string notes;
    for (const auto& n : r.notes) notes += (notes.empty() ? "" : "\n") + n;
    Stmt ins(db_,
             "INSERT INTO runs(run_dir, run_name, experiment, run_status, start_time_utc, stend_version, vendor, "
             "model, serial, procedure_fingerprint, procedure_canonical, notes, added_utc) "
             "VALUES(?,?,?,?,?,?,?,?,?,?,?,?,?)");
    const std::string vals[] = {r.dir.string(), r.run_name, r.experiment, r.run_status, r.start_time_utc,
                                r.stend_version, r.vendor, r.model, r.serial, r.procedure_fingerprint,
                                r.procedure_canonical, notes, now_utc()};
    for (int i = 0; i < 13; ++i) ins.text(i + 1, vals[i]);
    if (sqlite3_step(ins.s) != SQLITE_DONE) throw IoError(file_.string() + ": " + sqlite3_errmsg(db_));
    const long long id = sqlite3_last_insert_rowid(db_);
    for (const auto& e : r.estimators) {
      Stmt s(db_, "INSERT INTO estimators(run_id, name, version, file, status, message) VALUES(?,?,?,?,?,?)");
      s.integer(1, id);
      s.text(2, e.name);
      s.text(3, e.version);
      s.text(4, e.file);
      s.text(5, e.status);
      s.text(6, e.message);
      if (sqlite3_step(s.s) != SQLITE_DONE) throw IoError(file_.string() + ": " + sqlite3_errmsg(db_));
    }
    Stmt p(db_,
           "INSERT INTO parameters(run_id, estimator, name, unit, identifiable, value, std_error, interval_lo, "
           "interval_hi, confidence, reason) VALUES(?,?,?,?,?,?,?,?,?,?,?)");
    for (const auto& q : r.parameters) {
      sqlite3_reset(p.s);
      p.integer(1, id);
      p.text(2, q.estimator);
      p.text(3, q.name);
      p.text(4, q.unit);
      p.integer(5, q.identifiable ? 1 : 0);
      p.real(6, q.value);
      p.real(7, q.std_error);
      p.real(8, q.lo);
      p.real(9, q.hi);
      p.real(10, q.confidence);
      p.text(11, q.reason);
      if (sqlite3_step(p.s) != SQLITE_DONE) throw IoError(file_.string() + ": " + sqlite3_errmsg(db_));
    }
    exec("COMMIT");
    return id;
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

std::vector<RunResults> ResultsDb::query(const std::string& where, const std::string& arg) const {
  std::vector<RunResults> out;
  const std::string sql =
      "SELECT id, run_dir, run_name, experiment, run_status, start_time_utc, stend_version, vendor, model, serial, "
      "procedure_fingerprint, procedure_canonical, notes FROM runs " +
      where + " ORDER BY vendor, model, serial, run_name";
  Stmt s(db_, sql.c_str());
  if (!arg.empty()) {
    s.text(1, arg);
    if (where.find("?2") != std::string::npos) s.text(2, arg);
  }
  std::vector<long long> ids;
  while (sqlite3_step(s.s) == SQLITE_ROW) {
    RunResults r;
    ids.push_back(sqlite3_column_int64(s.s, 0));
    r.dir = s.col_text(1);
    r.run_name = s.col_text(2);
    r.experiment = s.col_text(3);
    r.run_status = s.col_text(4);
    r.start_time_utc = s.col_text(5);
    r.stend_version = s.col_text(6);
    r.vendor = s.col_text(7);
    r.model = s.col_text(8);
    r.serial = s.col_text(9);
    r.procedure_fingerprint = s.col_text(10);
    r.procedure_canonical = s.col_text(11);
    const std::string notes = s.col_text(12);
    if (!notes.empty()) r.notes.push_back(notes);
    out.push_back(std::move(r));
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    Stmt e(db_, "SELECT name, version, file, status, message FROM estimators WHERE run_id = ? ORDER BY rowid");
    e.integer(1, ids[i]);
    while (sqlite3_step(e.s) == SQLITE_ROW)
      out[i].estimators.push_back({e.col_text(0), e.col_text(1), e.col_text(2), e.col_text(3), e.col_text(4)});
    Stmt p(db_,
           "SELECT estimator, name, unit, identifiable, value, std_error, interval_lo, interval_hi, confidence, reason "
           "FROM parameters WHERE run_id = ? ORDER BY rowid");
    p.integer(1, ids[i]);
    while (sqlite3_step(p.s) == SQLITE_ROW) {
      ParameterResult q;
      q.estimator = p.col_text(0);
      q.name = p.col_text(1);
      q.unit = p.col_text(2);
      q.identifiable = sqlite3_column_int(p.s, 3) != 0;
      q.value = p.col_real(4);
      q.std_error = p.col_real(5);
      q.lo = p.col_real(6);
      q.hi = p.col_real(7);
      q.confidence = p.col_real(8);
      q.reason = p.col_text(9);
      out[i].parameters.push_back(std::move(q));
    }
  }
  return out;
}

std::vector<RunResults> ResultsDb::all() const { return query("", ""); }

std::vector<RunResults> ResultsDb::with_fingerprint(const std::string& fp) const {
  // A prefix of at least 8 hex digits is accepted (fingerprints are printed shortened).
  return query("WHERE procedure_fingerprint = ?1 OR (length(?2) >= 8 AND substr(procedure_fingerprint, 1, length(?2)) = ?2)", fp);
}

RunResults ResultsDb::find_run(const std::string& dir_or_name) const {
  std::string abs = dir_or_name;
  std::error_code ec;
  if (fs::exists(dir_or_name, ec)) {
    fs::path d = fs::absolute(dir_or_name).lexically_normal();
    if (!d.has_filename()) d = d.parent_path();
    abs = d.string();
  }
  auto v = query("WHERE run_dir = ?1 OR run_name = ?2", abs);
  if (v.empty() && abs != dir_or_name) v = query("WHERE run_name = ?1 OR run_dir = ?2", dir_or_name);
  return v.empty() ? RunResults{} : v.front();
}

}  // namespace stend::reporting
