// Both SQLite files from every layout a run folder may hold: each built here with that layout's
// own DDL, as the builds of the time wrote it (no version: versions were not kept then), and again
// marked with its version number. Opening migrates it to the newest layout, keeps its rows, and a
// file newer than the build is refused.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "keyfleet/agent/outbox.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/station_schema.hpp"
#include "test_support.hpp"

namespace keyfleet {
namespace {

// station.sqlite, version by version: what each version's build added.
const std::vector<std::string> kStationDdl = {
    // 1: the first station
    R"sql(
CREATE TABLE keyframes (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  frame_index INTEGER NOT NULL, capture_time_ns INTEGER NOT NULL, received_ns INTEGER NOT NULL,
  vslam_keyframe_index INTEGER NOT NULL, window_first_frame INTEGER NOT NULL,
  window_last_frame INTEGER NOT NULL, quality_score REAL NOT NULL, sharpness_score REAL NOT NULL,
  semantic_score REAL NOT NULL, encoding TEXT NOT NULL, width INTEGER NOT NULL,
  height INTEGER NOT NULL, image BLOB NOT NULL, image_fnv1a64 INTEGER NOT NULL,
  serialized_bytes INTEGER NOT NULL, pose_tx REAL, pose_ty REAL, pose_tz REAL, pose_qx REAL,
  pose_qy REAL, pose_qz REAL, pose_qw REAL, PRIMARY KEY (robot_id, sequence_number));
CREATE TABLE rejected (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  received_ns INTEGER NOT NULL, reason TEXT NOT NULL, PRIMARY KEY (robot_id, sequence_number));
CREATE TABLE agent_stats (robot_id TEXT PRIMARY KEY, report_time_ns INTEGER NOT NULL,
  finished INTEGER NOT NULL, frames_seen INTEGER NOT NULL, vslam_keyframes INTEGER NOT NULL,
  keyframes_sent INTEGER NOT NULL, keyframes_resent INTEGER NOT NULL,
  keyframes_dropped INTEGER NOT NULL, keyframes_pending INTEGER NOT NULL,
  bytes_sent INTEGER NOT NULL, bytes_resent INTEGER NOT NULL, stream_all_bytes INTEGER NOT NULL,
  stream_all_estimated INTEGER NOT NULL, stream_all_sampled_frames INTEGER NOT NULL,
  vslam_keyframe_bytes INTEGER NOT NULL, vslam_keyframe_estimated INTEGER NOT NULL);
CREATE TABLE stage_times (robot_id TEXT NOT NULL, stage TEXT NOT NULL,
  cpu_ms_total REAL NOT NULL, calls INTEGER NOT NULL, PRIMARY KEY (robot_id, stage));
INSERT INTO keyframes VALUES('old', 3, 30, 300, 3000, 29, 28, 31, 0.5, 0.25, 0.125, 'jpeg', 4, 2,
  x'FFD8FFD9', 77, 120, 1, 2, 3, 0, 0, 0, 1);
INSERT INTO rejected VALUES('old', 9, 9000, 'too big');
INSERT INTO agent_stats VALUES('old', 5000, 1, 100, 10, 7, 2, 1, 0, 800, 200, 90000, 0, 100,
  9000, 1);
INSERT INTO stage_times VALUES('old', 'select', 12.5, 100);)sql",
    // 2: the analysis' results
    R"sql(
CREATE TABLE keyframe_analysis (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL, status TEXT NOT NULL, detail TEXT NOT NULL,
  analysed_order INTEGER NOT NULL, words INTEGER NOT NULL, candidates_checked INTEGER NOT NULL,
  text_ms REAL NOT NULL, places_ms REAL NOT NULL, PRIMARY KEY (robot_id, sequence_number));
CREATE TABLE keyframe_features (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  count INTEGER NOT NULL, keypoints BLOB NOT NULL, descriptors BLOB NOT NULL,
  PRIMARY KEY (robot_id, sequence_number));
CREATE TABLE words (word_id INTEGER PRIMARY KEY, robot_id TEXT NOT NULL,
  sequence_number INTEGER NOT NULL, text TEXT NOT NULL, confidence REAL NOT NULL,
  x INTEGER NOT NULL, y INTEGER NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL);
CREATE INDEX words_by_keyframe ON words(robot_id, sequence_number);
CREATE VIRTUAL TABLE words_fts USING fts5(text, content='words', content_rowid='word_id');
CREATE TABLE place_matches (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  match_robot_id TEXT NOT NULL, match_sequence_number INTEGER NOT NULL, matches INTEGER NOT NULL,
  inliers INTEGER NOT NULL, bow_score REAL NOT NULL,
  PRIMARY KEY (robot_id, sequence_number, match_robot_id, match_sequence_number));
INSERT INTO keyframe_analysis VALUES('old', 3, 300, 'done', '', 1, 1, 0, 5.0, 1.0);
INSERT INTO words VALUES(1, 'old', 3, 'EXIT', 0.9, 1, 1, 2, 1);
INSERT INTO words_fts(rowid, text) VALUES(1, 'EXIT');)sql",
    // 3: analyses started
    R"sql(
CREATE TABLE analysis_attempts (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  attempts INTEGER NOT NULL, PRIMARY KEY (robot_id, sequence_number));)sql",
    // 4: the robot's text regions
    "ALTER TABLE keyframes ADD COLUMN text_regions BLOB;",
    // 5: every stats sample
    R"sql(
