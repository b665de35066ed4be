// The two SQL backends of the results store behind one small interface: a connection that runs
// statements with positional parameters ($1, $2, … in both dialects) and returns rows of typed
// cells. The store's schema, migrations and queries are written once, in results_store.cpp.
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace stend::reporting::sql {

// One parameter or result cell. A NaN real is bound as NULL (a number that does not exist is
// never a default).
struct Value {
  enum class Kind { kNull, kText, kReal, kInteger } kind = Kind::kNull;
  std::string text;
  double real = NAN;
  long long integer = 0;

  static Value null() { return {}; }
  static Value of(std::string s) { return {Kind::kText, std::move(s), NAN, 0}; }
  static Value of(double v) { return std::isfinite(v) ? Value{Kind::kReal, {}, v, 0} : Value{}; }
  static Value of(long long v) { return {Kind::kInteger, {}, NAN, v}; }

  bool is_null() const { return kind == Kind::kNull; }
  std::string as_text() const;   // "" for NULL
  double as_real() const;        // NaN for NULL
  long long as_integer() const;  // 0 for NULL
};

using Row = std::vector<Value>;

enum class Dialect { kSqlite, kPostgres };

class Connection {
 public:
  virtual ~Connection() = default;
  virtual Dialect dialect() const = 0;
  // Runs one or more statements without parameters.
  virtual void exec(const std::string& statements) = 0;
  // Runs one statement with $1…$n bound to `params`; returns its rows.
  virtual std::vector<Row> query(const std::string& statement, const std::vector<Value>& params = {}) = 0;
  // Starts a transaction that holds the write lock from its first statement (SQLite: BEGIN
  // IMMEDIATE; PostgreSQL: BEGIN, row locks taken by the upsert).
  virtual void begin_write() = 0;
  // Serializes schema changes between processes until the transaction ends (PostgreSQL: an
  // advisory transaction lock; SQLite: the write lock already does).
  virtual void lock_schema() = 0;
  // Where the store is, as it may be printed (a password in a URL is redacted).
  virtual std::string where() const = 0;
};

// Throws IoError naming the file or the redacted URL when the store cannot be opened.
std::unique_ptr<Connection> open_sqlite(const std::string& file);
std::unique_ptr<Connection> open_postgres(const std::string& url);

}  // namespace stend::reporting::sql
