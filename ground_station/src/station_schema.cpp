#include "keyfleet/station/station_schema.hpp"

#include <vector>

#include "keyfleet/common/record_sql.hpp"
#include "keyfleet/common/sqlite_schema.hpp"

namespace keyfleet::station {
namespace {

// Version 1: the first station's tables.
constexpr const char* kV1 = R"sql(
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
  PRIMARY KEY (robot_id, sequence_number)
);
CREATE TABLE IF NOT EXISTS rejected (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  received_ns INTEGER NOT NULL,
  reason TEXT NOT NULL,
  PRIMARY KEY (robot_id, sequence_number)
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
CREATE TABLE IF NOT EXISTS stage_times (
  robot_id TEXT NOT NULL,
  stage TEXT NOT NULL,
  cpu_ms_total REAL NOT NULL,
  calls INTEGER NOT NULL,
  PRIMARY KEY (robot_id, stage)
);)sql";

// Version 2: the analysis' results (keyframes (robot_id, sequence_number) is the key throughout).
constexpr const char* kV2 = R"sql(
CREATE TABLE IF NOT EXISTS keyframe_analysis (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL,
  status TEXT NOT NULL,
  detail TEXT NOT NULL,
  analysed_order INTEGER NOT NULL,
  words INTEGER NOT NULL,
  candidates_checked INTEGER NOT NULL,
  text_ms REAL NOT NULL,
  places_ms REAL NOT NULL,
  PRIMARY KEY (robot_id, sequence_number)
);
CREATE TABLE IF NOT EXISTS keyframe_features (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  count INTEGER NOT NULL,
  keypoints BLOB NOT NULL,
  descriptors BLOB NOT NULL,
  PRIMARY KEY (robot_id, sequence_number)
);
CREATE TABLE IF NOT EXISTS words (
  word_id INTEGER PRIMARY KEY,
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  text TEXT NOT NULL,
  confidence REAL NOT NULL,
  x INTEGER NOT NULL, y INTEGER NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL
);
CREATE INDEX IF NOT EXISTS words_by_keyframe ON words(robot_id, sequence_number);
CREATE VIRTUAL TABLE IF NOT EXISTS words_fts USING fts5(text, content='words', content_rowid='word_id');
CREATE TABLE IF NOT EXISTS place_matches (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  match_robot_id TEXT NOT NULL,
  match_sequence_number INTEGER NOT NULL,
  matches INTEGER NOT NULL,
  inliers INTEGER NOT NULL,
  bow_score REAL NOT NULL,
  PRIMARY KEY (robot_id, sequence_number, match_robot_id, match_sequence_number)
);)sql";

// Version 3: analyses started, so that one that ends the process is not started forever.
constexpr const char* kV3 =
    "CREATE TABLE IF NOT EXISTS analysis_attempts (robot_id TEXT NOT NULL, sequence_number "
    "INTEGER NOT NULL, attempts INTEGER NOT NULL, PRIMARY KEY (robot_id, sequence_number))";

// Version 4 is keyframes.text_regions, from the field list (types.hpp).

// Version 5: every stats sample, for the bytes-over-time plots.
constexpr const char* kV5 = R"sql(
CREATE TABLE IF NOT EXISTS agent_stats_history (
  robot_id TEXT NOT NULL,
  report_time_ns INTEGER NOT NULL,
  frames_seen INTEGER NOT NULL,
  stream_all_bytes INTEGER NOT NULL,
  vslam_keyframe_bytes INTEGER NOT NULL
);)sql";

// Version 6: keyframes whose (robot, sequence) was taken by another image.
constexpr const char* kV6 = R"sql(
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
);)sql";

// Version 7: place descriptors (CNN retrieval).
constexpr const char* kV7 = R"sql(
CREATE TABLE IF NOT EXISTS keyframe_descriptors (
  robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL,
  dimensions INTEGER NOT NULL,
  descriptor BLOB NOT NULL,
  PRIMARY KEY (robot_id, sequence_number)
);)sql";

// Version 9: the reading's CPU time beside its wall time.
void add_text_cpu_ms(SqliteDb& db) {
  db.add_column_if_missing("keyframe_analysis", "text_cpu_ms", "REAL NOT NULL DEFAULT 0");
}

// Files written before versions were kept hold some mix of these (branches merged
// in another order than they were written), so each step leaves alone what a file has.
const std::vector<Migration>& migrations() {
  static const std::vector<Migration> kAll = [] {
    std::vector<Migration> all = {{1, kV1, {}},
                                  {2, kV2, {}},
                                  {3, kV3, {}},
                                  {5, kV5, {}},
                                  {6, kV6, {}},
                                  {7, kV7, {}},
                                  {9, "", add_text_cpu_ms}};
    for (auto& m : column_migrations<Keyframe>("keyframes", RecordStore::kStation))
      all.push_back(std::move(m));
    for (auto& m : column_migrations<AgentStats>("agent_stats", RecordStore::kStation))
      all.push_back(std::move(m));
    return all;
  }();
  return kAll;
}

}  // namespace

int station_schema_version() { return newest_version(migrations()); }

void open_station_schema(SqliteDb& db, SqliteDb::Mode mode) {
  if (mode == SqliteDb::Mode::kReadOnly)
    refuse_newer_schema(db, station_schema_version(), "station database");
  else
    migrate_schema(db, migrations(), "station database");
}

}  // namespace keyfleet::station
