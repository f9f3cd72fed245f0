#include "keyfleet/common/sqlite_schema.hpp"

#include <algorithm>
#include <set>
#include <stdexcept>

namespace keyfleet {

int schema_version(SqliteDb& db) {
  auto query = db.prepare("PRAGMA user_version");
  return query.step() ? static_cast<int>(query.int64(0)) : 0;
}

int newest_version(const std::vector<Migration>& migrations) {
  std::set<int> versions;
  for (const auto& m : migrations) versions.insert(m.version);
  const int newest = versions.empty() ? 0 : *versions.rbegin();
  if (versions.count(0) || static_cast<int>(versions.size()) != newest)
    throw std::logic_error("schema migrations must be numbered 1.." + std::to_string(newest) +
                           " without a gap");
  return newest;
}

void refuse_newer_schema(SqliteDb& db, int newest, const std::string& what) {
  const int version = schema_version(db);
  if (version > newest)
    throw SqliteError(db.path() + ": " + what + " of schema version " + std::to_string(version) +
                      ", newer than this build knows (" + std::to_string(newest) +
                      "): open it with the keyfleet that wrote it");
}

int migrate_schema(SqliteDb& db, std::vector<Migration> migrations, const std::string& what) {
  const int newest = newest_version(migrations);
  refuse_newer_schema(db, newest, what);
  if (schema_version(db) == newest) return newest;
  std::stable_sort(migrations.begin(), migrations.end(),
                   [](const Migration& a, const Migration& b) { return a.version < b.version; });
  // IMMEDIATE: two processes opening the same old file migrate it once, one after the other.
  db.exec("BEGIN IMMEDIATE");
  try {
    const int version = schema_version(db);  // another process may have migrated it meanwhile
    for (const Migration& m : migrations) {
      if (m.version <= version) continue;
      if (!m.sql.empty())
        db.exec(m.sql);
      else
        m.apply(db);
    }
    db.exec("PRAGMA user_version = " + std::to_string(newest));
    db.exec("COMMIT");
  } catch (...) {
    db.exec("ROLLBACK");
    throw;
  }
  return newest;
}

}  // namespace keyfleet
