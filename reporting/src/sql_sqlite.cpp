// SQLite backend of the results store (sql.hpp): one file, writers serialized by its write lock.
#include "sql.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>
#include <sqlite3.h>

#include <cstdlib>

namespace stend::reporting::sql {

std::string Value::as_text() const {
  switch (kind) {
    case Kind::kNull: return "";
    case Kind::kText: return text;
    case Kind::kReal: return fmt::format("{}", real);
    case Kind::kInteger: return std::to_string(integer);
  }
  return "";
}
double Value::as_real() const {
  switch (kind) {
    case Kind::kReal: return real;
    case Kind::kInteger: return static_cast<double>(integer);
    case Kind::kText: return text.empty() ? std::nan("") : std::strtod(text.c_str(), nullptr);
    case Kind::kNull: break;
  }
  return NAN;
}
long long Value::as_integer() const {
  switch (kind) {
    case Kind::kInteger: return integer;
    case Kind::kReal: return static_cast<long long>(real);
    case Kind::kText: return std::atoll(text.c_str());
    case Kind::kNull: break;
  }
  return 0;
}

namespace {

// How long a writer waits for another writer's transaction before it fails [ms].
constexpr int kSqliteBusyTimeoutMs = 60000;

class SqliteConnection final : public Connection {
 public:
  explicit SqliteConnection(const std::string& file) : file_(file) {
    if (sqlite3_open(file.c_str(), &db_) != SQLITE_OK) {
      const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw IoError(file + ": cannot open the results database: " + msg +
                    " (check the folder exists and is writable, or give --db)");
    }
    sqlite3_busy_timeout(db_, kSqliteBusyTimeoutMs);
    exec("PRAGMA foreign_keys = ON;");
  }
  ~SqliteConnection() override { sqlite3_close(db_); }
  SqliteConnection(const SqliteConnection&) = delete;
  SqliteConnection& operator=(const SqliteConnection&) = delete;

  Dialect dialect() const override { return Dialect::kSqlite; }
  std::string where() const override { return file_; }
  void begin_write() override { exec("BEGIN IMMEDIATE"); }
  void lock_schema() override {}

  void exec(const std::string& statements) override {
    char* err = nullptr;
    if (sqlite3_exec(db_, statements.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string msg = err ? err : sqlite3_errmsg(db_);
      sqlite3_free(err);
      throw IoError(file_ + ": " + msg);
    }
  }

  std::vector<Row> query(const std::string& statement, const std::vector<Value>& params) override {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db_, statement.c_str(), -1, &s, nullptr) != SQLITE_OK)
      throw IoError(file_ + ": " + sqlite3_errmsg(db_));
    struct Finalize {
      sqlite3_stmt* s;
      ~Finalize() { sqlite3_finalize(s); }
    } fin{s};
    for (std::size_t i = 0; i < params.size(); ++i) bind(s, "$" + std::to_string(i + 1), params[i]);
    std::vector<Row> rows;
    int rc;
    while ((rc = sqlite3_step(s)) == SQLITE_ROW) rows.push_back(row_of(s));
    if (rc != SQLITE_DONE) throw IoError(file_ + ": " + sqlite3_errmsg(db_));
    return rows;
  }

 private:
  static void bind(sqlite3_stmt* s, const std::string& name, const Value& v) {
    const int i = sqlite3_bind_parameter_index(s, name.c_str());
    if (i == 0) return;  // the statement does not use this parameter
    switch (v.kind) {
      case Value::Kind::kNull: sqlite3_bind_null(s, i); break;
      case Value::Kind::kText:
        sqlite3_bind_text(s, i, v.text.c_str(), static_cast<int>(v.text.size()), SQLITE_TRANSIENT);
        break;
      case Value::Kind::kReal: sqlite3_bind_double(s, i, v.real); break;
      case Value::Kind::kInteger: sqlite3_bind_int64(s, i, v.integer); break;
    }
  }
  static Row row_of(sqlite3_stmt* s) {
    Row row;
    const int n = sqlite3_column_count(s);
    for (int c = 0; c < n; ++c) {
      switch (sqlite3_column_type(s, c)) {
        case SQLITE_NULL: row.push_back(Value::null()); break;
        case SQLITE_INTEGER: row.push_back(Value::of(static_cast<long long>(sqlite3_column_int64(s, c)))); break;
        case SQLITE_FLOAT: row.push_back(Value::of(sqlite3_column_double(s, c))); break;
        default: {
          const unsigned char* t = sqlite3_column_text(s, c);
          row.push_back(Value::of(std::string(t ? reinterpret_cast<const char*>(t) : "")));
        }
      }
    }
    return row;
  }

  sqlite3* db_ = nullptr;
  std::string file_;
};

}  // namespace

std::unique_ptr<Connection> open_sqlite(const std::string& file) { return std::make_unique<SqliteConnection>(file); }

}  // namespace stend::reporting::sql
