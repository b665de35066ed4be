// The results store (results_store.hpp): schema, migrations and queries written once for both
// backends (sql.hpp). Each migration's text uses {id}, {int64}, {real} and {backfill_seq} for the
// few words the two dialects spell differently.
#include "stend/reporting/results_store.hpp"

#include "sql.hpp"
#include "stend/errors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <ctime>
#include <map>
#include <set>

namespace stend::reporting {

namespace fs = std::filesystem;
using sql::Dialect;
using sql::Value;

namespace {

struct Migration {
  int version;
  const char* what;
  const char* statements;
};

// Every schema version, in order. Never edit a published entry: add the next one.
const Migration kMigrations[] = {
    {1, "runs, estimators, parameters", R"sql(
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs(
  id {id},
  run_dir TEXT NOT NULL UNIQUE,
  run_name TEXT NOT NULL,
  experiment TEXT, run_status TEXT, start_time_utc TEXT, stend_version TEXT,
  vendor TEXT, model TEXT, serial TEXT,
  procedure_fingerprint TEXT, procedure_canonical TEXT,
  notes TEXT,
  added_utc TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS runs_fp ON runs(procedure_fingerprint);
CREATE TABLE IF NOT EXISTS estimators(
  run_id {int64} NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  name TEXT NOT NULL, version TEXT, file TEXT, status TEXT, message TEXT);
CREATE TABLE IF NOT EXISTS parameters(
  run_id {int64} NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  estimator TEXT NOT NULL, name TEXT NOT NULL, unit TEXT,
  identifiable INTEGER NOT NULL,
  value {real}, std_error {real}, interval_lo {real}, interval_hi {real}, confidence {real},
  reason TEXT);
CREATE INDEX IF NOT EXISTS parameters_run ON parameters(run_id);
)sql"},
    {2, "one row per (run, estimator); insertion order; indexes for vendor, model and parameter", R"sql(
ALTER TABLE estimators ADD COLUMN seq INTEGER;
ALTER TABLE parameters ADD COLUMN seq INTEGER;
{backfill_seq}
CREATE UNIQUE INDEX IF NOT EXISTS estimators_run_name ON estimators(run_id, name);
CREATE INDEX IF NOT EXISTS parameters_run_estimator ON parameters(run_id, estimator);
CREATE INDEX IF NOT EXISTS parameters_name ON parameters(name, estimator);
CREATE INDEX IF NOT EXISTS runs_vendor_model ON runs(vendor, model);
)sql"},
    {3, "whole results documents by (run, kind): the gap diagnosis (gap.json)", R"sql(
CREATE TABLE IF NOT EXISTS documents(
  run_id {int64} NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  kind TEXT NOT NULL, file TEXT, status TEXT, document TEXT NOT NULL);
CREATE UNIQUE INDEX IF NOT EXISTS documents_run_kind ON documents(run_id, kind);
)sql"},
};

// The schema version that added the documents table (an older store, checked as it is, has none).
constexpr int kDocumentsSinceVersion = 3;

std::string spelled(const char* statements, Dialect d) {
  const bool pg = d == Dialect::kPostgres;
  return fmt::format(fmt::runtime(statements), fmt::arg("id", pg ? "BIGSERIAL PRIMARY KEY" : "INTEGER PRIMARY KEY"),
                     fmt::arg("int64", pg ? "BIGINT" : "INTEGER"), fmt::arg("real", pg ? "DOUBLE PRECISION" : "REAL"),
                     fmt::arg("backfill_seq",
                              pg ? "" : "UPDATE estimators SET seq = rowid; UPDATE parameters SET seq = rowid;"));
}

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// The version recorded in meta; 0 for a store without one (new, or not yet a results store).
int recorded_version(sql::Connection& db) {
  // Asked without an error when there is no meta table: a failed statement would end an open
  // PostgreSQL transaction.
  const char* has_meta = db.dialect() == Dialect::kPostgres
                             ? "SELECT COUNT(*) FROM information_schema.tables WHERE table_schema = current_schema() "
                               "AND table_name = 'meta'"
                             : "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name = 'meta'";
  if (db.query(has_meta).at(0).at(0).as_integer() == 0) return 0;
  const auto rows = db.query("SELECT value FROM meta WHERE key = 'schema_version'");
  return rows.empty() ? 0 : static_cast<int>(std::atoll(rows[0][0].as_text().c_str()));
}

void refuse_newer(int version, const std::string& where) {
  if (version > kResultsStoreSchemaVersion)
    throw InputError(fmt::format("{}: results store schema {} is newer than this Stend's ({}): upgrade Stend", where,
                                 version, kResultsStoreSchemaVersion));
}

// Rolls back the open transaction unless committed.
class Transaction {
 public:
  explicit Transaction(sql::Connection& db) : db_(db) { db_.begin_write(); }
  ~Transaction() {
    if (!done_) try {
        db_.exec("ROLLBACK");
      } catch (...) {  // the connection is gone: nothing to undo
      }
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit() {
    db_.exec("COMMIT");
    done_ = true;
  }

 private:
  sql::Connection& db_;
  bool done_ = false;
};

// Rows per multi-row INSERT of parameters (12 values each; well under SQLite's 32766 parameters).
constexpr std::size_t kParameterRowsPerInsert = 64;

void insert_parameters(sql::Connection& db, long long run_id, const std::vector<ParameterResult>& ps) {
  for (std::size_t first = 0; first < ps.size(); first += kParameterRowsPerInsert) {
    const std::size_t n = std::min(kParameterRowsPerInsert, ps.size() - first);
    std::string statement =
        "INSERT INTO parameters(run_id, estimator, name, unit, identifiable, value, std_error, interval_lo, "
        "interval_hi, confidence, reason, seq) VALUES";
    std::vector<Value> v;
    v.reserve(n * 12);
    for (std::size_t i = 0; i < n; ++i) {
      const ParameterResult& q = ps[first + i];
      statement += i ? "," : "";
      statement += "(";
      for (int c = 0; c < 12; ++c) statement += fmt::format("{}${}", c ? "," : "", v.size() + static_cast<std::size_t>(c) + 1);
      statement += ")";
      v.insert(v.end(), {Value::of(run_id), Value::of(q.estimator), Value::of(q.name), Value::of(q.unit),
                         Value::of(static_cast<long long>(q.identifiable ? 1 : 0)), Value::of(q.value),
                         Value::of(q.std_error), Value::of(q.lo), Value::of(q.hi), Value::of(q.confidence),
                         Value::of(q.reason), Value::of(static_cast<long long>(first + i))});
    }
    db.query(statement, v);
  }
}

// The run's documents, one per kind: upserted; kinds the folder no longer holds removed.
void upsert_documents(sql::Connection& db, long long run_id, const std::vector<ResultDocument>& docs) {
  std::set<std::string> kinds;
  for (const auto& d : docs) {
    kinds.insert(d.kind);
    db.query("INSERT INTO documents(run_id, kind, file, status, document) VALUES($1,$2,$3,$4,$5) "
             "ON CONFLICT(run_id, kind) DO UPDATE SET file = excluded.file, status = excluded.status, "
             "document = excluded.document",
             {Value::of(run_id), Value::of(d.kind), Value::of(d.file), Value::of(d.status), Value::of(d.document)});
  }
  for (const auto& row : db.query("SELECT kind FROM documents WHERE run_id = $1", {Value::of(run_id)}))
    if (!kinds.count(row[0].as_text()))
      db.query("DELETE FROM documents WHERE run_id = $1 AND kind = $2", {Value::of(run_id), row[0]});
}

long long count(sql::Connection& db, const std::string& statement) {
  const auto rows = db.query(statement);
  return rows.empty() ? 0 : rows[0][0].as_integer();
}

bool is_hex(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)) != 0; });
}

}  // namespace