CREATE TABLE agent_stats_history (robot_id TEXT NOT NULL, report_time_ns INTEGER NOT NULL,
  frames_seen INTEGER NOT NULL, stream_all_bytes INTEGER NOT NULL,
  vslam_keyframe_bytes INTEGER NOT NULL);
INSERT INTO agent_stats_history VALUES('old', 5000, 100, 90000, 9000);)sql",
    // 6: sequence conflicts
    R"sql(
CREATE TABLE conflicts (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  image_fnv1a64 INTEGER NOT NULL, received_ns INTEGER NOT NULL, frame_index INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,
  image BLOB NOT NULL, PRIMARY KEY (robot_id, sequence_number, image_fnv1a64));)sql",
    // 7: place descriptors
    R"sql(
CREATE TABLE keyframe_descriptors (robot_id TEXT NOT NULL, sequence_number INTEGER NOT NULL,
  dimensions INTEGER NOT NULL, descriptor BLOB NOT NULL,
  PRIMARY KEY (robot_id, sequence_number));)sql",
    // 8: the link adaptation's statistics
    R"sql(
ALTER TABLE agent_stats ADD COLUMN keyframes_reduced INTEGER NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN keyframes_thinned INTEGER NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN level_changes INTEGER NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN send_quality INTEGER NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN send_scale REAL NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN send_density INTEGER NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN link_bytes_per_s REAL NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN link_rtt_ms REAL NOT NULL DEFAULT 0;
ALTER TABLE agent_stats ADD COLUMN backlog_s REAL NOT NULL DEFAULT 0;)sql"};

int user_version(const std::string& path) {
  SqliteDb db(path, SqliteDb::Mode::kReadOnly);
  auto q = db.prepare("PRAGMA user_version");
  q.step();
  return static_cast<int>(q.int64(0));
}

void build(const std::string& path, const std::vector<std::string>& ddl, int version_mark) {
  SqliteDb db(path);
  for (const auto& step : ddl) db.exec(step);
  db.exec("PRAGMA user_version = " + std::to_string(version_mark));
}

std::vector<std::string> layout(int version) {
  return {kStationDdl.begin(), kStationDdl.begin() + version};
}

