// PostgreSQL backend of the results store (sql.hpp) through libpq. Credentials come only from
// libpq's own sources (PGPASSWORD, PGSERVICE, ~/.pgpass, the URL itself); what is printed of the
// URL has its password redacted.
#include "sql.hpp"

#include "stend/errors.hpp"
#include "stend/reporting/results_store.hpp"

#include <fmt/format.h>
#include <libpq-fe.h>
#include <stend/on_demand.hpp>

#include <cstdlib>
#include <vector>
#include <string_view>

namespace stend::reporting::sql {

namespace {

// libpq, opened the first time a command uses a PostgreSQL results store (core/on_demand/: libpq
// loads OpenSSL, Kerberos and LDAP, which no other command needs).
struct LibPq {
  OnDemandLibrary lib{STEND_LIBPQ_SONAME, "the PostgreSQL results store"};
  STEND_ON_DEMAND(lib, PQclear);
  STEND_ON_DEMAND(lib, PQconnectdbParams);
  STEND_ON_DEMAND(lib, PQconninfoFree);
  STEND_ON_DEMAND(lib, PQconninfoParse);
  STEND_ON_DEMAND(lib, PQerrorMessage);
  STEND_ON_DEMAND(lib, PQexec);
  STEND_ON_DEMAND(lib, PQexecParams);
  STEND_ON_DEMAND(lib, PQfinish);
  STEND_ON_DEMAND(lib, PQfreemem);
  STEND_ON_DEMAND(lib, PQftype);
  STEND_ON_DEMAND(lib, PQgetisnull);
  STEND_ON_DEMAND(lib, PQgetvalue);
  STEND_ON_DEMAND(lib, PQnfields);
  STEND_ON_DEMAND(lib, PQntuples);
  STEND_ON_DEMAND(lib, PQresultErrorMessage);
  STEND_ON_DEMAND(lib, PQresultStatus);
  STEND_ON_DEMAND(lib, PQsetNoticeProcessor);
  STEND_ON_DEMAND(lib, PQstatus);
};
const LibPq& pq() {
  static const LibPq table;
  return table;
}

// PostgreSQL type OIDs of the columns the store reads (catalog/pg_type.h).
constexpr Oid kOidBool = 16, kOidInt8 = 20, kOidInt2 = 21, kOidInt4 = 23, kOidFloat4 = 700, kOidFloat8 = 701,
              kOidNumeric = 1700;
// Timeouts added to a URL that does not state its own (docs/lab-scale.md, "Timeouts"): a server
// that accepts and then stalls fails the command instead of hanging it.
constexpr int kConnectTimeout_s = 10;           // libpq connect_timeout: the whole connection set-up [s]
constexpr int kStatementTimeout_ms = 300000;    // server statement_timeout: one statement [ms] (5 min)

// The value libpq would use for `keyword` from `url` alone, or "" when the URL does not state it
// (or cannot be parsed: PQconnectdbParams then says why).
std::string url_value(const std::string& url, std::string_view keyword) {
  char* err = nullptr;
  PQconninfoOption* opts = pq().PQconninfoParse(url.c_str(), &err);
  pq().PQfreemem(err);
  std::string value;
  for (PQconninfoOption* o = opts; o != nullptr && o->keyword != nullptr; ++o)
    if (keyword == o->keyword && o->val != nullptr) value = o->val;
  pq().PQconninfoFree(opts);
  return value;
}

bool env_set(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0';
}

// Whether the URL (or PGCONNECT_TIMEOUT) states a connect timeout.
bool states_connect_timeout(const std::string& url) {
  return !url_value(url, "connect_timeout").empty() || env_set("PGCONNECT_TIMEOUT");
}

// Whether the URL's options (or PGOPTIONS) set statement_timeout.
bool states_statement_timeout(const std::string& url) {
  const char* env = std::getenv("PGOPTIONS");
  return url_value(url, "options").find("statement_timeout") != std::string::npos ||
         (env != nullptr && std::string_view(env).find("statement_timeout") != std::string_view::npos);
}

// Connects with the URL's own parameters, and connect_timeout when it states none.
PGconn* connect_with_timeout(const std::string& url) {
  const std::string timeout = std::to_string(kConnectTimeout_s);
  std::vector<const char*> keys, values;
  if (!states_connect_timeout(url)) {
    keys.push_back("connect_timeout");
    values.push_back(timeout.c_str());
  }
  keys.push_back("dbname");  // expanded: every parameter of the URL, after (so over) the defaults above
  values.push_back(url.c_str());
  keys.push_back(nullptr);
  values.push_back(nullptr);
  return pq().PQconnectdbParams(keys.data(), values.data(), 1);
}

// Any two concurrent `stend db migrate` / store opens serialize their schema changes on this key.
constexpr long long kSchemaLockKey = 0x5374656e64L;  // "Stend"

class PostgresConnection final : public Connection {
 public:
  explicit PostgresConnection(const std::string& url) : where_(redact_url(url)) {
    conn_ = connect_with_timeout(url);
    if (!conn_ || pq().PQstatus(conn_) != CONNECTION_OK) {
      const std::string msg = conn_ ? pq().PQerrorMessage(conn_) : "out of memory";
      pq().PQfinish(conn_);
      throw IoError(where_ + ": cannot connect to the results store: " + trimmed(msg) +
                    " (check the server runs and the URL; the password comes from PGPASSWORD or ~/.pgpass; " +
                    timeout_note(url) + ")");
    }
    pq().PQsetNoticeProcessor(conn_, [](void*, const char*) {}, nullptr);  // "relation exists, skipping"
    if (!states_statement_timeout(url)) set_statement_timeout();
  }
  ~PostgresConnection() override { pq().PQfinish(conn_); }
  PostgresConnection(const PostgresConnection&) = delete;
  PostgresConnection& operator=(const PostgresConnection&) = delete;