// ---- locations -----------------------------------------------------------------------------

bool is_postgres_location(const std::string& location) {
  return location.rfind("postgresql://", 0) == 0 || location.rfind("postgres://", 0) == 0;
}

std::string results_store_location(const std::string& given, const fs::path& run_dir) {
  if (!given.empty()) return given;
  if (const char* env = std::getenv("STEND_RESULTS_DB"); env && *env) return env;
  if (run_dir.empty()) return "stend-results.sqlite";
  fs::path d = fs::absolute(run_dir).lexically_normal();
  if (!d.has_filename()) d = d.parent_path();
  return (d.parent_path() / "stend-results.sqlite").string();
}

std::string redact_url(const std::string& location) {
  std::string s = location;
  if (const auto scheme = s.find("://"); scheme != std::string::npos) {
    const std::size_t host_start = scheme + 3;
    const std::size_t end = s.find_first_of("/?", host_start);
    const std::size_t at = s.rfind('@', end == std::string::npos ? s.size() : end);
    if (at != std::string::npos && at > host_start) {
      const std::size_t colon = s.find(':', host_start);
      if (colon != std::string::npos && colon < at) s.replace(colon + 1, at - colon - 1, "***");
    }
  }
  for (std::size_t p = s.find("password="); p != std::string::npos; p = s.find("password=", p + 1)) {
    const std::size_t v = p + 9;
    const std::size_t e = s.find_first_of("& ", v);
    s.replace(v, (e == std::string::npos ? s.size() : e) - v, "***");
  }
  return s;
}