void expect_old_rows_kept_and_new_ones_stored(const std::string& path, bool had_words = true) {
  station::KeyframeStore store(path);
  EXPECT_EQ(user_version(path), station::station_schema_version());
  const auto old = store.load("old", 3);
  ASSERT_TRUE(old);
  EXPECT_EQ(old->frame_index, 30u);
  EXPECT_EQ(old->window_last_frame, 31u);
  EXPECT_DOUBLE_EQ(old->semantic_score, 0.125);
  EXPECT_EQ(old->image, (std::vector<std::uint8_t>{0xFF, 0xD8, 0xFF, 0xD9}));
  ASSERT_TRUE(old->camera_pose);
  EXPECT_DOUBLE_EQ(old->camera_pose->ty, 2.0);
  EXPECT_TRUE(old->text_regions.empty());
  const auto totals = store.totals();
  ASSERT_EQ(totals.size(), 1u);
  EXPECT_EQ(totals[0].keyframes, 1u);
  EXPECT_EQ(totals[0].rejected, 1u);
  ASSERT_TRUE(totals[0].latest_stats);
  EXPECT_EQ(totals[0].latest_stats->keyframes_resent, 2u);
  EXPECT_EQ(totals[0].latest_stats->stream_all_sampled_frames, 100u);
  ASSERT_EQ(totals[0].latest_stats->stages.size(), 1u);

  Keyframe k = test::make_valid_keyframe("new", 0, 32, 16);
  k.text_regions = {{1, 2, 3, 4}};
  EXPECT_EQ(store.store(k, 10, 1), station::StoreOutcome::kStored);
  EXPECT_EQ(store.load("new", 0)->text_regions, k.text_regions);
  station::AnalysisStore analysis(path);
  EXPECT_EQ(analysis.search_words("EXIT", 10).size(), had_words ? 1u : 0u);
  // Version 9: the reading's CPU time is stored beside its wall time.
  station::AnalysisResult result;
  result.key = {"new", 0};
  result.text_ms = 12.5;
  result.text_cpu_ms = 9.25;
  analysis.save(result);
  SqliteDb db(path, SqliteDb::Mode::kReadOnly);
  auto q = db.prepare(
      "SELECT text_ms, text_cpu_ms FROM keyframe_analysis WHERE robot_id = 'new' AND "
      "sequence_number = 0");
  ASSERT_TRUE(q.step());
  EXPECT_DOUBLE_EQ(q.real(0), 12.5);
  EXPECT_DOUBLE_EQ(q.real(1), 9.25);
}

TEST(StationSchema, EveryEarlierLayoutWithoutAVersionMigratesKeepingItsRows) {
  for (int version = 1; version <= 7; ++version) {
    SCOPED_TRACE("layout of version " + std::to_string(version));
    test::TempDir dir;
    const std::string path = dir.file("station.sqlite");
    build(path, layout(version), 0);
    expect_old_rows_kept_and_new_ones_stored(path, version >= 2);
  }
}

TEST(StationSchema, EveryEarlierVersionMigratesKeepingItsRows) {
  for (int version = 1; version < station::station_schema_version(); ++version) {
    SCOPED_TRACE("version " + std::to_string(version));
    test::TempDir dir;
    const std::string path = dir.file("station.sqlite");
    build(path, layout(version), version);
    expect_old_rows_kept_and_new_ones_stored(path, version >= 2);
  }
}

TEST(StationSchema, ALayoutFromAMergedBranchMigrates) {
  // The conflicts' branch had text regions and the stats history before main had the attempts.
  test::TempDir dir;
  const std::string path = dir.file("station.sqlite");
  build(path, {kStationDdl[0], kStationDdl[1], kStationDdl[3], kStationDdl[4], kStationDdl[5]}, 0);
  expect_old_rows_kept_and_new_ones_stored(path);
}

TEST(StationSchema, ReadOnlyOpeningOfAnOldFileChangesNothing) {
  test::TempDir dir;
  const std::string path = dir.file("station.sqlite");
  build(path, layout(1), 0);
  const station::KeyframeStore store(path, SqliteDb::Mode::kReadOnly);
  ASSERT_TRUE(store.load("old", 3));
  EXPECT_TRUE(store.stats_history().empty());
  EXPECT_EQ(user_version(path), 0);
}