  Dialect dialect() const override { return Dialect::kPostgres; }
  std::string where() const override { return where_; }
  void begin_write() override { exec("BEGIN"); }
  void lock_schema() override { exec(fmt::format("SELECT pg_advisory_xact_lock({})", kSchemaLockKey)); }

  void exec(const std::string& statements) override {
    PGresult* r = pq().PQexec(conn_, statements.c_str());
    check(r);
    pq().PQclear(r);
  }

  std::vector<Row> query(const std::string& statement, const std::vector<Value>& params) override {
    std::vector<std::string> texts(params.size());
    std::vector<const char*> values(params.size(), nullptr);
    for (std::size_t i = 0; i < params.size(); ++i) {
      if (params[i].is_null()) continue;
      texts[i] = params[i].kind == Value::Kind::kReal ? fmt::format("{}", params[i].real) : params[i].as_text();
      values[i] = texts[i].c_str();
    }
    PGresult* r = pq().PQexecParams(conn_, statement.c_str(), static_cast<int>(params.size()), nullptr, values.data(),
                               nullptr, nullptr, 0);
    check(r);
    std::vector<Row> rows;
    const int n = pq().PQntuples(r), m = pq().PQnfields(r);
    rows.reserve(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      Row row;
      row.reserve(static_cast<std::size_t>(m));
      for (int c = 0; c < m; ++c) row.push_back(cell(r, i, c));
      rows.push_back(std::move(row));
    }
    pq().PQclear(r);
    return rows;
  }

 private:
  void set_statement_timeout() {
    try {
      exec(fmt::format("SET statement_timeout = {}", kStatementTimeout_ms));
    } catch (...) {
      pq().PQfinish(conn_);
      throw;
    }
  }
  static std::string timeout_note(const std::string& url) {
    return states_connect_timeout(url)
               ? std::string("connect_timeout as the URL or PGCONNECT_TIMEOUT states it")
               : fmt::format("connect_timeout {} s by default; ?connect_timeout=N in the URL changes it", kConnectTimeout_s);
  }
  static std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    return s;
  }
  void check(PGresult* r) const {
    const ExecStatusType st = pq().PQresultStatus(r);
    if (st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK) return;
    const std::string msg = trimmed(r ? pq().PQresultErrorMessage(r) : pq().PQerrorMessage(conn_));
    pq().PQclear(r);
    throw IoError(where_ + ": " + msg);
  }
  static Value cell(PGresult* r, int i, int c) {
    if (pq().PQgetisnull(r, i, c)) return Value::null();
    const char* t = pq().PQgetvalue(r, i, c);
    switch (pq().PQftype(r, c)) {
      case kOidInt2:
      case kOidInt4:
      case kOidInt8: return Value::of(static_cast<long long>(std::atoll(t)));
      case kOidBool: return Value::of(static_cast<long long>(t[0] == 't' ? 1 : 0));
      case kOidFloat4:
      case kOidFloat8:
      case kOidNumeric: return Value::of(std::strtod(t, nullptr));
      default: return Value::of(std::string(t));
    }
  }

  PGconn* conn_ = nullptr;
  std::string where_;
};

}  // namespace

std::unique_ptr<Connection> open_postgres(const std::string& url) { return std::make_unique<PostgresConnection>(url); }

}  // namespace stend::reporting::sql