// ---- check ---------------------------------------------------------------------------------

bool StoreCheck::ok() const {
  return schema_version == kResultsStoreSchemaVersion && duplicate_runs == 0 && duplicate_estimators == 0 &&
         duplicate_parameters == 0 && duplicate_documents == 0 && orphan_estimators == 0 && orphan_parameters == 0 &&
         orphan_documents == 0;
}

std::string StoreCheck::print() const {
  return fmt::format(
      "schema:     {} (this Stend: {})\nruns:       {}\nestimators: {}\nparameters: {}\ndocuments:  {}\n"
      "duplicated: {} run(s), {} (run, estimator), {} (run, estimator, parameter), {} (run, document kind)\n"
      "orphaned:   {} estimator row(s), {} parameter row(s), {} document row(s)\nverdict:    {}\n",
      schema_version, kResultsStoreSchemaVersion, runs, estimators, parameters, documents, duplicate_runs,
      duplicate_estimators, duplicate_parameters, duplicate_documents, orphan_estimators, orphan_parameters,
      orphan_documents, ok() ? "consistent" : "NOT consistent");
}

bool StoreCheck::equals(const StoreCheck& o) const {
  return schema_version == o.schema_version && runs == o.runs && estimators == o.estimators &&
         parameters == o.parameters && documents == o.documents && duplicate_runs == o.duplicate_runs &&
         duplicate_documents == o.duplicate_documents && orphan_documents == o.orphan_documents &&
         duplicate_estimators == o.duplicate_estimators && duplicate_parameters == o.duplicate_parameters &&
         orphan_estimators == o.orphan_estimators && orphan_parameters == o.orphan_parameters;
}

std::string MigrationReport::print() const {
  if (from == to) return fmt::format("schema {} is current\n", to);
  std::string out;
  for (const auto& m : kMigrations)
    if (m.version > from && m.version <= to) out += fmt::format("migrated to schema {}: {}\n", m.version, m.what);
  return out;
}

// ---- the store -----------------------------------------------------------------------------

ResultsStore::ResultsStore(const std::string& location, Open open)
    : db_(is_postgres_location(location) ? sql::open_postgres(location)
                                         : sql::open_sqlite(location.rfind("sqlite://", 0) == 0 ? location.substr(9)
                                                                                                 : location)) {
  if (open == Open::kDefault) open = is_postgres() ? Open::kRequireCurrent : Open::kMigrate;
  const int version = recorded_version(*db_);
  refuse_newer(version, where());
  if (version == kResultsStoreSchemaVersion || open == Open::kAsIs) return;
  if (open == Open::kMigrate) {
    migrate();
    return;
  }
  throw InputError(fmt::format("{}: results store schema {} is older than this Stend's ({}): run `stend db migrate "
                               "--db URL` once, as a role allowed to change the schema (docs/lab-scale.md)",
                               where(), version == 0 ? std::string("none") : std::to_string(version),
                               kResultsStoreSchemaVersion));
}

ResultsStore::~ResultsStore() = default;

std::string ResultsStore::where() const { return db_->where(); }
bool ResultsStore::is_postgres() const { return db_->dialect() == Dialect::kPostgres; }
int ResultsStore::schema_version() const { return recorded_version(*db_); }

MigrationReport ResultsStore::migrate() {
  MigrationReport report;
  report.from = recorded_version(*db_);
  refuse_newer(report.from, where());
  for (const auto& m : kMigrations) {
    Transaction tx(*db_);
    db_->lock_schema();
    const int now = recorded_version(*db_);  // another process may have migrated meanwhile
    refuse_newer(now, where());
    if (m.version <= now) continue;
    db_->exec(spelled(m.statements, db_->dialect()));
    db_->query(m.version == 1 ? "INSERT INTO meta(key, value) VALUES('schema_version', $1)"
                              : "UPDATE meta SET value = $1 WHERE key = 'schema_version'",
               {Value::of(std::to_string(m.version))});
    tx.commit();
  }
  report.to = recorded_version(*db_);
  return report;
}