TEST(StationSchema, AFileNewerThanTheBuildIsRefusedNamingBothVersions) {
  test::TempDir dir;
  const std::string path = dir.file("station.sqlite");
  const int newer = station::station_schema_version() + 1;
  build(path, layout(7), newer);
  for (auto mode : {SqliteDb::Mode::kReadWrite, SqliteDb::Mode::kReadOnly}) {
    try {
      station::KeyframeStore store(path, mode);
      FAIL() << "a newer file opened";
    } catch (const SqliteError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find("schema version " + std::to_string(newer)), std::string::npos) << what;
      EXPECT_NE(what.find("newer than this build"), std::string::npos) << what;
    }
  }
  EXPECT_THROW(station::AnalysisStore analysis(path), SqliteError);
}

// The outbox's layouts.
const std::string kOutboxV1 = R"sql(
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE pending (sequence_number INTEGER PRIMARY KEY, created_ns INTEGER NOT NULL,
  last_sent_ns INTEGER, sends INTEGER NOT NULL DEFAULT 0, frame_index INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL, vslam_keyframe_index INTEGER NOT NULL,
  window_first_frame INTEGER NOT NULL, window_last_frame INTEGER NOT NULL,
  quality_score REAL NOT NULL, sharpness_score REAL NOT NULL, semantic_score REAL NOT NULL,
  encoding TEXT NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL, image BLOB NOT NULL,
  pose BLOB);
INSERT INTO meta VALUES('robot_id', 'drone_1');
INSERT INTO meta VALUES('next_sequence', '6');
INSERT INTO pending VALUES(5, 100, NULL, 0, 50, 500, 49, 48, 51, 0.5, 0.25, 0.125, 'jpeg', 4, 2,
  x'FFD8FFD9', NULL);)sql";
const std::string kOutboxV2 = "ALTER TABLE pending ADD COLUMN text_regions BLOB;";

void expect_outbox_kept(const std::string& path) {
  agent::Outbox outbox(path, "drone_1", OutboxConfig{});
  EXPECT_EQ(user_version(path), agent::Outbox::schema_version());
  EXPECT_EQ(outbox.next_sequence(), 6u);
  const auto due = outbox.due_for_resend(1000, 10);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].sequence_number, 5u);
  EXPECT_EQ(due[0].window_last_frame, 51u);
  EXPECT_FALSE(due[0].camera_pose);
  Keyframe k = test::make_valid_keyframe("drone_1", 6, 32, 16);
  k.text_regions = {{1, 2, 3, 4}};
  outbox.add(k, 1000);
  EXPECT_EQ(outbox.due_for_resend(1000, 10).back().text_regions, k.text_regions);
}

TEST(OutboxSchema, EveryEarlierLayoutMigratesKeepingItsKeyframes) {
  const std::vector<std::vector<std::string>> layouts = {{kOutboxV1}, {kOutboxV1, kOutboxV2}};
  for (int version = 1; version <= 2; ++version) {
    for (int mark : {0, version}) {
      if (mark == agent::Outbox::schema_version()) continue;  // already the newest
      SCOPED_TRACE("layout " + std::to_string(version) + ", marked " + std::to_string(mark));
      test::TempDir dir;
      const std::string path = dir.file("outbox.sqlite");
      build(path, layouts[version - 1], mark);
      expect_outbox_kept(path);
    }
  }
}

TEST(OutboxSchema, AnOutboxNewerThanTheBuildIsRefused) {
  test::TempDir dir;
  const std::string path = dir.file("outbox.sqlite");
  build(path, {kOutboxV1, kOutboxV2}, agent::Outbox::schema_version() + 1);
  EXPECT_THROW(agent::Outbox(path, "drone_1", OutboxConfig{}), StartupError);
}

}  // namespace
}  // namespace keyfleet
