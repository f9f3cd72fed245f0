#include "keyfleet/common/sqlite.hpp"

namespace keyfleet {

SqliteStatement::SqliteStatement(sqlite3* db, const std::string& sql, const std::string& origin)
    : db_(db), origin_(origin) {
  check(sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt_, nullptr), "prepare");
}

SqliteStatement::~SqliteStatement() { sqlite3_finalize(stmt_); }

SqliteStatement::SqliteStatement(SqliteStatement&& other) noexcept
    : db_(other.db_), stmt_(other.stmt_), origin_(std::move(other.origin_)) {
  other.stmt_ = nullptr;
}

void SqliteStatement::check(int rc, const char* what) const {
  if (rc == SQLITE_OK || rc == SQLITE_ROW || rc == SQLITE_DONE) return;
  throw SqliteError(origin_ + ": SQLite " + what + " failed: " + sqlite3_errmsg(db_));
}

SqliteStatement& SqliteStatement::bind(int index, std::int64_t value) {
  check(sqlite3_bind_int64(stmt_, index, value), "bind");
  return *this;
}
SqliteStatement& SqliteStatement::bind(int index, double value) {
  check(sqlite3_bind_double(stmt_, index, value), "bind");
  return *this;
}
SqliteStatement& SqliteStatement::bind(int index, const std::string& value) {
  check(sqlite3_bind_text(stmt_, index, value.c_str(), static_cast<int>(value.size()),
                          SQLITE_TRANSIENT),
        "bind");
  return *this;
}
SqliteStatement& SqliteStatement::bind(int index, const std::vector<std::uint8_t>& blob) {
  // An empty vector's data() may be null, which SQLite would bind as NULL, not as an empty blob.
  if (blob.empty()) {
    check(sqlite3_bind_zeroblob(stmt_, index, 0), "bind");
    return *this;
  }
  check(sqlite3_bind_blob64(stmt_, index, blob.data(), blob.size(), SQLITE_TRANSIENT), "bind");
  return *this;
}
SqliteStatement& SqliteStatement::bind_null(int index) {
  check(sqlite3_bind_null(stmt_, index), "bind");
  return *this;
}

int SqliteStatement::parameter_index(const std::string& name) const {
  return sqlite3_bind_parameter_index(stmt_, name.c_str());
}

bool SqliteStatement::step() {
  const int rc = sqlite3_step(stmt_);
  check(rc, "step");
  return rc == SQLITE_ROW;
}

void SqliteStatement::reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

std::int64_t SqliteStatement::int64(int column) const {
  return sqlite3_column_int64(stmt_, column);
}
double SqliteStatement::real(int column) const { return sqlite3_column_double(stmt_, column); }
std::string SqliteStatement::text(int column) const {
  const auto* p = sqlite3_column_text(stmt_, column);
  return p ? std::string(reinterpret_cast<const char*>(p)) : std::string();
}
std::vector<std::uint8_t> SqliteStatement::blob(int column) const {
  const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(stmt_, column));
  const int n = sqlite3_column_bytes(stmt_, column);
  return p ? std::vector<std::uint8_t>(p, p + n) : std::vector<std::uint8_t>();
}
bool SqliteStatement::is_null(int column) const {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}

int SqliteStatement::column_index(const std::string& name) const {
  const int count = sqlite3_column_count(stmt_);
  for (int i = 0; i < count; ++i)
    if (name == sqlite3_column_name(stmt_, i)) return i;
  return -1;
}

SqliteDb::SqliteDb(const std::string& path, Mode mode) : path_(path) {
  const int flags =
      mode == Mode::kReadOnly ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
  if (sqlite3_open_v2(path.c_str(), &db_, flags | SQLITE_OPEN_FULLMUTEX, nullptr) != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw SqliteError(path + ": cannot open SQLite database: " + message);
  }
  sqlite3_busy_timeout(db_, 5000);
  if (mode == Mode::kReadWrite) {
    // The first statement reads the schema: a damaged one is said as such, naming the file.
    const int rc = sqlite3_exec(db_, "PRAGMA journal_mode=WAL", nullptr, nullptr, nullptr);
    if (rc == SQLITE_CORRUPT || rc == SQLITE_NOTADB) {
      const std::string message = sqlite3_errmsg(db_);
      sqlite3_close(db_);
      throw SqliteError(path + ": fails SQLite's integrity check (" + message +
                        "): move it aside, or restore it from a copy, and start again");
    }
    if (rc != SQLITE_OK) exec("PRAGMA journal_mode=WAL");  // says why
  }
}

SqliteDb::~SqliteDb() { sqlite3_close(db_); }

void SqliteDb::exec(const std::string& sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : "unknown error";
    sqlite3_free(error);
    throw SqliteError(path_ + ": SQLite failed on '" + sql.substr(0, 60) + "': " + message);
  }
}

SqliteStatement SqliteDb::prepare(const std::string& sql) {
  return SqliteStatement(db_, sql, path_);
}

std::int64_t SqliteDb::changes() const { return sqlite3_changes64(db_); }

void SqliteDb::add_column_if_missing(const std::string& table, const std::string& column,
                                     const std::string& declaration) {
  auto columns = prepare("SELECT name FROM pragma_table_info(?)");
  columns.bind(1, table);
  while (columns.step())
    if (columns.text(0) == column) return;
  exec("ALTER TABLE " + table + " ADD COLUMN " + column + " " + declaration);
}

}  // namespace keyfleet