long long ResultsStore::add(const RunResults& r) {
  std::string notes;
  for (const auto& n : r.notes) notes += (notes.empty() ? "" : "\n") + n;
  Transaction tx(*db_);
  // The run: one row per folder, updated in place (its id, and so its results' keys, stay).
  const auto ids = db_->query(
      "INSERT INTO runs(run_dir, run_name, experiment, run_status, start_time_utc, stend_version, vendor, model, "
      "serial, procedure_fingerprint, procedure_canonical, notes, added_utc) "
      "VALUES($1,$2,$3,$4,$5,$6,$7,$8,$9,$10,$11,$12,$13) "
      "ON CONFLICT(run_dir) DO UPDATE SET run_name = excluded.run_name, experiment = excluded.experiment, "
      "run_status = excluded.run_status, start_time_utc = excluded.start_time_utc, "
      "stend_version = excluded.stend_version, vendor = excluded.vendor, model = excluded.model, "
      "serial = excluded.serial, procedure_fingerprint = excluded.procedure_fingerprint, "
      "procedure_canonical = excluded.procedure_canonical, notes = excluded.notes, added_utc = excluded.added_utc "
      "RETURNING id",
      {Value::of(r.dir.string()), Value::of(r.run_name), Value::of(r.experiment), Value::of(r.run_status),
       Value::of(r.start_time_utc), Value::of(r.stend_version), Value::of(r.vendor), Value::of(r.model),
       Value::of(r.serial), Value::of(r.procedure_fingerprint), Value::of(r.procedure_canonical), Value::of(notes),
       Value::of(now_utc())});
  const long long id = ids.at(0).at(0).as_integer();
  // Its results, one kind (estimator) each: upserted; kinds the folder no longer holds removed.
  std::set<std::string> kinds;
  for (std::size_t i = 0; i < r.estimators.size(); ++i) {
    const EstimatorUse& e = r.estimators[i];
    kinds.insert(e.name);
    db_->query(
        "INSERT INTO estimators(run_id, name, version, file, status, message, seq) VALUES($1,$2,$3,$4,$5,$6,$7) "
        "ON CONFLICT(run_id, name) DO UPDATE SET version = excluded.version, file = excluded.file, "
        "status = excluded.status, message = excluded.message, seq = excluded.seq",
        {Value::of(id), Value::of(e.name), Value::of(e.version), Value::of(e.file), Value::of(e.status),
         Value::of(e.message), Value::of(static_cast<long long>(i))});
  }
  for (const auto& row : db_->query("SELECT name FROM estimators WHERE run_id = $1", {Value::of(id)}))
    if (!kinds.count(row[0].as_text()))
      db_->query("DELETE FROM estimators WHERE run_id = $1 AND name = $2", {Value::of(id), row[0]});
  db_->query("DELETE FROM parameters WHERE run_id = $1", {Value::of(id)});
  insert_parameters(*db_, id, r.parameters);
  upsert_documents(*db_, id, r.documents);
  tx.commit();
  return id;
}

std::vector<RunResults> ResultsStore::query(const std::string& where, const std::vector<std::string>& args) const {
  std::vector<Value> params;
  for (const auto& a : args) params.push_back(Value::of(a));
  const std::string selected = "SELECT id FROM runs " + where;
  std::vector<RunResults> out;
  std::map<long long, std::size_t> index;  // run id → position in out
  for (const auto& row : db_->query(
           "SELECT id, run_dir, run_name, experiment, run_status, start_time_utc, stend_version, vendor, model, "
           "serial, procedure_fingerprint, procedure_canonical, notes FROM runs " +
               where + " ORDER BY vendor, model, serial, run_name",
           params)) {
    RunResults r;
    r.dir = row[1].as_text();
    r.run_name = row[2].as_text();
    r.experiment = row[3].as_text();
    r.run_status = row[4].as_text();
    r.start_time_utc = row[5].as_text();
    r.stend_version = row[6].as_text();
    r.vendor = row[7].as_text();
    r.model = row[8].as_text();
    r.serial = row[9].as_text();
    r.procedure_fingerprint = row[10].as_text();
    r.procedure_canonical = row[11].as_text();
    if (const std::string notes = row[12].as_text(); !notes.empty()) r.notes.push_back(notes);
    index[row[0].as_integer()] = out.size();
    out.push_back(std::move(r));
  }
  if (out.empty()) return out;
  for (const auto& row : db_->query("SELECT run_id, name, version, file, status, message FROM estimators "
                                    "WHERE run_id IN (" + selected + ") ORDER BY run_id, seq",
                                    params))
    out[index.at(row[0].as_integer())].estimators.push_back(
        {row[1].as_text(), row[2].as_text(), row[3].as_text(), row[4].as_text(), row[5].as_text()});
  for (const auto& row : db_->query(
           "SELECT run_id, estimator, name, unit, identifiable, value, std_error, interval_lo, interval_hi, "
           "confidence, reason FROM parameters WHERE run_id IN (" + selected + ") ORDER BY run_id, seq",
           params)) {
    ParameterResult q;
    q.estimator = row[1].as_text();
    q.name = row[2].as_text();
    q.unit = row[3].as_text();
    q.identifiable = row[4].as_integer() != 0;
    q.value = row[5].as_real();
    q.std_error = row[6].as_real();
    q.lo = row[7].as_real();
    q.hi = row[8].as_real();
    q.confidence = row[9].as_real();
    q.reason = row[10].as_text();
    out[index.at(row[0].as_integer())].parameters.push_back(std::move(q));
  }
  for (const auto& row : db_->query("SELECT run_id, kind, file, status, document FROM documents WHERE run_id IN (" +
                                        selected + ") ORDER BY run_id, kind",
                                    params))
    out[index.at(row[0].as_integer())].documents.push_back(
        {row[1].as_text(), row[2].as_text(), row[3].as_text(), row[4].as_text()});
  return out;
}

