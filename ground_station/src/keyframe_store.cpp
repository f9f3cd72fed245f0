#include "keyfleet/station/keyframe_store.hpp"

#include <map>

#include "keyfleet/common/fnv1a.hpp"
#include "keyfleet/common/text_region_blob.hpp"

namespace keyfleet::station {
namespace {

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS keyframes (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  frame_index INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL,
  received_ns INTEGER NOT NULL,
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
  image_fnv1a64 INTEGER NOT NULL,
  serialized_bytes INTEGER NOT NULL,
  pose_tx REAL, pose_ty REAL, pose_tz REAL,
  pose_qx REAL, pose_qy REAL, pose_qz REAL, pose_qw REAL,
  text_regions BLOB,
  PRIMARY KEY (robot_id, sequence_number)
);
CREATE TABLE IF NOT EXISTS rejected (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  received_ns INTEGER NOT NULL,
  reason TEXT NOT NULL,
  PRIMARY KEY (robot_id, sequence_number)
);
CREATE TABLE IF NOT EXISTS conflicts (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  image_fnv1a64 INTEGER NOT NULL,
  received_ns INTEGER NOT NULL,
  frame_index INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL,
  width INTEGER NOT NULL,
  height INTEGER NOT NULL,
  image BLOB NOT NULL,
  PRIMARY KEY (robot_id, sequence_number, image_fnv1a64)
);
CREATE TABLE IF NOT EXISTS agent_stats (
  robot_id TEXT PRIMARY KEY,
  report_time_ns INTEGER NOT NULL,
  finished INTEGER NOT NULL,
  frames_seen INTEGER NOT NULL,
  vslam_keyframes INTEGER NOT NULL,
  keyframes_sent INTEGER NOT NULL,
  keyframes_resent INTEGER NOT NULL,
  keyframes_dropped INTEGER NOT NULL,
  keyframes_pending INTEGER NOT NULL,
  bytes_sent INTEGER NOT NULL,
  bytes_resent INTEGER NOT NULL,
  stream_all_bytes INTEGER NOT NULL,
  stream_all_estimated INTEGER NOT NULL,
  stream_all_sampled_frames INTEGER NOT NULL,
  vslam_keyframe_bytes INTEGER NOT NULL,
  vslam_keyframe_estimated INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS agent_stats_history (
  robot_id TEXT NOT NULL,
  report_time_ns INTEGER NOT NULL,
  frames_seen INTEGER NOT NULL,
  stream_all_bytes INTEGER NOT NULL,
  vslam_keyframe_bytes INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS stage_times (
  robot_id TEXT NOT NULL,
  stage TEXT NOT NULL,
  cpu_ms_total REAL NOT NULL,
  calls INTEGER NOT NULL,
  PRIMARY KEY (robot_id, stage)
);)sql";

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
    auto columns = db_.prepare("SELECT 1 FROM pragma_table_info('keyframes') WHERE name = ?");
    has_text_regions_ = columns.bind(1, std::string("text_regions")).step();
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
  db_.exec(kSchema);
  // Databases written before keyframes carried text regions: their keyframes have none.
  db_.add_column_if_missing("keyframes", "text_regions", "BLOB");
  db_.exec("PRAGMA synchronous=FULL");  // an acknowledged keyframe survives a power cut
}

StoreOutcome KeyframeStore::store(const Keyframe& k, std::uint64_t serialized_bytes,
                                  std::int64_t received_ns) {
  auto insert = db_.prepare(
      "INSERT OR IGNORE INTO keyframes(robot_id, sequence_number, frame_index, capture_time_ns, "
      "received_ns, vslam_keyframe_index, window_first_frame, window_last_frame, quality_score, "
      "sharpness_score, semantic_score, encoding, width, height, image, image_fnv1a64, "
      "serialized_bytes, pose_tx, pose_ty, pose_tz, pose_qx, pose_qy, pose_qz, pose_qw, "
      "text_regions) VALUES(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
  insert.bind(1, k.robot_id)
      .bind(2, as_int(k.sequence_number))
      .bind(3, as_int(k.frame_index))
      .bind(4, k.capture_time_ns)
      .bind(5, received_ns)
      .bind(6, as_int(k.vslam_keyframe_index))
      .bind(7, as_int(k.window_first_frame))
      .bind(8, as_int(k.window_last_frame))
      .bind(9, k.quality_score)
      .bind(10, k.sharpness_score)
      .bind(11, k.semantic_score)
      .bind(12, k.encoding)
      .bind(13, std::int64_t{k.width})
      .bind(14, std::int64_t{k.height})
      .bind(15, k.image)
      .bind(16, as_int(fnv1a64(k.image)))
      .bind(17, as_int(serialized_bytes));
  if (k.camera_pose) {
    const Pose& p = *k.camera_pose;
    const double values[7] = {p.tx, p.ty, p.tz, p.qx, p.qy, p.qz, p.qw};
    for (int i = 0; i < 7; ++i) insert.bind(18 + i, values[i]);
  } else {
    for (int i = 0; i < 7; ++i) insert.bind_null(18 + i);
  }
  if (k.text_regions.empty())
    insert.bind_null(25);
  else
    insert.bind(25, text_regions_blob(k.text_regions));
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
    db_.prepare(
           "INSERT INTO agent_stats VALUES(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?) "
           "ON CONFLICT(robot_id) DO UPDATE SET report_time_ns=excluded.report_time_ns, "
           "finished=excluded.finished, frames_seen=excluded.frames_seen, "
           "vslam_keyframes=excluded.vslam_keyframes, keyframes_sent=excluded.keyframes_sent, "
           "keyframes_resent=excluded.keyframes_resent, "
           "keyframes_dropped=excluded.keyframes_dropped, "
           "keyframes_pending=excluded.keyframes_pending, bytes_sent=excluded.bytes_sent, "
           "bytes_resent=excluded.bytes_resent, stream_all_bytes=excluded.stream_all_bytes, "
           "stream_all_estimated=excluded.stream_all_estimated, "
           "stream_all_sampled_frames=excluded.stream_all_sampled_frames, "
           "vslam_keyframe_bytes=excluded.vslam_keyframe_bytes, "
           "vslam_keyframe_estimated=excluded.vslam_keyframe_estimated "
           "WHERE excluded.report_time_ns >= agent_stats.report_time_ns")
        .bind(1, s.robot_id)
        .bind(2, s.report_time_ns)
        .bind(3, std::int64_t{s.finished})
        .bind(4, as_int(s.frames_seen))
        .bind(5, as_int(s.vslam_keyframes))
        .bind(6, as_int(s.keyframes_sent))
        .bind(7, as_int(s.keyframes_resent))
        .bind(8, as_int(s.keyframes_dropped))
        .bind(9, as_int(s.keyframes_pending))
        .bind(10, as_int(s.bytes_sent))
        .bind(11, as_int(s.bytes_resent))
        .bind(12, as_int(s.stream_all_bytes))
        .bind(13, std::int64_t{s.stream_all_estimated})
        .bind(14, as_int(s.stream_all_sampled_frames))
        .bind(15, as_int(s.vslam_keyframe_bytes))
        .bind(16, std::int64_t{s.vslam_keyframe_estimated})
        .step();
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
    s.robot_id = stats.text(0);
    s.report_time_ns = stats.int64(1);
    s.finished = stats.int64(2) != 0;
    s.frames_seen = as_uint(stats.int64(3));
    s.vslam_keyframes = as_uint(stats.int64(4));
    s.keyframes_sent = as_uint(stats.int64(5));
    s.keyframes_resent = as_uint(stats.int64(6));
    s.keyframes_dropped = as_uint(stats.int64(7));
    s.keyframes_pending = as_uint(stats.int64(8));
    s.bytes_sent = as_uint(stats.int64(9));
    s.bytes_resent = as_uint(stats.int64(10));
    s.stream_all_bytes = as_uint(stats.int64(11));
    s.stream_all_estimated = stats.int64(12) != 0;
    s.stream_all_sampled_frames = as_uint(stats.int64(13));
    s.vslam_keyframe_bytes = as_uint(stats.int64(14));
    s.vslam_keyframe_estimated = stats.int64(15) != 0;
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
  auto query = db_.prepare(
      "SELECT frame_index, capture_time_ns, vslam_keyframe_index, window_first_frame, "
      "window_last_frame, quality_score, sharpness_score, semantic_score, encoding, width, "
      "height, image, pose_tx, pose_ty, pose_tz, pose_qx, pose_qy, pose_qz, pose_qw, " +
      std::string(has_text_regions_ ? "text_regions" : "NULL") +
      " FROM keyframes WHERE robot_id = ? AND sequence_number = ?");
  query.bind(1, robot_id).bind(2, as_int(sequence));
  if (!query.step()) return std::nullopt;
  Keyframe k;
  k.robot_id = robot_id;
  k.sequence_number = sequence;
  k.frame_index = as_uint(query.int64(0));
  k.capture_time_ns = query.int64(1);
  k.vslam_keyframe_index = as_uint(query.int64(2));
  k.window_first_frame = as_uint(query.int64(3));
  k.window_last_frame = as_uint(query.int64(4));
  k.quality_score = query.real(5);
  k.sharpness_score = query.real(6);
  k.semantic_score = query.real(7);
  k.encoding = query.text(8);
  k.width = static_cast<std::uint32_t>(query.int64(9));
  k.height = static_cast<std::uint32_t>(query.int64(10));
  k.image = query.blob(11);
  k.camera_pose = pose_at(query, 12);
  if (!query.is_null(19)) k.text_regions = text_regions_from_blob(query.blob(19));
  return k;
}

}  // namespace keyfleet::station
