#pragma once
// A thin RAII layer over SQLite's C API: errors become exceptions carrying the file name.
#include <sqlite3.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace keyfleet {

class SqliteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SqliteStatement {
 public:
  SqliteStatement(sqlite3* db, const std::string& sql, const std::string& origin);
  ~SqliteStatement();
  SqliteStatement(const SqliteStatement&) = delete;
  SqliteStatement& operator=(const SqliteStatement&) = delete;
  SqliteStatement(SqliteStatement&& other) noexcept;

  SqliteStatement& bind(int index, std::int64_t value);
  SqliteStatement& bind(int index, double value);
  SqliteStatement& bind(int index, const std::string& value);
  SqliteStatement& bind(int index, const std::vector<std::uint8_t>& blob);
  SqliteStatement& bind_null(int index);
  // The index of a named parameter (":name"), 0 when the statement has none of that name.
  int parameter_index(const std::string& name) const;

  bool step();  // true while a row is available
  void reset();

  std::int64_t int64(int column) const;
  double real(int column) const;
  std::string text(int column) const;
  std::vector<std::uint8_t> blob(int column) const;
  bool is_null(int column) const;
  // The index of a result column by name, -1 when the result has no such column.
  int column_index(const std::string& name) const;

 private:
  void check(int rc, const char* what) const;
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string origin_;
};

class SqliteDb {
 public:
  enum class Mode { kReadWrite, kReadOnly };
  // Opens (and in kReadWrite mode creates) the database; WAL journal in kReadWrite mode.
  SqliteDb(const std::string& path, Mode mode = Mode::kReadWrite);
  ~SqliteDb();
  SqliteDb(const SqliteDb&) = delete;
  SqliteDb& operator=(const SqliteDb&) = delete;

  void exec(const std::string& sql);
  SqliteStatement prepare(const std::string& sql);
  std::int64_t changes() const;
  const std::string& path() const { return path_; }
  // Schema migration for a database written by an older build: adds `column` (with its SQL
  // declaration, e.g. "BLOB") to `table` unless the table has it already.
  void add_column_if_missing(const std::string& table, const std::string& column,
                             const std::string& declaration);

 private:
  sqlite3* db_ = nullptr;
  std::string path_;
};

}  // namespace keyfleet