std::vector<RunResults> ResultsStore::all() const { return query("", {}); }

std::vector<RunResults> ResultsStore::with_fingerprint(const std::string& fp) const {
  // A prefix of at least 8 hex digits is accepted (fingerprints are printed shortened).
  if (fp.size() >= 8 && is_hex(fp))
    return query("WHERE procedure_fingerprint = $1 OR procedure_fingerprint LIKE $2", {fp, fp + "%"});
  return query("WHERE procedure_fingerprint = $1", {fp});
}

RunResults ResultsStore::find_run(const std::string& dir_or_name) const {
  std::string abs = dir_or_name;
  std::error_code ec;
  if (fs::exists(dir_or_name, ec)) {
    fs::path d = fs::absolute(dir_or_name).lexically_normal();
    if (!d.has_filename()) d = d.parent_path();
    abs = d.string();
  }
  auto v = query("WHERE run_dir = $1 OR run_name = $2", {abs, dir_or_name});
  return v.empty() ? RunResults{} : v.front();
}

StoreCheck ResultsStore::check() const {
  StoreCheck c;
  c.schema_version = recorded_version(*db_);
  c.runs = count(*db_, "SELECT COUNT(*) FROM runs");
  c.estimators = count(*db_, "SELECT COUNT(*) FROM estimators");
  c.parameters = count(*db_, "SELECT COUNT(*) FROM parameters");
  c.duplicate_runs =
      count(*db_, "SELECT COUNT(*) FROM (SELECT run_dir FROM runs GROUP BY run_dir HAVING COUNT(*) > 1) d");
  c.duplicate_estimators = count(
      *db_, "SELECT COUNT(*) FROM (SELECT run_id, name FROM estimators GROUP BY run_id, name HAVING COUNT(*) > 1) d");
  c.duplicate_parameters = count(*db_,
                                 "SELECT COUNT(*) FROM (SELECT run_id, estimator, name FROM parameters "
                                 "GROUP BY run_id, estimator, name HAVING COUNT(*) > 1) d");
  c.orphan_estimators =
      count(*db_, "SELECT COUNT(*) FROM estimators e WHERE NOT EXISTS (SELECT 1 FROM runs r WHERE r.id = e.run_id)");
  c.orphan_parameters = count(*db_,
                              "SELECT COUNT(*) FROM parameters p WHERE NOT EXISTS (SELECT 1 FROM estimators e "
                              "WHERE e.run_id = p.run_id AND e.name = p.estimator)");
  if (c.schema_version < kDocumentsSinceVersion) return c;
  c.documents = count(*db_, "SELECT COUNT(*) FROM documents");
  c.duplicate_documents = count(
      *db_, "SELECT COUNT(*) FROM (SELECT run_id, kind FROM documents GROUP BY run_id, kind HAVING COUNT(*) > 1) d");
  c.orphan_documents =
      count(*db_, "SELECT COUNT(*) FROM documents d WHERE NOT EXISTS (SELECT 1 FROM runs r WHERE r.id = d.run_id)");
  return c;
}

}  // namespace stend::reporting
