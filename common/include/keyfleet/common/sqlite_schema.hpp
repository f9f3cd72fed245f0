#pragma once
// Numbered schema migrations for a SQLite file, its version kept in PRAGMA user_version.
// Migration n takes a file from version n-1 to n; a file without a version (0) is new or was
// written before versions were kept, so every migration is written to leave alone what such a
// file already holds (CREATE ... IF NOT EXISTS, columns added only where missing).
#include <functional>
#include <string>
#include <vector>

#include "keyfleet/common/sqlite.hpp"

namespace keyfleet {

struct Migration {
  int version = 0;
  std::string sql;                       // run as it is, or, when empty,
  std::function<void(SqliteDb&)> apply;  // this
};

int schema_version(SqliteDb& db);

// The newest version of `migrations`; throws std::logic_error unless they cover 1..newest.
int newest_version(const std::vector<Migration>& migrations);

// Runs the migrations above the file's version, in version order and in one transaction, then
// sets the version to the newest; returns it. Throws SqliteError, naming the file and `what`
// (e.g. "station database"), when the file's version is newer than this build knows.
int migrate_schema(SqliteDb& db, std::vector<Migration> migrations, const std::string& what);

// For files opened read-only: the same refusal of a newer file, nothing written.
void refuse_newer_schema(SqliteDb& db, int newest, const std::string& what);

}  // namespace keyfleet
