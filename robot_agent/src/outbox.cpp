#include "keyfleet/agent/outbox.hpp"

#include <limits>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/record_sql.hpp"

namespace keyfleet::agent {
namespace {

// The outbox's layouts, oldest first: version 1 as the first agents wrote it; the columns of
// keyframe fields added later come from the field list (types.hpp: text_regions in version 2);
// version 3 adds the sending order's value and held columns.
std::vector<Migration> migrations() {
  std::vector<Migration> all = {{1,
                                 R"sql(
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS pending (
  sequence_number INTEGER PRIMARY KEY,
  created_ns INTEGER NOT NULL,
  last_sent_ns INTEGER,
  sends INTEGER NOT NULL DEFAULT 0,
  frame_index INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL,
  vslam_keyframe_index INTEGER NOT NULL,
  window_first_frame INTEGER NOT NULL,
  window_last_frame INTEGER NOT NULL,
  quality_score REAL NOT NULL,
  sharpness_score REAL NOT NULL,
  semantic_score REAL NOT NULL,
  encoding TEXT NOT NULL,
  width INTEGER NOT NULL,
  height INTEGER NOT NULL,
  image BLOB NOT NULL,
  pose BLOB
);)sql",
                                 {}}};
  for (auto& m : column_migrations<Keyframe>("pending", RecordStore::kOutbox))
    all.push_back(std::move(m));
  // Version 3: the order of sending (value, then age; held keyframes last).
  all.push_back({3, "", [](SqliteDb& db) {
                   db.add_column_if_missing("pending", "value", "REAL NOT NULL DEFAULT 0");
                   db.add_column_if_missing("pending", "held", "INTEGER NOT NULL DEFAULT 0");
                 }});
  return all;
}

const std::vector<SqlColumn>& columns() {
  static const std::vector<SqlColumn> kColumns = sql_columns<Keyframe>(RecordStore::kOutbox);
  return kColumns;
}

std::int64_t as_int(std::uint64_t v) { return static_cast<std::int64_t>(v); }

}  // namespace

Outbox::Outbox(const std::string& path, const std::string& robot_id, const OutboxConfig& bounds)
    : db_(path), bounds_(bounds), robot_id_(robot_id) {
  try {
    migrate_schema(db_, migrations(), "outbox");
  } catch (const SqliteError& e) {
    throw StartupError(e.what());
  }
  // FULL, not NORMAL: with NORMAL a power cut can roll back the last transactions, and with them
  // sequence numbers the station already holds; new keyframes would then reuse them.
  db_.exec("PRAGMA synchronous=FULL");
  auto owner = db_.prepare("SELECT value FROM meta WHERE key='robot_id'");
  if (owner.step()) {
    if (owner.text(0) != robot_id)
      throw StartupError("outbox " + path + " belongs to robot '" + owner.text(0) + "', not '" +
                         robot_id + "': use another outbox.path or run directory");
  } else {
    db_.prepare("INSERT INTO meta(key, value) VALUES('robot_id', ?)").bind(1, robot_id).step();
  }
  auto next = db_.prepare("SELECT value FROM meta WHERE key='next_sequence'");
  if (next.step()) next_sequence_ = std::stoull(next.text(0));
}

void Outbox::add(const Keyframe& k, std::int64_t now_ns, double value, bool held) {
  if (k.sequence_number != next_sequence_)
    throw std::logic_error("outbox: sequence " + std::to_string(k.sequence_number) +
                           " out of order, expected " + std::to_string(next_sequence_));
  db_.exec("BEGIN");
  try {
    auto insert =
        db_.prepare("INSERT INTO pending(created_ns, value, held, " + column_list(columns()) +
                    ") VALUES(:created_ns, :value, :held, " + column_list(columns(), ":") + ")");
    bind_record(insert, k, RecordStore::kOutbox);
    insert.bind(insert.parameter_index(":created_ns"), now_ns);
    insert.bind(insert.parameter_index(":value"), value);
    insert.bind(insert.parameter_index(":held"), static_cast<std::int64_t>(held ? 1 : 0));
    insert.step();
    db_.prepare("INSERT OR REPLACE INTO meta(key, value) VALUES('next_sequence', ?)")
        .bind(1, std::to_string(k.sequence_number + 1))
        .step();
    db_.exec("COMMIT");
  } catch (...) {
    db_.exec("ROLLBACK");
    throw;
  }
  next_sequence_ = k.sequence_number + 1;
}

void Outbox::mark_sent(std::uint64_t sequence, std::int64_t now_ns) {
  db_.prepare("UPDATE pending SET last_sent_ns=?, sends=sends+1 WHERE sequence_number=?")
      .bind(1, now_ns)
      .bind(2, as_int(sequence))
      .step();
}

