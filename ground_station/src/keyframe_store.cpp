#include "keyfleet/station/keyframe_store.hpp"

#include <map>

#include "keyfleet/common/fnv1a.hpp"
#include "keyfleet/common/record_sql.hpp"
#include "keyfleet/station/station_schema.hpp"

namespace keyfleet::station {
namespace {

const std::vector<SqlColumn>& keyframe_columns() {
  static const std::vector<SqlColumn> kColumns = sql_columns<Keyframe>(RecordStore::kStation);
  return kColumns;
}

const std::vector<SqlColumn>& stats_columns() {
  static const std::vector<SqlColumn> kColumns = sql_columns<AgentStats>(RecordStore::kStation);
  return kColumns;
}

// The newest report of a robot replaces the one stored, an older one (reordered) does not.
std::string upsert_stats_sql() {
  std::string updates;
  for (const SqlColumn& c : stats_columns())
    if (c.name != "robot_id")
      updates += (updates.empty() ? "" : ", ") + c.name + "=excluded." + c.name;
  return "INSERT INTO agent_stats(" + column_list(stats_columns()) + ") VALUES(" +
         column_list(stats_columns(), ":") + ") ON CONFLICT(robot_id) DO UPDATE SET " + updates +
         " WHERE excluded.report_time_ns >= agent_stats.report_time_ns";
}

std::int64_t as_int(std::uint64_t v) { return static_cast<std::int64_t>(v); }
std::uint64_t as_uint(std::int64_t v) { return static_cast<std::uint64_t>(v); }

// The seven pose columns (tx..qw) from `first` on; NULL when the keyframe carried no pose.
std::optional<Pose> pose_at(const SqliteStatement& row, int first) {
  if (row.is_null(first)) return std::nullopt;
  return Pose{row.real(first),     row.real(first + 1), row.real(first + 2), row.real(first + 3),
              row.real(first + 4), row.real(first + 5), row.real(first + 6)};
}

}  // namespace

KeyframeStore::KeyframeStore(const std::string& path, SqliteDb::Mode mode) : db_(path, mode) {
  if (mode == SqliteDb::Mode::kReadOnly) {
    open_station_schema(db_, mode);
    // A file the station wrote before versions were kept may lack the later tables.
    auto has_table = [this](const std::string& name) {
      return db_.prepare("SELECT 1 FROM sqlite_master WHERE type='table' AND name=?")
          .bind(1, name)
          .step();
    };
    has_stats_history_ = has_table("agent_stats_history");
    has_conflicts_ = has_table("conflicts");
    return;
  }
  // A damaged file found now is said once, at start, rather than as failures later on.
  {
    auto check = db_.prepare("PRAGMA quick_check(1)");
    const std::string verdict = check.step() ? check.text(0) : std::string("no answer");
    if (verdict != "ok")
      throw SqliteError(path + ": fails SQLite's integrity check (" + verdict +
                        "): move it aside, or restore it from a copy, and start again");
  }
  open_station_schema(db_, mode);
  db_.exec("PRAGMA synchronous=FULL");  // an acknowledged keyframe survives a power cut
}

StoreOutcome KeyframeStore::store(const Keyframe& k, std::uint64_t serialized_bytes,
                                  std::int64_t received_ns) {
  static const std::string sql =
      "INSERT OR IGNORE INTO keyframes(" + column_list(keyframe_columns()) +
      ", received_ns, image_fnv1a64, serialized_bytes) VALUES(" +
      column_list(keyframe_columns(), ":") + ", :received_ns, :image_fnv1a64, :serialized_bytes)";
  auto insert = db_.prepare(sql);
  bind_record(insert, k, RecordStore::kStation);
  insert.bind(insert.parameter_index(":received_ns"), received_ns)
      .bind(insert.parameter_index(":image_fnv1a64"), as_int(fnv1a64(k.image)))
      .bind(insert.parameter_index(":serialized_bytes"), as_int(serialized_bytes));
  insert.step();
  if (db_.changes() > 0) return StoreOutcome::kStored;
  auto stored =
      db_.prepare("SELECT image_fnv1a64 FROM keyframes WHERE robot_id=? AND sequence_number=?");
  stored.bind(1, k.robot_id).bind(2, as_int(k.sequence_number));
  const std::int64_t hash = as_int(fnv1a64(k.image));
  if (stored.step() && stored.int64(0) == hash) return StoreOutcome::kDuplicate;
  db_.prepare(
         "INSERT OR IGNORE INTO conflicts(robot_id, sequence_number, image_fnv1a64, received_ns, "
         "frame_index, capture_time_ns, width, height, image) VALUES(?,?,?,?,?,?,?,?,?)")
      .bind(1, k.robot_id)
      .bind(2, as_int(k.sequence_number))
      .bind(3, hash)
      .bind(4, received_ns)
      .bind(5, as_int(k.frame_index))
      .bind(6, k.capture_time_ns)
      .bind(7, std::int64_t{k.width})
      .bind(8, std::int64_t{k.height})
      .bind(9, k.image)
      .step();
  return StoreOutcome::kConflict;
}

bool KeyframeStore::record_rejection(const std::string& robot_id, std::uint64_t sequence,
                                     const std::string& reason, std::int64_t received_ns) {
  db_.prepare(
         "INSERT OR IGNORE INTO rejected(robot_id, sequence_number, received_ns, reason) "
         "VALUES(?,?,?,?)")
      .bind(1, robot_id)
      .bind(2, as_int(sequence))
      .bind(3, received_ns)
      .bind(4, reason)
      .step();
  return db_.changes() > 0;
}

void KeyframeStore::record_stats(const AgentStats& s) {
  db_.exec("BEGIN");
  try {
    static const std::string upsert = upsert_stats_sql();
    auto statement = db_.prepare(upsert);
    bind_record(statement, s, RecordStore::kStation);
    statement.step();
    if (db_.changes() > 0) {
      db_.prepare("INSERT INTO agent_stats_history VALUES(?,?,?,?,?)")
          .bind(1, s.robot_id)
          .bind(2, s.report_time_ns)
          .bind(3, as_int(s.frames_seen))
          .bind(4, as_int(s.stream_all_bytes))
          .bind(5, as_int(s.vslam_keyframe_bytes))
          .step();
      for (const auto& stage : s.stages) {
        db_.prepare("INSERT OR REPLACE INTO stage_times VALUES(?,?,?,?)")
            .bind(1, s.robot_id)
            .bind(2, stage.stage)
            .bind(3, stage.cpu_ms_total)
            .bind(4, as_int(stage.calls))
            .step();
      }
    }
    db_.exec("COMMIT");
  } catch (...) {
    db_.exec("ROLLBACK");
    throw;
  }
}

std::vector<RobotTotals> KeyframeStore::totals() const {
  std::map<std::string, RobotTotals> by_robot;
  auto keyframes = db_.prepare(
      "SELECT robot_id, COUNT(*), SUM(LENGTH(image)), SUM(serialized_bytes), MIN(received_ns), "
      "MAX(received_ns) FROM keyframes GROUP BY robot_id");
  while (keyframes.step()) {
    RobotTotals& t = by_robot[keyframes.text(0)];
    t.robot_id = keyframes.text(0);
    t.keyframes = as_uint(keyframes.int64(1));
    t.image_bytes = as_uint(keyframes.int64(2));
    t.serialized_bytes = as_uint(keyframes.int64(3));
    t.first_received_ns = keyframes.int64(4);
    t.last_received_ns = keyframes.int64(5);
  }
  auto rejected = db_.prepare("SELECT robot_id, COUNT(*) FROM rejected GROUP BY robot_id");
  while (rejected.step()) {
    RobotTotals& t = by_robot[rejected.text(0)];
    t.robot_id = rejected.text(0);
    t.rejected = as_uint(rejected.int64(1));
  }
  if (has_conflicts_) {
    auto conflicts = db_.prepare("SELECT robot_id, COUNT(*) FROM conflicts GROUP BY robot_id");
    while (conflicts.step()) {
      RobotTotals& t = by_robot[conflicts.text(0)];
      t.robot_id = conflicts.text(0);
      t.conflicts = as_uint(conflicts.int64(1));
    }
  }
  auto stats = db_.prepare("SELECT * FROM agent_stats");
  while (stats.step()) {
    AgentStats s;
    read_record(stats, s, RecordStore::kStation);
    RobotTotals& t = by_robot[s.robot_id];
    t.robot_id = s.robot_id;
    t.latest_stats = s;
  }
  auto stages = db_.prepare("SELECT robot_id, stage, cpu_ms_total, calls FROM stage_times");
  while (stages.step()) {
    auto it = by_robot.find(stages.text(0));
    if (it != by_robot.end() && it->second.latest_stats)
      it->second.latest_stats->stages.push_back(
          {stages.text(1), stages.real(2), as_uint(stages.int64(3))});
  }
  std::vector<RobotTotals> out;
  for (auto& [id, totals] : by_robot) out.push_back(std::move(totals));
  return out;
}

std::uint64_t KeyframeStore::keyframe_count() const {
  auto query = db_.prepare("SELECT COUNT(*) FROM keyframes");
  query.step();
  return as_uint(query.int64(0));
}

std::vector<StoredKeyframeInfo> KeyframeStore::keyframe_index() const {
  auto query = db_.prepare(
      "SELECT robot_id, sequence_number, capture_time_ns, pose_tx, pose_ty, pose_tz, pose_qx, "
      "pose_qy, pose_qz, pose_qw, frame_index, received_ns, serialized_bytes, width, height "
      "FROM keyframes ORDER BY received_ns");
  std::vector<StoredKeyframeInfo> out;
  while (query.step()) {
    out.push_back(StoredKeyframeInfo{
        query.text(0), as_uint(query.int64(1)), query.int64(2), pose_at(query, 3),
        as_uint(query.int64(10)), query.int64(11), as_uint(query.int64(12)),
        static_cast<std::uint32_t>(query.int64(13)), static_cast<std::uint32_t>(query.int64(14))});
  }
  return out;
}

std::vector<StatsSample> KeyframeStore::stats_history() const {
  std::vector<StatsSample> out;
  if (!has_stats_history_) return out;
  auto query = db_.prepare(
      "SELECT robot_id, report_time_ns, frames_seen, stream_all_bytes, vslam_keyframe_bytes "
      "FROM agent_stats_history ORDER BY robot_id, report_time_ns");
  while (query.step()) {
    out.push_back(StatsSample{query.text(0), query.int64(1), as_uint(query.int64(2)),
                              as_uint(query.int64(3)), as_uint(query.int64(4))});
  }
  return out;
}

std::optional<Keyframe> KeyframeStore::load(const std::string& robot_id,
                                            std::uint64_t sequence) const {
  // Every column the file has: one written before a field was added gives its default.
  auto query = db_.prepare("SELECT * FROM keyframes WHERE robot_id = ? AND sequence_number = ?");
  query.bind(1, robot_id).bind(2, as_int(sequence));
  if (!query.step()) return std::nullopt;
  Keyframe k;
  read_record(query, k, RecordStore::kStation);
  return k;
}

}  // namespace keyfleet::station