bool Outbox::acknowledge(std::uint64_t sequence) {
  db_.prepare("DELETE FROM pending WHERE sequence_number=?").bind(1, as_int(sequence)).step();
  return db_.changes() > 0;
}

std::optional<std::uint64_t> Outbox::renumber(std::uint64_t sequence) {
  const std::uint64_t renumbered = next_sequence_;
  db_.exec("BEGIN");
  try {
    db_.prepare(
           "UPDATE pending SET sequence_number=?, last_sent_ns=NULL, sends=0 "
           "WHERE sequence_number=?")
        .bind(1, as_int(renumbered))
        .bind(2, as_int(sequence))
        .step();
    if (db_.changes() == 0) {
      db_.exec("ROLLBACK");
      return std::nullopt;
    }
    db_.prepare("INSERT OR REPLACE INTO meta(key, value) VALUES('next_sequence', ?)")
        .bind(1, std::to_string(renumbered + 1))
        .step();
    db_.exec("COMMIT");
  } catch (...) {
    db_.exec("ROLLBACK");
    throw;
  }
  next_sequence_ = renumbered + 1;
  return renumbered;
}

std::vector<Keyframe> Outbox::due_for_resend(std::int64_t now_ns, std::size_t max, bool with_held) {
  const auto threshold = now_ns - static_cast<std::int64_t>(bounds_.resend_after_s * 1e9);
  if (!due_query_)
    due_query_.emplace(db_.prepare(
        "SELECT " + column_list(columns()) +
        " FROM pending WHERE (last_sent_ns IS NULL OR last_sent_ns <= ? OR last_sent_ns > ?) AND "
        "(held = 0 OR ?) ORDER BY held, value DESC, sequence_number LIMIT ?"));
  SqliteStatement& query = *due_query_;
  query.reset();  // also after a call that threw half-way
  query.bind(1, threshold)
      .bind(2, now_ns)
      .bind(3, static_cast<std::int64_t>(with_held ? 1 : 0))
      .bind(4, static_cast<std::int64_t>(max));
  std::vector<Keyframe> due;
  while (query.step()) {
    Keyframe k;
    k.robot_id = robot_id_;
    read_record(query, k, RecordStore::kOutbox);
    due.push_back(std::move(k));
  }
  query.reset();
  return due;
}

std::vector<std::uint64_t> Outbox::evict(std::int64_t now_ns, bool by_age) {
  if (!clock_checked_) {
    // Created before a reboot restarted the clock: aged from now, as after an outage. Once is
    // enough: every time stored after this comes from the same clock.
    db_.prepare("UPDATE pending SET created_ns = ?1 WHERE created_ns > ?1").bind(1, now_ns).step();
    clock_checked_ = true;
  }
  const auto oldest_allowed = by_age ? now_ns - static_cast<std::int64_t>(bounds_.max_age_s * 1e9)
                                     : std::numeric_limits<std::int64_t>::min();
  if (!evict_query_)
    evict_query_.emplace(db_.prepare(
        "SELECT sequence_number FROM pending WHERE created_ns < ? OR sequence_number NOT IN "
        "(SELECT sequence_number FROM pending ORDER BY held, sequence_number DESC LIMIT ?)"));
  SqliteStatement& query = *evict_query_;
  query.reset();
  query.bind(1, oldest_allowed).bind(2, static_cast<std::int64_t>(bounds_.max_pending));
  std::vector<std::uint64_t> evicted;
  while (query.step()) evicted.push_back(static_cast<std::uint64_t>(query.int64(0)));
  query.reset();  // its read ends before the deletions below
  for (const auto sequence : evicted) acknowledge(sequence);
  return evicted;
}

int Outbox::schema_version() { return newest_version(migrations()); }

std::uint64_t Outbox::pending_bytes() const {
  auto query = db_.prepare("SELECT COALESCE(SUM(LENGTH(image)), 0) FROM pending WHERE held = 0");
  query.step();
  return static_cast<std::uint64_t>(query.int64(0));
}

std::uint64_t Outbox::held() const {
  auto query = db_.prepare("SELECT COUNT(*) FROM pending WHERE held = 1");
  query.step();
  return static_cast<std::uint64_t>(query.int64(0));
}

std::uint64_t Outbox::pending() const {
  auto query = db_.prepare("SELECT COUNT(*) FROM pending");
  query.step();
  return static_cast<std::uint64_t>(query.int64(0));
}

}  // namespace keyfleet::agent
